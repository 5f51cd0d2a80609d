"""Uploaded files as raydamp reads them: an upload's check (a matrix or a record), and ParsedFiles (parsed once)."""

from __future__ import annotations

import io
import threading
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from raydamp.loads.records import describe_record, parse_record, record_format
from raydamp.systems.matrix_market import read_header
from raydamp.systems.structure import read_matrix

__all__ = ["UploadError", "MatrixFileInfo", "RecordFileInfo", "check_upload_file", "ParsedFiles"]


class UploadError(ValueError):
    """An upload that is not a file this service can use; the message says why."""


@dataclass(frozen=True)
class MatrixFileInfo:
    shape: tuple[int, int]
    nnz: int


@dataclass(frozen=True)
class RecordFileInfo:
    """A record's listing; columns 1: values only, 2: t, value."""

    format: str
    samples: int
    columns: int
    t_start: float | None
    t_end: float | None
    dt: float | None


def check_upload_file(path: str, name: str, *, max_dim: int) -> MatrixFileInfo | RecordFileInfo:
    """The upload spooled at path read as raydamp will: a matrix (its header checked first: max_dim), or a record."""
    content = Path(path).read_bytes()
    try:
        if record_format(content, name) == "mtx":
            rows, cols = read_header(content, name).shape
            if max(rows, cols) > max_dim:
                raise UploadError(f"the matrix is {rows} x {cols}; this service runs structures of at most "
                                  f"max_structure_dim = {max_dim} coordinates")
            matrix = read_matrix(io.BytesIO(content), name)
            return MatrixFileInfo(shape=matrix.shape, nnz=int(matrix.nnz))
        try:
            record, fmt = parse_record(content, name=name)
        except ValueError as error:
            raise UploadError(f"not a record raydamp can read: {error}") from None
    except UploadError:
        raise
    except ValueError as error:
        raise UploadError(str(error)) from None
    described = describe_record(record)
    return RecordFileInfo(format=fmt, samples=described["samples"], columns=1 if record.t is None else 2,
                          t_start=described["t_start"], t_end=described["t_end"], dt=described["dt"])


class ParsedFiles:
    """Uploaded files as raydamp reads them (a scipy.sparse matrix; a record's (t, values)), parsed once per id (a
    parse in progress is waited for); at most max_entries stored entries, the least recently used dropped first."""

    def __init__(self, store: Any, max_entries: int):  # store.file_content(id): the bytes, or None; file_exists(id)
        self._store, self._max = store, max_entries
        self._lock = threading.Lock()
        self._parsed: OrderedDict[str, tuple[threading.Lock, Any]] = OrderedDict()
        self._size: dict[str, int] = {}

    def __call__(self, file_id: str) -> Any:
        with self._lock:
            lock, _ = self._parsed.setdefault(file_id, (threading.Lock(), None))
            self._parsed.move_to_end(file_id)
        with lock:  # one parse per id; the others wait for it
            matrix = self._parsed.get(file_id, (None, None))[1]
            if matrix is not None and not self._store.file_exists(file_id):
                # Deleted since it was parsed (a check process's cache is not told): a check must not pass on it.
                self.forget(file_id)
                matrix = None
            if matrix is None:
                content = self._store.file_content(file_id)
                if content is None:
                    self.forget(file_id)
                    raise ValueError(f"no uploaded file with id {file_id!r} (POST /v1/files uploads one, GET "
                                     "/v1/files lists them)")
                try:
                    matrix = _parse(content, file_id)
                except BaseException:
                    self.forget(file_id)
                    raise
                with self._lock:
                    if self._parsed.get(file_id, (None, None))[0] is lock:  # not forgotten meanwhile (deleted)
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
