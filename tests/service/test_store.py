"""The SQLite job store on its own: state changes, recovery after a crash, trajectory blobs."""

from __future__ import annotations

import sqlite3
import time
from datetime import datetime, timezone

import numpy as np
import pytest

from raydamp_service.kinds.jobs import JobStore, TrajectoryArrays

SPEC = {"model": "damped_pendulum", "method": "3s"}


@pytest.fixture
def store(tmp_path):
    store = JobStore(tmp_path / "missing" / "dir" / "jobs.sqlite3")  # directories are created
    store.open()
    yield store
    store.close()


def test_the_database_is_in_wal_mode(store):
    with sqlite3.connect(store.path) as db:
        assert db.execute("PRAGMA journal_mode").fetchone()[0] == "wal"


def test_trajectory_round_trips_exactly(store):
    job = store.create(SPEC)
    rng = np.random.default_rng(1)
    arrays = TrajectoryArrays(t=np.arange(5.0), q=rng.normal(size=(5, 3)), p=rng.normal(size=(5, 3)),
                              energy=np.array([1.0, 2.0, 3.0, 4.0, np.inf]), momentum=np.empty((5, 0)))
    store.finish(job.id, "failed", error="blew up", failed_step=5, trajectory=arrays)
    back = store.trajectory(job.id)
    for name in ("t", "q", "p", "energy", "momentum"):
        np.testing.assert_array_equal(getattr(back, name), getattr(arrays, name))
    assert back.work is None
    assert store.get(job.id).has_trajectory and store.get(job.id).failed_step == 5

    with_work = store.create(SPEC)
    store.finish(with_work.id, "completed", trajectory=TrajectoryArrays(**{**arrays.__dict__, "work": np.arange(5.0)}))
    np.testing.assert_array_equal(store.trajectory(with_work.id).work, np.arange(5.0))
    assert store.stored_bytes() == 8 * (5 * (2 + 6) + 5 * (3 + 6))  # the work column is counted


def test_a_database_from_before_the_work_column_is_upgraded(tmp_path):
    """A file written by an older service (no trajectories.work) opens, keeps its trajectories
    (their work reads as None) and stores work for new jobs."""
    path = tmp_path / "old.sqlite3"
    with sqlite3.connect(path) as db:
        db.executescript("""
            CREATE TABLE jobs (seq INTEGER PRIMARY KEY AUTOINCREMENT, id TEXT NOT NULL UNIQUE, status TEXT NOT NULL,
                spec TEXT NOT NULL, progress REAL NOT NULL DEFAULT 0, attempts INTEGER NOT NULL DEFAULT 0,
                cancel_requested INTEGER NOT NULL DEFAULT 0, summary TEXT, error TEXT, failed_step INTEGER,
                created_at TEXT NOT NULL, started_at TEXT, finished_at TEXT);
            CREATE TABLE trajectories (job_id TEXT PRIMARY KEY REFERENCES jobs(id) ON DELETE CASCADE,
                points INTEGER NOT NULL, dim INTEGER NOT NULL, momenta INTEGER NOT NULL,
                t BLOB NOT NULL, q BLOB NOT NULL, p BLOB NOT NULL, energy BLOB NOT NULL, momentum BLOB NOT NULL);""")
        one = np.ones(2).tobytes()
        db.execute("INSERT INTO jobs (id, status, spec, created_at, finished_at) VALUES "
                   "('old', 'completed', '{}', '2026-01-01T00:00:00+00:00', '2026-01-01T00:00:00+00:00')")
        db.execute("INSERT INTO trajectories VALUES ('old', 2, 1, 0, ?, ?, ?, ?, ?)", (one, one, one, one, b""))
    store = JobStore(path)
    store.open()
    try:
        old = store.trajectory("old")
        assert old.work is None and old.t.tolist() == [1.0, 1.0]
        job = store.create(SPEC)
        store.finish(job.id, "completed", trajectory=TrajectoryArrays(
            t=np.zeros(2), q=np.zeros((2, 1)), p=np.zeros((2, 1)), energy=np.zeros(2), momentum=np.empty((2, 0)),
            work=np.array([0.0, 0.5])))
        assert store.trajectory(job.id).work.tolist() == [0.0, 0.5]
    finally:
        store.close()


def test_a_cancelled_queued_job_cannot_be_claimed(store):
    job = store.create(SPEC)
    assert store.request_cancel(job.id).status == "cancelled"
    assert store.claim(job.id) is None


def test_cancelling_a_running_job_only_flags_it(store):
    job = store.create(SPEC)
    assert store.claim(job.id).attempts == 1
    flagged = store.request_cancel(job.id)
    assert flagged.status == "running" and flagged.cancel_requested


def test_recover_requeues_interrupted_runs_and_honours_cancels(store):
    queued, running, cancelling, done = (store.create(SPEC) for _ in range(4))
    for job in (running, cancelling, done):
        store.claim(job.id)
    store.request_cancel(cancelling.id)
    store.finish(done.id, "completed", summary={"status": "completed"})

    assert store.recover() == [queued.id, running.id]  # oldest first
    assert store.get(running.id).status == "queued" and store.get(running.id).attempts == 1
    assert store.get(cancelling.id).status == "cancelled"
    assert store.get(done.id).status == "completed"


def test_recent_is_newest_first(store):
    ids = [store.create(SPEC).id for _ in range(4)]
    assert [job.id for job in store.recent(3)] == ids[::-1][:3]
    store.request_cancel(ids[0])
    assert [job.id for job in store.recent(10, "cancelled")] == [ids[0]]


def _finished(store, seconds_ago: float = 0.0, points: int = 10):
    job = store.create(SPEC)
    arrays = TrajectoryArrays(t=np.zeros(points), q=np.zeros((points, 1)), p=np.zeros((points, 1)),
                              energy=np.zeros(points), momentum=np.empty((points, 0)))
    store.finish(job.id, "completed", summary={"status": "completed"}, trajectory=arrays)
    if seconds_ago:
        stamp = datetime.fromtimestamp(time.time() - seconds_ago, timezone.utc).isoformat()
        with sqlite3.connect(store.path) as db:
            db.execute("UPDATE jobs SET finished_at = ? WHERE id = ?", (stamp, job.id))
    return job.id


def test_prune_keeps_the_newest_finished_jobs_and_never_a_queued_one(store):
    old = [_finished(store) for _ in range(3)]
    queued = store.create(SPEC).id
    new = [_finished(store) for _ in range(2)]
    assert store.prune() == 0  # no bound given, nothing removed
    assert store.prune(max_jobs=2) == 3
    assert all(store.get(job_id) is None for job_id in old)
    assert all(store.get(job_id) is not None for job_id in [queued, *new])


def test_prune_by_bytes_and_by_age(store):
    first, second, third = (_finished(store, points=100) for _ in range(3))  # 100 x 4 x 8 = 3200 bytes each
    assert store.stored_bytes() == 3 * 3200
    assert store.prune(max_bytes=6400) == 1 and store.get(first) is None
    assert store.prune(max_bytes=6399) == 1 and store.get(second) is None and store.stored_bytes() == 3200
    stale = _finished(store, seconds_ago=3600)
    assert store.prune(max_age_seconds=1800) == 1 and store.get(stale) is None and store.get(third) is not None


def test_queue_bound_in_create(store):
    assert store.create(SPEC, max_queued=2) and store.create(SPEC, max_queued=2)
    assert store.create(SPEC, max_queued=2) is None
    assert len(store.recent(10)) == 2


def test_delete_finished_refuses_a_running_job(store):
    job = store.create(SPEC)
    store.claim(job.id)
    assert not store.delete_finished(job.id) and store.get(job.id).status == "running"


def test_create_returns_the_row_as_stored(store):
    created = store.create({**SPEC, "n_steps": 10})
    assert created == store.get(created.id)


def test_claim_gives_the_row_it_changed(store):
    job = store.create(SPEC)
    claimed = store.claim(job.id)
    assert (claimed.status, claimed.attempts, claimed.progress, claimed.spec, claimed.has_trajectory) == (
        "running", 1, 0.0, SPEC, False)
    assert claimed == store.get(job.id)
    assert store.claim(job.id) is None  # no longer queued
    store.requeue(job.id)
    assert store.claim(job.id).attempts == 2


def test_the_saved_arrays_are_listed_once(store):
    """stored_arrays.SAVED is the one list of a trajectory's arrays: the table's blob columns, the fields of
    TrajectoryArrays and of the Trajectory JSON schema, and Solution attributes are its names, so an array added
    there but missed elsewhere fails here; the store's byte count (retention's measure, SQL) is the
    StoredTrajectory's row_bytes per point, with or without the optional arrays."""
    import dataclasses

    import raydamp
    from raydamp_service.schemas import Trajectory
    from raydamp_service.trajectories.arrays import SAVED, StoredTrajectory

    names = [a.name for a in SAVED]
    assert [f.name for f in dataclasses.fields(TrajectoryArrays)] == names == list(Trajectory.model_fields)
    assert all(name in {f.name for f in dataclasses.fields(raydamp.Solution)} for name in names)
    with sqlite3.connect(store.path) as db:
        columns = [row[1] for row in db.execute("PRAGMA table_info(trajectories)")]
    assert columns == ["job_id", "points", "dim", "momenta", *names]

    rng = np.random.default_rng(2)
    base = dict(t=np.arange(4.0), q=rng.normal(size=(4, 2)), p=rng.normal(size=(4, 2)), energy=np.ones(4),
                momentum=np.ones((4, 1)))
    expected = 0
    for extra in ({}, {"work": np.ones(4)}, {"work": np.ones(4), "load_work": np.zeros(4)}):
        arrays = TrajectoryArrays(**base, **extra)
        store.finish(store.create(SPEC).id, "completed", trajectory=arrays)
        expected += 4 * StoredTrajectory.of(arrays).row_bytes
    assert expected == 8 * 4 * (3 * (1 + 2 + 2 + 1 + 1) + 0 + 1 + 2)
    assert store.stored_bytes() == expected


def test_a_submission_whose_file_was_deleted_meanwhile_is_not_stored(store):
    # Submitted while a DELETE of its file ran: the check read the file, the DELETE found no job naming it yet
    # (204), the insert went in (202), and the run failed later with "no uploaded file" (3 of 25 tries in a
    # service audit). The insert now checks, in its transaction, that the files it names are still there.
    from raydamp.jobs import JobSpec
    from raydamp_service.tasks.store import FileGone

    kept = store.add_file("M.mtx", b"%%MatrixMarket matrix coordinate real general\n1 1 1\n1 1 1.0\n", (1, 1), 1)
    gone = store.add_file("K.mtx", b"%%MatrixMarket matrix coordinate real general\n1 1 1\n1 1 2.0\n", (1, 1), 1)
    record = store.add_file("a_g.txt", b"0 0\n1 1\n", record=None, shape=(2, 2))
    spec = {"system": {"kind": "linear_structure", "M": {"file": kept.id}, "K": {"file": gone.id}, "f": [1.0]},
            "ground_motion": {"acceleration": {"file": {"id": record.id, "factor": 9.81}}, "direction": [1.0]},
            "initial_state": {"q": {"file": kept.id}, "p": {"file": kept.id}}, "h": 0.1, "n_steps": 10}
    files = JobSpec.model_validate(spec).uploads()  # what the service's routes give the store
    assert files == (kept.id, gone.id, record.id)
    # Only upload ids where uploads go: a momentum map the user named "file" is none (a review: every such job
    # got 409), nor a record's path.
    assert JobSpec.model_validate({
        "system": {"coordinates": ["x", "y"], "potential": "x^2 + y^2", "momenta": {"file": "x*p_y - y*p_x"}},
        "parameters": {"file": 1.0}, "load": {"file": {"path": "/data/a_g.AT2"}}, "h": 0.1, "n_steps": 10,
        "initial_state": {"rest": True}}).uploads() == ()
    assert store.delete_file(gone.id) == "deleted"
    with pytest.raises(FileGone, match=f"the uploaded file {gone.id} was deleted"):
        store.create(spec, files=files)
    assert store.recent(10) == []
    spec["system"]["K"] = {"file": kept.id}
    assert store.create(spec, files=JobSpec.model_validate(spec).uploads()) is not None


def committed(store: JobStore) -> dict[str, str]:
    """id -> status as another connection sees the file: what has been committed, not only written."""
    with sqlite3.connect(store.path) as db:
        return dict(db.execute("SELECT id, status FROM jobs").fetchall())


def submit_at_once(store: JobStore, count: int, max_queued: int | None, handed: list[str]) -> list:
    """count submissions one after another, as the event loop makes them; the id of each row stored is handed."""
    records = [store.create({**SPEC, "n_steps": i}, max_queued) for i in range(count)]
    handed += [record.id for record in records if record is not None]
    return records


def test_the_queue_bound_is_exact_for_submissions_at_once(store):
    handed: list[str] = []
    store.create(SPEC)  # one queued already
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

    again = JobStore(store.path)  # a restart: the count comes from the file, not from memory
    again.open()
    try:
        assert again.recover() == [first[1].id, first[2].id, second[0].id]  # the running one queued again
        assert submit_at_once(again, 1, 3, handed) == [None]
        assert submit_at_once(again, 2, 4, handed)[1] is None
        assert sum(status == "queued" for status in committed(again).values()) == 4
    finally:
        again.close()
