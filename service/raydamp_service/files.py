"""Uploaded Matrix Market files: checking an upload, storing it, and handing stored ones to raydamp.

An upload is read as Matrix Market by scipy (what raydamp.LinearStructure reads too), after its
header has been checked against the file's size: the reader allocates what the header announces,
so a 100-byte file claiming 10^9 entries must be refused before it is read, not after.
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

from raydamp.systems.structure import read_matrix

from .store import UNFINISHED_SQL, Database, now

__all__ = ["FILES_TABLE", "FileRecord", "FileStore", "MatrixFileError", "MatrixFileInfo", "check_matrix_market",
           "file_resolver", "ParsedFiles"]

FILES_TABLE = """
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

# The shortest line an entry can take: "1 1\n" (pattern), and "1\n" for a dense (array) file.
_MIN_COORDINATE_LINE = 4
_MIN_ARRAY_LINE = 2


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


class MatrixFileError(ValueError):
    """An upload that is not a Matrix Market file this service can use; the message says why."""


@dataclass(frozen=True)
class MatrixFileInfo:
    shape: tuple[int, int]
    nnz: int


def check_matrix_market(content: bytes, *, max_dim: int) -> MatrixFileInfo:
    """Read the upload as Matrix Market: a real (or integer, or pattern) square matrix of at most max_dim
    rows with finite entries. Raises MatrixFileError saying what is wrong."""
    import numpy as np
    import scipy.io
    import scipy.sparse

    try:
        rows, cols, entries, layout, field, _ = scipy.io.mminfo(io.BytesIO(content))
    except Exception as error:  # noqa: BLE001 - the reader's own words: "Missing banner", ...
        raise MatrixFileError(f"not a Matrix Market file: {error}") from None
    if field == "complex":
        raise MatrixFileError("a complex matrix; M and K must be real")
    if rows != cols:
        raise MatrixFileError(f"the matrix is {rows} x {cols}; M and K must be square")
    if rows > max_dim:
        raise MatrixFileError(f"the matrix is {rows} x {cols}; this service runs structures of at most "
                              f"max_structure_dim = {max_dim} coordinates")
    announced = entries if layout == "coordinate" else rows * cols
    shortest = _MIN_COORDINATE_LINE if layout == "coordinate" else _MIN_ARRAY_LINE
    if announced > len(content) // shortest:
        raise MatrixFileError(f"the header announces {announced} entries, more than a file of {len(content)} "
                              "bytes can hold")
    try:
        matrix = scipy.io.mmread(io.BytesIO(content))
    except Exception as error:  # noqa: BLE001
        raise MatrixFileError(f"cannot read it as Matrix Market: {error}") from None
    values = matrix.data if scipy.sparse.issparse(matrix) else np.asarray(matrix)
    if values.dtype.kind not in "biuf" or not np.isfinite(values).all():
        raise MatrixFileError("the entries must be finite real numbers")
    nnz = int(matrix.nnz) if scipy.sparse.issparse(matrix) else int(np.count_nonzero(values))
    return MatrixFileInfo(shape=(int(rows), int(cols)), nnz=nnz)


class FileStore:
    """The uploads, in the database of the task store this is mixed into (jobs.JobStore): a file that one of
    its tasks still to run names cannot be removed."""

    db: Database
    TABLE: str
    PARSED_ENTRIES = 20_000_000  # stored entries kept parsed (about 240 MB as CSC) across uploads

    @functools.cached_property
    def parsed_files(self) -> ParsedFiles:
        return ParsedFiles(self, self.PARSED_ENTRIES)

    def add_file(self, name: str, content: bytes, shape: tuple[int, int], nnz: int,
                 max_total_bytes: int = 0) -> FileRecord | None:
        """Store an upload; None (nothing written) when it would take the files past max_total_bytes (0: no bound)."""
        record = FileRecord(id=uuid.uuid4().hex, name=name, bytes=len(content), shape=tuple(shape), nnz=nnz,
                            created_at=now())
        with self.db.transaction() as db:
            # Checked and inserted in one statement, under the write lock, as create() does for the queue.
            inserted = db.execute(
                "INSERT INTO files (id, name, bytes, rows, cols, nnz, created_at, content) "
                "SELECT ?, ?, ?, ?, ?, ?, ?, ? WHERE ? = 0 OR (SELECT COALESCE(SUM(bytes), 0) FROM files) + ? <= ?",
                (record.id, name, len(content), *shape, nnz, record.created_at, content, max_total_bytes,
                 len(content), max_total_bytes)).rowcount
        return record if inserted else None

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
    A parse in progress is waited for, not repeated; at most max_entries stored entries are kept,
    the least recently used dropped first."""

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
                matrix = read_matrix(io.BytesIO(content))
                with self._lock:
                    self._parsed[file_id] = (lock, matrix)
                    self._size[file_id] = matrix.nnz
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


def file_resolver(store: FileStore) -> Callable[[str], Any]:
    """files(ref) for raydamp.LinearStructure.from_dict: a stored upload, parsed once (the store's
    ParsedFiles); an unknown id is a ValueError that raydamp reports at the matrix's path (system.K.file)."""
    return store.parsed_files
