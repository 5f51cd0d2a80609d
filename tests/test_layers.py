"""The layering of pyproject.toml's [tool.importlinter] holds on the source tree, and it is a real
check: the library importing the service breaks it."""

from __future__ import annotations

import ast
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("importlinter")

ROOT = Path(__file__).resolve().parents[1]
LIBRARY = ROOT / "python" / "raydamp"


def lint_imports(python: Path, service: Path, config: Path) -> subprocess.CompletedProcess:
    """`lint-imports` on the packages under ``python`` and ``service`` (found first on the path, so
    an installed raydamp is not what is read)."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(python), str(service)])}
    command = [sys.executable, "-c", "from importlinter.cli import lint_imports_command; lint_imports_command()",
               "--config", str(config), "--no-cache", "--no-logo"]
    return subprocess.run(command, env=env, cwd=config.parent, capture_output=True, text=True, timeout=60)


def test_the_contracts_hold():
    done = lint_imports(ROOT / "python", ROOT / "service", ROOT / "pyproject.toml")
    assert done.returncode == 0, done.stdout + done.stderr
    assert "5 kept, 0 broken" in done.stdout


def test_the_library_importing_the_service_breaks_them(tmp_path):
    leave_out = shutil.ignore_patterns("__pycache__", "*.so", "static")
    shutil.copytree(LIBRARY, tmp_path / "python" / "raydamp", ignore=leave_out)
    shutil.copytree(ROOT / "service" / "raydamp_service", tmp_path / "service" / "raydamp_service", ignore=leave_out)
    shutil.copy(ROOT / "pyproject.toml", tmp_path / "pyproject.toml")
    commands = tmp_path / "python" / "raydamp" / "cli" / "commands.py"
    commands.write_text(commands.read_text() + "\nfrom raydamp_service.__main__ import serve_command  # noqa\n")
    done = lint_imports(tmp_path / "python", tmp_path / "service", tmp_path / "pyproject.toml")
    assert done.returncode == 1, done.stdout + done.stderr
    assert "raydamp is not allowed to import raydamp_service" in done.stdout
    assert "4 kept, 1 broken" in done.stdout


@pytest.mark.parametrize(("module", "imported", "broken", "count"), [
    # a circle too: kinds import tasks
    ("tasks/store.py", "raydamp_service.kinds.jobs", "raydamp_service.tasks.store -> raydamp_service.kinds.jobs",
     "3 kept, 2 broken"),
    # edge/ imports only config: the guard stays optional
    ("edge/guard.py", "raydamp_service.tasks.lock", "raydamp_service.edge.guard -> raydamp_service.tasks.lock",
     "4 kept, 1 broken"),
])
def test_a_lower_wing_of_the_service_importing_a_higher_one_breaks_them(tmp_path, module, imported, broken, count):
    leave_out = shutil.ignore_patterns("__pycache__", "*.so", "static")
    shutil.copytree(LIBRARY, tmp_path / "python" / "raydamp", ignore=leave_out)
    service = tmp_path / "service" / "raydamp_service"
    shutil.copytree(ROOT / "service" / "raydamp_service", service, ignore=leave_out)
    shutil.copy(ROOT / "pyproject.toml", tmp_path / "pyproject.toml")
    (service / module).write_text((service / module).read_text() + f"\nimport {imported}  # noqa\n")
    done = lint_imports(tmp_path / "python", tmp_path / "service", tmp_path / "pyproject.toml")
    assert done.returncode == 1, done.stdout + done.stderr
    assert count in done.stdout and broken in done.stdout, done.stdout


def _imports_of_the_package_itself(path: Path) -> list[str]:
    """What a module of raydamp takes from the package raydamp itself (``from .. import x``,
    ``from raydamp import x``, ``import raydamp``)."""
    module = ".".join(path.relative_to(LIBRARY.parent).with_suffix("").parts)
    package = module.rsplit(".", 1)[0] if path.name != "__init__.py" else module.removesuffix(".__init__")
    taken = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            base = package.split(".")[: len(package.split(".")) - node.level + 1] if node.level else []
            target = ".".join(base + ([node.module] if node.module else []))
            if target == "raydamp":
                taken += [alias.name for alias in node.names]
        elif isinstance(node, ast.Import):
            taken += [f"import {alias.name}" for alias in node.names if alias.name == "raydamp"]
    return taken


def test_the_compiled_core_is_all_the_layers_take_from_the_package_itself():
    """The layers contract ignores imports of the package raydamp by its own modules (grimp reads
    `from .. import _core` as one, the compiled module having no source), so none may take anything
    else from it; its __init__, the public face, stands above every layer."""
    taken = {path: _imports_of_the_package_itself(path) for path in sorted(LIBRARY.rglob("*.py"))
             if path != LIBRARY / "__init__.py"}
    assert {name for names in taken.values() for name in names} == {"_core"}, \
        {str(path): names for path, names in taken.items() if set(names) - {"_core"}}
