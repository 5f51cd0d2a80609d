"""`raydamp sweep spec.json --grid ...`: a grid through raydamp.sweep on a real Dask cluster (its own
LocalCluster, or a scheduler's address), a NetCDF or Zarr file whose members equal single runs,
exit codes 0 / 1 (a member blew up) / 2 (bad input, named)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import raydamp

distributed = pytest.importorskip("dask.distributed")
xr = pytest.importorskip("xarray")
pytestmark = [pytest.mark.filterwarnings("ignore::ResourceWarning"),
              pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")]

ROOT = Path(__file__).resolve().parents[1]
RAYDAMP = [sys.executable, "-m", "raydamp"]
ELASTIC = {"model": "elastic_pendulum", "parameters": {"eps": 0.1}, "method": "3s", "step_size": 0.05,
           "n_steps": 400, "save_every": 100, "initial_state": {"q": [0.0, 1.55884573, -0.6], "p": [1.34164079, 0, 0]}}


def sweep(tmp_path: Path, spec: dict, *args: str, env: dict | None = None) -> subprocess.CompletedProcess:
    path = tmp_path / "spec.json"
    path.write_text(json.dumps(spec))
    return subprocess.run([*RAYDAMP, "sweep", str(path), *args], capture_output=True, text=True, timeout=300,
                          cwd=tmp_path, env=env)


def test_readme_pendulum_spec_over_an_eps_range_writes_netcdf(tmp_path):
    spec = json.loads((ROOT / "examples" / "pendulum.json").read_text())
    out = tmp_path / "sweep.nc"
    done = sweep(tmp_path, spec, "--grid", "eps=0.001:0.1:5", "--grid", "method=3s,2s", "--out", str(out),
                 "--chunk-size", "3", "--workers", "1")
    assert done.returncode == 0, done.stderr
    assert "members      10" in done.stdout and "completed    10" in done.stdout
    assert '"work": true is ignored' in done.stderr  # the README's spec records W for `raydamp run`
    ds = raydamp.load(out)
    assert ds.attrs["kind"] == "sweep" and ds.sizes["member"] == 10
    assert np.allclose(np.unique(ds["eps"].values), [0.001, 0.02575, 0.0505, 0.07525, 0.1], rtol=1e-15, atol=0)
    model, q0, p0, options = raydamp.jobs.job_arguments(spec)
    for i in (0, 7):
        member = raydamp.models.DampedPendulum(eps=float(ds["eps"].values[i]))
        ref = raydamp.integrate(member, q0, p0, **{**options, "method": str(ds["method"].values[i]), "work": False})
        assert np.array_equal(ds["q"].values[i], ref.q) and np.array_equal(ds["energy"].values[i], ref.energy)


def test_blow_up_exits_1_naming_the_members_and_zarr_keeps_them(tmp_path):
    out = tmp_path / "sweep.zarr"
    done = sweep(tmp_path, ELASTIC, "--grid", "h=0.05,3.0", "--grid", "k=1,50", "--out", str(out),
                 "--no-progress", "--workers", "1")
    assert done.returncode == 1, done.stderr
    assert "completed    2" in done.stdout and "non_finite   2" in done.stdout
    assert "member 3 (h=3.0, k=50.0): the state stopped being finite at step 60" in done.stderr
    ds = raydamp.load(out)
    status = ds["status"].values
    assert list(status) == [0, 0, 1, 1]
    # the blown-up members keep their last finite state
    assert np.isfinite(ds["q_final"].values[3]).all() and ds["failed_step"].values[3] == 60


def test_scheduler_address_from_the_environment(tmp_path):
    import os

    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0") as cluster:
        env = {**os.environ, "RAYDAMP_DASK_SCHEDULER": cluster.scheduler_address}
        done = sweep(tmp_path, ELASTIC, "--grid", "k=1:2:3", "--no-progress", env=env)
        assert done.returncode == 0, done.stderr
        assert "members      3" in done.stdout
        with distributed.Client(cluster) as client:  # the tasks ran on this cluster's worker
            (log,) = client.run(lambda dask_worker: len(dask_worker.data) + dask_worker.state.executed_count).values()
            assert log >= 1


@pytest.mark.parametrize("args, message", [
    (["--grid", "kk=1,2"], "grid.kk: not a parameter of the model"),
    (["--grid", "k=1:2"], "a range is name=start:stop:num"),
    (["--grid", "k=1,2", "--out", "x.csv"], "--out: unknown format '.csv'"),
    ([], "--grid: give at least one"),
])
def test_bad_input_exits_2_naming_it(tmp_path, args, message):
    done = sweep(tmp_path, ELASTIC, *args)
    assert done.returncode == 2 and message in done.stderr, done.stderr


def test_thermal_flags_of_a_sweep_seed_every_member_from_the_stream(tmp_path):
    oscillator = {"model": "damped_pendulum", "parameters": {"eps": 0.5}, "method": "baoab", "h": 0.1,
                  "n_steps": 100, "save_every": 25, "initial_state": {"q": [0.3], "p": [0.0]}}
    done = sweep(tmp_path, oscillator, "--grid", "eps=0.2,0.5,0.8", "--temperature", "0.5", "--seed", "21",
                 "--stream", "4", "--out", "thermal.nc", "--workers", "1", "--no-progress")
    assert done.returncode == 0, done.stderr
    assert "seed         21" in done.stdout and "stream       4" in done.stdout
    ds = xr.open_dataset(tmp_path / "thermal.nc")
    provenance = json.loads(ds.attrs["provenance"])
    assert (provenance["temperature"], provenance["seed"], provenance["stream"]) == (0.5, 21, 4)
    for k, eps in enumerate(ds["eps"].values):
        single = raydamp.integrate(raydamp.models.DampedPendulum(float(eps)), [0.3], [0.0], method="baoab", h=0.1,
                                   n_steps=100, save_every=25, temperature=0.5, seed=21, stream=4 + k)
        assert np.array_equal(ds["q"].values[k], single.q), k
    ds.close()
    refused = sweep(tmp_path, oscillator, "--grid", "eps=0.2,0.5", "--temperature", "-0.5")
    assert refused.returncode == 2 and "argument --temperature: must be a finite number >= 0" in refused.stderr


@pytest.mark.parametrize(("args", "message"), [
    (["--grid", "k=1,2", "--grid", "k=3"], "--grid k: given twice"),
    (["--grid", "k=1,2", "--scheduler", "garbage"], "--scheduler 'garbage': not a scheduler address"),
    (["--grid", "k=1,2", "--out", "nodir/x.nc"], "--out nodir/x.nc: no such directory nodir"),
    (["--grid", "k=1,2", "--out", "d.nc"], "--out d.nc: is a directory"),
    (["--grid", "k=1,2", "--out", "f.zarr"], "--out f.zarr: exists and is not a directory"),
])
def test_bad_grid_scheduler_or_out_exits_2_before_the_sweep(tmp_path, args, message):
    """Before: a repeated axis replaced the first; the others were tracebacks (an output path's after the sweep)."""
    (tmp_path / "d.nc").mkdir()
    (tmp_path / "f.zarr").write_text("")
    done = sweep(tmp_path, ELASTIC, "--no-progress", "--workers", "1", *args)
    assert done.returncode == 2, done.stdout
    assert message in done.stderr and "Traceback" not in done.stderr, done.stderr


def test_a_bad_scheduler_address_in_the_environment_is_named(tmp_path):
    import os

    done = sweep(tmp_path, ELASTIC, "--grid", "k=1,2", env={**os.environ, "RAYDAMP_DASK_SCHEDULER": "garbage"})
    assert done.returncode == 2
    assert "RAYDAMP_DASK_SCHEDULER 'garbage': not a scheduler address" in done.stderr and "Traceback" not in done.stderr


def test_ctrl_c_stops_the_sweep_and_writes_the_members_so_far(tmp_path):
    """Ctrl-C gave a KeyboardInterrupt traceback, and a Zarr store whose unfinished members read "completed"
    (an audit). Now it cancels the sweep: the finished members and the others "cancelled" are written,
    exit 1, one line saying so."""
    import signal
    import time

    spec = {"model": "damped_pendulum", "parameters": {"eps": 0.01}, "method": "3s", "h": 0.01,
            "n_steps": 500_000_000, "save_every": 100_000_000, "initial_state": {"q": [2.8], "p": [0.0]}}
    (tmp_path / "spec.json").write_text(json.dumps(spec))
    out = tmp_path / "cut.zarr"
    process = subprocess.Popen([*RAYDAMP, "sweep", "spec.json", "--grid", "eps=0.01:0.1:6", "--chunk-size", "1",
                                "--workers", "1", "--no-progress", "--out", str(out)], cwd=tmp_path,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while not (out / ".zattrs").exists():  # the store's template: written inside sweep, once Ctrl-C is handled
        assert process.poll() is None and time.monotonic() < deadline, process.communicate()
        time.sleep(0.05)
    process.send_signal(signal.SIGINT)
    stdout, stderr = process.communicate(timeout=120)
    assert process.returncode == 1, stderr
    # (Dask may log its own shutdown noise: the point is that no KeyboardInterrupt escapes)
    assert "KeyboardInterrupt" not in stderr and "stopped early (Ctrl-C)" in stderr, stderr
    status = raydamp.load(out)["status"].values
    cancelled = raydamp.results.ensemble_solution.STATUSES.index("cancelled")
    assert status.size == 6 and (status == cancelled).any() and np.isin(status, [0, cancelled]).all(), status
