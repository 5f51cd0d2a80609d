"""The SQLite store: one table per kind of task (kinds/), one lifecycle (queued -> running -> completed | failed |
cancelled). Every state change is one UPDATE guarded by the state it expects: a cancel and a claim cannot both win."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import sqlite3
import threading
import uuid
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, ClassVar, Generic, TypeVar

from pydantic import BaseModel, ValidationError

__all__ = ["Database", "TaskStore", "TaskRecord", "StoreUnavailable", "FileGone", "FINAL_STATUSES", "UNFINISHED_SQL",
           "normalise_stored", "now"]

FINAL_STATUSES = frozenset({"completed", "failed", "cancelled"})
_FINAL_SQL = "('completed', 'failed', 'cancelled')"
UNFINISHED_SQL = "('queued', 'running')"
_INCREMENTAL = 2  # PRAGMA auto_vacuum value
MIN_SQLITE = (3, 35)
# The lifecycle's columns in every kind's table. seq: submission order; spec: the validated spec as JSON.
_LIFECYCLE = """seq INTEGER PRIMARY KEY AUTOINCREMENT, id TEXT NOT NULL UNIQUE, status TEXT NOT NULL,
    spec TEXT NOT NULL, attempts INTEGER NOT NULL DEFAULT 0, cancel_requested INTEGER NOT NULL DEFAULT 0,
    error TEXT, created_at TEXT NOT NULL, started_at TEXT, finished_at TEXT"""


class StoreUnavailable(RuntimeError):
    """The database cannot be opened for writing; the message says what is wrong and what to do."""

    def __init__(self, path: Path, error: BaseException):
        reason = str(error) or type(error).__name__
        if isinstance(error, sqlite3.NotSupportedError):
            advice = "run it with a Python whose sqlite3 module links a newer SQLite"
        elif isinstance(error, sqlite3.DatabaseError) and "not a database" in reason:
            advice = "the file is corrupt or not SQLite: move it aside, or set RAYDAMP_DB to another file"
        elif "readonly" in reason.replace("-", "").replace(" ", "") or isinstance(error, PermissionError):
            advice = "the service must be able to write it and its directory: fix the permissions or set RAYDAMP_DB"
        else:
            advice = "check the path and the disk, or set RAYDAMP_DB to another file"
        super().__init__(f"cannot use the job database {path}: {reason}; {advice}")


def now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="microseconds")


class Database:
    """One SQLite file, shared by the stores of every kind: a connection per thread, one writer at a time."""

    def __init__(self, path: Path | str):
        self.path = Path(path)
        self._local = threading.local()
        self._connections: list[sqlite3.Connection] = []
        self._lock = threading.Lock()
        self._write_lock = threading.Lock()
        self._space_pending = False  # freed pages not yet returned (a checkpoint met readers)

    def open(self, schema: str, upgrade: Callable[[sqlite3.Connection], None]) -> None:
        """Create or upgrade the tables and prove the file writable; StoreUnavailable saying what to do."""
        try:
            if sqlite3.sqlite_version_info < MIN_SQLITE:  # claim() is one UPDATE ... RETURNING
                raise sqlite3.NotSupportedError(f"SQLite {sqlite3.sqlite_version} is too old, the service needs "
                                                f"{'.'.join(map(str, MIN_SQLITE))} or newer")
            self.path.parent.mkdir(parents=True, exist_ok=True)
            connection = self.connection()
            if connection.execute("PRAGMA auto_vacuum").fetchone()[0] != _INCREMENTAL:
                # Before the first table (or by one VACUUM of an older file): removed tasks' pages can go back.
                connection.execute(f"PRAGMA auto_vacuum = {_INCREMENTAL}")
                connection.execute("VACUUM")
            with self.transaction() as db:
                db.executescript(schema + "CREATE TABLE IF NOT EXISTS service (key TEXT PRIMARY KEY, value TEXT);")
                upgrade(db)
                # A real write: a read-only file or directory fails here, not at the first task.
                db.execute("INSERT OR REPLACE INTO service (key, value) VALUES ('opened_at', ?)", (now(),))
        except (sqlite3.DatabaseError, OSError) as error:
            self.close()
            raise StoreUnavailable(self.path, error) from None

    def close(self) -> None:
        with self._lock:
            for connection in self._connections:
                connection.close()
            self._connections.clear()
        self._local = threading.local()

    def connection(self) -> sqlite3.Connection:
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
    def transaction(self) -> Iterator[sqlite3.Connection]:
        connection = self.connection()
        # One writer at a time: a lock wakes the next at once, where SQLITE_BUSY's handler sleeps up to 100 ms.
        with self._write_lock, connection:  # commits, or rolls back on an exception
            yield connection

    def snapshot(self, query: str, args: tuple) -> tuple[sqlite3.Connection, sqlite3.Row] | None:
        """A read-only snapshot connection and the row the query finds in it (None: no row); the caller closes it."""
        connection = sqlite3.connect(f"{self.path.resolve().as_uri()}?mode=ro", uri=True, timeout=30.0,
                                     check_same_thread=False)  # used by one response, one piece at a time
        try:
            connection.execute("BEGIN")  # the snapshot: later deletions do not cut the body short
            row = connection.execute(query, args).fetchone()
            if row is not None:
                return connection, row
        except BaseException:
            connection.close()
            raise
        connection.close()
        return None

    def give_back_space(self, *, pending_only: bool = False) -> None:
        """Return freed pages to the file system, and fold the WAL back so the file really shrinks."""
        if pending_only and not self._space_pending:
            return
        connection = self.connection()
        with self._write_lock:
            connection.executescript("PRAGMA incremental_vacuum;")  # execute() would free one page per call
        # TRUNCATE waits for older snapshots' readers (a stream's: seconds): briefly; the next retention pass retries.
        connection.execute("PRAGMA busy_timeout = 200")
        try:
            busy = connection.execute("PRAGMA wal_checkpoint(TRUNCATE)").fetchone()[0]
        finally:
            connection.execute("PRAGMA busy_timeout = 30000")
        self._space_pending = bool(busy)


def normalise_stored(db: sqlite3.Connection, table: str, model: type[BaseModel]) -> None:
    """Rewrite a table's specs as the model's JSON (views send them as stored) once per schema change; invalid: kept."""
    key = f"{table}.spec schema"
    schema = hashlib.sha256(json.dumps(model.model_json_schema(), sort_keys=True).encode()).hexdigest()
    if db.execute("SELECT 1 FROM service WHERE key = ? AND value = ?", (key, schema)).fetchone():
        return
    for (task_id,) in db.execute(f"SELECT id FROM {table}").fetchall():
        text = db.execute(f"SELECT spec FROM {table} WHERE id = ?", (task_id,)).fetchone()[0]
        try:
            normal = json.dumps(model.model_validate(json.loads(text)).model_dump(mode="json"))
        except (ValidationError, ValueError):
            continue
        if normal != text:
            db.execute(f"UPDATE {table} SET spec = ? WHERE id = ?", (normal, task_id))
    db.execute("INSERT OR REPLACE INTO service (key, value) VALUES (?, ?)", (key, schema))


class FileGone(LookupError):
    """An uploaded file a submission names was deleted between its check and its insert."""

    def __init__(self, file_id: str):
        super().__init__(f"the uploaded file {file_id} was deleted while this submission was being checked; "
                         "upload it again")


@dataclasses.dataclass(frozen=True, kw_only=True)
class TaskRecord:
    """A task's row: the lifecycle's columns, then the kind's (defaults: values at creation; dict: JSON, bool: 0/1)."""

    id: str
    status: str
    spec: dict[str, Any]
    attempts: int = 0
    cancel_requested: bool = False
    error: str | None = None
    created_at: str
    started_at: str | None = None
    finished_at: str | None = None


Record = TypeVar("Record", bound=TaskRecord)


class TaskStore(Generic[Record]):
    """The tasks of one kind: a table of the lifecycle's columns and the kind's own (a path: a database of its own)."""

    TABLE: ClassVar[str]
    COLUMNS: ClassVar[str]  # the kind's columns in SQL: name type, ...
    TABLES: ClassVar[str] = ""  # CREATE TABLE IF NOT EXISTS ... for tables of the kind's own
    RECORD: ClassVar[type[TaskRecord]]
    PROGRESS: ClassVar[str]  # the column of the kind's progress measure; 0 whenever a run starts
    COMPUTED: ClassVar[dict[str, str]] = {}  # record fields that are SQL expressions, not columns
    BYTES: ClassVar[str] = "0"  # SQL: the bytes a finished task keeps (retention's measure)
    RETAINED: ClassVar[bool] = False  # finished tasks are removed by the retention settings
    NOUN: ClassVar[str] = "run"  # what stopped with the service, in the message of a cancel honoured at recovery

    def __init__(self, database: Database | Path | str):
        self.db = database if isinstance(database, Database) else Database(database)
        self._requeued = f"status = 'queued', started_at = NULL, {self.PROGRESS} = 0"
        fields = dataclasses.fields(self.RECORD)
        self._columns = ", ".join(f"{self.COMPUTED[field.name]} AS {field.name}" if field.name in self.COMPUTED
                                  else field.name for field in fields)
        self._names = tuple(field.name for field in fields)
        self._json = tuple(field.name for field in fields if field.type.startswith("dict"))
        self._bool = tuple(field.name for field in fields if field.type == "bool")

    @property
    def path(self) -> Path:
        return self.db.path

    def open(self) -> None:
        self.db.open(f"CREATE TABLE IF NOT EXISTS {self.TABLE} (\n    {_LIFECYCLE},\n    {self.COLUMNS});\n"
                     f"CREATE INDEX IF NOT EXISTS {self.TABLE}_by_status ON {self.TABLE} (status, finished_at);\n"
                     f"{self.TABLES}", self._upgrade)

    def _upgrade(self, db: sqlite3.Connection) -> None:
        """Bring the kind's tables in a file written by an older service up to today's columns."""

    def close(self) -> None:
        self.db.close()

    def _record(self, row: sqlite3.Row) -> Record:
        """The record of a row selected as self._columns (the record's fields, in order)."""
        values = dict(zip(self._names, row))
        for name in self._json:
            if values[name] is not None:
                values[name] = json.loads(values[name])
        for name in self._bool:
            values[name] = bool(values[name])
        return self.RECORD(**values)

    def ping(self) -> None:
        self.db.connection().execute("SELECT 1").fetchone()

    def get(self, task_id: str) -> Record | None:
        row = self.db.connection().execute(f"SELECT {self._columns} FROM {self.TABLE} WHERE id = ?",
                                           (task_id,)).fetchone()
        return self._record(row) if row else None

    def recent(self, limit: int, status: str | None = None) -> list[Record]:
        """Newest first."""
        where, args = ("WHERE status = ?", (status,)) if status else ("", ())
        rows = self.db.connection().execute(
            f"SELECT {self._columns} FROM {self.TABLE} {where} ORDER BY seq DESC LIMIT ?", (*args, limit)).fetchall()
        return [self._record(row) for row in rows]

    def stored_bytes(self) -> int:
        """Bytes of results held (the arrays; SQLite's own overhead is small beside them)."""
        return self.db.connection().execute(f"SELECT COALESCE(SUM({self.BYTES}), 0) FROM {self.TABLE}").fetchone()[0]

    def create(self, spec: dict[str, Any], max_queued: int | None = None, *, files: tuple[str, ...] = (),
               **columns: Any) -> Record | None:
        """A new queued task; None (nothing written) if max_queued are queued; FileGone if an upload in `files` went."""
        values = {"id": uuid.uuid4().hex, "status": "queued", "spec": json.dumps(spec), "created_at": now(), **columns}
        with self.db.transaction() as db:  # counted and inserted under the write lock: the bound is exact
            if max_queued is not None and db.execute(
                    f"SELECT COUNT(*) FROM {self.TABLE} WHERE status = 'queued'").fetchone()[0] >= max_queued:
                return None
            for file_id in files:  # the check read them; a DELETE may have removed one since
                if db.execute("SELECT 1 FROM files WHERE id = ?", (file_id,)).fetchone() is None:
                    raise FileGone(file_id)
            db.execute(f"INSERT INTO {self.TABLE} ({', '.join(values)}) VALUES ({', '.join('?' * len(values))})",
                       tuple(values.values()))
        return self.RECORD(**{**values, "spec": spec})  # the row as written, its JSON not parsed back

    def _change(self, task_id: str, expected: str, changes: str, *args: Any,
                also: tuple[str, tuple] | None = None) -> bool:
        """One UPDATE guarded by the expected states (SQL: "('queued')"), with `also` if it changed the task: True."""
        with self.db.transaction() as db:
            changed = db.execute(f"UPDATE {self.TABLE} SET {changes} WHERE id = ? AND status IN {expected}",
                                 (*args, task_id)).rowcount
            if changed and also is not None:
                db.execute(*also)
        return bool(changed)

    def claim(self, task_id: str) -> Record | None:
        """queued -> running, in one statement returning the row; None if no longer queued (cancelled)."""
        with self.db.transaction() as db:
            rows = db.execute(f"UPDATE {self.TABLE} SET status = 'running', started_at = ?, {self.PROGRESS} = 0, "
                              f"attempts = attempts + 1 WHERE id = ? AND status = 'queued' RETURNING {self._columns}",
                              (now(), task_id)).fetchall()  # every row read before the commit: none in progress
        return self._record(rows[0]) if rows else None

    def set_progress(self, task_id: str, progress: float) -> None:
        self._change(task_id, "('running')", f"{self.PROGRESS} = ?", progress)

    def finish(self, task_id: str, status: str, *, error: str | None = None, progress: float | None = None,
               also: tuple[str, tuple] | None = None, **columns: Any) -> bool:
        """Record the end of a run, its result in the kind's columns and `also`, all or none; True if it changed."""
        assert status in FINAL_STATUSES
        values = tuple(json.dumps(value) if isinstance(value, dict) else value for value in columns.values())
        changes = (f"status = ?, error = ?, finished_at = ?, {self.PROGRESS} = COALESCE(?, {self.PROGRESS})"
                   f"{''.join(f', {name} = ?' for name in columns)}")
        return self._change(task_id, UNFINISHED_SQL, changes, status, error, now(), progress, *values, also=also)

    def request_cancel(self, task_id: str) -> Record | None:
        """A queued task is cancelled at once; a running one is flagged (the runner stops it)."""
        if not self._change(task_id, "('queued')", "status = 'cancelled', cancel_requested = 1, finished_at = ?",
                            now()):
            self._change(task_id, "('running')", "cancel_requested = 1")
        return self.get(task_id)

    def requeue(self, task_id: str) -> None:
        """Hand a run interrupted by shutdown back to the queue, to run again from the start."""
        self._change(task_id, "('running')", self._requeued)

    def recover(self) -> list[str]:
        """At startup: runs a previous process left behind are queued again. Returns the queue, oldest first."""
        with self.db.transaction() as db:
            # A cancel was asked for before the process died: honour it rather than run again.
            db.execute(f"UPDATE {self.TABLE} SET status = 'cancelled', finished_at = ?, error = 'cancelled; the "
                       f"service stopped before the {self.NOUN} did' WHERE status = 'running' AND cancel_requested = 1",
                       (now(),))
            db.execute(f"UPDATE {self.TABLE} SET {self._requeued} WHERE status = 'running'")
            queued = db.execute(f"SELECT id FROM {self.TABLE} WHERE status = 'queued' ORDER BY seq").fetchall()
        return [row["id"] for row in queued]

    def delete_finished(self, task_id: str) -> bool:
        """Remove a finished task and its result; False if it is not (or no longer) finished."""
        return self._delete_finished([task_id]) == 1

    def _delete_finished(self, task_ids: list[str]) -> int:
        with self.db.transaction() as db:
            deleted = db.executemany(f"DELETE FROM {self.TABLE} WHERE id = ? AND status IN {_FINAL_SQL}",
                                     [(task_id,) for task_id in task_ids]).rowcount
        if deleted:
            self.db.give_back_space()
        return deleted

    def prune(self, *, max_jobs: int = 0, max_age_seconds: float = 0, max_bytes: int = 0) -> int:
        """Remove finished tasks, oldest first, until every given bound (0 = none) holds; returns how many."""
        self.db.give_back_space(pending_only=True)
        if not (max_jobs or max_age_seconds or max_bytes):
            return 0
        cutoff = (datetime.now(timezone.utc).timestamp() - max_age_seconds) if max_age_seconds else None

        def over(count: int, total: int, finished_at: str | None) -> bool:
            """Whether tasks this many, of these bytes, the oldest finished at finished_at, pass a bound."""
            return bool((max_jobs and count > max_jobs) or (max_bytes and total > max_bytes) or (cutoff is not None
                        and finished_at is not None and datetime.fromisoformat(finished_at).timestamp() < cutoff))

        finished = f"FROM {self.TABLE} WHERE status IN {_FINAL_SQL}"
        # The common case, every bound held, is one aggregate in SQLite, not a Python loop over every task.
        if not over(*self.db.connection().execute(
                f"SELECT COUNT(*), COALESCE(SUM({self.BYTES}), 0), MIN(finished_at) {finished}").fetchone()):
            return 0
        # Each task with itself and the newer ones: past a bound it goes and every older one too, so what is kept is
        # always the newest.
        rows = self.db.connection().execute(
            f"SELECT id, ROW_NUMBER() OVER newer, SUM(COALESCE({self.BYTES}, 0)) OVER newer, finished_at {finished} "
            "WINDOW newer AS (ORDER BY finished_at DESC, seq DESC)").fetchall()
        return self._delete_finished([row[0] for row in rows if over(*row[1:])])
