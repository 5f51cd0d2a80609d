"""A finished job's trajectory as a raydamp.Solution with the job's spec as provenance, from which raydamp writes a
file (CSV, NPZ, NetCDF: a slice of rows at a time, read from the blobs) or draws a plot."""

from __future__ import annotations

import sqlite3
from pathlib import Path
from typing import Literal

import numpy as np

import raydamp
from raydamp.jobs import JobSpec
from raydamp.results.io import write_solution
from raydamp.results.io.dataset import events_csv
from raydamp.results.stored import stored_solution as solution_of

from .arrays import SAVED, StoredTrajectory, TrajectoryArrays
from .stream import read_arrays, read_column

__all__ = ["draw_plot", "events_file", "stored_solution", "write_file"]

FILES = {"csv": (".csv", "text/csv"), "npz": (".npz", "application/octet-stream"),
         "netcdf": (".nc", "application/x-netcdf")}  # format -> (suffix, media type)


def stored_solution(record, arrays: TrajectoryArrays, spec: JobSpec) -> raydamp.Solution:
    """The stored run as a Solution; its provenance is the job spec as submitted (spec: it validated)."""
    return solution_of(spec, record.summary, {a.name: getattr(arrays, a.name) for a in SAVED},
                       origin={**record.spec, "job_id": record.id}, status=record.status, message=record.error or "",
                       failed_step=record.failed_step)


def write_file(record, spec: JobSpec, connection: sqlite3.Connection, stored: StoredTrajectory,
               selection: range, fmt: Literal["csv", "npz", "netcdf"], directory: Path) -> tuple[Path, str]:
    """(path, media type) of the selected points written in directory, a slice at a time."""
    head = stored_solution(record, read_arrays(connection, stored, selection[:1]), spec)

    def read(column: str, start: int, stop: int) -> np.ndarray:
        return read_column(connection, stored, column, selection[start:stop])

    suffix, media_type = FILES[fmt]
    write_solution(path := directory / f"trajectory{suffix}", fmt, head, read, len(selection))
    return path, media_type


def events_file(record, spec: JobSpec, connection: sqlite3.Connection, stored: StoredTrajectory,
                directory: Path) -> Path:
    """The job's events table as CSV (name, t, direction, q_<name>..., p_<name>...), written in directory."""
    head = stored_solution(record, read_arrays(connection, stored, range(1)), spec)
    names, rows = events_csv(head)
    path = directory / "events.csv"
    path.write_text("\n".join([",".join(names), *(",".join(row) for row in rows)]) + "\n")
    return path


def draw_plot(record, arrays: TrajectoryArrays, spec: JobSpec, kind: str,
              options: dict) -> tuple[str | None, bytes | None]:
    """(None, the PNG), or (raydamp's refusal, None) for a plot this run cannot have; in a check process."""
    try:
        return None, stored_solution(record, arrays, spec).plot.png(kind, **options)
    except ValueError as error:
        return str(error), None
