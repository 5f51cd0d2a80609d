"""A stored trajectory as a JSON body (exactly the Trajectory schema), the saved points of a range (start/stop/every)
written piece by piece: each array read from its blob a bounded slice at a time, so a fetch holds about CHUNK_BYTES."""

from __future__ import annotations

import json
import shutil
import sqlite3
import threading
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from .arrays import SAVED, Saved, StoredTrajectory, TrajectoryArrays

__all__ = ["FetchLease", "read_arrays", "read_column", "trajectory_chunks"]

CHUNK_BYTES = 1 << 16  # read per piece; small: json.dumps holds the GIL (and the event loop) for a piece
_ROW_READ_LIMIT = 1 << 16  # bytes of one read of a blob


class FetchLease:
    """A slot among the large fetches served at once, and a download's directory: given back exactly once, by
    whoever ends first: the body's generator, the response's background task, or the lease's own collection."""

    def __init__(self, semaphore: threading.Semaphore | None, directory: Path | None = None):
        self._semaphore, self._directory = semaphore, directory
        self._lock = threading.Lock()

    def release(self) -> None:
        with self._lock:
            semaphore, self._semaphore, directory, self._directory = self._semaphore, None, self._directory, None
        if semaphore is not None:
            semaphore.release()
        if directory is not None:
            shutil.rmtree(directory, ignore_errors=True)

    def __del__(self) -> None:  # a client gone before the first byte: neither body nor background task runs
        self.release()


_BY_NAME = {array.name: array for array in SAVED}


def read_column(connection: sqlite3.Connection, stored: StoredTrajectory, column: str,
                selection: range) -> np.ndarray:
    """One array's selected rows, (points,) or (points, width), read from a part of its blob."""
    array = _BY_NAME[column]
    width, n = stored.width(array), len(selection)
    if width == 0 or n == 0:
        rows = np.empty((n, width))
    else:
        with connection.blobopen("trajectories", column, stored.rowid, readonly=True) as blob:
            rows = _read_rows(blob, selection.start, n, selection.step, width)
    return rows if array.width else rows[:, 0]


def read_arrays(connection: sqlite3.Connection, stored: StoredTrajectory, selection: range) -> TrajectoryArrays:
    """The selected points of every array (a caller bounds their size: a file's first row, a plot's decimation)."""
    return TrajectoryArrays(**{a.name: read_column(connection, stored, a.name, selection)
                               for a in SAVED if stored.has(a)})


def _json_rows(array: np.ndarray) -> str:
    """The rows as JSON without the enclosing brackets; non-finite values (an overflowed energy) are null."""
    if array.ndim == 2 and array.shape[1] == 0:  # momentum of a model without symmetries: nothing stored
        return ",".join(["[]"] * len(array))
    finite = np.isfinite(array)
    rows = array if finite.all() else np.where(finite, array.astype(object), None)
    return json.dumps(rows.tolist(), allow_nan=False, separators=(",", ":"))[1:-1]


def _read_rows(blob: sqlite3.Blob, first: int, count: int, every: int, width: int) -> np.ndarray:
    """Rows first, first + every, ... (count of them) of a row-major float64 array `width` wide, read in spans of
    about _ROW_READ_LIMIT bytes (a row at a time when one step is wider): what is held is the rows asked for."""
    row_bytes = 8 * width
    per_read = max(1, _ROW_READ_LIMIT // (every * row_bytes))
    out = np.empty((count, width))
    for done in range(0, count, per_read):
        rows = min(per_read, count - done)
        blob.seek((first + done * every) * row_bytes)
        span = np.frombuffer(blob.read(((rows - 1) * every + 1) * row_bytes), dtype="<f8")
        out[done:done + rows] = span.reshape(-1, width)[::every]
    return out


def _array_json(connection: sqlite3.Connection, stored: StoredTrajectory, array: Saved,
                selection: range) -> Iterator[str]:
    """One array's JSON value, '[' ... ']', in pieces of about CHUNK_BYTES (a width of 0: empty rows, nothing read)."""
    per_piece = max(1, CHUNK_BYTES // (8 * max(stored.width(array), 1) * selection.step))
    yield "["
    for done in range(0, len(selection), per_piece):
        rows = read_column(connection, stored, array.name, selection[done:done + per_piece])
        yield ("," if done else "") + _json_rows(rows)
    yield "]"


def trajectory_chunks(connection: sqlite3.Connection, stored: StoredTrajectory, selection: range,
                      lease: FetchLease) -> Iterator[bytes]:
    """The body of GET .../trajectory. Owns the read connection (a snapshot: a concurrent DELETE or
    retention pass does not change what is being sent) and the lease; both end when the body does."""
    try:
        for i, array in enumerate(SAVED):
            yield f'{"{" if i == 0 else ","}"{array.name}":'.encode()
            if not stored.has(array):  # an optional array the job has not: null, as the Trajectory schema says
                yield b"null"
                continue
            for piece in _array_json(connection, stored, array, selection):
                yield piece.encode()
        yield b"}"
    finally:
        connection.close()
        lease.release()
