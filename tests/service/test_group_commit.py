"""The store's group commit in-process: concurrent submissions' inserts committed together, each returned once
committed, the queue bound exact within and across transactions, one failing write failing only itself."""

from __future__ import annotations

import asyncio
import sqlite3
import time

import pytest
from raydamp_service.jobs import JobStore

SPEC = {"model": "damped_pendulum", "method": "3s"}


def committed(store: JobStore) -> dict[str, str]:
    """id -> status as another connection sees the file: what has been committed, not only written."""
    with sqlite3.connect(store.path) as db:
        return dict(db.execute("SELECT id, status FROM jobs").fetchall())


def ids_to(handed: list[str]):
    """The runner's part (then): note the id of each row handed over."""
    return lambda record: handed.append(record.id)


def submit_at_once(store: JobStore, count: int, max_queued: int | None, handed: list[str]) -> list:
    async def both():
        return await asyncio.gather(*(store.create_committed({**SPEC, "n_steps": i}, max_queued, ids_to(handed))
                                      for i in range(count)))
    return asyncio.run(both())


def test_concurrent_submissions_are_committed_together_and_each_answered_once_stored(store, monkeypatch):
    commits = []
    transaction = store.db.transaction

    def counted():
        commits.append(1)
        return transaction()

    monkeypatch.setattr(store.db, "transaction", counted)
    handed: list[str] = []
    records = submit_at_once(store, 50, None, handed)
    assert len({record.id for record in records}) == 50
    assert [record.spec["n_steps"] for record in records] == list(range(50))  # each caller gets its own row
    assert committed(store) == {record.id: "queued" for record in records}
    assert sorted(handed) == sorted(record.id for record in records)  # each handed to the runner once
    # 50 inserts awaited in one turn of the event loop are handed over together: one transaction (one commit
    # per insert before).
    assert len(commits) == 1, len(commits)
    assert all(record == store.get(record.id) for record in records)


def test_the_queue_bound_is_exact_within_one_transaction(store):
    handed: list[str] = []
    store.create(SPEC)  # one queued already, counted once by the transaction
    records = submit_at_once(store, 30, 7, handed)
    accepted = [record for record in records if record is not None]
    assert len(accepted) == 6 and records.count(None) == 24
    assert len(committed(store)) == 7 and sorted(handed) == sorted(record.id for record in accepted)


def test_the_queue_bound_counts_afresh_after_a_cancel_and_a_restart(store, tmp_path):
    handed: list[str] = []
    first = submit_at_once(store, 3, 3, handed)
    assert None not in first
    assert submit_at_once(store, 1, 3, handed) == [None]  # full
    store.request_cancel(first[0].id)
    second = submit_at_once(store, 2, 3, handed)
    assert second[0] is not None and second[1] is None  # the cancelled one's place, and no more
    store.claim(first[1].id)  # running: no longer queued
    store.close()

    again = JobStore(tmp_path / "jobs.sqlite3")  # a restart: the count comes from the file, not from memory
    again.open()
    try:
        assert again.recover() == [first[1].id, first[2].id, second[0].id]  # the running one queued again
        assert submit_at_once(again, 1, 3, handed) == [None]
        assert submit_at_once(again, 2, 4, handed)[1] is None
        assert sum(status == "queued" for status in committed(again).values()) == 4
    finally:
        again.close()


def test_a_failing_write_fails_alone_and_a_gone_caller_still_gets_its_job_run(store):
    handed: list[str] = []

    def broken(db, batch):
        db.execute("INSERT INTO no_such_table VALUES (1)")

    async def mixed():
        writer = store.db.writer
        good = [store.create_committed({**SPEC, "n_steps": i}, None, ids_to(handed)) for i in range(5)]
        results = await asyncio.gather(*good[:2], writer.write(broken), *good[2:], return_exceptions=True)
        # A caller cancelled while its insert waits (its client went away): the row is still stored and run.
        gone = asyncio.ensure_future(store.create_committed({**SPEC, "n_steps": 99}, None, ids_to(handed)))
        await asyncio.sleep(0)
        gone.cancel()
        await asyncio.gather(gone, return_exceptions=True)
        await store.create_committed({**SPEC, "n_steps": 100}, None, ids_to(handed))  # after the gone one
        return results

    results = asyncio.run(mixed())
    assert isinstance(results[2], sqlite3.OperationalError) and "no_such_table" in str(results[2])
    good = [results[i] for i in (0, 1, 3, 4, 5)]
    stored = committed(store)
    assert all(record.id in stored for record in good)
    assert len(stored) == 7 and len(handed) == 7  # the five, the gone caller's, the last
    assert sorted(job.spec["n_steps"] for job in store.recent(10)) == [0, 1, 2, 3, 4, 99, 100]


def test_closing_the_store_commits_what_waits(store):
    handed: list[str] = []

    async def then_close():
        pending = [asyncio.ensure_future(store.create_committed(SPEC, None, ids_to(handed))) for _ in range(20)]
        await asyncio.sleep(0)  # all handed to the writer
        await asyncio.get_running_loop().run_in_executor(None, store.db.close)
        return await asyncio.gather(*pending)

    records = asyncio.run(then_close())
    assert len(committed(store)) == 20 and len(handed) == 20 and None not in records


def test_a_quick_run_goes_from_queued_to_its_end_in_one_write_unless_cancelled_first(store):
    """Runner._run_quick: a run of milliseconds is recorded without a claim, by one guarded write through the
    group commit: queued -> completed with attempts 1 and its start time; a cancel that came first wins."""
    import numpy as np
    from raydamp_service.jobs import TrajectoryArrays
    from raydamp_service.store import now

    arrays = TrajectoryArrays(t=np.arange(3.0), q=np.ones((3, 1)), p=np.zeros((3, 1)), energy=np.full(3, 2.0),
                              momentum=np.empty((3, 0)), work=np.zeros(3))
    ran, cancelled = store.create(SPEC), store.create(SPEC)
    started = now()
    assert store.finish(ran.id, "completed", summary={"steps": 2}, trajectory=arrays, unclaimed_since=started).wait()
    record = store.get(ran.id)
    assert (record.status, record.attempts, record.started_at, record.progress, record.summary) == (
        "completed", 1, started, 1.0, {"steps": 2})
    assert record.started_at <= record.finished_at and committed(store)[ran.id] == "completed"
    np.testing.assert_array_equal(store.trajectory(ran.id).q, arrays.q)

    store.request_cancel(cancelled.id)  # while it ran: cancelled in the store at once
    assert not store.finish(cancelled.id, "completed", summary={"steps": 2}, trajectory=arrays,
                            unclaimed_since=now()).wait()
    record = store.get(cancelled.id)
    assert (record.status, record.attempts, record.summary, record.has_trajectory) == ("cancelled", 0, None, False)


def test_a_worker_holds_a_bounded_number_of_uncommitted_quick_records(store, tmp_path, monkeypatch):
    """Runner._run_quick hands its records to the group commit without waiting, up to _UNCOMMITTED per worker
    (each holds a run's arrays); then it waits for the oldest. With the writer stalled, a worker hands over
    exactly _UNCOMMITTED records and the next run waits; released, all are committed."""
    import math
    import threading

    from raydamp_service.config import Settings
    from raydamp_service.runner import _UNCOMMITTED, Runner

    stall = threading.Event()
    transaction = store.db.transaction

    def stalled():
        stall.wait(30)
        return transaction()

    small = {"model": "damped_pendulum", "parameters": {"eps": 0.01}, "method": "3s", "step_size": 0.01,
             "n_steps": 100, "initial_state": {"q": [0.9 * math.pi], "p": [0.0]}}
    runner = Runner(store, Settings(db=tmp_path / "jobs.sqlite3", workers=1))
    handed = []
    finish = store.finish
    monkeypatch.setattr(store, "finish", lambda *args, **kw: (handed.append(args[0]), finish(*args, **kw))[1])
    runner.start()  # before the jobs exist: its recovery at start would queue them too
    try:
        jobs = [store.create(small) for _ in range(_UNCOMMITTED + 3)]
        monkeypatch.setattr(store.db, "transaction", stalled)
        for job in jobs:
            runner.submit(job.id)
        waiting = jobs[_UNCOMMITTED]  # run, its record waiting for the oldest one's commit
        deadline = time.monotonic() + 30
        while runner.progress(waiting.id) is None and time.monotonic() < deadline:
            time.sleep(0.01)
        time.sleep(0.2)
        assert handed == [job.id for job in jobs[:_UNCOMMITTED]]
        assert committed(store) == {job.id: "queued" for job in jobs}
        stall.set()
        while not all(status == "completed" for status in committed(store).values()):
            assert time.monotonic() < deadline
            time.sleep(0.01)
        assert handed == [job.id for job in jobs]
    finally:
        stall.set()
        runner.stop()


def test_a_write_after_stop_is_refused_not_lost_in_silence(store):
    """Once the writer has stopped (the store closing), a write is refused at once, from a thread or from the
    event loop, rather than queued where nothing would ever commit it."""
    writer = store.db.writer
    writer.stop()
    with pytest.raises(sqlite3.ProgrammingError, match="closed"):
        writer.post(lambda db, batch: None)

    async def write():
        return await writer.write(lambda db, batch: None)

    with pytest.raises(sqlite3.ProgrammingError, match="closed"):
        asyncio.run(write())
