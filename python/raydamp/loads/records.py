"""Load histories from files: PEER NGA ``.AT2`` records, two-column text/CSV (t, value) and ``.npy``.

Each reader gives (t, values) as float arrays, t starting where the file says (0 for a
record given by its sample interval), and refuses a malformed file with a ValueError that
names the file and what is wrong in it.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

__all__ = ["read_record", "parse_at2", "parse_columns"]

# "NPTS=  5590, DT=   .0050 SEC" (NGA-West2) or "5590    .0050    NPTS, DT" (the older format).
_NPTS_DT = re.compile(r"NPTS\s*=\s*([0-9]+)\s*,?\s*DT\s*=\s*([-+0-9.eE]+)", re.IGNORECASE)
_OLD_NPTS_DT = re.compile(r"^\s*([0-9]+)\s+([-+0-9.eE]+)\s+NPTS\s*,\s*DT", re.IGNORECASE)
_HEADER_LINES = 4


def read_record(path, *, dt: float | None = None, name: str = "path") -> tuple[np.ndarray, np.ndarray]:
    """(t, values) of the file at ``path``, read by its suffix: .AT2, .npy, else text columns."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{name}: no such file {str(path)!r}")
    suffix = path.suffix.lower()
    if suffix == ".at2":
        return parse_at2(path.read_text(errors="replace"), source=str(path))
    if suffix == ".npy":
        try:
            array = np.load(path, allow_pickle=False)
        except ValueError as e:
            raise ValueError(f"{name}: {path.name} is not a NumPy array file ({e})") from None
        return from_array(array, dt=dt, source=path.name)
    return parse_columns(path.read_text(errors="replace"), source=path.name, dt=dt)


def parse_at2(text: str, *, source: str = "record") -> tuple[np.ndarray, np.ndarray]:
    """A PEER NGA record: four header lines, the fourth giving NPTS and DT, then NPTS values
    (in the units the third line names, usually g), sample k at t = k DT."""
    lines = text.splitlines()
    if len(lines) < _HEADER_LINES:
        raise ValueError(f"{source}: not a PEER .AT2 record: {len(lines)} lines, the header alone has 4")
    header = lines[_HEADER_LINES - 1]
    found = _NPTS_DT.search(header) or _OLD_NPTS_DT.search(header)
    if found is None:
        raise ValueError(f"{source}: line 4 must give NPTS and DT (e.g. 'NPTS=  5590, DT=   .0050 SEC'), "
                         f"got {header[:80]!r}")
    npts = int(found.group(1))
    try:
        dt = float(found.group(2))
    except ValueError:
        raise ValueError(f"{source}: DT on line 4 is not a number: {found.group(2)!r}") from None
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"{source}: DT must be > 0, got {dt!r}")
    values = []
    for number, line in enumerate(lines[_HEADER_LINES:], start=_HEADER_LINES + 1):
        for item in line.replace(",", " ").split():
            try:
                values.append(float(item))
            except ValueError:
                raise ValueError(f"{source}: line {number}: {item[:40]!r} is not a number") from None
    if len(values) != npts:
        raise ValueError(f"{source}: the header says NPTS={npts} but the record has {len(values)} values")
    array = np.asarray(values, dtype=float)
    if not np.all(np.isfinite(array)):
        bad = int(np.flatnonzero(~np.isfinite(array))[0])
        raise ValueError(f"{source}: value {bad} is not finite")
    return np.arange(npts) * dt, array


def parse_columns(text: str, *, source: str = "file", dt: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Two columns t, value (comma, semicolon or white space between), one header line allowed;
    or one column of values with ``dt`` given."""
    rows: list[list[float]] = []
    for number, line in enumerate(text.splitlines(), start=1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        items = re.split(r"[,;\s]+", line)
        try:
            rows.append([float(x) for x in items])
        except ValueError:
            if not rows and number == 1:
                continue  # a header line
            raise ValueError(f"{source}: line {number}: not numbers: {line[:80]!r}") from None
    if not rows:
        raise ValueError(f"{source}: no numbers in the file")
    widths = {len(r) for r in rows}
    if len(widths) != 1:
        raise ValueError(f"{source}: every line needs the same number of columns (found {sorted(widths)})")
    return from_array(np.asarray(rows, dtype=float), dt=dt, source=source)


def from_array(array: np.ndarray, *, dt: float | None, source: str) -> tuple[np.ndarray, np.ndarray]:
    """(t, values) of an (T, 2) array of t, value, or of a (T,) array of values sampled at dt."""
    array = np.asarray(array)
    if array.dtype.kind not in "iuf":
        raise ValueError(f"{source}: expected numbers, got an array of {array.dtype}")
    array = array.astype(float)
    if array.ndim == 2 and array.shape[1] == 1:
        array = array[:, 0]
    if array.ndim == 1:
        if dt is None:
            raise ValueError(f"{source}: one column of values needs dt (the sample interval)")
        if not (np.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be > 0, got {dt!r}")
        t, values = np.arange(array.size) * float(dt), array
    elif array.ndim == 2 and array.shape[1] == 2:
        if dt is not None:
            raise ValueError(f"{source}: has a time column, so dt must not be given")
        t, values = array[:, 0].copy(), array[:, 1].copy()
    else:
        raise ValueError(f"{source}: expected columns t, value (shape (T, 2)) or one column, got shape {array.shape}")
    if t.size == 0:
        raise ValueError(f"{source}: no samples")
    return t, values
