"""A database written by the service before jobs and sweeps shared one lifecycle (its tables as that
service created them, column order and all) opens with today's stores: its jobs, trajectories and
sweeps read back, its interrupted runs are recovered, and new tasks go into the same tables."""

from __future__ import annotations

import json
import sqlite3

import numpy as np
import pytest

from raydamp_service.kinds.jobs import JobStore, TrajectoryArrays
from raydamp_service.kinds.sweeps import SweepStore
from raydamp_service.tasks.store import Database

# The schema of jobs (store.py) and sweeps (sweep_store.py) as of commit 6cd9b70.
OLD_SCHEMA = """
CREATE TABLE IF NOT EXISTS jobs (
    seq INTEGER PRIMARY KEY AUTOINCREMENT,  -- submission order, for newest-first listing
    id TEXT NOT NULL UNIQUE,
    status TEXT NOT NULL,
    spec TEXT NOT NULL,                     -- the validated JobSpec as JSON
    progress REAL NOT NULL DEFAULT 0,
    attempts INTEGER NOT NULL DEFAULT 0,
    cancel_requested INTEGER NOT NULL DEFAULT 0,
    summary TEXT,                           -- raydamp Solution.summary() as JSON
    error TEXT,
    failed_step INTEGER,
    created_at TEXT NOT NULL,
    started_at TEXT,
    finished_at TEXT
);
CREATE TABLE IF NOT EXISTS trajectories (
    job_id TEXT PRIMARY KEY REFERENCES jobs(id) ON DELETE CASCADE,
    points INTEGER NOT NULL,
    dim INTEGER NOT NULL,
    momenta INTEGER NOT NULL,
    t BLOB NOT NULL, q BLOB NOT NULL, p BLOB NOT NULL, energy BLOB NOT NULL, momentum BLOB NOT NULL,
    work BLOB                               -- the damping work W(t) (N), NULL for jobs stored before it was kept
);
CREATE INDEX IF NOT EXISTS jobs_by_status ON jobs (status, finished_at);
CREATE TABLE IF NOT EXISTS service (key TEXT PRIMARY KEY, value TEXT);
CREATE TABLE IF NOT EXISTS files (          -- uploaded Matrix Market files, for a structure's {"file": id}
    seq INTEGER PRIMARY KEY AUTOINCREMENT,
    id TEXT NOT NULL UNIQUE,
    name TEXT NOT NULL,
    bytes INTEGER NOT NULL,
    rows INTEGER NOT NULL, cols INTEGER NOT NULL, nnz INTEGER NOT NULL,
    created_at TEXT NOT NULL,
    content BLOB NOT NULL                   -- the file as uploaded
);
CREATE TABLE IF NOT EXISTS sweeps (
    seq INTEGER PRIMARY KEY AUTOINCREMENT,
    id TEXT NOT NULL UNIQUE,
    status TEXT NOT NULL,
    spec TEXT NOT NULL,                     -- the validated SweepSpec as JSON
    members INTEGER NOT NULL,
    members_done INTEGER NOT NULL DEFAULT 0,
    attempts INTEGER NOT NULL DEFAULT 0,
    cancel_requested INTEGER NOT NULL DEFAULT 0,
    outcomes TEXT,                          -- {status: members} as JSON, once finished
    error TEXT,
    result BLOB,                            -- the Dataset as NetCDF (raydamp.load reads it)
    created_at TEXT NOT NULL,
    started_at TEXT,
    finished_at TEXT
);
CREATE INDEX IF NOT EXISTS sweeps_by_status ON sweeps (status, finished_at);
"""
SPEC = {"model": "damped_pendulum", "method": "3s"}
DONE = "2026-01-01T00:00:00+00:00"


@pytest.fixture
def old_database(tmp_path):
    path = tmp_path / "raydamp.sqlite3"
    with sqlite3.connect(path) as db:
        db.executescript(OLD_SCHEMA)
        db.execute("INSERT INTO jobs (id, status, spec, progress, attempts, summary, created_at, started_at, "
                   "finished_at) VALUES ('done', 'completed', ?, 1.0, 1, ?, ?, ?, ?)",
                   (json.dumps(SPEC), json.dumps({"steps": 1}), DONE, DONE, DONE))
        one = np.arange(2.0).tobytes()
        db.execute("INSERT INTO trajectories VALUES ('done', 2, 1, 0, ?, ?, ?, ?, ?, NULL)", (one, one, one, one, b""))
        db.execute("INSERT INTO jobs (id, status, spec, progress, attempts, created_at, started_at) "
                   "VALUES ('running', 'running', ?, 0.5, 1, ?, ?)", (json.dumps(SPEC), DONE, DONE))
        db.execute("INSERT INTO sweeps (id, status, spec, members, members_done, attempts, outcomes, result, "
                   "created_at, started_at, finished_at) VALUES ('swept', 'completed', ?, 3, 3, 1, ?, ?, ?, ?, ?)",
                   (json.dumps({"job": SPEC}), json.dumps({"completed": 3}), b"netcdf", DONE, DONE, DONE))
        db.execute("INSERT INTO sweeps (id, status, spec, members, members_done, attempts, cancel_requested, "
                   "created_at, started_at) VALUES ('sweeping', 'running', '{}', 4, 2, 1, 1, ?, ?)", (DONE, DONE))
    connection = sqlite3.connect(path)  # the old service opened it with the same pragmas
    connection.execute("PRAGMA journal_mode=WAL")
    connection.close()
    database = Database(path)
    jobs, sweeps = JobStore(database), SweepStore(database)
    jobs.open()
    sweeps.open()
    yield jobs, sweeps
    database.close()


def test_jobs_and_their_trajectories_read_back(old_database):
    jobs, _ = old_database
    done = jobs.get("done")
    assert (done.status, done.progress, done.summary, done.spec, done.has_trajectory) == (
        "completed", 1.0, {"steps": 1}, SPEC, True)
    trajectory = jobs.trajectory("done")
    assert trajectory.t.tolist() == [0.0, 1.0] and trajectory.work is None
    assert [job.id for job in jobs.recent(10)] == ["running", "done"]
    assert jobs.recover() == ["running"]
    again = jobs.get("running")
    assert (again.status, again.progress, again.attempts) == ("queued", 0.0, 1)
    assert jobs.claim("running").attempts == 2
    jobs.finish("running", "completed", summary={"steps": 2}, trajectory=TrajectoryArrays(
        t=np.zeros(3), q=np.zeros((3, 1)), p=np.zeros((3, 1)), energy=np.zeros(3), momentum=np.empty((3, 0)),
        work=np.zeros(3)))
    assert jobs.get("running").summary == {"steps": 2} and jobs.trajectory("running").work.tolist() == [0.0] * 3
    created = jobs.create(SPEC)
    assert jobs.get(created.id) == created
    assert jobs.delete_finished("done") and jobs.get("done") is None


def test_sweeps_and_their_results_read_back(old_database):
    _, sweeps = old_database
    swept = sweeps.get("swept")
    assert (swept.status, swept.members, swept.members_done, swept.outcomes, swept.result_bytes) == (
        "completed", 3, 3, {"completed": 3}, 6)
    connection, rowid, size = sweeps.result_handle("swept")
    with connection.blobopen("sweeps", "result", rowid, readonly=True) as blob:
        assert blob.read(size) == b"netcdf"
    connection.close()
    assert sweeps.recover() == []  # a cancel asked for before the old process died is honoured
    assert sweeps.get("sweeping").status == "cancelled"
    created = sweeps.create({"job": SPEC}, members=5)
    assert sweeps.get(created.id) == created and created.members == 5
