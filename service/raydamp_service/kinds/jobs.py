"""The job: one raydamp integration, its table (summary; trajectory as float64 blobs), its files, its run."""

from __future__ import annotations

import functools
import sqlite3
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from raydamp.jobs import JobSpec
from raydamp.jobs.statuses import FAILED, FINISHED

from ..checks.limits import RaydampCall, planned_steps
from ..checks.pool import CheckPool, build_for_run, checked_inline
from ..config import Settings
from ..tasks.runner import Outcome, Run
from ..tasks.store import TaskRecord, TaskStore, normalise_stored
from ..trajectories.arrays import SAVED, SPRINGS_SQL, WIDTH_SQL, StoredTrajectory, TrajectoryArrays
from ..trajectories.stream import read_arrays
from .files import FILE_COLUMNS_ADDED, FILES_TABLE, FileStore

__all__ = ["JobStore", "JobRecord", "JobWork", "TrajectoryArrays", "StoredTrajectory"]

_FLOAT = np.dtype("<f8")  # the blob format: little-endian float64, row-major
_SHORT_WORK = 100_000  # steps x coordinates of a built-in model's run of milliseconds
_TABLES = f"""
CREATE TABLE IF NOT EXISTS trajectories (job_id TEXT PRIMARY KEY REFERENCES jobs(id) ON DELETE CASCADE,
    points INTEGER NOT NULL, dim INTEGER NOT NULL, momenta INTEGER NOT NULL,
    {", ".join(f"{a.name} BLOB{'' if a.optional else ' NOT NULL'}" for a in SAVED)});
"""


@dataclass(frozen=True, kw_only=True)
class JobRecord(TaskRecord):
    progress: float = 0.0
    summary: dict[str, Any] | None = None
    failed_step: int | None = None
    has_trajectory: bool = False

    @functools.cached_property
    def job_spec(self) -> JobSpec:
        return JobSpec.model_validate(self.spec)

    checked_call: ClassVar[RaydampCall | None] = None  # the run the submission's check built here (checked())

    def checked(self, spec: JobSpec, call: RaydampCall | None) -> JobRecord:
        """This record with the spec and run its submission's check built, which the runner then reuses."""
        self.__dict__["job_spec"] = spec  # not fields: no columns
        self.__dict__["checked_call"] = call
        return self


def _blob(array: np.ndarray | None) -> memoryview | None:  # the array's own buffer, not a copy
    return memoryview(np.ascontiguousarray(array, dtype=_FLOAT).reshape(-1)).cast("B") if array is not None else None


def _first_given(*paths: str, otherwise: str = "NULL") -> str:
    """SQL: the first of these JSON values that is given and not "" (as Python's `a or b`), else otherwise."""
    return "COALESCE(" + ", ".join([*(f"NULLIF(json_extract({path}), '')" for path in paths), otherwise]) + ")"


_LABEL = _first_given("spec, '$.model'", "spec, '$.system.name'", "spec, '$.system.kind'", otherwise="'system'")
_METHOD = _first_given("summary, '$.method'", "spec, '$.method'")


class JobStore(TaskStore[JobRecord], FileStore):
    """The jobs, their trajectories, and the uploaded files their systems name."""

    TABLE, RECORD, PROGRESS, RETAINED, TABLES = "jobs", JobRecord, "progress", True, _TABLES + FILES_TABLE
    COLUMNS = "progress REAL NOT NULL DEFAULT 0, summary TEXT, failed_step INTEGER"  # summary: Solution.summary()
    COMPUTED = {"has_trajectory": "EXISTS (SELECT 1 FROM trajectories WHERE job_id = jobs.id)"}
    # Stored bytes of a job's trajectory (StoredTrajectory.row_bytes per point).
    BYTES = ("(SELECT points * (" + " + ".join(f"({a.name} IS NOT NULL) * {WIDTH_SQL.get(a.width, 1)}" if a.optional
                                               else WIDTH_SQL.get(a.width, "1") for a in SAVED) +
             ") * 8 FROM trajectories WHERE job_id = jobs.id)")

    def _upgrade(self, db: sqlite3.Connection) -> None:
        kept = {row["name"] for row in db.execute("PRAGMA table_info(trajectories)")}
        for array in SAVED:  # an optional array from after the file was written (work, then load_work)
            if array.name not in kept:
                db.execute(f"ALTER TABLE trajectories ADD COLUMN {array.name} BLOB")
        present = {row["name"] for row in db.execute("PRAGMA table_info(files)")}
        for column, declaration in FILE_COLUMNS_ADDED.items():  # from before records were uploaded
            if column not in present:
                db.execute(f"ALTER TABLE files ADD COLUMN {column} {declaration}")
        normalise_stored(db, self.TABLE, JobSpec)

    def listing(self, limit: int, status: str | None = None) -> list[sqlite3.Row]:
        """Newest first, a line per job: label and method read by SQLite from the stored JSON (no spec parsed here)."""
        where, args = ("WHERE status = ?", (status,)) if status else ("", ())
        return self.db.connection().execute(
            f"SELECT id, status, progress, created_at, finished_at, {_LABEL} AS label, {_METHOD} AS method "
            f"FROM jobs {where} ORDER BY seq DESC LIMIT ?", (*args, limit)).fetchall()

    def work(self, settings: Settings, checks: CheckPool | None = None) -> JobWork:
        return JobWork(self, settings, checks)

    def finish(self, job_id: str, status: str, *, summary: dict[str, Any] | None = None, error: str | None = None,
               failed_step: int | None = None, trajectory: TrajectoryArrays | None = None,
               progress: float | None = None) -> bool:
        """TaskStore.finish with the saved points, in one transaction."""
        row = None if trajectory is None else (
            f"INSERT OR REPLACE INTO trajectories (job_id, points, dim, momenta, {', '.join(a.name for a in SAVED)}) "
            f"VALUES (?, ?, ?, ?{', ?' * len(SAVED)})",
            (job_id, *trajectory.q.shape, trajectory.momentum.shape[1],
             *(_blob(getattr(trajectory, a.name)) for a in SAVED)))
        return super().finish(job_id, status, error=error, progress=1.0 if status == "completed" else progress,
                              also=row, summary=summary, failed_step=failed_step)

    def trajectory(self, job_id: str) -> TrajectoryArrays | None:
        opened = self.open_trajectory(job_id)
        if opened is None:
            return None
        connection, stored = opened
        try:
            return read_arrays(connection, stored, range(stored.points))
        finally:
            connection.close()

    def open_trajectory(self, job_id: str) -> tuple[sqlite3.Connection, StoredTrajectory] | None:
        """A snapshot connection in which the job's trajectory exists, and where it is; the caller closes it."""
        optional = [a.name for a in SAVED if a.optional]
        flags = "".join(f", {name} IS NOT NULL" for name in optional)
        found = self.db.snapshot(f"SELECT rowid, points, dim, momenta, {SPRINGS_SQL}{flags} FROM trajectories "
                                 "WHERE job_id = ?", (job_id,))
        if found is None:
            return None
        connection, row = found
        return connection, StoredTrajectory(*row[:4], frozenset(name for name, kept in zip(optional, row[5:]) if kept),
                                            springs=row[4])


class JobWork:
    """A job's run: raydamp.integrate on a worker thread (the C++ loop releases the GIL), `workers` at once."""

    def __init__(self, store: JobStore, settings: Settings, checks: CheckPool | None = None):
        self._store = store
        self._checks = checks
        self.threads, self.fraction = settings.workers, True

    @staticmethod
    def _short(spec: JobSpec) -> bool:
        """A run of milliseconds, which reports no progress (a report takes the interpreter lock from the loop)."""
        state = spec.initial_state  # numbers, if checked_inline
        return checked_inline(spec) and planned_steps(spec) * max(len(state.q), len(state.p), 1) < _SHORT_WORK

    def run(self, record: JobRecord, run: Run) -> Outcome:
        spec = record.job_spec
        call = record.checked_call or build_for_run(self._checks, spec, run, files=self._store.parsed_files)
        if call is None:
            return Outcome("cancelled", None, run.progress)
        solution = call.run(progress=None if self._short(spec) else run.report, cancel=run.token)
        result = {"summary": solution.summary(), "trajectory": TrajectoryArrays.of(solution)}
        if solution.status in FAILED:
            # A blow-up (or a trajectory that outgrew memory) fails, keeping everything computed up to it.
            return Outcome("failed", solution.message, run.progress, {**result, "failed_step": solution.failed_step})
        return Outcome("completed" if solution.status in FINISHED else "cancelled", None, run.progress, result)

    def close(self) -> None:
        """Nothing held between runs."""
