"""Matrix Market files (a LinearStructure's M or K): the header, checked against the file's size before
the file is read.

scipy's reader allocates what the header announces, so a 100-byte file claiming 10^9 entries must be
refused before it is read, not after. Every stored entry takes a line of its own: at least "1 1\\n"
(4 bytes, a pattern entry) in a coordinate file and "1\\n" (2 bytes) in a dense (array) one, which
stores the lower triangle only when the matrix is symmetric (or skew-symmetric, without the diagonal).
"""

from __future__ import annotations

import io
import os
from dataclasses import dataclass

__all__ = ["MatrixMarketHeader", "read_header"]

_MIN_LINE = {"coordinate": 4, "array": 2}  # the shortest line an entry can take, in bytes
# A coordinate file's size bounds its entries, not its dimension: "10^11 x 10^11, 1 entry" in 59 bytes made the
# sparse form's column pointers alone 745 GiB. A structure's M stores its diagonal and a mesh's K about as much,
# so a dimension above twice the entries is mostly empty rows: allowed while the pointers stay small.
_EMPTY_ROWS_ALLOWED = 10_000_000


@dataclass(frozen=True)
class MatrixMarketHeader:
    """A Matrix Market file's header: shape, the entries it stores (as the header announces them),
    layout ("coordinate" or "array"), field ("real", "integer", "complex", "pattern") and symmetry
    ("general", "symmetric", "skew-symmetric", "hermitian")."""

    shape: tuple[int, int]
    entries: int
    layout: str
    field: str
    symmetry: str


def _stored_entries(rows: int, cols: int, entries: int, layout: str, symmetry: str) -> int:
    if layout == "coordinate":
        return entries
    if symmetry == "general":
        return rows * cols
    return rows * (rows + 1) // 2 if symmetry != "skew-symmetric" else rows * (rows - 1) // 2


def read_header(source, name: str = "matrix") -> MatrixMarketHeader:
    """The header of a Matrix Market file (its bytes, a path, or a seekable binary file object, left where
    it was), once it is known that the file is long enough to hold the entries the header announces.
    ValueError, naming ``name``, for a file that is not Matrix Market or whose header announces more
    entries than its size can hold."""
    import scipy.io

    where = None  # a file object's position, given back
    if isinstance(source, (bytes, bytearray, memoryview)):
        size, opened = len(source), io.BytesIO(source)
    elif isinstance(source, (str, os.PathLike)):
        if not os.path.isfile(source):
            raise ValueError(f"{name}: no Matrix Market file at {os.fspath(source)!r}")
        size, opened = os.path.getsize(source), source
    else:
        where = source.tell()
        size = source.seek(0, io.SEEK_END) - where
        source.seek(where)
        opened = source
    try:
        rows, cols, entries, layout, field, symmetry = scipy.io.mminfo(opened)
    except Exception as error:  # noqa: BLE001 - the reader's own words: "Missing banner", ...
        raise ValueError(f"{name}: cannot read it as Matrix Market: {error}") from None
    finally:
        if where is not None:
            source.seek(where)
    stored = _stored_entries(rows, cols, entries, layout, symmetry)
    if stored > size // _MIN_LINE[layout]:
        raise ValueError(f"{name}: the header announces {stored} entries, more than a file of {size} bytes can hold")
    n = max(rows, cols)
    if layout == "coordinate" and n > _EMPTY_ROWS_ALLOWED and n > 2 * stored:
        raise ValueError(f"{name}: the header announces a {rows} x {cols} matrix with {stored} stored entries: mostly "
                         f"empty rows, whose column pointers alone would take {8 * (n + 1) / 2**30:.3g} GiB (a "
                         "structure's M stores its whole diagonal)")
    return MatrixMarketHeader(shape=(int(rows), int(cols)), entries=int(stored), layout=layout, field=field,
                              symmetry=symmetry)
