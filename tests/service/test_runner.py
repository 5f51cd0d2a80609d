"""The worker pool in-process: live progress, and shutdown handing runs back to the queue."""

from __future__ import annotations

import math
import time

import pytest
from raydamp_service.config import Settings
from raydamp_service.runner import Runner
from raydamp_service.jobs import JobStore

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


@pytest.fixture
def store(tmp_path):
    store = JobStore(tmp_path / "jobs.sqlite3")
    store.open()
    yield store
    store.close()


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
