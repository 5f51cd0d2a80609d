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

__all__ = ["JobStore", "JobRecord", "FileRecord", "TrajectoryArrays", "StoredTrajectory", "FINAL_STATUSES", "StoreUnavailable"]

FINAL_STATUSES = frozenset({"completed", "failed", "cancelled"})
_FINAL_SQL = "('completed', 'failed', 'cancelled')"
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
"""
_UNFINISHED_SQL = "('queued', 'running')"
_INCREMENTAL = 2  # PRAGMA auto_vacuum value
# Stored bytes of a trajectory row: t, energy, work (N), q, p (N x dim), momentum (N x m), float64.
_TRAJECTORY_BYTES = "(t.points * (2 + (t.work IS NOT NULL) + 2 * t.dim + t.momenta) * 8)"
_JOB_COLUMNS = ("id, status, spec, progress, attempts, cancel_requested, summary, error, failed_step, "
                "created_at, started_at, finished_at, "
                "EXISTS (SELECT 1 FROM trajectories WHERE job_id = jobs.id) AS has_trajectory")


class StoreUnavailable(RuntimeError):
    """The database cannot be opened for writing; the message says what is wrong and what to do."""

    def __init__(self, path: Path, error: BaseException):
        reason = str(error) or type(error).__name__
        if isinstance(error, sqlite3.DatabaseError) and "not a database" in reason:
            advice = "the file is corrupt or not SQLite: move it aside, or set RAYDAMP_DB to another file"
        elif "readonly" in reason.replace("-", "").replace(" ", "") or isinstance(error, PermissionError):
            advice = "the service must be able to write it and its directory: fix the permissions or set RAYDAMP_DB"
        else:
            advice = "check the path and the disk, or set RAYDAMP_DB to another file"
        super().__init__(f"cannot use the job database {path}: {reason}; {advice}")


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
class FileRecord:
    id: str
    name: str
    bytes: int
    shape: tuple[int, int]
    nnz: int
    created_at: str


_FILE_COLUMNS = "id, name, bytes, rows, cols, nnz, created_at"


def _file_record(row: sqlite3.Row) -> FileRecord:
    return FileRecord(id=row["id"], name=row["name"], bytes=row["bytes"], shape=(row["rows"], row["cols"]),
                      nnz=row["nnz"], created_at=row["created_at"])


@dataclass(frozen=True)
class TrajectoryArrays:
    """The saved points: t (N,), q and p (N, n), energy (N,), momentum (N, m), work W(t) (N,) or None."""

    t: np.ndarray
    q: np.ndarray
    p: np.ndarray
    energy: np.ndarray
    momentum: np.ndarray
    work: np.ndarray | None = None


@dataclass(frozen=True)
class StoredTrajectory:
    """Where a trajectory's blobs are (the row) and their shapes, for reading them in slices."""

    rowid: int
    points: int
    dim: int
    momenta: int
    has_work: bool = False


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
        self._write_lock = threading.Lock()
        self._space_pending = False  # freed pages not yet returned (a checkpoint met readers)

    # ---- connections ----

    def open(self) -> None:
        """Create or open the database and prove it writable; raises StoreUnavailable saying what to do."""
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            connection = self._connection()
            if connection.execute("PRAGMA auto_vacuum").fetchone()[0] != _INCREMENTAL:
                # Set before the first table exists (or by one VACUUM for an older file), so that
                # removed jobs give their pages back to the file system (incremental_vacuum).
                connection.execute(f"PRAGMA auto_vacuum = {_INCREMENTAL}")
                connection.execute("VACUUM")
            with self._transaction() as db:
                db.executescript(_SCHEMA)
                columns = {row["name"] for row in db.execute("PRAGMA table_info(trajectories)")}
                if "work" not in columns:  # a database from before the work integral was stored
                    db.execute("ALTER TABLE trajectories ADD COLUMN work BLOB")
                # A real write: a read-only file or directory fails here, not at the first job.
                db.execute("INSERT OR REPLACE INTO service (key, value) VALUES ('opened_at', ?)", (_now(),))
        except (sqlite3.DatabaseError, OSError) as error:
            self.close()
            raise StoreUnavailable(self.path, error) from None

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
        # One writer at a time inside this process: threads queue on a lock that wakes the next at
        # once, rather than meeting SQLITE_BUSY, whose handler sleeps 1, 2, 5 ... 100 ms between
        # tries (the tail of the submission latency under concurrent POSTs).
        with self._write_lock, connection:  # commits, or rolls back on an exception
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
                                energy=_array(row["energy"], n), momentum=_array(row["momentum"], n, m),
                                work=_array(row["work"], n) if row["work"] is not None else None)

    def open_trajectory(self, job_id: str) -> tuple[sqlite3.Connection, StoredTrajectory] | None:
        """A read-only connection holding a snapshot in which the job's trajectory exists, and where it is.
        The caller reads the blobs through it (incremental I/O) and closes it."""
        connection = sqlite3.connect(f"{self.path.resolve().as_uri()}?mode=ro", uri=True, timeout=30.0,
                                     check_same_thread=False)  # used by one response, one piece at a time
        try:
            connection.execute("BEGIN")  # the snapshot: later deletions do not cut the body short
            row = connection.execute("SELECT rowid, points, dim, momenta, work IS NOT NULL FROM trajectories "
                                     "WHERE job_id = ?", (job_id,)).fetchone()
        except BaseException:
            connection.close()
            raise
        if row is None:
            connection.close()
            return None
        return connection, StoredTrajectory(*row[:4], has_work=bool(row[4]))

    # ---- state changes ----

    def create(self, spec: dict[str, Any], max_queued: int | None = None) -> JobRecord | None:
        """A new queued job; None (nothing written) when max_queued jobs are already queued."""
        job_id, text, created_at = uuid.uuid4().hex, json.dumps(spec), _now()
        with self._transaction() as db:
            # Count and insert in one statement, under the write lock: concurrent submissions
            # cannot all see room for one more.
            inserted = db.execute(
                "INSERT INTO jobs (id, status, spec, created_at) SELECT ?, 'queued', ?, ? "
                "WHERE ? IS NULL OR (SELECT COUNT(*) FROM jobs WHERE status = 'queued') < ?",
                (job_id, text, created_at, max_queued, max_queued)).rowcount
        if not inserted:
            return None
        # The row as written, without reading it back (one query fewer on the submission path).
        return JobRecord(id=job_id, status="queued", spec=json.loads(text), progress=0.0, attempts=0,
                         cancel_requested=False, summary=None, error=None, failed_step=None, created_at=created_at,
                         started_at=None, finished_at=None, has_trajectory=False)

    def delete_finished(self, job_id: str) -> bool:
        """Remove a finished job and its trajectory; False if it is not (or no longer) finished."""
        with self._transaction() as db:
            deleted = db.execute(f"DELETE FROM jobs WHERE id = ? AND status IN {_FINAL_SQL}", (job_id,)).rowcount
        if deleted:
            self._give_back_space()
        return bool(deleted)

    def stored_bytes(self) -> int:
        """Bytes of trajectory data held (the arrays; SQLite's own overhead is small beside them)."""
        return self._connection().execute(f"SELECT COALESCE(SUM({_TRAJECTORY_BYTES}), 0) FROM trajectories t"
                                          ).fetchone()[0]

    def prune(self, *, max_jobs: int = 0, max_age_seconds: float = 0, max_bytes: int = 0) -> int:
        """Remove finished jobs, oldest first, until every given bound (0 = none) holds; returns how many."""
        if self._space_pending:
            self._give_back_space()
        if not (max_jobs or max_age_seconds or max_bytes):
            return 0
        # The common case, every bound held, decided by one aggregate in SQLite (which runs without
        # the GIL) rather than by a Python loop over every finished job once a second.
        count, total, oldest = self._connection().execute(
            f"SELECT COUNT(*), COALESCE(SUM({_TRAJECTORY_BYTES}), 0), MIN(j.finished_at) FROM jobs j "
            f"LEFT JOIN trajectories t ON t.job_id = j.id WHERE j.status IN {_FINAL_SQL}").fetchone()
        cutoff = (datetime.now(timezone.utc).timestamp() - max_age_seconds) if max_age_seconds else None
        if not ((max_jobs and count > max_jobs) or (max_bytes and total > max_bytes) or (
                cutoff is not None and oldest is not None and datetime.fromisoformat(oldest).timestamp() < cutoff)):
            return 0
        rows = self._connection().execute(
            f"SELECT j.id, j.finished_at, COALESCE({_TRAJECTORY_BYTES}, 0) AS bytes FROM jobs j "
            f"LEFT JOIN trajectories t ON t.job_id = j.id WHERE j.status IN {_FINAL_SQL} "
            "ORDER BY j.finished_at DESC, j.seq DESC").fetchall()  # newest first: the ones kept
        doomed, kept, kept_bytes, full = [], 0, 0, False
        for row in rows:
            too_old = cutoff is not None and datetime.fromisoformat(row["finished_at"]).timestamp() < cutoff
            # Once a bound is reached every older job goes, so what is kept is always the newest.
            full = full or bool(max_jobs and kept >= max_jobs) or bool(
                max_bytes and kept_bytes + row["bytes"] > max_bytes)
            if full or too_old:
                doomed.append(row["id"])
            else:
                kept, kept_bytes = kept + 1, kept_bytes + row["bytes"]
        if doomed:
            with self._transaction() as db:
                db.executemany(f"DELETE FROM jobs WHERE id = ? AND status IN {_FINAL_SQL}",
                               [(job_id,) for job_id in doomed])
            self._give_back_space()
        return len(doomed)

    def _give_back_space(self) -> None:
        """Return freed pages to the file system, and fold the WAL back so the file really shrinks."""
        connection = self._connection()
        with self._write_lock:
            connection.executescript("PRAGMA incremental_vacuum;")  # execute() would free one page per call
        # TRUNCATE waits for the readers of older snapshots; a client streaming a trajectory may hold
        # one for seconds, and other writers would wait as long. So wait briefly, and if readers
        # remain, leave it to the next retention pass.
        connection.execute("PRAGMA busy_timeout = 200")
        try:
            busy = connection.execute("PRAGMA wal_checkpoint(TRUNCATE)").fetchone()[0]
        finally:
            connection.execute("PRAGMA busy_timeout = 30000")
        self._space_pending = bool(busy)

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
                db.execute("INSERT OR REPLACE INTO trajectories (job_id, points, dim, momenta, t, q, p, energy, "
                           "momentum, work) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                           (job_id, n, dim, trajectory.momentum.shape[1], _blob(trajectory.t), _blob(trajectory.q),
                            _blob(trajectory.p), _blob(trajectory.energy), _blob(trajectory.momentum),
                            _blob(trajectory.work) if trajectory.work is not None else None))
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

    # ---- uploaded files ----

    def add_file(self, name: str, content: bytes, shape: tuple[int, int], nnz: int,
                 max_total_bytes: int = 0) -> FileRecord | None:
        """Store an upload; None (nothing written) when it would take the files past max_total_bytes (0: no bound)."""
        file_id, created_at = uuid.uuid4().hex, _now()
        with self._transaction() as db:
            # Checked and inserted in one statement, under the write lock, as create() does for the queue.
            inserted = db.execute(
                "INSERT INTO files (id, name, bytes, rows, cols, nnz, created_at, content) "
                "SELECT ?, ?, ?, ?, ?, ?, ?, ? WHERE ? = 0 OR (SELECT COALESCE(SUM(bytes), 0) FROM files) + ? <= ?",
                (file_id, name, len(content), *shape, nnz, created_at, content, max_total_bytes, len(content),
                 max_total_bytes)).rowcount
        if not inserted:
            return None
        return FileRecord(id=file_id, name=name, bytes=len(content), shape=tuple(shape), nnz=nnz,
                          created_at=created_at)

    def file(self, file_id: str) -> FileRecord | None:
        row = self._connection().execute(f"SELECT {_FILE_COLUMNS} FROM files WHERE id = ?", (file_id,)).fetchone()
        return _file_record(row) if row else None

    def files(self, limit: int) -> list[FileRecord]:
        """Newest first."""
        rows = self._connection().execute(f"SELECT {_FILE_COLUMNS} FROM files ORDER BY seq DESC LIMIT ?",
                                          (limit,)).fetchall()
        return [_file_record(row) for row in rows]

    def file_content(self, file_id: str) -> bytes | None:
        row = self._connection().execute("SELECT content FROM files WHERE id = ?", (file_id,)).fetchone()
        return bytes(row[0]) if row else None

    def delete_file(self, file_id: str) -> str:
        """"deleted", "missing", or "in_use" when a queued or running job refers to it (then nothing changes).

        One statement: a job that names the file and is still to run keeps it, so a run never loses its
        matrix. Specs are stored as JSON, where the id appears as the string "<id>"."""
        with self._transaction() as db:
            deleted = db.execute(
                f"DELETE FROM files WHERE id = ? AND NOT EXISTS (SELECT 1 FROM jobs WHERE status IN "
                f"{_UNFINISHED_SQL} AND instr(spec, ?) > 0)", (file_id, f'"{file_id}"')).rowcount
            exists = not deleted and db.execute("SELECT 1 FROM files WHERE id = ?", (file_id,)).fetchone()
        if deleted:
            self._give_back_space()
            return "deleted"
        return "in_use" if exists else "missing"

    def jobs_using_file(self, file_id: str, limit: int = 10) -> list[str]:
        """Ids of queued or running jobs whose spec names the file."""
        rows = self._connection().execute(
            f"SELECT id FROM jobs WHERE status IN {_UNFINISHED_SQL} AND instr(spec, ?) > 0 ORDER BY seq LIMIT ?",
            (f'"{file_id}"', limit)).fetchall()
        return [row["id"] for row in rows]

    def recover(self) -> list[str]:
        """At startup: runs a previous process left behind are queued again. Returns the queue, oldest first."""
        with self._transaction() as db:
            # A cancel was asked for before the process died: honour it rather than run again.
            db.execute("UPDATE jobs SET status = 'cancelled', finished_at = ?, "
                       "error = 'cancelled; the service stopped before the run did' "
                       "WHERE status = 'running' AND cancel_requested = 1", (_now(),))
            db.execute("UPDATE jobs SET status = 'queued', started_at = NULL, progress = 0 WHERE status = 'running'")
            return [row["id"] for row in db.execute("SELECT id FROM jobs WHERE status = 'queued' ORDER BY seq")]
