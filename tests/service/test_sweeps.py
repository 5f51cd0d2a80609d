"""/v1/sweeps against a real server process whose sweeps run on a real Dask LocalCluster (started
here, handed over as RAYDAMP_DASK_SCHEDULER), and once on the service's own in-process cluster:
results equal single raydamp runs bit for bit, progress per chunk, cancel keeps the finished
chunks, delete removes, bad grids are 422s naming the path."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

import raydamp
from raydamp.models import DampedPendulum

JOB_TIMEOUT, POLL = 120.0, 0.05  # as conftest's

distributed = pytest.importorskip("dask.distributed")
pytestmark = [pytest.mark.filterwarnings("ignore::ResourceWarning"),
              pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")]

JOB = {"model": "damped_pendulum", "parameters": {"eps": 0.01}, "method": "3s", "step_size": 0.1, "t_end": 20.0,
       "save_every": 50, "initial_state": {"q": [0.9 * math.pi], "p": [0.0]}}


@pytest.fixture(scope="module")
def cluster():
    # One worker process: chunks run one after another, so progress moves chunk by chunk.
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0") as c:
        yield c


@pytest.fixture(scope="module")
def sweeps(cluster, start_module_server):
    return start_module_server(RAYDAMP_DASK_SCHEDULER=cluster.scheduler_address, RAYDAMP_MAX_SWEEP_MEMBERS="5000")


def submit(server, body: dict) -> str:
    response = server.client.post("/v1/sweeps", json=body)
    assert response.status_code == 202, response.text
    assert response.headers["location"] == f"/v1/sweeps/{response.json()['id']}"
    return response.json()["id"]


def wait(server, sweep_id: str, predicate, timeout: float = JOB_TIMEOUT) -> dict:
    deadline = time.monotonic() + timeout
    while True:
        view = server.client.get(f"/v1/sweeps/{sweep_id}").json()
        if predicate(view):
            return view
        assert time.monotonic() < deadline, f"sweep {sweep_id} did not get there; last seen {view}"
        time.sleep(POLL)


def finished(view: dict) -> bool:
    return view["status"] in {"completed", "failed", "cancelled"}


def result(server, sweep_id: str, tmp_path):
    response = server.client.get(f"/v1/sweeps/{sweep_id}/result")
    assert response.status_code == 200, response.text
    assert response.headers["content-type"] == "application/x-netcdf"
    path = tmp_path / f"{sweep_id}.nc"
    path.write_bytes(response.content)
    return raydamp.load(path)


def test_grid_of_eps_and_q0_equals_single_runs(sweeps, cluster, tmp_path):
    body = {"job": JOB, "grid": {"eps": {"start": 0.0, "stop": 0.2, "num": 3}, "q0[0]": [0.5, 2.0]},
            "chunk_size": 4}
    sweep_id = submit(sweeps, body)
    view = wait(sweeps, sweep_id, finished)
    assert view["status"] == "completed" and view["error"] is None
    assert (view["members"], view["members_done"], view["progress"]) == (6, 6, 1.0)
    assert view["outcomes"] == {"completed": 6} and view["result"] == f"/v1/sweeps/{sweep_id}/result"
    ds = result(sweeps, sweep_id, tmp_path)
    assert ds.attrs["kind"] == "sweep" and ds.sizes["member"] == 6
    alias = sweeps.client.get(f"/v1/sweeps/{sweep_id}/result", params={"format": "nc"})  # the README's alias
    assert alias.status_code == 200 and alias.content == sweeps.client.get(f"/v1/sweeps/{sweep_id}/result").content
    assert sorted(set(ds["eps"].values.tolist())) == [0.0, 0.1, 0.2]
    for i in range(6):
        ref = raydamp.integrate(DampedPendulum(float(ds["eps"].values[i])), [float(ds["q0[0]"].values[i])], [0.0],
                                h=0.1, t_end=20.0, save_every=50)
        assert np.array_equal(ds["q"].values[i], ref.q) and np.array_equal(ds["energy"].values[i], ref.energy)
    # the tasks ran on the cluster handed over in RAYDAMP_DASK_SCHEDULER
    with distributed.Client(cluster) as client:
        (executed,) = client.run(lambda dask_worker: dask_worker.state.executed_count).values()
    assert executed >= 2  # 6 members in chunks of 4
    listed = sweeps.client.get("/v1/sweeps", params={"status": "completed"}).json()["sweeps"]
    assert sweep_id in {s["id"] for s in listed}


def test_progress_per_chunk_then_cancel_keeps_finished_chunks(sweeps, tmp_path):
    # 200 members in chunks of 2, each chunk 2 x 2*10^6 steps (~40 ms): seconds in all on one worker.
    body = {"job": {**JOB, "t_end": None, "n_steps": 2_000_000, "save_every": 1_000_000},
            "grid": {"eps": {"start": 0.0, "stop": 0.1, "num": 200}}, "chunk_size": 2}
    sweep_id = submit(sweeps, body)
    view = wait(sweeps, sweep_id, lambda v: v["members_done"] >= 4 or finished(v))
    assert view["status"] == "running", view
    assert view["members_done"] % 2 == 0 and 0 < view["progress"] < 1  # moves chunk by chunk
    response = sweeps.client.post(f"/v1/sweeps/{sweep_id}/cancel")
    assert response.status_code == 202 and response.json()["cancel_requested"]
    view = wait(sweeps, sweep_id, finished)
    assert view["status"] == "cancelled", view
    done = view["members_done"]
    assert 4 <= done < 200 and view["outcomes"] == {"completed": done, "cancelled": 200 - done}
    ds = result(sweeps, sweep_id, tmp_path)  # the finished chunks are kept
    status = ds["status"].values
    assert (status == 0).sum() == done and ds.attrs["cancelled"] == 1
    i = int(np.flatnonzero(status == 0)[-1])
    ref = raydamp.integrate(DampedPendulum(float(ds["eps"].values[i])), JOB["initial_state"]["q"], [0.0], h=0.1,
                            n_steps=2_000_000, save_every=1_000_000)
    assert np.array_equal(ds["q"].values[i], ref.q)
    assert sweeps.client.post(f"/v1/sweeps/{sweep_id}/cancel").status_code == 409
    # delete: finished -> 204, then gone
    assert sweeps.client.delete(f"/v1/sweeps/{sweep_id}").status_code == 204
    assert sweeps.client.get(f"/v1/sweeps/{sweep_id}").status_code == 404
    assert sweeps.client.get(f"/v1/sweeps/{sweep_id}/result").status_code == 404


def test_blown_up_members_are_counted_and_kept(sweeps, tmp_path):
    job = {"model": "elastic_pendulum", "parameters": {"eps": 0.1}, "method": "3s", "step_size": 0.05, "n_steps": 400,
           "save_every": 100, "initial_state": {"q": [0.0, 1.55884573, -0.6], "p": [1.34164079, 0, 0]}}
    sweep_id = submit(sweeps, {"job": job, "grid": {"step_size": [0.05, 3.0], "k": [1.0, 50.0]}})
    view = wait(sweeps, sweep_id, finished)
    assert view["status"] == "completed" and view["outcomes"] == {"completed": 2, "non_finite": 2}
    assert view["error"].startswith("2 of 4 members did not complete")
    ds = result(sweeps, sweep_id, tmp_path)
    assert list(ds["h"].values) == [0.05, 0.05, 3.0, 3.0] and list(ds["status"].values) == [0, 0, 1, 1]
    assert ds["failed_step"].values[3] == 60  # as `raydamp sweep` reports for the same member


@pytest.mark.parametrize("change, loc, words", [
    ({"grid": {"k": [1.0]}}, ["body", "grid", "k"], "not a parameter of the model"),
    ({"grid": {"eps": {"start": 0, "stop": 1}}}, ["body", "grid", "eps", "num"], "Field required"),
    ({"grid": {"eps": {"start": 0, "stop": 1, "num": 3, "scale": "log"}}}, ["body", "grid", "eps"], "log range"),
    ({"grid": {"step_size": [0.1, -1.0]}}, ["body", "grid", "step_size"], "grid.step_size must be > 0"),
    ({"grid": {"method": ["3s", "rk9"]}}, ["body", "grid", "method"], "unknown method 'rk9'"),
    ({"grid": {"eps": list(range(100)), "q0[0]": list(range(100))}}, ["body", "grid"], "max_sweep_members = 5000"),
    # 10^8 members: refused from the axes' lengths (the server built them first, gigabytes, and stalled)
    ({"grid": {"eps": [0.1] * 10_000, "h": [0.1] * 10_000}}, ["body", "grid"],
     "grid: 100000000 members (the product of the axes' lengths); this service runs at most max_sweep_members = 5000"),
    # every value of an axis is checked, not the first member's only (a later one failed the sweep on a worker)
    ({"grid": {"eps": [0.1, -0.5]}}, ["body", "grid", "eps"], "grid.eps[1] = -0.5: parameters.eps must be"),
    ({"grid": {"method": ["3s", "sv"]}}, ["body", "grid", "method"], "grid.method[1] = 'sv': method: 'sv' ignores"),
    # the axis is the key the client wrote, dot and all
    ({"grid": {"load.omega": ["abc"]}}, ["body", "grid", "load.omega"], "grid.load.omega: not a parameter"),
    ({"grid": {}}, ["body", "grid"], "at least 1 item"),
    ({"job": {**JOB, "work": True}}, ["body", "job", "work"], "do not record the damping work"),
    ({"job": {**JOB, "step_size": 0.0}}, ["body", "job", "step_size"], "greater than 0"),
    ({"job": {**JOB, "initial_state": {"q": [1.0, 2.0], "p": [0.0, 0.0]}}}, ["body", "job", "initial_state", "q"],
     "length"),
    ({"chunk_size": 0}, ["body", "chunk_size"], "greater than or equal to 1"),
])
def test_bad_sweeps_are_422_naming_the_path(sweeps, change, loc, words):
    body = {"job": JOB, "grid": {"eps": [0.1]}, **change}
    response = sweeps.client.post("/v1/sweeps", json=body)
    assert response.status_code == 422, response.text
    detail = response.json()["detail"]
    assert any(d["loc"] == loc and words in d["msg"] for d in detail), detail


@pytest.mark.parametrize("settings, message", [
    ({"max_sweep_members": 5000}, "grid: 100000000 members (the product of the axes' lengths); this service runs at "
                                  "most max_sweep_members = 5000"),
    ({"max_sweep_members": 10**9, "max_sweep_steps": 10**6},
     "grid: 100000000 members x 200 steps = 20000000000 steps; this service runs at most max_sweep_steps = 1000000 "
     "per sweep"),
])
def test_a_huge_grid_is_refused_before_raydamp_builds_it(settings, message):
    """Audit, serious: check_sweep_spec let raydamp build the whole grid before comparing its members with
    max_sweep_members (10^8 members: 220 MB/s past 10 GB, no answer). Both bounds now reach raydamp as one on
    the members, applied to the product of the axes' lengths; the messages are the service's own."""
    import tracemalloc

    from raydamp.jobs import JobError, SweepSpec
    from raydamp_service.checks.limits import check_sweep_spec
    from raydamp_service.config import Settings

    spec = SweepSpec.model_validate({"job": JOB, "grid": {"eps": [0.1] * 10_000, "q0[0]": {"start": 0.0, "stop": 1.0,
                                                                                           "num": 10_000}}})
    tracemalloc.start()
    try:
        with pytest.raises(JobError) as caught:
            check_sweep_spec(spec, Settings(**settings))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert caught.value.loc == ("grid",) and str(caught.value) == message
    assert peak < 50 * 2**20  # numpy reports its arrays to tracemalloc: nothing of the grid's size was made


def test_in_process_cluster_by_default(start_server, tmp_path):
    server = start_server()  # no RAYDAMP_DASK_SCHEDULER: a LocalCluster inside the service
    sweep_id = submit(server, {"job": JOB, "grid": {"method": ["3s", "2s"], "eps": [0.0, 0.3]}, "chunk_size": 1})
    view = wait(server, sweep_id, finished)
    assert view["status"] == "completed" and view["members_done"] == 4
    ds = result(server, sweep_id, tmp_path)
    for i in range(4):
        ref = raydamp.integrate(DampedPendulum(float(ds["eps"].values[i])), JOB["initial_state"]["q"], [0.0],
                                method=str(ds["method"].values[i]), h=0.1, t_end=20.0, save_every=50)
        assert np.array_equal(ds["p"].values[i], ref.p)


def test_a_sweep_interrupted_by_a_crash_runs_again_at_restart(start_server, tmp_path):
    server = start_server()
    # 200 members: 2.4-3.2 s between the first chunk's end and the sweep's (1.3-1.7 s with 100), for the kill
    # to land in on a loaded machine too.
    body = {"job": {**JOB, "t_end": None, "n_steps": 2_000_000, "save_every": 1_000_000},
            "grid": {"eps": {"start": 0.0, "stop": 0.1, "num": 200}}, "chunk_size": 2}
    sweep_id = submit(server, body)
    wait(server, sweep_id, lambda v: v["members_done"] > 0 or finished(v))
    server.kill()  # SIGKILL mid-sweep: no shutdown code runs
    server.start()
    view = wait(server, sweep_id, finished)
    assert view["status"] == "completed" and view["attempts"] == 2, view
    assert view["outcomes"] == {"completed": 200}
    ds = result(server, sweep_id, tmp_path)
    ref = raydamp.integrate(DampedPendulum(float(ds["eps"].values[57])), JOB["initial_state"]["q"], [0.0], h=0.1,
                            n_steps=2_000_000, save_every=1_000_000)
    assert np.array_equal(ds["q"].values[57], ref.q)


def test_a_cancelled_sweep_frees_the_worker_its_chunk_held(start_server):
    # The in-process cluster with one thread: a sweep's chunk of 10^11 steps (about half an hour) holds it.
    # Cancelled while that chunk runs, the chunk stops there too, so the next sweep runs at once; before,
    # it waited for the cancelled chunk's end.
    server = start_server(RAYDAMP_SWEEP_THREADS="1", RAYDAMP_MAX_STEPS=str(10**12),
                          RAYDAMP_MAX_SWEEP_STEPS=str(10**12))
    blocker = submit(server, {"job": {**JOB, "t_end": None, "n_steps": 10**11, "save_every": 10**11},
                              "grid": {"eps": [0.01]}})
    wait(server, blocker, lambda v: v["status"] == "running")
    time.sleep(1.0)  # its chunk is in the step loop by now
    assert server.client.post(f"/v1/sweeps/{blocker}/cancel").status_code == 202
    assert wait(server, blocker, finished)["status"] == "cancelled"
    quick = submit(server, {"job": JOB, "grid": {"eps": [0.0, 0.3]}})
    view = wait(server, quick, finished, timeout=60)
    assert view["status"] == "completed" and view["members_done"] == 2, view
