"""A finished job's trajectory as a file (CSV, NPZ, NetCDF) or a plot (PNG).

No numerics here: the stored arrays become a raydamp.Solution carrying the job's spec as its
provenance, and raydamp writes the file (raydamp.results.io) or draws the plot (raydamp.results.plotting).
A file is written in slices of about SLICE_BYTES of stored floats, whatever the trajectory's length (four
downloads of a 960 MB trajectory, each read whole and written whole, took the service past 6 GB: issue 27,
F3): raydamp writes the first slice, which fixes the file's layout, names and attributes; the rest follow
in the same layout (CSV rows as raydamp writes them; NPZ members as .npy data; NetCDF along time, unlimited).
Plots use matplotlib's object API on a fresh Figure per request (no pyplot state), so requests
served on different threads do not share a figure.
"""

from __future__ import annotations

import io
import sqlite3
import zipfile
from pathlib import Path
from typing import Literal

import numpy as np
import raydamp
from raydamp.jobs import JobSpec

from .jobs import JobRecord, StoredTrajectory, TrajectoryArrays
from .trajectory_stream import Selection, read_arrays, read_column

__all__ = ["SLICE_BYTES", "stored_solution", "write_file", "plot_png"]

SLICE_BYTES = 4 << 20  # stored floats read and written at once

MEDIA_TYPES = {"csv": "text/csv", "npz": "application/octet-stream", "netcdf": "application/x-netcdf"}
SUFFIXES = {"csv": ".csv", "npz": ".npz", "netcdf": ".nc"}


def stored_solution(record: JobRecord, arrays: TrajectoryArrays, spec: JobSpec | None = None) -> raydamp.Solution:
    """The stored run as a Solution; its provenance is the job spec as submitted (spec: it validated, when the
    caller has it already)."""
    summary = record.summary or {}
    spec = spec or JobSpec.model_validate(record.spec)
    coordinates, momentum_names = spec.names(arrays.q.shape[1], arrays.momentum.shape[1], spec.save_dofs)
    provenance = {**record.spec, "raydamp_version": raydamp.__version__, "job_id": record.id,
                  "coordinates": coordinates, "momentum_names": momentum_names}
    drift = summary.get("momentum_drift")
    return raydamp.Solution(
        t=arrays.t, q=arrays.q, p=arrays.p, energy=arrays.energy, momentum=arrays.momentum, work=arrays.work,
        load_work=arrays.load_work,
        status=summary.get("status", record.status), steps=int(summary.get("steps", 0)),
        failed_step=record.failed_step, message=summary.get("message") or record.error or "",
        method=summary.get("method") or record.spec.get("method") or "3s", tableau=summary.get("tableau"), composition=summary.get("composition"),
        h=spec.h,
        max_momentum_drift=float(drift) if drift is not None else 0.0,
        wall_time=float(summary.get("wall_time", 0.0)), origin=provenance)


def write_file(record: JobRecord, connection: sqlite3.Connection, stored: StoredTrajectory, selection: Selection,
               fmt: Literal["csv", "npz", "netcdf"], directory: Path) -> tuple[Path, str]:
    """(path, media type) of the selected points written in directory as raydamp writes them, a slice at a time."""
    rows = max(1, SLICE_BYTES // stored.row_bytes)
    pieces = selection.pieces(rows)
    first = next(pieces)
    spec = JobSpec.model_validate(record.spec)  # once for the file, not once per slice
    head = stored_solution(record, read_arrays(connection, stored, first), spec)
    path = directory / f"trajectory{SUFFIXES[fmt]}"
    if fmt == "npz":
        _write_npz(head, connection, stored, selection, rows, path)
    elif fmt == "csv":
        head.save(path)
        part = directory / "part.csv"
        with path.open("ab") as out:
            for piece in pieces:
                stored_solution(record, read_arrays(connection, stored, piece), spec).save(part)
                with part.open("rb") as text:
                    text.readline()  # the header, written once
                    while block := text.read(1 << 20):
                        out.write(block)
        part.unlink(missing_ok=True)
    else:
        _write_netcdf(head, connection, stored, selection, pieces, path)
    return path, MEDIA_TYPES[fmt]


def _write_npz(head: raydamp.Solution, connection: sqlite3.Connection, stored: StoredTrajectory,
               selection: Selection, rows: int, path: Path) -> None:
    """raydamp's .npz (np.savez: a zip of .npy members), each member's data copied a slice at a time."""
    sample = path.with_name("head.npz")
    head.save(sample)
    columns = (["t", "q", "p", "energy", "momentum"] + (["work"] if stored.has_work else [])
               + (["load_work"] if stored.has_load_work else []))
    n = len(selection)
    with zipfile.ZipFile(sample) as written, zipfile.ZipFile(path, "w", zipfile.ZIP_STORED, allowZip64=True) as out:
        for column in columns:
            width = {"q": stored.dim, "p": stored.dim, "momentum": stored.momenta}.get(column)
            with out.open(f"{column}.npy", "w", force_zip64=True) as member:
                np.lib.format.write_array_header_1_0(member, {"descr": np.lib.format.dtype_to_descr(np.dtype("<f8")),
                                                             "fortran_order": False,
                                                             "shape": (n,) if width is None else (n, width)})
                for piece in selection.pieces(rows):
                    member.write(np.ascontiguousarray(read_column(connection, stored, column, piece),
                                                      dtype="<f8").tobytes())
        for name in written.namelist():  # raydamp's attributes (the provenance), as it wrote them
            if name.removesuffix(".npy") not in columns:
                out.writestr(name, written.read(name))
    sample.unlink()


def _write_netcdf(head: raydamp.Solution, connection: sqlite3.Connection, stored: StoredTrajectory,
                  selection: Selection, pieces, path: Path) -> None:
    """raydamp's Dataset of the first slice with time unlimited, then each further slice appended along it."""
    import h5netcdf

    head.to_xarray().to_netcdf(path, engine="h5netcdf", unlimited_dims=["time"])
    done = head.t.size
    with h5netcdf.File(path, "a") as out:
        for piece in pieces:
            arrays = read_arrays(connection, stored, piece)
            end = done + arrays.t.size
            out.resize_dimension("time", end)
            for name in ("t", "q", "p", "energy", "momentum", "work", "load_work"):
                values = getattr(arrays, name)
                if values is not None and values.size and name in out.variables:
                    out.variables[name][done:end, ...] = values
            done = end


def plot_png(sol: raydamp.Solution, kind: Literal["energy", "phase", "projection"], *, width: int, height: int,
             coordinate: str | None = None, x: str | None = None, y: str | None = None) -> bytes:
    """A PNG of width x height pixels; ValueError (naming the argument) for an impossible plot."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    dpi = 100
    figure = Figure(figsize=(width / dpi, height / dpi), dpi=dpi, layout="constrained")
    FigureCanvasAgg(figure)
    ax = figure.add_subplot()
    if kind == "energy":
        sol.plot.energy(ax=ax)
    elif kind == "phase":
        sol.plot.phase(coordinate if coordinate is not None else 0, ax=ax)
    else:
        sol.plot.projection(x if x is not None else 0, y if y is not None else 1, ax=ax)
    out = io.BytesIO()
    figure.savefig(out, format="png", dpi=dpi)
    return out.getvalue()
