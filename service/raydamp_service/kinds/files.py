"""Uploaded files: their table (matrices and records, kept as uploaded), handed to raydamp parsed once."""

from __future__ import annotations

import functools
import io
import sqlite3
import uuid
from dataclasses import dataclass, replace
from typing import BinaryIO

from ..checks.uploads import ParsedFiles, RecordFileInfo
from ..tasks.store import UNFINISHED_SQL, Database, now

__all__ = ["FILES_TABLE", "FILE_COLUMNS_ADDED", "FileRecord", "FileStore"]

# Columns a files table from before records lacks (JobStore._upgrade adds them); format: records.FORMATS.
FILE_COLUMNS_ADDED = {"kind": "TEXT NOT NULL DEFAULT 'matrix'", "format": "TEXT NOT NULL DEFAULT 'mtx'",
                      "t_start": "REAL", "t_end": "REAL", "dt": "REAL"}
_PIECE = 1 << 20  # bytes of an upload written at once
FILES_TABLE = f"""
CREATE TABLE IF NOT EXISTS files (seq INTEGER PRIMARY KEY AUTOINCREMENT, id TEXT NOT NULL UNIQUE, name TEXT NOT NULL,
    bytes INTEGER NOT NULL, rows INTEGER NOT NULL, cols INTEGER NOT NULL, nnz INTEGER NOT NULL,
    created_at TEXT NOT NULL, content BLOB NOT NULL,
    {", ".join(f"{column} {declaration}" for column, declaration in FILE_COLUMNS_ADDED.items())});
"""


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
    values = dict(row)
    return FileRecord(shape=(values.pop("rows"), values.pop("cols")), **values)


class FileStore:
    """The uploads, in the database of the task store this is mixed into (jobs.JobStore)."""

    db: Database
    TABLE: str
    PARSED_ENTRIES = 20_000_000  # stored entries kept parsed (about 240 MB as CSC) across uploads

    @functools.cached_property
    def parsed_files(self) -> ParsedFiles:
        """files(id) for raydamp.jobs.build_job: a stored upload, parsed once (an unknown id: ValueError)."""
        return ParsedFiles(self, self.PARSED_ENTRIES)

    def add_file(self, name: str, content: bytes | BinaryIO, shape: tuple[int, int] = (0, 0), nnz: int = 0,
                 max_total_bytes: int = 0, *, record: RecordFileInfo | None = None) -> FileRecord | None:
        """Store an upload (bytes or a file, written a piece at a time); None (nothing written) past max_total_bytes."""
        content = io.BytesIO(content) if isinstance(content, bytes) else content
        size = content.seek(0, io.SEEK_END)
        file = FileRecord(id=uuid.uuid4().hex, name=name, bytes=size, shape=tuple(shape), nnz=nnz, created_at=now())
        if record is not None:
            file = replace(file, shape=(record.samples, record.columns), nnz=0, kind="record", format=record.format,
                           t_start=record.t_start, t_end=record.t_end, dt=record.dt)
        with self.db.transaction() as db:
            # VALUES' zeroblob is written page by page (INSERT ... SELECT builds it in memory), then filled piecewise.
            stored = db.execute("SELECT COALESCE(SUM(bytes), 0) FROM files").fetchone()[0]
            if max_total_bytes and stored + size > max_total_bytes:
                return None
            row = db.execute(
                f"INSERT INTO files ({_FILE_COLUMNS}, content) VALUES ({', '.join('?' * 12)}, zeroblob(?))",
                (file.id, name, size, *file.shape, file.nnz, file.created_at, file.kind, file.format, file.t_start,
                 file.t_end, file.dt, size))
            with db.blobopen("files", "content", row.lastrowid) as blob:
                content.seek(0)
                while piece := content.read(_PIECE):
                    blob.write(piece)
        return file

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

    def file_exists(self, file_id: str) -> bool:
        return self.db.connection().execute("SELECT 1 FROM files WHERE id = ?", (file_id,)).fetchone() is not None

    def delete_file(self, file_id: str) -> str:
        """"deleted", "missing", or "in_use" when a queued or running job names it (as the JSON string "<id>"),
        checked in the DELETE itself: a run never loses its file."""
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

