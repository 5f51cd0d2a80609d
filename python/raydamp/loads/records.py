"""Load histories from files: PEER NGA ``.AT2`` records, two-column text/CSV (t, value) and ``.npy``.

Each reader gives (t, values) as float arrays, t starting where the file says (0 for a
record given by its sample interval), and refuses a malformed file with a ValueError that
names the file and what is wrong in it.

Text is read in pieces of whole lines, each converted by NumPy: a record costs its samples x 8
bytes (and one piece's work), not a Python object per value (a 64 MiB upload took 5 GB that way).
A record of more than max_record_samples() samples is refused from its header (.AT2's NPTS, a
.npy's shape) or as soon as its text has that many lines of numbers.
"""

from __future__ import annotations

import io
import os
import re
import tokenize
from collections.abc import Iterator
from pathlib import Path
from typing import NamedTuple

import numpy as np

from .._validation import _short

__all__ = ["read_record", "parse_at2", "parse_columns", "from_array", "Record", "record_format", "parse_record",
           "with_times", "describe_record", "FORMATS", "max_record_samples", "MAX_RECORD_SAMPLES"]

MAX_RECORD_SAMPLES = "RAYDAMP_MAX_RECORD_SAMPLES"  # the environment variable that sets the limit
_DEFAULT_MAX_SAMPLES = 10**7  # a day at 100 Hz is 8.64e6 samples
_PIECE = 1 << 20  # bytes of text converted at once


def max_record_samples() -> int:
    """The most samples a record may have: $RAYDAMP_MAX_RECORD_SAMPLES, by default 10^7."""
    text = os.environ.get(MAX_RECORD_SAMPLES, "")
    try:
        value = int(text) if text.strip() else _DEFAULT_MAX_SAMPLES
    except ValueError:
        raise ValueError(f"{MAX_RECORD_SAMPLES} must be an integer, got {text[:40]!r}") from None
    if value < 1:
        raise ValueError(f"{MAX_RECORD_SAMPLES} must be >= 1, got {value}")
    return value

# What an uploaded file holds, told apart by its name's suffix and its content (record_format).
FORMATS = ("mtx", "at2", "npy", "columns")
_SUFFIXES = {".mtx": "mtx", ".mm": "mtx", ".at2": "at2", ".npy": "npy"}
_NPY_MAGIC = b"\x93NUMPY"


class Record(NamedTuple):
    """A record as read from a file: ``t`` the sample times, or None for a file of one column of
    values (sampled at a dt the user gives, or a vector such as an initial state), and ``values``."""

    t: np.ndarray | None
    values: np.ndarray


# "NPTS=  5590, DT=   .0050 SEC" (NGA-West2) or "5590    .0050    NPTS, DT" (the older format).
# DT may carry a Fortran exponent (5.0D-03): the number stopped at the D, and DT was read as 5.0.
_NPTS_DT = re.compile(r"NPTS\s*=\s*([0-9]+)\s*,?\s*DT\s*=\s*([-+0-9.eEdD]+)", re.IGNORECASE)
_OLD_NPTS_DT = re.compile(r"^\s*([0-9]+)\s+([-+0-9.eEdD]+)\s+NPTS\s*,\s*DT", re.IGNORECASE)
_HEADER_LINES = 4


def _fortran_float(text: str) -> float:
    """A number as Python writes it or as Fortran may (1.5D-03: a double's exponent)."""
    return float(text.replace("D", "E").replace("d", "e"))


def read_record(path, *, dt: float | None = None, name: str = "path") -> tuple[np.ndarray, np.ndarray]:
    """(t, values) of the file at ``path``, read by its suffix: .AT2, .npy, else text columns."""
    if not isinstance(path, (str, os.PathLike)):  # None was Path's TypeError
        raise ValueError(f"{name} must be a file path, got {_short(path)}")
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{name}: no such file {str(path)!r}")
    suffix = path.suffix.lower()
    if suffix == ".at2":
        return _at2(path.read_bytes(), str(path), max_record_samples())
    if suffix == ".npy":
        try:
            array = _npy(path.read_bytes(), path.name, max_record_samples())
        except ValueError as e:
            raise ValueError(f"{name}: {e}") from None
        return from_array(array, dt=dt, source=path.name)
    return from_array(_text_columns(path.read_bytes(), path.name, max_record_samples()), dt=dt, source=path.name)


def parse_at2(text: str, *, source: str = "record") -> tuple[np.ndarray, np.ndarray]:
    """A PEER NGA record: four header lines, the fourth giving NPTS and DT, then NPTS values
    (in the units the third line names, usually g), sample k at t = k DT."""
    return _at2(text.encode(), source, max_record_samples())


def _at2(content: bytes, source: str, max_samples: int) -> tuple[np.ndarray, np.ndarray]:
    header, body = [], 0
    while len(header) < _HEADER_LINES and body < len(content):
        end = _LINE_END.search(content, body)
        header.append(content[body:end.start() if end else len(content)])
        body = end.end() if end else len(content)
    if len(header) < _HEADER_LINES:
        raise ValueError(f"{source}: not a PEER .AT2 record: {len(header)} lines, the header alone has 4")
    header = header[-1].decode("utf-8", errors="replace")
    found = _NPTS_DT.search(header) or _OLD_NPTS_DT.search(header)
    if found is None:
        raise ValueError(f"{source}: line 4 must give NPTS and DT (e.g. 'NPTS=  5590, DT=   .0050 SEC'), "
                         f"got {header[:80]!r}")
    npts = int(found.group(1))
    try:
        dt = _fortran_float(found.group(2))
    except ValueError:
        raise ValueError(f"{source}: DT on line 4 is not a number: {found.group(2)!r}") from None
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"{source}: DT must be > 0, got {dt!r}")
    if npts > max_samples:
        raise ValueError(f"{source}: the header says NPTS={npts}; records of at most {max_samples} samples are "
                         f"read ({MAX_RECORD_SAMPLES})")
    if npts > (len(content) - body + 1) // 2:  # each value takes a character and a separator
        raise ValueError(f"{source}: the header says NPTS={npts} but the record has fewer values (a file of "
                         f"{len(content)} bytes)")
    values = _numbers(content, body, _HEADER_LINES + 1, source, npts + 1, fortran=True, width=None)
    if values.size != npts:
        raise ValueError(f"{source}: the header says NPTS={npts} but the record has "
                         f"{'more' if values.size > npts else values.size} values")
    if not np.all(np.isfinite(values)):
        bad = int(np.flatnonzero(~np.isfinite(values))[0])
        raise ValueError(f"{source}: value {bad} is not finite")
    return np.arange(npts) * dt, values


# Separators of a record's numbers become blanks (and a Fortran exponent an E) before NumPy reads a piece.
_BLANKS = bytes.maketrans(b",;\t\r\v\f", b"      ")
_FORTRAN = bytes.maketrans(b",\t\r\v\fDd", b"     Ee")
_LINE_END = re.compile(rb"\r\n|\n|\r")
_NEWLINE = re.compile(rb"\n")
_BLANK = re.compile(rb"[\s,]")
_LONGEST_LINE = 1 << 20


def _pieces(content: bytes, start: int, breaks: re.Pattern) -> Iterator[tuple[int, int]]:
    """(start, end) of consecutive pieces of about _PIECE bytes, each ending after a match of breaks (a line's
    end, or any blank for a record whose lines do not matter)."""
    while start < len(content):
        found = breaks.search(content, min(start + _PIECE, len(content)) - 1)
        end = len(content) if found is None else found.end()
        yield start, end
        start = end


def _numbers(content: bytes, start: int, first_line: int, source: str, limit: int, *, fortran: bool,
             width: list | None) -> np.ndarray:
    """The numbers of content[start:], read a piece at a time: one flat array (at most limit numbers, or
    rows of numbers when width is a list, which then gets the count of numbers of every line of numbers).
    A piece NumPy cannot read exactly is read line by line, for the message naming its line."""
    parts, count, line = [], 0, first_line
    for begin, end in _pieces(content, start, _BLANK if fortran else _NEWLINE):
        if end - begin > _PIECE + _LONGEST_LINE:  # a line of a megabyte would cost ten as one piece
            at = line + content.count(b"\n", begin, end - 1)
            raise ValueError(f"{source}: line {at} is longer than "
                             f"{_LONGEST_LINE} bytes (a record's line holds one or two numbers)")
        piece = content[begin:end]
        if b"#" in piece and not fortran:  # comments: dropped line by line (the line count kept)
            piece = b"\n".join(text.split(b"#", 1)[0] for text in piece.split(b"\n"))
        blank = piece.translate(_FORTRAN if fortran else _BLANKS)
        values, widths = _read_piece(blank, piece, line, source, fortran)
        if width is not None:
            width.extend(sorted(set(widths.tolist()) - set(width)))
            count += widths.size
        else:
            count += values.size
        parts.append(values)
        if count > limit:
            break
        line += piece.count(b"\n")
    return np.concatenate(parts) if parts else np.empty(0)


def _read_piece(blank: bytes, piece: bytes, line: int, source: str, fortran: bool) -> tuple[np.ndarray, np.ndarray]:
    """(the numbers, the count of numbers on each line that has any) of one piece of whole lines."""
    codes = np.frombuffer(blank, dtype=np.uint8)
    space = (codes == 32) | (codes == 10)
    starts = ~space
    starts[1:] &= space[:-1]
    lines = np.cumsum(codes == 10, dtype=np.int32)
    widths = np.bincount(lines[starts])
    widths = widths[widths > 0]
    try:
        values = np.fromstring(blank.decode("latin-1"), sep=" ")  # noqa: NPY201 - text mode, not the binary one
    except ValueError:
        values = None
    if values is None or values.size != int(widths.sum()):  # a token NumPy stopped at, or read as two numbers
        return _read_lines(piece, line, source, fortran)
    return values, widths


def _read_lines(piece: bytes, line: int, source: str, fortran: bool) -> tuple[np.ndarray, np.ndarray]:
    """A piece read as Python reads numbers, line by line; the first item that is no number is named."""
    values, widths = [], []
    for number, text in enumerate(piece.decode("utf-8", errors="replace").split("\n"), start=line):
        items = text.replace(",", " ").split() if fortran else [x for x in re.split(r"[,;\s]+", text.strip()) if x]
        row = []
        for item in items:
            try:
                row.append(_fortran_float(item) if fortran else float(item))
            except ValueError:
                if fortran:
                    raise ValueError(f"{source}: line {number}: {item[:40]!r} is not a number") from None
                raise ValueError(f"{source}: line {number}: not numbers: {text.strip()[:80]!r}") from None
        if row:
            values.extend(row)
            widths.append(len(row))
    return np.asarray(values, dtype=float), np.asarray(widths, dtype=np.int64)


def record_format(content: bytes, name: str | None = None) -> str:
    """Which reader a file's bytes are for: "mtx" (Matrix Market), "at2" (PEER NGA), "npy" or "columns"
    (text). A name's suffix (.mtx, .mm, .AT2, .npy) decides; otherwise (and with no name) the content:
    the Matrix Market banner, NumPy's magic string, NPTS and DT on line 4, else text columns."""
    if name is not None:
        by_name = _SUFFIXES.get(Path(name).suffix.lower())
        if by_name is not None:
            return by_name
    if content[:4096].lstrip()[:14].lower() == b"%%matrixmarket":  # as scipy reads it, after leading blanks
        return "mtx"
    if content.startswith(_NPY_MAGIC):
        return "npy"
    lines = content[:4096].decode("utf-8", errors="replace").splitlines()
    header = lines[_HEADER_LINES - 1] if len(lines) >= _HEADER_LINES else ""
    if not header.lstrip().startswith("#") and (_NPTS_DT.search(header) or _OLD_NPTS_DT.search(header)):
        return "at2"  # (a text file's comment line may mention NPTS; an .AT2 header line is no comment)
    return "columns"


def parse_record(content: bytes, *, name: str | None = None, source: str | None = None,
                 max_samples: int | None = None) -> tuple[Record, str]:
    """(the record, its format) of a file's bytes: a PEER .AT2 record, a .npy array ((T, 2) of t, value,
    or (T,) of values) or text columns (t, value, or one column of values). Every check of a load's
    record is made here (times increasing, values finite, DT > 0, NPTS as announced), so that a file
    read once serves any job; a ValueError names the file and the problem. A Matrix Market file is
    refused: read it with raydamp.LinearStructure. At most max_samples samples (max_record_samples())."""
    source = source or name or "file"
    limit = max_record_samples() if max_samples is None else max_samples
    fmt = record_format(content, name)
    if fmt == "mtx":
        raise ValueError(f"{source}: a Matrix Market matrix, not a record")
    if fmt == "at2":
        t, values = _at2(content, source, limit)
    elif fmt == "npy":
        t, values = _columns(_npy(content, source, limit), source)
    else:
        t, values = _columns(_text_columns(content, source, limit), source)
    if name is not None and record_format(content) != fmt:
        raise ValueError(f"{source}: read as {fmt} by its name, but its content reads as {record_format(content)}; "
                         "rename it")
    from .terms import history, times

    try:
        values = history("values", values, values.shape[0])
        t = None if t is None else times("t", t)
    except ValueError as error:
        raise ValueError(f"{source}: {error}") from None
    if values.ndim != 1:
        raise ValueError(f"{source}: expected one column of values, got shape {values.shape}")
    return Record(t, values), fmt


def describe_record(record: Record) -> dict:
    """What a listing shows of a record: samples, and for one with times t_start, t_end and dt (the
    sample interval when the times are uniform to rounding, else None)."""
    t, values = record
    out = {"samples": int(values.size), "t_start": None, "t_end": None, "dt": None}
    if t is not None:
        out["t_start"], out["t_end"] = float(t[0]), float(t[-1])
        if t.size > 1:
            steps = np.diff(t)
            mean = (t[-1] - t[0]) / (t.size - 1)
            if np.all(np.abs(steps - mean) <= 1e-9 * mean):
                out["dt"] = float(mean)
    return out


def _npy(content: bytes, source: str, max_samples: int) -> np.ndarray:
    """A .npy file's array, its header checked against the file's size and the samples limit first: np.load
    allocates what the header announces, so a 100-byte file claiming 10^12 floats must be refused before it
    is read."""
    stream = io.BytesIO(content)
    try:
        version = np.lib.format.read_magic(stream)
        if version == (1, 0):
            shape, _, dtype = np.lib.format.read_array_header_1_0(stream)
        elif version == (2, 0):
            shape, _, dtype = np.lib.format.read_array_header_2_0(stream)
        else:
            raise ValueError(f"format version {version} (1.0 and 2.0 are read)")
    except (ValueError, SyntaxError, tokenize.TokenError) as error:
        # A header cut short: NumPy's reader lets the tokenizer's and the parser's errors out
        raise ValueError(f"{source}: not a NumPy array file ({error})") from None
    if dtype.hasobject or dtype.kind not in "iuf":
        raise ValueError(f"{source}: expected numbers, got an array of {dtype}")
    announced = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
    if announced > len(content) - stream.tell():
        raise ValueError(f"{source}: the header announces shape {tuple(shape)}, more than a file of {len(content)} "
                         "bytes holds")
    if shape and shape[0] > max_samples:
        raise ValueError(f"{source}: the header announces {shape[0]} samples; records of at most {max_samples} "
                         f"samples are read ({MAX_RECORD_SAMPLES})")
    try:
        return np.load(io.BytesIO(content), allow_pickle=False)
    except ValueError as error:
        raise ValueError(f"{source}: not a NumPy array file ({error})") from None


def _text_columns(content: bytes, source: str, max_samples: int) -> np.ndarray:
    """Rows of numbers, comma, semicolon or white space between, # starting a comment; line 1 may be a
    header (not numbers)."""
    end = content.find(b"\n")
    end = len(content) if end < 0 else end + 1
    start, line = 0, 1
    first = content[:end].split(b"#", 1)[0].decode("utf-8", errors="replace")
    items = [x for x in re.split(r"[,;\s]+", first.strip()) if x]
    try:
        [float(x) for x in items]
    except ValueError:
        start, line = end, 2  # a header line
    widths: list[int] = []
    values = _numbers(content, start, line, source, max_samples, fortran=False, width=widths)
    if not widths:
        raise ValueError(f"{source}: no numbers in the file")
    if len(widths) != 1:
        raise ValueError(f"{source}: every line needs the same number of columns (found {sorted(widths)})")
    rows = values.reshape(-1, widths[0])
    if rows.shape[0] > max_samples:
        raise ValueError(f"{source}: more than {max_samples} samples; records of at most {max_samples} samples "
                         f"are read ({MAX_RECORD_SAMPLES})")
    return rows


def _columns(array: np.ndarray, source: str) -> tuple[np.ndarray | None, np.ndarray]:
    """(t, values) of a (T, 2) array, (None, values) of a (T,) or (T, 1) one."""
    array = np.asarray(array)
    if array.dtype.kind not in "iuf":
        raise ValueError(f"{source}: expected numbers, got an array of {array.dtype}")
    array = array.astype(float)
    if array.ndim == 2 and array.shape[1] == 1:
        array = array[:, 0]
    if array.ndim == 1:
        t, values = None, array
    elif array.ndim == 2 and array.shape[1] == 2:
        t, values = array[:, 0].copy(), array[:, 1].copy()
    else:
        raise ValueError(f"{source}: expected columns t, value (shape (T, 2)) or one column, got shape {array.shape}")
    if values.size == 0:
        raise ValueError(f"{source}: no samples")
    return t, values


def parse_columns(text: str, *, source: str = "file", dt: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Two columns t, value (comma, semicolon or white space between), one header line allowed;
    or one column of values with ``dt`` given."""
    return from_array(_text_columns(text.encode(), source, max_record_samples()), dt=dt, source=source)


def from_array(array: np.ndarray, *, dt: float | None, source: str) -> tuple[np.ndarray, np.ndarray]:
    """(t, values) of an (T, 2) array of t, value, or of a (T,) array of values sampled at dt."""
    return with_times(*_columns(array, source), dt=dt, source=source)


def with_times(t: np.ndarray | None, values: np.ndarray, *, dt: float | None, source: str,
               dt_name: str = "dt") -> tuple[np.ndarray, np.ndarray]:
    """(t, values): a record's own times, or values sampled at dt from t = 0 (one column)."""
    if t is None:
        if dt is None:
            raise ValueError(f"{source}: one column of values needs {dt_name} (the sample interval)")
        if isinstance(dt, bool) or not isinstance(dt, (int, float, np.floating, np.integer)) \
                or not (np.isfinite(dt) and dt > 0):
            raise ValueError(f"{dt_name} must be > 0, got {dt!r}")
        return np.arange(values.size) * float(dt), values
    if dt is not None:
        raise ValueError(f"{source}: has a time column, so {dt_name} must not be given")
    return t, values
