"""python/raydamp/_core.pyi is the compiled module's own signature list (make stubs).

The stub is regenerated from the module under test by pybind11-stubgen and compared
line by line with the committed one: a binding added, removed or changed without
`make stubs` fails here with the difference.
"""

from __future__ import annotations

import difflib
import subprocess
import sys
from pathlib import Path

import raydamp._core

COMMITTED = Path(__file__).resolve().parents[1] / "python" / "raydamp" / "_core.pyi"


def stub_difference(generated: str, committed: str) -> str:
    """A unified diff from the committed stub to the generated one ('' when equal)."""
    return "".join(difflib.unified_diff(committed.splitlines(keepends=True), generated.splitlines(keepends=True),
                                        fromfile="python/raydamp/_core.pyi (committed)",
                                        tofile="raydamp._core (generated)"))


def generated_stub(out: Path) -> str:
    subprocess.run([sys.executable, "-m", "pybind11_stubgen", "raydamp._core", "-o", str(out)], check=True,
                   capture_output=True, text=True, timeout=120)
    return (out / "raydamp" / "_core.pyi").read_text()


def test_committed_stub_is_the_modules(tmp_path):
    difference = stub_difference(generated_stub(tmp_path), COMMITTED.read_text())
    assert difference == "", "python/raydamp/_core.pyi is out of date; run `make stubs`:\n" + difference


def test_a_binding_without_its_stub_shows_in_the_difference():
    # The committed stub as it would be had a module function been bound without `make stubs`.
    committed = COMMITTED.read_text()
    assert "def resolve_composition(" in committed
    without = "".join(line for line in committed.splitlines(keepends=True)
                      if not line.startswith("def resolve_composition("))
    difference = stub_difference(committed, without)
    assert "+def resolve_composition(" in difference
    assert hasattr(raydamp._core, "resolve_composition")
