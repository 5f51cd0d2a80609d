"""The one lifecycle, checked on each kind of task: jobs and sweeps in one database go through the same
states by the same code, each in its own table."""

from __future__ import annotations

import pytest

from raydamp_service.kinds.jobs import JobStore
from raydamp_service.kinds.sweeps import SweepStore
from raydamp_service.tasks.store import Database

KINDS = {"job": (JobStore, {}, "progress"), "sweep": (SweepStore, {"members": 4}, "members_done")}


@pytest.fixture
def database(tmp_path):
    database = Database(tmp_path / "raydamp.sqlite3")
    yield database
    database.close()


@pytest.mark.parametrize("kind", KINDS)
def test_the_lifecycle_of_each_kind(database, kind):
    store_class, columns, progress = KINDS[kind]
    store, other = store_class(database), (SweepStore if store_class is JobStore else JobStore)(database)
    store.open()
    other.open()
    task = store.create({"kind": kind}, max_queued=2, **columns)
    assert store.get(task.id) == task and other.get(task.id) is None  # one table per kind
    assert store.create({}, max_queued=2, **columns) and store.create({}, max_queued=2, **columns) is None

    assert store.claim(task.id).attempts == 1 and store.claim(task.id) is None
    store.set_progress(task.id, 2)
    assert getattr(store.get(task.id), progress) == 2
    assert store.request_cancel(task.id).cancel_requested and store.get(task.id).status == "running"
    assert not store.delete_finished(task.id)

    store.finish(task.id, "cancelled", error="stopped", progress=3)
    done = store.get(task.id)
    assert (done.status, done.error, getattr(done, progress)) == ("cancelled", "stopped", 3)
    store.finish(task.id, "failed", error="late")  # a finished task stays as it ended
    assert store.get(task.id) == done
    assert store.delete_finished(task.id) and store.get(task.id) is None


@pytest.mark.parametrize("kind", KINDS)
def test_recovery_after_a_crash(database, kind):
    store_class, columns, progress = KINDS[kind]
    store = store_class(database)
    store.open()
    running, queued = store.create({}, **columns), store.create({}, **columns)
    store.claim(running.id)
    store.set_progress(running.id, 1)
    assert store.recover() == [running.id, queued.id]
    again = store.get(running.id)
    assert (again.status, again.attempts, getattr(again, progress), again.started_at) == ("queued", 1, 0, None)
    assert store.claim(running.id).attempts == 2
