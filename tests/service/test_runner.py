"""The worker pool in-process: live progress, and shutdown handing runs back to the queue."""

from __future__ import annotations

import math
import time

import pytest

from raydamp_service.config import Settings
from raydamp_service.tasks.runner import Runner

LONG_RUN = {  # about a minute of steps: always still running when the test acts
    "model": "damped_pendulum", "parameters": {"eps": 0.01}, "method": "3s", "step_size": 0.001,
    "n_steps": 4 * 10**9, "save_every": 10**6, "initial_state": {"q": [0.9 * math.pi], "p": [0.0]},
}


def wait_until(condition, timeout: float = 60.0):
    deadline = time.monotonic() + timeout
    while not (value := condition()):
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.02)
    return value


def test_progress_is_live_and_saved(store, tmp_path):
    runner = Runner(store, Settings(db=tmp_path / "jobs.sqlite3", workers=1, progress_save_seconds=0.01))
    runner.start()
    try:
        job = store.create(LONG_RUN)
        runner.submit(job.id)
        live = wait_until(lambda: runner.progress(job.id))
        assert 0 < live < 1
        assert 0 < wait_until(lambda: store.get(job.id).progress) < 1
        runner.cancel(job.id)
        wait_until(lambda: store.get(job.id).status == "cancelled")
    finally:
        runner.stop()


def test_shutdown_hands_running_and_queued_jobs_back(store, tmp_path):
    runner = Runner(store, Settings(db=tmp_path / "jobs.sqlite3", workers=1))
    runner.start()
    running, waiting = store.create(LONG_RUN), store.create(LONG_RUN)
    runner.submit(running.id)
    runner.submit(waiting.id)
    wait_until(lambda: runner.progress(running.id))
    runner.stop()

    for job in (store.get(running.id), store.get(waiting.id)):
        assert job.status == "queued" and not job.has_trajectory and job.summary is None
    assert store.get(running.id).attempts == 1
    assert store.recover() == [running.id, waiting.id]


@pytest.mark.parametrize(("n_steps", "calls"), [(99_999, 0), (100_000, 100)])
def test_a_run_of_milliseconds_reports_only_its_end(store, tmp_path, monkeypatch, n_steps, calls):
    """raydamp calls progress about 100 times a run, each taking the interpreter lock from the C++ loop; below
    10^5 steps x coordinates (a pendulum: 10^5 steps) the run gets no callback and reports 1.0 at its end."""
    from raydamp_service.tasks.runner import Run

    reports = []
    report = Run.report
    monkeypatch.setattr(Run, "report", lambda self, done, total: (reports.append(done), report(self, done, total)))
    runner = Runner(store, Settings(db=tmp_path / "jobs.sqlite3", workers=1))
    runner.start()
    try:
        job = store.create({**LONG_RUN, "n_steps": n_steps, "save_every": 1000})
        runner.submit(job.id)
        finished = wait_until(lambda: (record := store.get(job.id)).status == "completed" and record)
    finally:
        runner.stop()
    assert finished.progress == 1.0 and finished.summary["steps"] == n_steps
    assert len(reports) == calls and (calls == 0 or reports[-1] == n_steps)


def test_a_row_handed_over_by_its_submission_and_cancelled_since_records_nothing(store, tmp_path):
    """A submission hands the runner the row it stored (no read back); cancelled before the run, its claim
    expects "queued" and changes nothing: still cancelled, never attempted, no result. The same row not
    cancelled completes, attempted once."""
    small = {**LONG_RUN, "n_steps": 100, "save_every": 1}
    runner = Runner(store, Settings(db=tmp_path / "jobs.sqlite3", workers=1))
    runner.start()  # before the jobs exist: its recovery at start would queue them too
    try:
        cancelled, kept = store.create(small), store.create(small)
        store.request_cancel(cancelled.id)
        runner.submit(cancelled.id, cancelled)  # the row as it was stored: "queued"
        runner.submit(kept.id, kept)
        done = wait_until(lambda: (record := store.get(kept.id)).status == "completed" and record)
    finally:
        runner.stop()
    assert (done.attempts, done.summary["steps"], done.has_trajectory) == (1, 100, True)
    record = store.get(cancelled.id)
    assert (record.status, record.attempts, record.summary, record.has_trajectory) == ("cancelled", 0, None, False)


def test_a_submitted_builtin_job_is_built_once_for_its_check_and_its_run(tmp_path, monkeypatch):
    """The runner gets the submitted row with the spec validated at submission and the run the check built: the
    model is built once per job (the check's), and the result equals raydamp's own run of the spec."""
    import asyncio

    import httpx
    import numpy as np

    import raydamp
    import raydamp_service.checks.limits
    import raydamp_service.checks.pool
    from raydamp.models import make_model
    from raydamp_service.app import create_app

    built = []
    build_call = raydamp_service.checks.limits.build_call

    def counted(*args, **kwargs):
        built.append(1)
        return build_call(*args, **kwargs)

    monkeypatch.setattr(raydamp_service.checks.limits, "build_call", counted)
    monkeypatch.setattr(raydamp_service.checks.pool, "build_call", counted)  # a run builds its call there
    spec = {"model": "damped_pendulum", "parameters": {"eps": 0.01}, "method": "3s", "h": 0.01, "n_steps": 100,
            "initial_state": {"q": [0.9 * math.pi], "p": [0.0]}}

    async def submit_and_wait():
        app = create_app(Settings(db=tmp_path / "jobs.sqlite3", check_workers=1))
        async with app.router.lifespan_context(app), httpx.AsyncClient(
                transport=httpx.ASGITransport(app=app), base_url="http://127.0.0.1") as client:
            job_id = (await client.post("/v1/jobs", json=spec)).json()["id"]
            for _ in range(600):
                job = (await client.get(f"/v1/jobs/{job_id}")).json()
                if job["status"] == "completed":
                    return job, (await client.get(f"/v1/jobs/{job_id}/trajectory")).json()
                await asyncio.sleep(0.05)
        raise AssertionError(f"not completed: {job}")

    job, trajectory = asyncio.run(submit_and_wait())
    assert len(built) == 1
    expected = raydamp.integrate(make_model("damped_pendulum", {"eps": 0.01}), [0.9 * math.pi], [0.0], method="3s",
                                 h=0.01, n_steps=100)
    assert job["attempts"] == 1 and job["summary"]["steps"] == 100
    np.testing.assert_allclose(np.array(trajectory["q"]).ravel(), expected.q.ravel(), rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(trajectory["energy"], expected.energy, rtol=1e-14, atol=1e-14)
