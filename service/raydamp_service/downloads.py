"""A finished job's trajectory as a file (CSV, NPZ, NetCDF) or a plot (PNG).

No numerics here: the stored arrays become a raydamp.Solution carrying the job's spec as its
provenance, and raydamp writes the file (raydamp.results.io) or draws the plot (raydamp.results.plotting).
Plots use matplotlib's object API on a fresh Figure per request (no pyplot state), so requests
served on different threads do not share a figure.
"""

from __future__ import annotations

import io
import tempfile
from pathlib import Path
from typing import Literal

import raydamp
from raydamp.jobs import JobSpec

from .jobs import JobRecord, TrajectoryArrays

__all__ = ["FORMATS", "PLOTS", "stored_solution", "file_bytes", "plot_png"]

FORMATS = ("json", "csv", "npz", "netcdf")
PLOTS = ("energy", "phase", "projection")
MEDIA_TYPES = {"csv": "text/csv", "npz": "application/octet-stream", "netcdf": "application/x-netcdf"}
SUFFIXES = {"csv": ".csv", "npz": ".npz", "netcdf": ".nc"}


def stored_solution(record: JobRecord, arrays: TrajectoryArrays) -> raydamp.Solution:
    """The stored run as a Solution; its provenance is the job spec as submitted."""
    summary = record.summary or {}
    spec = JobSpec.model_validate(record.spec)
    coordinates, momentum_names = spec.names(arrays.q.shape[1], arrays.momentum.shape[1], spec.save_dofs)
    provenance = {**record.spec, "raydamp_version": raydamp.__version__, "job_id": record.id,
                  "coordinates": coordinates, "momentum_names": momentum_names}
    drift = summary.get("momentum_drift")
    return raydamp.Solution(
        t=arrays.t, q=arrays.q, p=arrays.p, energy=arrays.energy, momentum=arrays.momentum, work=arrays.work,
        status=summary.get("status", record.status), steps=int(summary.get("steps", 0)),
        failed_step=record.failed_step, message=summary.get("message") or record.error or "",
        method=summary.get("method") or record.spec.get("method") or "3s", tableau=summary.get("tableau"), composition=summary.get("composition"),
        h=spec.h,
        max_momentum_drift=float(drift) if drift is not None else 0.0,
        wall_time=float(summary.get("wall_time", 0.0)), origin=provenance)


def file_bytes(sol: raydamp.Solution, fmt: Literal["csv", "npz", "netcdf"]) -> tuple[bytes, str, str]:
    """(body, media type, file name) of the solution written by raydamp in this format."""
    suffix = SUFFIXES[fmt]
    with tempfile.TemporaryDirectory(prefix="raydamp-download-") as directory:
        path = Path(directory) / f"trajectory{suffix}"
        sol.save(path)
        return path.read_bytes(), MEDIA_TYPES[fmt], path.name


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
