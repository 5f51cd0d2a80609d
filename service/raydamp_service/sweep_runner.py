"""The thread that runs queued sweeps through raydamp.sweep on a Dask client, one sweep at a time
(a sweep already spreads over every worker of the cluster).

The client is made at the first sweep: to the scheduler at settings.dask_scheduler, or to a
LocalCluster inside this process (threads). Progress is recorded per finished chunk; a cancel
keeps the chunks finished so far as the result; at shutdown a running sweep is interrupted and
queued again, like a job.
"""

from __future__ import annotations

import logging
import queue
import sqlite3
import tempfile
import threading
from pathlib import Path

import numpy as np

import raydamp
from raydamp.results.ensemble_solution import STATUSES
from raydamp.results.io.sweep import save_sweep

from .config import Settings
from .problems import sweep_arguments
from .schemas import SweepSpec
from .sweep_store import SweepStore

__all__ = ["SweepRunner"]

log = logging.getLogger("raydamp_service.sweeps")


class SweepRunner:
    def __init__(self, store: SweepStore, settings: Settings):
        self._store = store
        self._settings = settings
        self._queue: queue.Queue[str | None] = queue.Queue()
        self._thread: threading.Thread | None = None
        self._stopping = threading.Event()
        self._lock = threading.Lock()
        self._active: tuple[str, raydamp.CancelToken] | None = None
        self._cancelled_by_user: set[str] = set()
        self._client = None
        self._cluster = None
        self._done: dict[str, int] = {}

    def start(self) -> None:
        self._thread = threading.Thread(target=self._work, name="raydamp-sweeps", daemon=True)
        self._thread.start()
        for sweep_id in self._store.recover():
            self._queue.put(sweep_id)

    def stop(self) -> None:
        self._stopping.set()
        with self._lock:
            if self._active is not None:
                self._active[1].cancel()
        self._queue.put(None)
        if self._thread is not None:
            self._thread.join(timeout=self._settings.shutdown_seconds)
        for thing in (self._client, self._cluster):
            if thing is not None:
                try:
                    thing.close()
                except Exception:  # a cluster already gone must not stop the shutdown
                    log.warning("closing the Dask client failed", exc_info=True)

    def submit(self, sweep_id: str) -> None:
        self._queue.put(sweep_id)

    def cancel(self, sweep_id: str) -> None:
        with self._lock:
            if self._active is not None and self._active[0] == sweep_id:
                self._cancelled_by_user.add(sweep_id)
                self._active[1].cancel()

    def members_done(self, sweep_id: str) -> int | None:
        """Live count for a running sweep (None if this process is not running it)."""
        return self._done.get(sweep_id)

    def _dask_client(self):
        if self._client is None:
            from dask.distributed import Client, LocalCluster

            if self._settings.dask_scheduler:
                self._client = Client(self._settings.dask_scheduler, timeout=30)
            else:
                self._cluster = LocalCluster(n_workers=1, threads_per_worker=self._settings.sweep_threads,
                                             processes=False, dashboard_address=None)
                self._client = Client(self._cluster)
        return self._client

    def _work(self) -> None:
        while True:
            sweep_id = self._queue.get()
            if sweep_id is None or self._stopping.is_set():
                return
            try:
                self._run(sweep_id)
            except Exception as error:  # the thread outlives any one sweep
                log.exception("sweep %s: internal error", sweep_id)
                try:
                    self._store.finish(sweep_id, "failed", error=f"{type(error).__name__}: {error}")
                except sqlite3.Error:
                    log.exception("sweep %s: could not record the failure", sweep_id)
            finally:
                self._done.pop(sweep_id, None)

    def _run(self, sweep_id: str) -> None:
        token = raydamp.CancelToken()
        with self._lock:
            self._active = (sweep_id, token)
        try:
            record = self._store.claim(sweep_id)
            if record is None:
                return  # cancelled while queued
            if record.cancel_requested:
                self._cancelled_by_user.add(sweep_id)
                token.cancel()
            if self._stopping.is_set():
                self._store.requeue(sweep_id)
                return
            self._execute(sweep_id, SweepSpec.model_validate(record.spec), token)
        finally:
            with self._lock:
                self._active = None
            self._cancelled_by_user.discard(sweep_id)

    def _execute(self, sweep_id: str, spec: SweepSpec, token: raydamp.CancelToken) -> None:
        job, grid = sweep_arguments(spec)

        def progress(done: int, total: int) -> None:  # once per finished chunk
            self._done[sweep_id] = done
            try:
                self._store.set_done(sweep_id, done)
            except sqlite3.Error:  # advisory; never stop a sweep for it
                log.warning("sweep %s: could not save progress", sweep_id, exc_info=True)

        self._done[sweep_id] = 0
        try:
            ds = raydamp.sweep(job, grid, client=self._dask_client(), chunk_size=spec.chunk_size, progress=progress,
                               cancel=token)
        except ValueError as error:  # checked at submission; report rather than crash
            self._store.finish(sweep_id, "failed", error=str(error))
            return
        if ds.attrs.get("cancelled") and sweep_id not in self._cancelled_by_user and self._stopping.is_set():
            self._store.requeue(sweep_id)  # interrupted by shutdown: run again at the next start
            return
        status = ds["status"].values
        outcomes = {name: int((status == code).sum()) for code, name in enumerate(STATUSES)
                    if (status == code).any()}
        done = int(status.size - (status == STATUSES.index("cancelled")).sum()) if ds.attrs.get("cancelled") \
            else int(status.size)
        with tempfile.TemporaryDirectory(dir=Path(self._settings.db).resolve().parent) as scratch:
            path = Path(scratch) / "sweep.nc"
            save_sweep(ds, path)
            result = path.read_bytes()
        final = "cancelled" if ds.attrs.get("cancelled") else "completed"
        failed = int(np.count_nonzero(status != STATUSES.index("completed"))) if final == "completed" else 0
        error = f"{failed} of {status.size} members did not complete (see outcomes and the result's messages)" \
            if failed else None
        self._store.finish(sweep_id, final, outcomes=outcomes, error=error, result=result, members_done=done)
