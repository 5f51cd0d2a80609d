"""Uploaded files: checking an upload, storing it, and handing stored ones to raydamp.

Two kinds. A matrix (Matrix Market, for a linear structure's M or K) is read by raydamp's reader
(raydamp.systems.structure.read_matrix), which checks the header against the file's size before it reads
(raydamp.systems.matrix_market); the service adds only its limit on the matrix's size. A record (a PEER
.AT2 record, text columns t, value, or a .npy array; one column of values serves as a vector too, for an
initial state) is read by raydamp's own reader
(raydamp.loads.records.parse_record), which checks everything a load needs of it. The kind and format
come from the name's suffix and the content (records.record_format); a stored file is read again by its
content alone, which the upload made sure agrees.
"""

from __future__ import annotations

import functools
import io
import sqlite3
import threading
import uuid
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from raydamp.loads.records import describe_record, parse_record, record_format
from raydamp.systems.matrix_market import read_header
from raydamp.systems.structure import read_matrix

from .store import UNFINISHED_SQL, Database, now

__all__ = ["FILES_TABLE", "FILE_COLUMNS_ADDED", "FileRecord", "FileStore", "UploadError",
           "MatrixFileInfo", "RecordFileInfo", "check_matrix_market", "check_record", "check_upload", "file_resolver",
           "ParsedFiles"]

FILES_TABLE = """
CREATE TABLE IF NOT EXISTS files (          -- uploads: a structure's {"file": id}, a load's {"file": {"id": id}}
    seq INTEGER PRIMARY KEY AUTOINCREMENT,
    id TEXT NOT NULL UNIQUE,
    name TEXT NOT NULL,
    bytes INTEGER NOT NULL,
    rows INTEGER NOT NULL, cols INTEGER NOT NULL, nnz INTEGER NOT NULL,  -- a record: samples, columns, 0
    created_at TEXT NOT NULL,
    content BLOB NOT NULL,                  -- the file as uploaded
    kind TEXT NOT NULL DEFAULT 'matrix',    -- matrix or record
    format TEXT NOT NULL DEFAULT 'mtx',     -- mtx, at2, npy or columns (raydamp.loads.records.FORMATS)
    t_start REAL, t_end REAL, dt REAL       -- a record's time range and uniform sample interval
);
"""
# Columns a files table from before records lacks (JobStore._upgrade adds them).
FILE_COLUMNS_ADDED = {"kind": "TEXT NOT NULL DEFAULT 'matrix'", "format": "TEXT NOT NULL DEFAULT 'mtx'",
                      "t_start": "REAL", "t_end": "REAL", "dt": "REAL"}


@dataclass(frozen=True)
class FileRecord:
    """A stored upload. shape and nnz: a matrix's; a record's shape is (samples, columns)."""

    id: str
    name: str
    bytes: int
    shape: tuple[int, int]
    nnz: int
    created_at: str
    kind: str = "matrix"
    format: str = "mtx"
    t_start: float | None = None
    t_end: float | None = None
    dt: float | None = None


_FILE_COLUMNS = "id, name, bytes, rows, cols, nnz, created_at, kind, format, t_start, t_end, dt"


def _file_record(row: sqlite3.Row) -> FileRecord:
    return FileRecord(id=row["id"], name=row["name"], bytes=row["bytes"], shape=(row["rows"], row["cols"]),
                      nnz=row["nnz"], created_at=row["created_at"], kind=row["kind"], format=row["format"],
                      t_start=row["t_start"], t_end=row["t_end"], dt=row["dt"])


class UploadError(ValueError):
    """An upload that is not a file this service can use; the message says why."""


@dataclass(frozen=True)
class MatrixFileInfo:
    shape: tuple[int, int]
    nnz: int


@dataclass(frozen=True)
class RecordFileInfo:
    """A record's listing: its format, samples and columns (1: values only; 2: t, value), time range, dt."""

    format: str
    samples: int
    columns: int
    t_start: float | None
    t_end: float | None
    dt: float | None


def check_record(content: bytes, name: str) -> RecordFileInfo:
    """Read the upload as raydamp reads a load's record; raises UploadError with raydamp's reason (wrong NPTS,
    a value that is not a number, DT <= 0, times not increasing, a value that is not finite)."""
    try:
        record, fmt = parse_record(content, name=name)
    except ValueError as error:
        raise UploadError(f"not a record raydamp can read: {error}") from None
    described = describe_record(record)
    return RecordFileInfo(format=fmt, samples=described["samples"], columns=1 if record.t is None else 2,
                          t_start=described["t_start"], t_end=described["t_end"], dt=described["dt"])


def check_upload(content: bytes, name: str, *, max_dim: int) -> MatrixFileInfo | RecordFileInfo:
    """A matrix or a record, told apart by the name's suffix (.mtx, .AT2, .npy) and the content."""
    if record_format(content, name) == "mtx":
        return check_matrix_market(content, max_dim=max_dim, name=name)
    return check_record(content, name)


def check_matrix_market(content: bytes, *, max_dim: int, name: str = "the matrix") -> MatrixFileInfo:
    """Read the upload as raydamp reads a structure's M or K (a real square matrix with finite entries, its
    header first checked against the file's size), once the header shows at most max_dim rows. Raises
    UploadError with raydamp's reason or the limit."""
    try:
        rows, cols = read_header(content, name).shape
        if max(rows, cols) > max_dim:
            raise UploadError(f"the matrix is {rows} x {cols}; this service runs structures of at most "
                              f"max_structure_dim = {max_dim} coordinates")
        matrix = read_matrix(io.BytesIO(content), name)
    except UploadError:
        raise
    except ValueError as error:
        raise UploadError(str(error)) from None
    return MatrixFileInfo(shape=matrix.shape, nnz=int(matrix.nnz))


class FileStore:
    """The uploads, in the database of the task store this is mixed into (jobs.JobStore): a file that one of
    its tasks still to run names cannot be removed."""

    db: Database
    TABLE: str
    PARSED_ENTRIES = 20_000_000  # stored entries kept parsed (about 240 MB as CSC) across uploads

    @functools.cached_property
    def parsed_files(self) -> ParsedFiles:
        return ParsedFiles(self, self.PARSED_ENTRIES)

    def add_file(self, name: str, content: bytes, shape: tuple[int, int] = (0, 0), nnz: int = 0,
                 max_total_bytes: int = 0, *, record: RecordFileInfo | None = None) -> FileRecord | None:
        """Store an upload: a matrix (its shape and nnz) or a record; None (nothing written) when it would take
        the files past max_total_bytes (0: no bound)."""
        if record is not None:
            file = FileRecord(id=uuid.uuid4().hex, name=name, bytes=len(content), shape=(record.samples, record.columns),
                              nnz=0, created_at=now(), kind="record", format=record.format, t_start=record.t_start,
                              t_end=record.t_end, dt=record.dt)
        else:
            file = FileRecord(id=uuid.uuid4().hex, name=name, bytes=len(content), shape=tuple(shape), nnz=nnz,
                              created_at=now())
        with self.db.transaction() as db:
            # Checked and inserted in one statement, under the write lock, as create() does for the queue.
            inserted = db.execute(
                "INSERT INTO files (id, name, bytes, rows, cols, nnz, created_at, content, kind, format, t_start, "
                "t_end, dt) SELECT ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ? "
                "WHERE ? = 0 OR (SELECT COALESCE(SUM(bytes), 0) FROM files) + ? <= ?",
                (file.id, name, len(content), *file.shape, file.nnz, file.created_at, content, file.kind, file.format,
                 file.t_start, file.t_end, file.dt, max_total_bytes, len(content), max_total_bytes)).rowcount
        return file if inserted else None

    def file(self, file_id: str) -> FileRecord | None:
        row = self.db.connection().execute(f"SELECT {_FILE_COLUMNS} FROM files WHERE id = ?", (file_id,)).fetchone()
        return _file_record(row) if row else None

    def files(self, limit: int) -> list[FileRecord]:
        """Newest first."""
        rows = self.db.connection().execute(f"SELECT {_FILE_COLUMNS} FROM files ORDER BY seq DESC LIMIT ?",
                                            (limit,)).fetchall()
        return [_file_record(row) for row in rows]

    def file_content(self, file_id: str) -> bytes | None:
        row = self.db.connection().execute("SELECT content FROM files WHERE id = ?", (file_id,)).fetchone()
        return bytes(row[0]) if row else None

    def delete_file(self, file_id: str) -> str:
        """"deleted", "missing", or "in_use" when a queued or running job refers to it (then nothing changes).

        One statement: a job that names the file and is still to run keeps it, so a run never loses its
        matrix. Specs are stored as JSON, where the id appears as the string "<id>"."""
        with self.db.transaction() as db:
            deleted = db.execute(
                f"DELETE FROM files WHERE id = ? AND NOT EXISTS (SELECT 1 FROM {self.TABLE} WHERE status IN "
                f"{UNFINISHED_SQL} AND instr(spec, ?) > 0)", (file_id, f'"{file_id}"')).rowcount
            exists = not deleted and db.execute("SELECT 1 FROM files WHERE id = ?", (file_id,)).fetchone()
        if deleted:
            self.parsed_files.forget(file_id)
            self.db.give_back_space()
            return "deleted"
        return "in_use" if exists else "missing"

    def jobs_using_file(self, file_id: str, limit: int = 10) -> list[str]:
        """Ids of queued or running jobs whose spec names the file."""
        rows = self.db.connection().execute(
            f"SELECT id FROM {self.TABLE} WHERE status IN {UNFINISHED_SQL} AND instr(spec, ?) > 0 "
            "ORDER BY seq LIMIT ?", (f'"{file_id}"', limit)).fetchall()
        return [row["id"] for row in rows]


class ParsedFiles:
    """Uploaded files as raydamp reads them, parsed once per id (an upload never changes): eight
    submissions naming one 46 MB file parsed it eight times, 10-13 s each and 2.3 GB (issue 27, F4).
    A matrix is a scipy.sparse matrix; a record its (t, values), t None for one column of values.
    A parse in progress is waited for, not repeated; at most max_entries stored entries (a matrix's
    nonzeros, a record's numbers) are kept, the least recently used dropped first."""

    def __init__(self, store: FileStore, max_entries: int):
        self._store, self._max = store, max_entries
        self._lock = threading.Lock()
        self._parsed: OrderedDict[str, tuple[threading.Lock, Any]] = OrderedDict()
        self._size: dict[str, int] = {}

    def __call__(self, file_id: str) -> Any:
        with self._lock:
            entry = self._parsed.get(file_id)
            if entry is None:
                entry = self._parsed[file_id] = (threading.Lock(), None)
            self._parsed.move_to_end(file_id)
        lock, _ = entry
        with lock:  # one parse per id; the others wait for it
            matrix = self._parsed.get(file_id, (None, None))[1]
            if matrix is None:
                content = self._store.file_content(file_id)
                if content is None:
                    with self._lock:
                        self._parsed.pop(file_id, None)
                    raise ValueError(f"no uploaded file with id {file_id!r} (POST /v1/files uploads one, GET "
                                     "/v1/files lists them)")
                try:
                    matrix = _parse(content, file_id)
                except BaseException:
                    with self._lock:
                        self._parsed.pop(file_id, None)
                    raise
                with self._lock:
                    self._parsed[file_id] = (lock, matrix)
                    self._size[file_id] = _entries(matrix)
                    self._evict()
        return matrix

    def forget(self, file_id: str) -> None:
        with self._lock:
            self._parsed.pop(file_id, None)
            self._size.pop(file_id, None)

    def _evict(self) -> None:
        while sum(self._size.values()) > self._max and len(self._parsed) > 1:
            oldest = next(iter(self._parsed))
            self._parsed.pop(oldest)
            self._size.pop(oldest, None)


def _parse(content: bytes, file_id: str) -> Any:
    """A stored upload as raydamp takes it, by its content (which the upload checked agrees with its name)."""
    if record_format(content) == "mtx":
        return read_matrix(io.BytesIO(content))
    return parse_record(content, source=f"file {file_id}")[0]


def _entries(parsed: Any) -> int:
    if isinstance(parsed, tuple):
        return sum(part.size for part in parsed if part is not None)
    return parsed.nnz


def file_resolver(store: FileStore) -> Callable[[str], Any]:
    """files(ref) for raydamp's job (raydamp.jobs.build_job): a stored upload, parsed once (the store's
    ParsedFiles): a matrix for a structure's M or K, a record's (t, values) for a load's or ground motion's
    {"file": {"id": ...}}, a one-column record's values for an initial state's {"file": id}. An unknown id
    is a ValueError that raydamp reports at the path that names it (system.K.file, load.file.id, ...)."""
    return store.parsed_files
