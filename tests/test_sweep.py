"""Sweeps (issue 8): a grid cut into chunks of ensemble members on a real Dask LocalCluster
(processes, 2 workers), equal bit for bit to the serial ensemble, with progress per chunk."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import raydamp
from raydamp.models import DampedPendulum

distributed = pytest.importorskip("dask.distributed")
xr = pytest.importorskip("xarray")

# distributed's scheduler leaves sockets for the garbage collector (its warnings, not ours).
pytestmark = [pytest.mark.filterwarnings("ignore::ResourceWarning"),
              pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")]


@pytest.fixture(scope="module")
def client():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0") as cluster:
        with distributed.Client(cluster) as c:
            yield c


SPEC = {"model": "damped_pendulum", "parameters": {"eps": 0.01}, "q0": [0.9 * math.pi], "p0": [0.0],
        "method": "3s", "h": 0.1, "t_end": 2.0, "save_every": 4}


def test_sweep_equals_the_serial_ensemble_bit_for_bit(client):
    eps = [0.0, 0.05, 0.3]
    q = [0.5, 1.5, 2.5, 3.0]
    hs = [0.1, 0.15]  # t_end = 2 takes 20 steps of 0.1 and 14 (the last shortened) of 0.15
    calls = []
    ds = raydamp.sweep(SPEC, grid={"h": hs, "eps": eps, "q0[0]": q}, client=client, chunk_size=5,
                       progress=lambda done, total: calls.append((done, total)))
    members = len(eps) * len(q) * len(hs)
    assert ds.sizes["member"] == members
    # 12 members per h, chunks of 5: 3 chunks per h
    assert len(calls) == 6 and calls[-1] == (members, members)
    assert ds["t"].dims == ("member", "time")  # the two h give different save grids
    for h in hs:
        sel = np.flatnonzero(ds["h"].values == h)
        serial = raydamp.integrate_ensemble(DampedPendulum(), ds["q0"].values[sel], ds["p0"].values[sel],
                                            parameters={"eps": ds["eps"].values[sel]}, h=h, t_end=2.0, save_every=4)
        rows = serial.t.size
        assert np.array_equal(ds["t"].values[sel[0], :rows], serial.t)
        assert np.isnan(ds["t"].values[sel[0], rows:]).all()
        for name in ("q", "p", "energy"):
            assert np.array_equal(ds[name].values[sel, :rows], getattr(serial, name)), name
        for name in ("q_final", "p_final", "t_final", "steps", "rows"):
            assert np.array_equal(ds[name].values[sel], getattr(serial, name)), name
    # each grid point once
    points = {(h, e, q0) for h, e, q0 in zip(ds["h"].values, ds["eps"].values, ds["q0[0]"].values)}
    assert len(points) == members
    assert np.array_equal(ds["q0"].values[:, 0], ds["q0[0]"].values)


def test_sweep_of_ten_thousand_members_reports_progress(client, tmp_path):
    calls = []
    grid = {"eps": np.linspace(0.0, 0.5, 100), "q0[0]": np.linspace(-3.0, 3.0, 100)}
    ds = raydamp.sweep({**SPEC, "t_end": None, "n_steps": 20, "save_every": 20}, grid=grid, client=client,
                       chunk_size=2500, progress=lambda done, total: calls.append((done, total)),
                       store=tmp_path / "sweep.zarr")
    assert ds.sizes["member"] == 10**4 and ds.sizes["time"] == 2
    assert [c[1] for c in calls] == [10**4] * 4 and sorted(c[0] for c in calls) == [2500, 5000, 7500, 10**4]
    assert (ds["status"].values == 0).all() and (ds["steps"].values == 20).all()
    # spot checks against single runs
    for i in (0, 4321, 9999):
        eps, q0 = float(ds["eps"].values[i]), float(ds["q0[0]"].values[i])
        ref = raydamp.integrate(DampedPendulum(eps), [q0], [0.0], h=0.1, n_steps=20, save_every=20)
        assert np.array_equal(ds["q"].values[i], ref.q) and np.array_equal(ds["p"].values[i], ref.p)


def test_job_json_spec_and_method_grid_with_own_cluster():
    # The service's job form, a grid over method and composition, and client=None: a LocalCluster
    # of 2 worker processes is started and closed by the sweep.
    job = {"model": "elastic_pendulum", "parameters": {"eps": 0.1}, "method": "3s", "step_size": 0.05,
           "n_steps": 12, "save_every": 3, "initial_state": {"q": [0.0, 1.55884573, -0.6], "p": [1.34164079, 0, 0]}}
    ds = raydamp.sweep(job, grid={"method": ["3s", "2s"], "composition": [None, "yoshida4"], "k": [1.0, 2.0]},
                       chunk_size=2)
    assert ds.sizes["member"] == 8
    for i in range(8):
        method, composition = str(ds["method"].values[i]), str(ds["composition"].values[i]) or None
        model = raydamp.models.ElasticPendulum(eps=0.1, k=float(ds["k"].values[i]))
        ref = raydamp.integrate(model, job["initial_state"]["q"], job["initial_state"]["p"], method=method,
                                composition=composition, h=0.05, n_steps=12, save_every=3)
        assert np.array_equal(ds["q"].values[i], ref.q) and np.array_equal(ds["momentum"].values[i], ref.momentum)


def test_bad_grid_names_the_entry():
    with pytest.raises(ValueError, match=r"grid.k: not a parameter"):
        raydamp.sweep(SPEC, grid={"k": [1.0]})
    with pytest.raises(ValueError, match=r"grid.q0\[3\]: the model has 1 coordinates"):
        raydamp.sweep(SPEC, grid={"q0[3]": [1.0]})
    with pytest.raises(ValueError, match=r"grid.eps: every value must be finite"):
        raydamp.sweep(SPEC, grid={"eps": [0.1, math.inf]})
    with pytest.raises(ValueError, match=r"spec.x0: unknown key"):
        raydamp.sweep({**SPEC, "x0": 1}, grid={"eps": [0.1]})
    with pytest.raises(ValueError, match=r"method: unknown method 'rk9'"):
        raydamp.sweep(SPEC, grid={"method": ["3s", "rk9"]})
    # the job form's save_dofs would be silently ignored (a sweep saves every coordinate): refused,
    # as the service refuses it
    job = {"model": "damped_pendulum", "parameters": {"eps": 0.01}, "method": "3s", "step_size": 0.1,
           "n_steps": 10, "initial_state": {"q": [1.0], "p": [0.0]}, "save_dofs": [0]}
    with pytest.raises(ValueError, match=r"save_dofs: a sweep saves every coordinate"):
        raydamp.check_sweep(job, {"eps": [0.1]})


def test_ranges_and_command_line_items():
    # {start, stop, num[, scale]} ranges include both ends; "log" is geometric.
    plan = raydamp.check_sweep(SPEC, {"eps": {"start": 0.001, "stop": 0.1, "num": 3, "scale": "log"},
                                      "q0[0]": {"start": 0.0, "stop": 1.0, "num": 5}}, chunk_size=4)
    assert np.allclose(plan.grid["eps"], [0.001, 0.01, 0.1], rtol=1e-14, atol=0)
    assert plan.grid["q0[0]"] == [0.0, 0.25, 0.5, 0.75, 1.0]
    # 15 members of 1 dof, 6 saved points (20 steps, every 4th, and the last), 4 per chunk
    assert (plan.members, plan.rows, plan.chunks) == (15, 6, 4)
    assert plan.values == 15 * 6 * (2 + 2 * 1 + 0)
    assert raydamp.parse_grid_item("eps=0.001:0.1:20") == ("eps", {"start": 0.001, "stop": 0.1, "num": 20,
                                                                     "scale": "linear"})
    assert raydamp.parse_grid_item("eps=1e-3:0.1:5:log")[1]["scale"] == "log"
    assert raydamp.parse_grid_item("method=3s, 2s") == ("method", ["3s", "2s"])
    assert raydamp.parse_grid_item("q0[0]=0.5,1.5") == ("q0[0]", [0.5, 1.5])
    for bad, match in (("eps", "expected name="), ("eps=1:2", "a range is"), ("eps=a:2:3", "must be numbers"),
                       ("eps=1,x", "expected numbers")):
        with pytest.raises(ValueError, match=match):
            raydamp.parse_grid_item(bad)
    for grid, match in (({"eps": {"start": 0, "stop": 1}}, r"grid.eps.num: missing"),
                        ({"eps": {"start": 0, "stop": 1, "num": 0}}, r"grid.eps.num must be >= 1"),
                        ({"eps": {"start": 0, "stop": 1, "num": 2, "scale": "log"}}, r"grid.eps: a log range"),
                        ({"eps": {"start": 0, "stop": 1, "num": 2, "step": 1}}, r"grid.eps.step: unknown key")):
        with pytest.raises(ValueError, match=match):
            raydamp.check_sweep(SPEC, grid)


def test_cancel_keeps_the_finished_chunks(client, tmp_path):
    token = raydamp.CancelToken()
    calls = []

    def progress(done, total):
        calls.append(done)
        token.cancel()  # after the first chunk

    grid = {"eps": np.linspace(0.0, 0.2, 40)}
    spec = {**SPEC, "t_end": None, "n_steps": 20000, "save_every": 10000}
    for store in (None, tmp_path / "cancelled.zarr"):
        calls.clear()
        token.reset()
        ds = raydamp.sweep(spec, grid=grid, client=client, chunk_size=2, progress=progress, cancel=token, store=store)
        status = ds["status"].values
        done = status == 0
        assert len(calls) == 1 and done.sum() == calls[0] == 2, store
        assert (status[~done] == raydamp.results.ensemble_solution.STATUSES.index("cancelled")).all()
        assert ds.attrs["cancelled"] == 1 and (ds["rows"].values[~done] == 0).all()
        i = int(np.flatnonzero(done)[0])
        ref = raydamp.integrate(DampedPendulum(float(ds["eps"].values[i])), SPEC["q0"], [0.0], h=0.1, n_steps=20000,
                                save_every=10000)
        assert np.array_equal(ds["q"].values[i], ref.q)


def test_a_store_left_by_an_interrupted_sweep_reads_its_unfinished_members_as_cancelled(client, tmp_path):
    """Ctrl-C (or any error, or a crash) between chunks: the members whose chunks were never written read the
    store's fill value, 0 = "completed", with no rows (found by an audit of the CLI). Now they read
    "cancelled" from the start, and the finished ones their own status."""
    def interrupt(done, total):
        raise KeyboardInterrupt

    store = tmp_path / "interrupted.zarr"
    spec = {**SPEC, "t_end": None, "n_steps": 200, "save_every": 100}
    with pytest.raises(KeyboardInterrupt):
        raydamp.sweep(spec, grid={"eps": np.linspace(0.0, 0.2, 8)}, client=client, chunk_size=2, progress=interrupt,
                      store=store)
    ds = raydamp.load(store)
    written = ds["rows"].values > 0
    assert written.sum() == 2, ds["rows"].values  # the first chunk's two members
    assert (ds["status"].values[written] == 0).all()
    assert (ds["status"].values[~written] == raydamp.results.ensemble_solution.STATUSES.index("cancelled")).all()


def test_cancel_stops_the_chunks_running_on_the_workers(client):
    # Two chunks of one member each, 10^11 steps (about half an hour each), one on each worker's only
    # thread. Cancelled once both run, the sweep returns, and the chunks stop on the workers too: a new
    # task then runs at once. Before, they ran to their end, holding the workers (and a service's
    # shutdown, which waited for them).
    token = raydamp.CancelToken()
    spec = {**SPEC, "t_end": None, "n_steps": 10**11, "save_every": 10**11}
    grid = {"eps": [0.01, 0.02]}

    def cancel_once_both_run():
        deadline = time.monotonic() + 60
        while sum(len(tasks) for tasks in client.processing().values()) < 2 and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(0.5)  # inside the step loop by now
        token.cancel()

    canceller = threading.Thread(target=cancel_once_both_run)
    canceller.start()
    ds = raydamp.sweep(spec, grid=grid, client=client, chunk_size=1, cancel=token)
    canceller.join()
    assert ds.attrs["cancelled"] == 1 and (ds["rows"].values == 0).all()
    assert_every_worker_is_free(client)  # the chunks, left running, would hold the threads for half an hour


def test_an_error_in_the_driver_stops_the_chunks_still_running(client):
    # Two chunks: 20 steps, and 2 x 10^10 (h = 1e-10 to t = 2: about five minutes). The progress callback
    # raises at the first; the sweep raises it, and the long chunk stops on its worker rather than holding
    # it for minutes: then a task on each worker's only thread runs at once.
    def progress(done, total):
        raise RuntimeError("the caller's callback failed")

    spec = {**SPEC, "save_every": 10**11}
    with pytest.raises(RuntimeError, match="callback failed"):
        raydamp.sweep(spec, grid={"h": [0.1, 1e-10]}, client=client, chunk_size=1, progress=progress)
    assert_every_worker_is_free(client)


def assert_every_worker_is_free(client):
    """A task pinned to each worker finishes within 60 s (a chunk left running would hold its thread)."""
    workers = sorted(client.scheduler_info()["workers"])
    futures = [client.submit(lambda x: x + 1, i, pure=False, workers=[w], allow_other_workers=False)
               for i, w in enumerate(workers)]
    distributed.wait(futures, timeout=60)
    assert client.gather(futures) == list(range(1, len(workers) + 1))


def test_sweep_over_a_chains_initial_state_equals_the_ensemble(client):
    # the large-system kinds sweep too (over initial states and run arguments)
    chain = raydamp.Chain(n=32, bond="fput", parameters={"alpha": 0.25, "beta": 1.0}, boundary="fixed",
                          dampers={"bonds": [9, 10, 19], "c": 0.1})
    q0 = np.zeros(32)
    spec = {"model": chain, "q0": q0, "p0": np.zeros(32), "method": "3s", "h": 0.05, "n_steps": 100,
            "save_every": 25}
    amplitudes = np.array([0.1, 0.5, 1.0])
    ds = raydamp.sweep(spec, grid={"q0[5]": amplitudes, "method": ["3s", "2s"]}, client=client, chunk_size=2)
    for method in ("3s", "2s"):
        starts = np.tile(q0, (3, 1))
        starts[:, 5] = amplitudes
        ens = raydamp.integrate_ensemble(chain, starts, np.zeros(32), method=method, h=0.05, n_steps=100,
                                         save_every=25)
        picked = ds.sel(member=(ds["method"] == method).values)
        np.testing.assert_array_equal(picked["q"].values, ens.q)
        np.testing.assert_array_equal(picked["energy"].values, ens.energy)


UNGUARDED = """\
import raydamp

spec = {"model": "damped_pendulum", "parameters": {"eps": 0.01}, "q0": [1.0], "p0": [0.0], "h": 0.1, "n_steps": 10}
ds = raydamp.sweep(spec, grid={"eps": [0.0, 0.1]})
print("members", ds.sizes["member"])
"""


def _run_script(path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(Path(raydamp.__file__).resolve().parent.parent)}
    return subprocess.run([sys.executable, str(path)], capture_output=True, text=True, timeout=120, env=env,
                          cwd=path.parent)


def test_script_without_main_guard_gets_one_line_instead_of_dask_tracebacks(tmp_path):
    # Issue 28, point 4: pasted into a script, the README's sweep printed 814 lines of Dask tracebacks
    # ending in "Nanny failed to start", the worker processes (spawned) importing the script again.
    # sweep now sees the call run while the main script is imported and says so in one line; the
    # same script under the guard runs.
    script = tmp_path / "unguarded.py"
    script.write_text(UNGUARDED)
    started = time.perf_counter()
    out = _run_script(script)
    assert out.returncode == 1 and "members" not in out.stdout
    lines = out.stderr.strip().splitlines()
    assert lines[-1].startswith(f"RuntimeError: raydamp.sweep: {script}:4 calls sweep while the script is being "
                                "imported"), out.stderr
    assert 'put the call under `if __name__ == "__main__":`' in lines[-1]
    assert len(lines) <= 12 and "Nanny" not in out.stderr  # Python's own few lines of traceback, no more
    assert time.perf_counter() - started < 30  # no cluster was started

    guarded = tmp_path / "guarded.py"
    body = UNGUARDED.split("\n", 2)[2]
    guarded.write_text("import raydamp\n\nif __name__ == \"__main__\":\n" +
                       "".join(f"    {line}\n" for line in body.splitlines() if line))
    out = _run_script(guarded)
    assert out.returncode == 0 and out.stdout.strip() == "members 2", out.stderr[-2000:]


def test_spec_without_parameters_takes_the_defaults():
    # The README's sweep spec gives no "parameters"; it was refused ("parameters: Input should be a
    # valid dictionary") once the job schema built the model.
    plan = raydamp.check_sweep({"model": "damped_pendulum", "q0": [0.0], "p0": [0.0], "h": 0.05, "t_end": 50},
                               grid={"eps": [0.0, 0.5]})
    assert plan.members == 2 and plan.model.parameters == DampedPendulum().parameters


def test_frequency_response_is_one_sweep_over_load_omega(client):
    """A sweep over load.omega of a damped oscillator's job JSON: the steady-state amplitude of each
    member equals F0 / sqrt((k - m w^2)^2 + (c w)^2) (issue 26)."""
    m, k, c, F0 = 1.0, 4.0, 0.4, 0.5
    job = {"system": {"kind": "linear_structure", "M": {"diagonal": [m]},
                      "K": {"coo": {"rows": [0], "cols": [0], "values": [k], "shape": [1, 1]}}, "alpha": c / m},
           "method": "3s", "h": 0.002, "t_end": 120.0, "save_every": 5, "initial_state": {"rest": True},
           "work": False, "load": {"harmonic": {"amplitude": [F0], "omega": 1.0}}}
    omegas = np.linspace(0.5, 3.5, 7)
    ds = raydamp.sweep(job, grid={"load.omega": omegas}, client=client)
    assert np.array_equal(ds["load.omega"].values, omegas)
    t = ds["t"].values[0] if ds["t"].ndim == 2 else ds["t"].values
    for i, w in enumerate(omegas):
        tail = t > 120.0 - 6 * np.pi / w
        basis = np.column_stack([np.sin(w * t[tail]), np.cos(w * t[tail])])
        coef, *_ = np.linalg.lstsq(basis, ds["q"].values[i, tail, 0], rcond=None)
        exact = F0 / np.hypot(k - m * w ** 2, c * w)
        assert abs(np.hypot(*coef) - exact) / exact < 2e-5, w


def test_a_job_without_a_method_sweeps_with_the_chosen_one():
    """JobSpec.method may be null (raydamp chooses); a sweep of such a job chooses as integrate does
    (found in review: it said "unknown method None")."""
    job = {"model": "damped_pendulum", "h": 0.1, "t_end": 1.0, "initial_state": {"q": [0.5], "p": [0.0]},
           "work": False}
    plan = raydamp.check_sweep(job, {"eps": [0.0, 0.1]})
    assert plan.members == 2


def test_a_thermal_sweep_starts_its_members_streams_at_the_jobs_stream(client):
    """Review finding: a sweep dropped the job's "stream" (every sweep drew streams 0, 1, ...). Member k
    (index in the Dataset) draws stream job_stream + k, across chunks and run groups."""
    job = {"model": "damped_pendulum", "parameters": {"eps": 0.3}, "method": "baoab", "h": 0.05, "n_steps": 40,
           "save_every": 10, "initial_state": {"q": [0.5], "p": [0.0]}, "temperature": 0.5, "seed": 1234,
           "stream": 7, "work": False}
    ds = raydamp.sweep(job, grid={"h": [0.05, 0.04], "eps": [0.1, 0.3], "q0[0]": [0.2, 0.6, 1.0]}, client=client,
                       chunk_size=4)
    members = ds.sizes["member"]
    provenance = json.loads(ds.attrs["provenance"])
    assert members == 12 and provenance["stream"] == 7 and provenance["seed"] == 1234
    for k in range(members):
        single = raydamp.integrate(DampedPendulum(float(ds["eps"].values[k])), [float(ds["q0[0]"].values[k])], [0.0],
                                   method="baoab", h=float(ds["h"].values[k]), n_steps=40, save_every=10,
                                   temperature=0.5, seed=1234, stream=7 + k)
        assert np.array_equal(ds["q"].values[k], single.q) and np.array_equal(ds["p"].values[k], single.p), k
    # stream 0 (the former behaviour) gives a different path: the test sees the stream
    first = raydamp.integrate(DampedPendulum(float(ds["eps"].values[0])), [float(ds["q0[0]"].values[0])], [0.0],
                              method="baoab", h=float(ds["h"].values[0]), n_steps=40, save_every=10, temperature=0.5,
                              seed=1234, stream=0)
    assert not np.array_equal(ds["q"].values[0], first.q)
    with pytest.raises(ValueError, match=r"stream: members draw streams stream \+ k for k < 12"):
        raydamp.check_sweep({**job, "stream": 2**64 - 5}, {"h": [0.05, 0.04], "eps": [0.1, 0.3],
                                                            "q0[0]": [0.2, 0.6, 1.0]})


def test_a_member_failing_on_a_worker_is_named_by_its_index_in_the_sweep(client):
    """Audit: a member that failed on a worker was named by its index in its chunk ("member 0" for the
    sweep's member 3 in chunks of 1). A combination of values each right alone (sv, and eps 0.1 with 3s)
    passes the driver's check, whose steps grow with the axes' lengths, not their product, and fails on the
    worker, named as the Dataset's member."""
    grid = {"method": ["3s", "sv"], "eps": [0.0, 0.1]}
    plan = raydamp.check_sweep(SPEC, grid, chunk_size=1)
    assert (plan.columns["method"][3], plan.columns["eps"][3]) == ("sv", 0.1)  # member 3, in chunk 3 of 4
    with pytest.raises(ValueError, match=r"^member 3: method: 'sv' ignores damping and this model has eps = 0\.1"):
        raydamp.sweep(SPEC, grid, client=client, chunk_size=1)
    with pytest.raises(ValueError, match=r"^member 3: method: 'sv' ignores damping"):  # chunks of 2: member 1 of 2
        raydamp.sweep(SPEC, grid, client=client, chunk_size=2)
