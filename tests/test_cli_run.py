"""`raydamp run`: the job JSON from a file, a progress bar on a terminal, files written, exit codes."""

from __future__ import annotations

import json
import os
import pty
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import raydamp

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "pendulum.json"
RAYDAMP = [sys.executable, "-m", "raydamp"]


def run_in_terminal(args: list[str], cwd: Path, timeout: float = 120.0) -> tuple[int, str]:
    """Run args with stdin/stdout/stderr on a pseudo-terminal; return (exit code, all output)."""
    controller, terminal = pty.openpty()
    process = subprocess.Popen(args, stdin=terminal, stdout=terminal, stderr=terminal, cwd=cwd, close_fds=True)
    os.close(terminal)
    chunks = []
    while True:
        try:
            data = os.read(controller, 65536)
        except OSError:  # the terminal closed: the process is done
            break
        if not data:
            break
        chunks.append(data)
    os.close(controller)
    return process.wait(timeout=timeout), b"".join(chunks).decode("utf-8", "replace")


def test_example_spec_writes_netcdf_and_png_with_a_progress_bar(tmp_path):
    code, output = run_in_terminal([*RAYDAMP, "run", str(EXAMPLE), "--out", "pendulum.nc", "--plot", "energy.png"],
                                   cwd=tmp_path)
    assert code == 0, output
    assert "integrating" in output and "100%" in output  # tqdm's bar, drawn on the terminal
    assert "energy_dissipated" in output and "completed" in output  # the summary table
    sol = raydamp.load(tmp_path / "pendulum.nc")
    spec = json.loads(EXAMPLE.read_text())
    direct = raydamp.integrate(raydamp.models.DampedPendulum(eps=0.01), spec["initial_state"]["q"],
                               spec["initial_state"]["p"], method="3s", h=0.2, t_end=200, save_every=10, work=True)
    np.testing.assert_array_equal(sol.q, direct.q)
    np.testing.assert_array_equal(sol.work, direct.work)
    assert sol.provenance["model"] == "damped_pendulum"
    png = (tmp_path / "energy.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000


def test_no_bar_when_not_a_terminal(tmp_path):
    done = subprocess.run([*RAYDAMP, "run", str(EXAMPLE)], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "integrating" not in done.stderr and "completed" in done.stdout


def test_blow_up_exits_non_zero_naming_the_step_and_keeps_the_points(tmp_path):
    spec = {"model": "elastic_pendulum", "parameters": {"eps": 0.1}, "method": "heun", "step_size": 2.5,
            "n_steps": 100000, "save_every": 100,
            "initial_state": {"q": [0.0, 1.55884573, -0.6], "p": [1.34164079, 0.0, 0.0]}}
    (tmp_path / "spec.json").write_text(json.dumps(spec))
    done = subprocess.run([*RAYDAMP, "run", "spec.json", "--out", "blown.npz"], cwd=tmp_path, capture_output=True,
                          text=True, timeout=120)
    sol = raydamp.load(tmp_path / "blown.npz")
    assert done.returncode == 1
    assert f"stopped early (non_finite) at step {sol.failed_step}" in done.stderr
    assert sol.status == "non_finite" and np.isfinite(sol.q).all()


@pytest.mark.parametrize(("content", "message"), [
    ("{not json", "not JSON"),
    (json.dumps({"model": "damped_pendulum", "method": "3s", "step_size": -1, "n_steps": 10,
                 "initial_state": {"q": [1.0], "p": [0.0]}}), "step_size: Input should be greater than 0"),
    (json.dumps({"system": {"coordinates": ["x"], "potential": "__import__('os')"}, "method": "3s",
                 "step_size": 0.1, "n_steps": 10, "initial_state": {"q": [1.0], "p": [0.0]}}), "system.potential: "),
])
def test_bad_specs_exit_2_with_a_message(tmp_path, content, message):
    (tmp_path / "spec.json").write_text(content)
    done = subprocess.run([*RAYDAMP, "run", "spec.json"], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2
    assert message in done.stderr and "Traceback" not in done.stderr


def test_methods_and_models_listings():
    methods = subprocess.run([*RAYDAMP, "methods"], capture_output=True, text=True, timeout=60)
    assert methods.returncode == 0
    assert {line.split()[0] for line in methods.stdout.splitlines()} >= {"3s", "2s", "rks", "sv", "heun"}
    models = subprocess.run([*RAYDAMP, "models"], capture_output=True, text=True, timeout=60)
    assert "damped_pendulum" in models.stdout and "elastic_pendulum" in models.stdout
