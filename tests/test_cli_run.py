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
    # A CLI and service audit: a key twice ran with the last (h = 10 here); deep nesting was a RecursionError.
    ('{"model": "damped_pendulum", "h": 0.1, "h": 10, "n_steps": 10, "initial_state": {"rest": true}}',
     "the key 'h' appears twice in one object"),
    ("[" * 100_000 + "]" * 100_000, "nested too deeply to read"),
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


def test_methods_lists_newmark_with_what_each_method_runs(capsys):
    """`raydamp methods` lists newmark too (structure_methods(), which methods() leaves out) with its description,
    and says on every line what the method runs: newmark a Structure with springs only, midpoint and gauss4 a
    LinearStructure only, the others any system (issue 42: newmark was missing where users look)."""
    from raydamp.cli.commands import main
    from raydamp.methods.catalogue import structure_methods

    assert main(["methods"]) == 0
    lines = capsys.readouterr().out.splitlines()
    rows = [(line.split()[0], line[line.index("[") + 1:line.index("]")], line) for line in lines]
    [newmark] = structure_methods()
    assert [name for name, _, _ in rows] == [m.name for m in raydamp.methods()] + ["newmark"]
    applies = {name: kind for name, kind, _ in rows}
    assert applies["newmark"] == "Structure with springs only" and rows[-1][2].endswith(newmark.description)
    assert applies["midpoint"] == applies["gauss4"] == "LinearStructure only"
    assert {applies[name] for name in ("sv", "3s", "2s", "baoab", "rks", "rk4")} == {"any system"}


OSCILLATOR = {"model": "damped_pendulum", "parameters": {"eps": 0.5}, "method": "baoab", "h": 0.1, "n_steps": 400,
              "save_every": 20, "initial_state": {"q": [0.3], "p": [0.0]}}


def _run(tmp_path: Path, spec: dict, *args: str) -> subprocess.CompletedProcess:
    (tmp_path / "spec.json").write_text(json.dumps(spec))
    return subprocess.run([*RAYDAMP, "run", "spec.json", "--no-progress", *args], cwd=tmp_path, capture_output=True,
                          text=True, timeout=120)


def _table(stdout: str) -> dict[str, str]:
    return dict(line.split(None, 1) for line in stdout.splitlines() if len(line.split(None, 1)) == 2)


def test_temperature_and_seed_flags_repeat_a_run_bit_for_bit(tmp_path):
    runs = [_run(tmp_path, OSCILLATOR, "--temperature", "0.5", "--seed", "7", "--out", f"{name}.npz")
            for name in ("a", "b")]
    assert all(done.returncode == 0 for done in runs), runs[0].stderr
    a, b = (raydamp.load(tmp_path / f"{name}.npz") for name in ("a", "b"))
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_array_equal(a.p, b.p)
    assert a.provenance["temperature"] == 0.5 and a.provenance["seed"] == 7
    assert _table(runs[0].stdout)["seed"] == "7" and _table(runs[0].stdout)["temperature"] == "0.5"
    direct = raydamp.integrate(raydamp.models.DampedPendulum(eps=0.5), [0.3], [0.0], method="baoab", h=0.1,
                               n_steps=400, save_every=20, temperature=0.5, seed=7, work=True)  # the job's default
    np.testing.assert_array_equal(a.q, direct.q)
    assert np.std(a.p) > 0.1  # noise was drawn: a noiseless run from rest at q = 0.3 decays to |p| < 1e-3
    # --stream picks another stream of the seed: integrate(..., stream=3) exactly, and not stream 0's path
    streamed = _run(tmp_path, OSCILLATOR, "--temperature", "0.5", "--seed", "7", "--stream", "3", "--out", "c.npz")
    assert streamed.returncode == 0, streamed.stderr
    c = raydamp.load(tmp_path / "c.npz")
    third = raydamp.integrate(raydamp.models.DampedPendulum(eps=0.5), [0.3], [0.0], method="baoab", h=0.1,
                              n_steps=400, save_every=20, temperature=0.5, seed=7, stream=3, work=True)
    np.testing.assert_array_equal(c.q, third.q)
    assert c.provenance["stream"] == 3 and not np.array_equal(c.q, a.q)


def test_a_drawn_seed_is_printed_and_repeats_the_run(tmp_path):
    first = _run(tmp_path, {**OSCILLATOR, "temperature": 0.2}, "--out", "a.npz")  # the file's temperature, no seed
    assert first.returncode == 0, first.stderr
    seed = _table(first.stdout)["seed"]
    a = raydamp.load(tmp_path / "a.npz")
    assert a.provenance["seed"] == int(seed) and a.provenance["temperature"] == 0.2
    again = _run(tmp_path, {**OSCILLATOR, "temperature": 0.2}, "--seed", seed, "--out", "b.npz")
    np.testing.assert_array_equal(raydamp.load(tmp_path / "b.npz").q, a.q)
    # the flag wins over the file's temperature
    over = _run(tmp_path, {**OSCILLATOR, "temperature": 0.2}, "--temperature", "0.8", "--seed", seed, "--out", "c.npz")
    assert again.returncode == over.returncode == 0
    assert raydamp.load(tmp_path / "c.npz").provenance["temperature"] == 0.8


@pytest.mark.parametrize(("args", "message"), [
    (["--temperature", "-1"], "argument --temperature: must be a finite number >= 0 (kT), got '-1'"),
    (["--temperature", "inf"], "argument --temperature: must be a finite number >= 0"),
    (["--temperature", "warm"], "argument --temperature: expected a number"),
    (["--temperature", "1", "--seed", "1.5"], "argument --seed: expected an integer in [0, 2^64), got '1.5'"),
    (["--temperature", "1", "--seed", "18446744073709551616"], "argument --seed: expected an integer in [0, 2^64)"),
    (["--temperature", "1", "--stream", "-2"], "argument --stream: expected an integer"),
    (["--seed", "3"], "--seed: there is no temperature to draw noise at"),
    (["--temperature", "0", "--stream", "3"], "--stream: there is no temperature to draw noise at"),
])
def test_bad_thermal_flags_exit_2_naming_the_flag(tmp_path, args, message):
    done = _run(tmp_path, OSCILLATOR, *args)
    assert done.returncode == 2, done.stdout
    assert message in done.stderr and "Traceback" not in done.stderr, done.stderr


@pytest.mark.parametrize(("extra", "args", "message"), [
    ({"seed": 5}, [], "seed: the file gives a seed but no temperature"),
    ({"seed": 5, "stream": 3}, [], "seed: the file gives a seed but no temperature"),
    ({"stream": 3, "temperature": 0.2}, ["--temperature", "0"], "stream: the file gives a stream but no temperature"),
])
def test_a_files_seed_or_stream_without_a_temperature_exits_2_naming_the_key(tmp_path, extra, args, message):
    """The file's keys are checked as the flags are (the module's docstring says so): before, a file's seed
    without a temperature ran, exit code 0, and the seed was dropped from the provenance."""
    done = _run(tmp_path, {**OSCILLATOR, **extra}, *args)
    assert done.returncode == 2, done.stdout
    assert message in done.stderr and "Traceback" not in done.stderr, done.stderr


def test_a_temperature_flag_on_a_method_without_noise_flows_exits_2(tmp_path):
    done = _run(tmp_path, {**OSCILLATOR, "method": "rks"}, "--temperature", "1")
    assert done.returncode == 2
    assert "temperature: method 'rks' has no exact noise flow" in done.stderr and "Traceback" not in done.stderr


# About 20 s of steps on a free core: a Ctrl-C after a few seconds lands mid-run.
LONG = {"model": "damped_pendulum", "parameters": {"eps": 0.01}, "method": "3s", "h": 0.01, "n_steps": 2_000_000_000,
        "initial_state": {"q": [2.8], "p": [0.0]}, "save_every": 1_000_000}


def _running_in_a_thread(pid: int) -> bool:
    """A thread other than the main one has had 0.3 s of CPU: raydamp run's worker, stepping (it starts once
    the Ctrl-C handler is in place). A fixed wait instead could send the signal while imports still ran."""
    ticks = os.sysconf("SC_CLK_TCK")
    for task in Path(f"/proc/{pid}/task").iterdir():
        try:
            fields = (task / "stat").read_text().rsplit(")", 1)[1].split()
        except OSError:  # the thread ended meanwhile
            continue
        if int(task.name) != pid and int(fields[11]) / ticks > 0.3:  # utime
            return True
    return False


@pytest.mark.parametrize("flags", [[], ["--no-progress"]], ids=["progress", "no-progress"])
def test_ctrl_c_cancels_the_run_and_writes_the_points_so_far(tmp_path, flags):
    """Before, SIGINT gave a KeyboardInterrupt traceback and no file (with the progress callback) or was
    ignored until the run's end (--no-progress: the main thread stayed in C++)."""
    import signal
    import time

    (tmp_path / "spec.json").write_text(json.dumps(LONG))
    process = subprocess.Popen([*RAYDAMP, "run", "spec.json", "--out", "cut.npz", *flags], cwd=tmp_path,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while not _running_in_a_thread(process.pid):  # the run's worker, started once Ctrl-C is handled
        assert process.poll() is None and time.monotonic() < deadline, process.communicate()
        time.sleep(0.05)
    process.send_signal(signal.SIGINT)
    stdout, stderr = process.communicate(timeout=60)
    assert process.returncode == 1, stderr  # (ignored, the run would have completed its 2e9 steps)
    assert "Traceback" not in stderr and "stopped early (cancelled)" in stderr
    assert "cancelled" in _table(stdout)["status"]
    sol = raydamp.load(tmp_path / "cut.npz")
    assert sol.status == "cancelled" and len(sol.t) > 1 and sol.steps < LONG["n_steps"]


@pytest.mark.parametrize(("args", "message"), [
    (["--out", "nodir/a.nc"], "--out nodir/a.nc: no such directory nodir"),
    (["--out", "d.nc"], "--out d.nc: is a directory"),
    (["--out", "f.nc/a.nc"], "--out f.nc/a.nc: f.nc is not a directory"),
    (["--plot", "nodir/e.png"], "--plot nodir/e.png: no such directory nodir"),
])
def test_an_output_path_that_cannot_be_written_exits_2_before_the_run(tmp_path, args, message):
    """Before, the run finished, then writing the file raised a traceback and its results were lost."""
    (tmp_path / "d.nc").mkdir()
    (tmp_path / "f.nc").write_text("")
    done = _run(tmp_path, OSCILLATOR, *args)
    assert done.returncode == 2 and message in done.stderr and "Traceback" not in done.stderr, done.stderr
    assert done.stdout == ""  # refused before the run: no summary


def test_reproduce_into_an_existing_file_exits_2(tmp_path):
    (tmp_path / "report").write_text("")
    done = subprocess.run([*RAYDAMP, "reproduce", "--out", "report", "--quick"], cwd=tmp_path, capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr
    assert "--out report: exists and is not a directory" in done.stderr


def test_a_structures_matrix_file_is_a_path_for_raydamp_run(tmp_path):
    """The README's plain form of a structure, {"file": "K.mtx"} (a Matrix Market path), in a job file: the
    job schema took only an upload's id, and refused the path with a hex pattern's message. The service
    refuses the path (tests/service/test_structures.py)."""
    import scipy.io
    import scipy.sparse

    K = scipy.sparse.diags([[-1.0] * 3, [2.0] * 4, [-1.0] * 3], [-1, 0, 1]).tocoo()
    scipy.io.mmwrite(tmp_path / "K.mtx", K, symmetry="symmetric")
    system = {"kind": "linear_structure", "M": {"diagonal": [1.0] * 4}, "K": {"file": "K.mtx"}, "alpha": 0.1}
    spec = {"system": system, "method": "3s", "h": 0.1, "n_steps": 50, "initial_state": {"rest": True},
            "load": {"harmonic": {"amplitude": [1.0, 0.0, 0.0, 0.0], "omega": 1.0}}}
    done = _run(tmp_path, spec, "--out", "k.npz")
    assert done.returncode == 0, done.stderr
    local = raydamp.integrate(raydamp.LinearStructure(np.eye(4), K, alpha=0.1), np.zeros(4), np.zeros(4), method="3s",
                              h=0.1, n_steps=50, work=True, load=raydamp.Load.harmonic([1.0, 0.0, 0.0, 0.0], 1.0))
    np.testing.assert_array_equal(raydamp.load(tmp_path / "k.npz").q, local.q)
    missing = _run(tmp_path, {**spec, "system": {**system, "K": {"file": "nope.mtx"}}})
    assert missing.returncode == 2 and "system.K.file" in missing.stderr and "Traceback" not in missing.stderr


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full")
def test_an_output_that_fails_to_write_says_so_and_still_draws_the_plot(tmp_path):
    # A full disk while writing --out was a traceback and exit code 1 (as if the run had stopped early), and
    # the plot was not drawn (a CLI and service audit).
    (tmp_path / "full.csv").symlink_to("/dev/full")
    done = subprocess.run([*RAYDAMP, "run", str(EXAMPLE), "--out", "full.csv", "--plot", "energy.png",
                           "--no-progress"], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr
    assert "raydamp run: could not write full.csv: No space left on device" in done.stderr
    assert (tmp_path / "energy.png").read_bytes().startswith(b"\x89PNG")
