"""The sweep: a job over a grid of members, run through raydamp.sweep on a Dask client; its table and its run."""

from __future__ import annotations

import logging
import sqlite3
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import raydamp
from raydamp.jobs import SweepSpec
from raydamp.results.ensemble_solution import STATUSES
from raydamp.results.io.sweep import save_sweep
from raydamp.run.cluster import local_cluster

from ..checks.pool import CheckPool, build_for_run, isolated
from ..config import Settings
from ..tasks.runner import Outcome, Run
from ..tasks.store import TaskRecord, TaskStore, normalise_stored

__all__ = ["SweepStore", "SweepRecord", "SweepWork"]

log = logging.getLogger("raydamp_service.sweeps")


@dataclass(frozen=True, kw_only=True)
class SweepRecord(TaskRecord):
    members: int
    members_done: int = 0
    outcomes: dict[str, int] | None = None
    result_bytes: int | None = None


class SweepStore(TaskStore[SweepRecord]):
    TABLE, RECORD, PROGRESS, NOUN = "sweeps", SweepRecord, "members_done", "sweep"
    # outcomes: {status: members} as JSON; result: the Dataset as NetCDF (raydamp.load reads it)
    COLUMNS = "members INTEGER NOT NULL, members_done INTEGER NOT NULL DEFAULT 0, outcomes TEXT, result BLOB"
    COMPUTED = {"result_bytes": "length(result)"}
    BYTES = "length(result)"

    def _upgrade(self, db: sqlite3.Connection) -> None:
        normalise_stored(db, self.TABLE, SweepSpec)

    def work(self, settings: Settings, checks: CheckPool | None = None) -> SweepWork:
        return SweepWork(self, settings, checks)

    def result_handle(self, sweep_id: str) -> tuple[sqlite3.Connection, int, int] | None:
        """(a read-only snapshot connection, the blob's rowid, its size), or None; the caller closes it."""
        found = self.db.snapshot("SELECT rowid, length(result) FROM sweeps WHERE id = ? AND result IS NOT NULL",
                                 (sweep_id,))
        return (found[0], *found[1]) if found else None


class SweepWork:
    """A sweep's run, one at a time (it spreads over the whole cluster), on a Dask client made at the first sweep."""

    threads, fraction = 1, False  # progress: members done

    def __init__(self, store: SweepStore, settings: Settings, checks: CheckPool | None = None):
        self._store, self._settings, self._checks = store, settings, checks
        self._client = self._cluster = None

    def _dask_client(self):
        if self._client is None:
            from dask.distributed import Client

            if self._settings.dask_scheduler:
                self._client = Client(self._settings.dask_scheduler, timeout=30)
            else:  # its servers on 127.0.0.1 only (Dask's own open port 8787 on every address)
                self._cluster = local_cluster(1, self._settings.sweep_threads, processes=False)
                self._client = Client(self._cluster)
        return self._client

    def close(self) -> None:
        for thing in (self._client, self._cluster):
            if thing is not None:
                try:
                    thing.close()
                except Exception:  # a cluster already gone must not stop the shutdown
                    log.warning("closing the Dask client failed", exc_info=True)

    def _loaded(self, spec: SweepSpec, run: Run) -> bool:
        """The base system's functions compiled and loaded; False if the service stops meanwhile."""
        return self._checks is None or not isolated(spec.job) or build_for_run(self._checks, spec.job, run) is not None

    def run(self, record: SweepRecord, run: Run) -> Outcome:
        spec = SweepSpec.model_validate(record.spec)
        if not self._loaded(spec, run):
            return Outcome("cancelled")  # the service is stopping: back to the queue
        job, grid = spec.job_form(), spec.grid_arguments()
        ds = raydamp.sweep(job, grid, client=self._dask_client(), chunk_size=spec.chunk_size,
                           progress=run.report, cancel=run.token)  # once per chunk
        cancelled = bool(ds.attrs.get("cancelled"))
        if cancelled and run.interrupted:
            return Outcome("cancelled")  # handed back to the queue: no result to write
        status = ds["status"].values
        outcomes = {name: int((status == code).sum()) for code, name in enumerate(STATUSES) if (status == code).any()}
        done = int(status.size - (status == STATUSES.index("cancelled")).sum()) if cancelled else int(status.size)
        with tempfile.TemporaryDirectory(dir=self._store.path.resolve().parent) as scratch:
            path = Path(scratch) / "sweep.nc"
            save_sweep(ds, path)
            result: dict[str, Any] = {"outcomes": outcomes, "result": path.read_bytes()}
        failed = 0 if cancelled else status.size - outcomes.get("completed", 0)
        error = f"{failed} of {status.size} members did not complete (see outcomes and the result's messages)" \
            if failed else None
        return Outcome("cancelled" if cancelled else "completed", error, done, result)
