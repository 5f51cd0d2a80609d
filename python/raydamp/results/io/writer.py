"""A Solution written to CSV, NPZ or NetCDF a slice of rows at a time: the one writer of these formats.

``Solution.save`` uses it on the arrays it holds; the service uses it on a stored trajectory read
from its database a slice at a time, so a 960 MB trajectory is written in bounded memory (issue 27,
F3: four downloads read whole took the service past 6 GB). The formats:

- CSV: a header line (t, q_<name>..., p_<name>..., energy, the momentum maps' names, work,
  load_work, multiplier_<i>..., spring_force_<s>..., spring_deformation_<s>..., hysteretic_work_<s>...),
  then one line per row, every number as ``%.17g`` (it reads back to the same double).
- NPZ: ``np.savez``'s layout (a zip of .npy members t, q, p, energy, momentum, [work], [load_work],
  [multipliers] (a constrained System's, rows x constraints), [spring_forces], [spring_deformations],
  [hysteretic_work] (a Structure's with springs, rows x springs), and ``attrs``, the scalars and provenance
  as JSON); each member's data is written a slice at a time after its header, which states the full shape.
- NetCDF: ``Solution.to_xarray``'s Dataset; from a reader, the Dataset of the first slice with ``time``
  unlimited and each further slice appended along it (from arrays in memory, the whole Dataset at once).
"""

from __future__ import annotations

import dataclasses
import json
import os
import zipfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, Any

import numpy as np

from .dataset import _FORMAT_OF_SUFFIX, FORMATS, SPRING_ARRAYS, _attributes, _csv_table, event_columns, to_xarray

__all__ = ["write_solution", "save", "SLICE_BYTES", "WRITE_FORMATS", "ReadRows"]

SLICE_BYTES = 4 << 20  # floats read and written at once
WRITE_FORMATS = ("csv", "npz", "netcdf")
# read(column, start, stop): rows [start, stop) of one column of the trajectory; column is one of
# t, energy, work, load_work ((rows,) arrays) or q, p, momentum, multipliers, spring_forces,
# spring_deformations, hysteretic_work ((rows, width) arrays).
ReadRows = Callable[[str, int, int], np.ndarray]
Target = str | os.PathLike | IO[bytes]

_WIDE = ("q", "p", "momentum", "multipliers", *SPRING_ARRAYS)


def _columns(head: Any) -> list[str]:
    """The stored columns in the order every format writes them (np.savez's member order)."""
    return (["t", "q", "p", "energy", "momentum"] + (["work"] if head.work is not None else [])
            + (["load_work"] if head.load_work is not None else [])
            + (["multipliers"] if getattr(head, "multipliers", None) is not None else [])
            + [name for name in SPRING_ARRAYS if getattr(head, name, None) is not None])


def _width(head: Any, column: str) -> int | None:
    if column == "multipliers" or column in SPRING_ARRAYS:
        return getattr(head, column).shape[1]
    return {"q": head.q.shape[1], "p": head.p.shape[1], "momentum": head.momentum.shape[1]}.get(column)


def write_solution(target: Target, fmt: str, head: Any, read: ReadRows | None = None,
                   rows: int | None = None, *, slice_bytes: int = SLICE_BYTES) -> None:
    """Write a trajectory to ``target`` (a path, or a binary file object: NetCDF needs one open for
    reading and writing, ``"w+b"``) as ``fmt`` ("csv", "npz" or "netcdf"), at most about
    ``slice_bytes`` of its floats in memory at once.

    ``head`` gives everything but the numbers: the coordinates' and momentum maps' names, the scalars
    and the provenance, and which of work and load_work there are. Without ``read`` the numbers are
    ``head``'s own arrays (``Solution.save``); with it, they are ``rows`` rows that ``read(column,
    start, stop)`` returns a slice at a time (columns t, q, p, energy, momentum, work, load_work), and
    ``head``'s arrays serve only for their widths. NetCDF from ``head``'s own arrays is written
    whole (they are in memory already). ValueError names ``fmt``, ``rows`` or ``slice_bytes`` when
    one is not usable."""
    if fmt not in WRITE_FORMATS:
        raise ValueError(f"fmt: unknown format {fmt!r} (known: {', '.join(WRITE_FORMATS)})")
    if read is None:
        if fmt == "netcdf":  # in memory already: written whole, time fixed (2.5x faster than unlimited, chunked)
            to_xarray(head).to_netcdf(target, engine="h5netcdf")
            return
        rows = head.t.shape[0]

        def read(column: str, start: int, stop: int) -> np.ndarray:
            return getattr(head, column)[start:stop]
    if isinstance(rows, bool) or not isinstance(rows, (int, np.integer)) or rows < 1:
        raise ValueError(f"rows: the number of rows to write, at least 1, got {rows!r}")
    if isinstance(slice_bytes, bool) or not isinstance(slice_bytes, (int, np.integer)) or slice_bytes < 1:
        raise ValueError(f"slice_bytes: a positive number of bytes, got {slice_bytes!r}")
    row_bytes = 8 * sum(_width(head, column) or 1 for column in _columns(head))
    step = max(1, slice_bytes // row_bytes)
    bounds = [(start, min(start + step, int(rows))) for start in range(0, int(rows), step)]
    {"csv": _write_csv, "npz": _write_npz, "netcdf": _write_netcdf}[fmt](target, head, read, bounds)


def _slice(head: Any, read: ReadRows, start: int, stop: int) -> Any:
    """Rows [start, stop) as a Solution with head's names, scalars and provenance."""
    arrays = {column: np.asarray(read(column, start, stop), dtype=float) for column in _columns(head)}
    return dataclasses.replace(head, **arrays)


def _opened(target: Target, mode: str):
    """(file, whether we opened it): a path is opened here and closed by the caller."""
    if isinstance(target, (str, os.PathLike)):
        return Path(target).open(mode), True
    return target, False


def _write_csv(target: Target, head: Any, read: ReadRows, bounds: list[tuple[int, int]]) -> None:
    out, owned = _opened(target, "wb")
    try:
        for i, (start, stop) in enumerate(bounds):
            names, table = _csv_table(_slice(head, read, start, stop))
            # savetxt writes no header line when header is "": the header goes before the first slice only.
            np.savetxt(out, table, delimiter=",", header=",".join(names) if i == 0 else "", comments="", fmt="%.17g")
    finally:
        if owned:
            out.close()


def _write_npz(target: Target, head: Any, read: ReadRows, bounds: list[tuple[int, int]]) -> None:
    rows = bounds[-1][1]
    # As np.savez does: stored (not compressed) members, each with zip64 sizes, as it may pass 4 GB.
    with zipfile.ZipFile(target, "w", zipfile.ZIP_STORED, allowZip64=True) as out:
        for column in _columns(head):
            width = _width(head, column)
            with out.open(f"{column}.npy", "w", force_zip64=True) as member:
                np.lib.format.write_array_header_1_0(member, {
                    "descr": np.lib.format.dtype_to_descr(np.dtype("<f8")), "fortran_order": False,
                    "shape": (rows,) if width is None else (rows, width)})
                for start, stop in bounds:
                    member.write(np.ascontiguousarray(read(column, start, stop), dtype="<f8").tobytes())
        for name, (_, values, _) in event_columns(head).items():  # the events table, in memory already
            with out.open(f"{name}.npy", "w", force_zip64=True) as member:
                np.lib.format.write_array(member, values.astype(str) if name == "event_name" else values)
        with out.open("attrs.npy", "w", force_zip64=True) as member:
            np.lib.format.write_array(member, np.array(json.dumps(_attributes(head), allow_nan=True)))


def _write_netcdf(target: Target, head: Any, read: ReadRows, bounds: list[tuple[int, int]]) -> None:
    import h5netcdf

    slices: Iterator[tuple[int, int]] = iter(bounds)
    start, done = next(slices)
    to_xarray(_slice(head, read, start, done)).to_netcdf(target, engine="h5netcdf", unlimited_dims=["time"])
    if len(bounds) == 1:
        return
    with h5netcdf.File(target, "a") as out:
        for start, end in slices:
            out.resize_dimension("time", end)
            for column in _columns(head):
                values = read(column, start, end)
                if np.size(values) and column in out.variables:  # momentum of width 0: nothing stored
                    out.variables[column][start:end, ...] = values


def save(sol: Any, path) -> None:
    """Write ``sol`` to ``path``, the format chosen by the suffix (.nc, .npz, .csv), a slice of rows at a
    time (write_solution, which the service's downloads use too)."""
    path = Path(path)
    fmt = _FORMAT_OF_SUFFIX.get(path.suffix.lower())
    if fmt is None:
        raise ValueError(f"path: unknown format {path.suffix!r} (known: {', '.join(FORMATS)})")
    write_solution(path, fmt, sol)
