"""The SQLite job store: jobs, their results, and their trajectories as float64 blobs.

One connection per thread (sqlite3 connections are not for sharing), WAL so that readers
never wait for the writer. Every state change is one UPDATE guarded by the state it
expects, so a cancel and a worker's claim cannot both win.
"""

from __future__ import annotations

import json
import sqlite3
import threading
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["JobStore", "JobRecord", "TrajectoryArrays", "FINAL_STATUSES"]

FINAL_STATUSES = frozenset({"completed", "failed", "cancelled"})
_FLOAT = np.dtype("<f8")  # the blob format: little-endian float64, row-major

_SCHEMA = """
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
    t BLOB NOT NULL, q BLOB NOT NULL, p BLOB NOT NULL, energy BLOB NOT NULL, momentum BLOB NOT NULL
);
"""
_JOB_COLUMNS = ("id, status, spec, progress, attempts, cancel_requested, summary, error, failed_step, "
                "created_at, started_at, finished_at, "
                "EXISTS (SELECT 1 FROM trajectories WHERE job_id = jobs.id) AS has_trajectory")


def _now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="microseconds")


@dataclass(frozen=True)
class JobRecord:
    id: str
    status: str
    spec: dict[str, Any]
    progress: float
    attempts: int
    cancel_requested: bool
    summary: dict[str, Any] | None
    error: str | None
    failed_step: int | None
    created_at: str
    started_at: str | None
    finished_at: str | None
    has_trajectory: bool

    @classmethod
    def from_row(cls, row: sqlite3.Row) -> JobRecord:
        return cls(id=row["id"], status=row["status"], spec=json.loads(row["spec"]), progress=row["progress"],
                   attempts=row["attempts"], cancel_requested=bool(row["cancel_requested"]),
                   summary=json.loads(row["summary"]) if row["summary"] else None, error=row["error"],
                   failed_step=row["failed_step"], created_at=row["created_at"], started_at=row["started_at"],
                   finished_at=row["finished_at"], has_trajectory=bool(row["has_trajectory"]))


@dataclass(frozen=True)
class TrajectoryArrays:
    """The saved points: t (N,), q and p (N, n), energy (N,), momentum (N, m)."""

    t: np.ndarray
    q: np.ndarray
    p: np.ndarray
    energy: np.ndarray
    momentum: np.ndarray


def _blob(array: np.ndarray) -> bytes:
    return np.ascontiguousarray(array, dtype=_FLOAT).tobytes()


def _array(blob: bytes, *shape: int) -> np.ndarray:
    return np.frombuffer(blob, dtype=_FLOAT).reshape(shape)


class JobStore:
    def __init__(self, path: Path | str):
        self.path = Path(path)
        self._local = threading.local()
        self._connections: list[sqlite3.Connection] = []
        self._lock = threading.Lock()

    # ---- connections ----

    def open(self) -> None:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with self._transaction() as db:
            db.executescript(_SCHEMA)

    def close(self) -> None:
        with self._lock:
            for connection in self._connections:
                connection.close()
            self._connections.clear()
        self._local = threading.local()

    def _connection(self) -> sqlite3.Connection:
        connection = getattr(self._local, "connection", None)
        if connection is None:
            # check_same_thread=False only so close() may close it; it is used by its own thread alone.
            connection = sqlite3.connect(self.path, timeout=30.0, check_same_thread=False)
            connection.row_factory = sqlite3.Row
            connection.execute("PRAGMA journal_mode=WAL")
            connection.execute("PRAGMA foreign_keys=ON")
            # WAL + NORMAL is durable across process crashes (only an OS crash may lose the last commits).
            connection.execute("PRAGMA synchronous=NORMAL")
            self._local.connection = connection
            with self._lock:
                self._connections.append(connection)
        return connection

    @contextmanager
    def _transaction(self) -> Iterator[sqlite3.Connection]:
        connection = self._connection()
        with connection:  # commits, or rolls back on an exception
            yield connection

    # ---- reading ----

    def ping(self) -> None:
        self._connection().execute("SELECT 1").fetchone()

    def get(self, job_id: str) -> JobRecord | None:
        row = self._connection().execute(f"SELECT {_JOB_COLUMNS} FROM jobs WHERE id = ?", (job_id,)).fetchone()
        return JobRecord.from_row(row) if row else None

    def recent(self, limit: int, status: str | None = None) -> list[JobRecord]:
        """Newest first."""
        where, args = ("WHERE status = ?", (status,)) if status else ("", ())
        rows = self._connection().execute(
            f"SELECT {_JOB_COLUMNS} FROM jobs {where} ORDER BY seq DESC LIMIT ?", (*args, limit)).fetchall()
        return [JobRecord.from_row(row) for row in rows]

    def trajectory(self, job_id: str) -> TrajectoryArrays | None:
        row = self._connection().execute("SELECT * FROM trajectories WHERE job_id = ?", (job_id,)).fetchone()
        if row is None:
            return None
        n, dim, m = row["points"], row["dim"], row["momenta"]
        return TrajectoryArrays(t=_array(row["t"], n), q=_array(row["q"], n, dim), p=_array(row["p"], n, dim),
                                energy=_array(row["energy"], n), momentum=_array(row["momentum"], n, m))

    # ---- state changes ----

    def create(self, spec: dict[str, Any]) -> JobRecord:
        job_id = uuid.uuid4().hex
        with self._transaction() as db:
            db.execute("INSERT INTO jobs (id, status, spec, created_at) VALUES (?, 'queued', ?, ?)",
                       (job_id, json.dumps(spec), _now()))
        return self.get(job_id)

    def claim(self, job_id: str) -> JobRecord | None:
        """queued -> running; None if the job is no longer queued (cancelled meanwhile)."""
        with self._transaction() as db:
            claimed = db.execute("UPDATE jobs SET status = 'running', started_at = ?, progress = 0, "
                                 "attempts = attempts + 1 WHERE id = ? AND status = 'queued'",
                                 (_now(), job_id)).rowcount
        return self.get(job_id) if claimed else None

    def set_progress(self, job_id: str, fraction: float) -> None:
        with self._transaction() as db:
            db.execute("UPDATE jobs SET progress = ? WHERE id = ? AND status = 'running'", (fraction, job_id))

    def finish(self, job_id: str, status: str, *, summary: dict[str, Any] | None = None, error: str | None = None,
               failed_step: int | None = None, trajectory: TrajectoryArrays | None = None,
               progress: float | None = None) -> None:
        """Record the end of a run and its saved points in one transaction: all of it or none."""
        assert status in FINAL_STATUSES
        if status == "completed":
            progress = 1.0
        with self._transaction() as db:
            if trajectory is not None:
                n, dim = trajectory.q.shape
                db.execute("INSERT OR REPLACE INTO trajectories VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                           (job_id, n, dim, trajectory.momentum.shape[1], _blob(trajectory.t), _blob(trajectory.q),
                            _blob(trajectory.p), _blob(trajectory.energy), _blob(trajectory.momentum)))
            db.execute("UPDATE jobs SET status = ?, summary = ?, error = ?, failed_step = ?, finished_at = ?, "
                       "progress = COALESCE(?, progress) WHERE id = ?",
                       (status, json.dumps(summary) if summary is not None else None, error, failed_step, _now(),
                        progress, job_id))

    def request_cancel(self, job_id: str) -> JobRecord | None:
        """A queued job is cancelled at once; a running one is flagged (the runner stops it)."""
        with self._transaction() as db:
            cancelled = db.execute("UPDATE jobs SET status = 'cancelled', cancel_requested = 1, finished_at = ? "
                                   "WHERE id = ? AND status = 'queued'", (_now(), job_id)).rowcount
            if not cancelled:
                db.execute("UPDATE jobs SET cancel_requested = 1 WHERE id = ? AND status = 'running'", (job_id,))
        return self.get(job_id)

    def requeue(self, job_id: str) -> None:
        """Hand a run interrupted by shutdown back to the queue, to run again from the start."""
        with self._transaction() as db:
            db.execute("UPDATE jobs SET status = 'queued', started_at = NULL, progress = 0 "
                       "WHERE id = ? AND status = 'running'", (job_id,))

    def recover(self) -> list[str]:
        """At startup: runs a previous process left behind are queued again. Returns the queue, oldest first."""
        with self._transaction() as db:
            # A cancel was asked for before the process died: honour it rather than run again.
            db.execute("UPDATE jobs SET status = 'cancelled', finished_at = ?, "
                       "error = 'cancelled; the service stopped before the run did' "
                       "WHERE status = 'running' AND cancel_requested = 1", (_now(),))
            db.execute("UPDATE jobs SET status = 'queued', started_at = NULL, progress = 0 WHERE status = 'running'")
            return [row["id"] for row in db.execute("SELECT id FROM jobs WHERE status = 'queued' ORDER BY seq")]
