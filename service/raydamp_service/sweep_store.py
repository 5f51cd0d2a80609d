"""Sweeps in the job database: their specs, progress per chunk, outcomes, and the NetCDF result as
a blob. Same rules as the job store (store.py): every state change is one UPDATE guarded by the
state it expects, and a sweep left running by a dead process is queued again at the next start."""

from __future__ import annotations

import json
import sqlite3
import uuid
from dataclasses import dataclass
from typing import Any

from .store import FINAL_STATUSES, JobStore, _now

__all__ = ["SweepStore", "SweepRecord"]

_FINAL_SQL = "(" + ", ".join(f"'{s}'" for s in sorted(FINAL_STATUSES)) + ")"
_SCHEMA = """
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
_COLUMNS = ("id, status, spec, members, members_done, attempts, cancel_requested, outcomes, error, "
            "length(result) AS result_bytes, created_at, started_at, finished_at")


@dataclass(frozen=True)
class SweepRecord:
    id: str
    status: str
    spec: dict[str, Any]
    members: int
    members_done: int
    attempts: int
    cancel_requested: bool
    outcomes: dict[str, int] | None
    error: str | None
    result_bytes: int | None
    created_at: str
    started_at: str | None
    finished_at: str | None

    @classmethod
    def from_row(cls, row: sqlite3.Row) -> SweepRecord:
        return cls(id=row["id"], status=row["status"], spec=json.loads(row["spec"]), members=row["members"],
                   members_done=row["members_done"], attempts=row["attempts"],
                   cancel_requested=bool(row["cancel_requested"]),
                   outcomes=json.loads(row["outcomes"]) if row["outcomes"] else None, error=row["error"],
                   result_bytes=row["result_bytes"], created_at=row["created_at"], started_at=row["started_at"],
                   finished_at=row["finished_at"])


class SweepStore:
    """The sweeps table, on the job store's connections and write lock (one writer per process)."""

    def __init__(self, jobs: JobStore):
        self._jobs = jobs

    def open(self) -> None:
        with self._jobs._transaction() as db:
            db.executescript(_SCHEMA)

    def get(self, sweep_id: str) -> SweepRecord | None:
        row = self._jobs._connection().execute(f"SELECT {_COLUMNS} FROM sweeps WHERE id = ?", (sweep_id,)).fetchone()
        return SweepRecord.from_row(row) if row else None

    def recent(self, limit: int, status: str | None = None) -> list[SweepRecord]:
        where, args = ("WHERE status = ?", (status,)) if status else ("", ())
        rows = self._jobs._connection().execute(
            f"SELECT {_COLUMNS} FROM sweeps {where} ORDER BY seq DESC LIMIT ?", (*args, limit)).fetchall()
        return [SweepRecord.from_row(row) for row in rows]

    def result_handle(self, sweep_id: str):
        """(a read-only connection holding a snapshot, the blob's rowid) for streaming the result;
        None if there is no result. The caller closes the connection."""
        connection = sqlite3.connect(f"{self._jobs.path.resolve().as_uri()}?mode=ro", uri=True, timeout=30.0,
                                     check_same_thread=False)
        try:
            connection.execute("BEGIN")
            row = connection.execute("SELECT rowid, length(result) FROM sweeps WHERE id = ? AND result IS NOT NULL",
                                     (sweep_id,)).fetchone()
        except BaseException:
            connection.close()
            raise
        if row is None:
            connection.close()
            return None
        return connection, row[0], row[1]

    def create(self, spec: dict[str, Any], members: int, max_queued: int) -> SweepRecord | None:
        sweep_id, created_at = uuid.uuid4().hex, _now()
        with self._jobs._transaction() as db:
            inserted = db.execute(
                "INSERT INTO sweeps (id, status, spec, members, created_at) SELECT ?, 'queued', ?, ?, ? "
                "WHERE (SELECT COUNT(*) FROM sweeps WHERE status = 'queued') < ?",
                (sweep_id, json.dumps(spec), members, created_at, max_queued)).rowcount
        return self.get(sweep_id) if inserted else None

    def claim(self, sweep_id: str) -> SweepRecord | None:
        with self._jobs._transaction() as db:
            claimed = db.execute("UPDATE sweeps SET status = 'running', started_at = ?, members_done = 0, "
                                 "attempts = attempts + 1 WHERE id = ? AND status = 'queued'",
                                 (_now(), sweep_id)).rowcount
        return self.get(sweep_id) if claimed else None

    def set_done(self, sweep_id: str, members_done: int) -> None:
        with self._jobs._transaction() as db:
            db.execute("UPDATE sweeps SET members_done = ? WHERE id = ? AND status = 'running'",
                       (members_done, sweep_id))

    def finish(self, sweep_id: str, status: str, *, outcomes: dict[str, int] | None = None,
               error: str | None = None, result: bytes | None = None, members_done: int | None = None) -> None:
        assert status in FINAL_STATUSES
        with self._jobs._transaction() as db:
            db.execute("UPDATE sweeps SET status = ?, outcomes = ?, error = ?, result = ?, finished_at = ?, "
                       "members_done = COALESCE(?, members_done) WHERE id = ?",
                       (status, json.dumps(outcomes) if outcomes is not None else None, error, result, _now(),
                        members_done, sweep_id))

    def request_cancel(self, sweep_id: str) -> SweepRecord | None:
        with self._jobs._transaction() as db:
            cancelled = db.execute("UPDATE sweeps SET status = 'cancelled', cancel_requested = 1, finished_at = ? "
                                   "WHERE id = ? AND status = 'queued'", (_now(), sweep_id)).rowcount
            if not cancelled:
                db.execute("UPDATE sweeps SET cancel_requested = 1 WHERE id = ? AND status = 'running'", (sweep_id,))
        return self.get(sweep_id)

    def delete_finished(self, sweep_id: str) -> bool:
        with self._jobs._transaction() as db:
            deleted = db.execute(f"DELETE FROM sweeps WHERE id = ? AND status IN {_FINAL_SQL}", (sweep_id,)).rowcount
        if deleted:
            self._jobs._give_back_space()
        return bool(deleted)

    def requeue(self, sweep_id: str) -> None:
        with self._jobs._transaction() as db:
            db.execute("UPDATE sweeps SET status = 'queued', started_at = NULL, members_done = 0 "
                       "WHERE id = ? AND status = 'running'", (sweep_id,))

    def recover(self) -> list[str]:
        """At startup: sweeps a previous process left running are queued again (or cancelled, if asked)."""
        with self._jobs._transaction() as db:
            db.execute("UPDATE sweeps SET status = 'cancelled', finished_at = ?, "
                       "error = 'cancelled; the service stopped before the sweep did' "
                       "WHERE status = 'running' AND cancel_requested = 1", (_now(),))
            db.execute("UPDATE sweeps SET status = 'queued', started_at = NULL, members_done = 0 "
                       "WHERE status = 'running'")
            return [row["id"] for row in db.execute("SELECT id FROM sweeps WHERE status = 'queued' ORDER BY seq")]
