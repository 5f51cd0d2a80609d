"""Uploaded Matrix Market files: checking an upload, and handing stored ones to raydamp.

An upload is read as Matrix Market by scipy (what raydamp.LinearStructure reads too), after its
header has been checked against the file's size: the reader allocates what the header announces,
so a 100-byte file claiming 10^9 entries must be refused before it is read, not after.
"""

from __future__ import annotations

import io
from collections.abc import Callable
from dataclasses import dataclass

from .store import JobStore

__all__ = ["MatrixFileError", "MatrixFileInfo", "check_matrix_market", "file_resolver"]

# The shortest line an entry can take: "1 1\n" (pattern), and "1\n" for a dense (array) file.
_MIN_COORDINATE_LINE = 4
_MIN_ARRAY_LINE = 2


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


def file_resolver(store: JobStore) -> Callable[[str], io.BytesIO]:
    """files(ref) for raydamp.LinearStructure.from_dict: a stored upload as an open file; an unknown id is
    a ValueError that raydamp reports at the matrix's path (system.K.file)."""

    def resolve(file_id: str) -> io.BytesIO:
        content = store.file_content(file_id)
        if content is None:
            raise ValueError(f"no uploaded file with id {file_id!r} (POST /v1/files uploads one, GET /v1/files "
                             "lists them)")
        return io.BytesIO(content)

    return resolve
