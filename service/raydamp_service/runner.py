"""Worker threads that run queued jobs through raydamp.integrate.

HTTP handlers only write a row and put its id on the queue. Each worker takes an id,
claims the job in the store, runs it (the C++ loop releases the GIL, so the event loop
and the other workers keep going) and records the outcome with its trajectory.
"""

from __future__ import annotations

import logging
import math
import queue
import sqlite3
import threading
import time
from dataclasses import dataclass, field

import raydamp

from .config import Settings
from .files import file_resolver
from .problems import JobError, build_call
from .schemas import JobSpec
from .store import JobStore, TrajectoryArrays

__all__ = ["Runner"]

log = logging.getLogger("raydamp_service.runner")


@dataclass
class _ActiveRun:
    token: raydamp.CancelToken = field(default_factory=raydamp.CancelToken)
    progress: float = 0.0
    saved_at: float = field(default_factory=time.monotonic)
    cancelled_by_user: bool = False


class Runner:
    def __init__(self, store: JobStore, settings: Settings):
        self._store = store
        self._settings = settings
        self._queue: queue.Queue[str | None] = queue.Queue()
        self._threads: list[threading.Thread] = []
        self._active: dict[str, _ActiveRun] = {}
        self._lock = threading.Lock()
        self._stopping = threading.Event()
        self._retention_wake = threading.Event()
        self._retention: threading.Thread | None = None

    # ---- called by the application ----

    def start(self) -> None:
        for i in range(self._settings.workers):
            # daemon: a run that ignores cancellation must not keep a stopped service alive.
            thread = threading.Thread(target=self._work, name=f"raydamp-worker-{i}", daemon=True)
            thread.start()
            self._threads.append(thread)
        self._retention = threading.Thread(target=self._retain, name="raydamp-retention", daemon=True)
        self._retention.start()
        recovered = self._store.recover()
        if recovered:
            log.info("re-queued %d job(s) left queued or running by a previous process", len(recovered))
        for job_id in recovered:
            self._queue.put(job_id)

    def stop(self) -> None:
        """Interrupt the runs; their jobs go back to "queued" and run again at the next start."""
        self._stopping.set()
        with self._lock:
            for run in self._active.values():
                run.token.cancel()
        for _ in self._threads:
            self._queue.put(None)
        self._retention_wake.set()
        deadline = time.monotonic() + self._settings.shutdown_seconds
        for thread in [*self._threads, *([self._retention] if self._retention else [])]:
            thread.join(timeout=max(0.0, deadline - time.monotonic()))
        self._threads.clear()

    def submit(self, job_id: str) -> None:
        self._queue.put(job_id)

    def cancel(self, job_id: str) -> None:
        with self._lock:
            run = self._active.get(job_id)
            if run is not None:
                run.cancelled_by_user = True
                run.token.cancel()

    def progress(self, job_id: str) -> float | None:
        """The live progress of a running job (None if this process is not running it)."""
        run = self._active.get(job_id)
        return run.progress if run is not None else None

    # ---- worker threads ----

    def _work(self) -> None:
        while True:
            job_id = self._queue.get()
            if job_id is None or self._stopping.is_set():
                return  # a job still queued stays "queued" in the store and is recovered at the next start
            try:
                self._run(job_id)
            except Exception as error:  # a worker outlives any one job
                log.exception("job %s: internal error", job_id)
                try:
                    self._store.finish(job_id, "failed", error=f"internal error: {type(error).__name__}: {error}")
                except sqlite3.Error:
                    log.exception("job %s: could not record the failure; it is re-run at the next start", job_id)

    def _retain(self) -> None:
        """The retention pass: at start, after jobs finish (at most once a second), and periodically."""
        settings = self._settings
        while not self._stopping.is_set():
            self._retention_wake.clear()
            try:
                removed = self._store.prune(max_jobs=settings.retain_jobs, max_age_seconds=settings.retain_seconds,
                                            max_bytes=settings.retain_bytes)
                if removed:
                    log.info("retention: removed %d finished job(s)", removed)
            except sqlite3.Error:
                log.warning("retention pass failed; it is tried again later", exc_info=True)
            if self._stopping.wait(1.0):
                return
            self._retention_wake.wait(settings.retention_interval_seconds)

    def _run(self, job_id: str) -> None:
        run = _ActiveRun()
        # Registered before the claim, so a cancel arriving once the job is "running" always finds the token.
        with self._lock:
            self._active[job_id] = run
        try:
            record = self._store.claim(job_id)
            if record is None:
                return  # cancelled while queued
            if record.cancel_requested:
                run.cancelled_by_user = True
                run.token.cancel()
            if self._stopping.is_set():
                self._store.requeue(job_id)
                return
            self._execute(job_id, JobSpec.model_validate(record.spec), run)
        finally:
            with self._lock:
                self._active.pop(job_id, None)
            self._retention_wake.set()

    def _execute(self, job_id: str, spec: JobSpec, run: _ActiveRun) -> None:
        def on_progress(done: int, total: int) -> None:
            run.progress = done / total if total else 1.0
            now = time.monotonic()
            if now - run.saved_at >= self._settings.progress_save_seconds:
                run.saved_at = now
                try:
                    self._store.set_progress(job_id, run.progress)
                except sqlite3.Error:  # the stored progress is advisory; never stop a run for it
                    log.warning("job %s: could not save progress", job_id, exc_info=True)

        try:
            solution = build_call(spec, files=file_resolver(self._store)).run(progress=on_progress, cancel=run.token)
        except JobError as error:  # passed at submission; an uploaded file it names has gone since
            self._store.finish(job_id, "failed", error=error.message)
            return
        except ValueError as error:  # the spec passed the checks at submission; report, do not crash
            self._store.finish(job_id, "failed", error=str(error))
            return

        if solution.status == "cancelled" and not run.cancelled_by_user and self._stopping.is_set():
            self._store.requeue(job_id)
            return
        trajectory = TrajectoryArrays(t=solution.t, q=solution.q, p=solution.p, energy=solution.energy,
                                      momentum=solution.momentum, work=solution.work)
        outcome = {"summary": solution.summary(), "trajectory": trajectory, "progress": run.progress}
        if solution.status == "completed" and not math.isfinite(float(solution.t[-1])):
            # Refused at submission (step_size x steps must be finite); kept as a last guard, since a
            # run whose times overflowed has not computed what was asked.
            self._store.finish(job_id, "failed", error="the time overflowed to a non-finite value", **outcome)
        elif solution.status == "completed":
            self._store.finish(job_id, "completed", **outcome)
        elif solution.status in ("non_finite", "out_of_memory"):
            # A blow-up (or a trajectory that outgrew memory) is a failed job that keeps everything
            # computed up to it.
            self._store.finish(job_id, "failed", error=solution.message, failed_step=solution.failed_step, **outcome)
        else:
            self._store.finish(job_id, "cancelled", **outcome)
