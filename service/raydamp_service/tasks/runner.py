"""The runner of one kind of task: worker threads claim queued tasks, run the kind's work (kinds/) and record
how it ended. A cancel stops a run through its token; at shutdown runs go back to the queue."""

from __future__ import annotations

import logging
import queue
import sqlite3
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

import raydamp

from ..config import Settings
from .store import TaskRecord, TaskStore

__all__ = ["Runner", "Run", "Outcome", "Work"]

log = logging.getLogger("raydamp_service.runner")


@dataclass
class Run:
    """A task being run: its cancel token, and its live progress saved at most every `every` seconds."""

    save: Callable[[float], None]
    every: float
    fraction: bool
    stopping: threading.Event
    token: raydamp.CancelToken = field(default_factory=raydamp.CancelToken)
    progress: float = 0
    saved_at: float = field(default_factory=time.monotonic)
    cancelled_by_user: bool = False

    def report(self, done: int, total: int) -> None:
        """raydamp's progress callback."""
        self.progress = (done / total if total else 1.0) if self.fraction else done
        if time.monotonic() - self.saved_at >= self.every:
            self.saved_at = time.monotonic()
            self.save(self.progress)

    @property
    def interrupted(self) -> bool:
        """Stopped by the service's shutdown, not by a user: a cancelled run is then queued again."""
        return self.stopping.is_set() and not self.cancelled_by_user


@dataclass(frozen=True)
class Outcome:
    """How a run ended: a final status, and the kind's result as its store's finish() takes it."""

    status: str
    error: str | None = None
    progress: float | None = None
    result: dict[str, Any] = field(default_factory=dict)


class Work(Protocol):
    """What a kind supplies: its threads, its progress measure, its run, and what to release at shutdown."""

    threads: int
    fraction: bool  # progress is done / total (a job's steps); else the count done (a sweep's members)

    def run(self, record: TaskRecord, run: Run) -> Outcome: ...

    def close(self) -> None: ...


class Runner:
    def __init__(self, store: TaskStore, settings: Settings, work: Work | None = None):
        self._store = store
        self._settings = settings
        self._work: Work = work if work is not None else store.work(settings)
        # (id, the row as its submission stored it, or None), or None: stop.
        self._queue: queue.SimpleQueue[tuple[str, TaskRecord | None] | None] = queue.SimpleQueue()
        self._threads: list[threading.Thread] = []
        self._active: dict[str, Run] = {}
        self._lock = threading.Lock()
        self._stopping = threading.Event()
        self._retention_wake = threading.Event()

    def start(self) -> None:
        for i in range(self._work.threads):
            # daemon: a run that ignores cancellation must not keep a stopped service alive.
            self._threads.append(threading.Thread(target=self._serve, name=f"raydamp-{self._store.TABLE}-{i}",
                                                  daemon=True))
        if self._store.RETAINED:
            self._threads.append(threading.Thread(target=self._retain, name="raydamp-retention", daemon=True))
        for thread in self._threads:
            thread.start()
        recovered = self._store.recover()
        if recovered:
            log.info("re-queued %d %s left queued or running by a previous process", len(recovered), self._store.TABLE)
        for task_id in recovered:
            self._queue.put((task_id, None))

    def stop(self) -> None:
        """Interrupt the runs; their tasks go back to "queued" and run again at the next start."""
        self._stopping.set()
        with self._lock:
            for run in self._active.values():
                run.token.cancel()
        for _ in range(self._work.threads):
            self._queue.put(None)
        self._retention_wake.set()
        deadline = time.monotonic() + self._settings.shutdown_seconds
        for thread in self._threads:
            thread.join(timeout=max(0.0, deadline - time.monotonic()))
        self._threads.clear()
        self._work.close()

    def submit(self, task_id: str, record: TaskRecord | None = None) -> None:
        """Queue a task; record, its row as just stored, carries what the submission's check built."""
        self._queue.put((task_id, record))

    def cancel(self, task_id: str) -> None:
        with self._lock:
            run = self._active.get(task_id)
            if run is not None:
                run.cancelled_by_user = True
                run.token.cancel()

    def progress(self, task_id: str, status: str = "running", stored: float | None = None) -> float | None:
        """The live progress of a running task this process runs, else `stored`."""
        run = self._active.get(task_id) if status == "running" else None
        return run.progress if run is not None else stored

    def _serve(self) -> None:
        while True:
            task = self._queue.get()
            if task is None or self._stopping.is_set():
                return  # a task still queued stays "queued" in the store and is recovered at the next start
            task_id, stored = task
            try:
                self._run(task_id, stored)
            except Exception as error:  # a worker outlives any one task
                log.exception("%s %s: internal error", self._store.TABLE, task_id)
                try:
                    self._store.finish(task_id, "failed", error=f"internal error: {type(error).__name__}: {error}")
                except sqlite3.Error:
                    log.exception("%s %s: could not record the failure; it is re-run at the next start",
                                  self._store.TABLE, task_id)

    def _retain(self) -> None:
        """The retention pass: at start, after runs finish (at most once a second), and periodically."""
        settings = self._settings
        while not self._stopping.is_set():
            self._retention_wake.clear()
            try:
                removed = self._store.prune(max_jobs=settings.retain_jobs, max_age_seconds=settings.retain_seconds,
                                            max_bytes=settings.retain_bytes)
                if removed:
                    log.info("retention: removed %d finished %s", removed, self._store.TABLE)
            except sqlite3.Error:
                log.warning("retention pass failed; it is tried again later", exc_info=True)
            if self._stopping.wait(1.0):
                return
            self._retention_wake.wait(settings.retention_interval_seconds)

    def _save_progress(self, task_id: str, progress: float) -> None:
        try:
            self._store.set_progress(task_id, progress)
        except sqlite3.Error:  # the stored progress is advisory; never stop a run for it
            log.warning("%s %s: could not save progress", self._store.TABLE, task_id, exc_info=True)

    def _run(self, task_id: str, stored: TaskRecord | None) -> None:
        """Run the task (stored: its row as submitted, if this process submitted it)."""
        run = Run(save=lambda progress: self._save_progress(task_id, progress),
                  every=self._settings.progress_save_seconds, fraction=self._work.fraction, stopping=self._stopping)
        # Registered before the claim: a cancel arriving once the task is "running" finds the token.
        with self._lock:
            self._active[task_id] = run
        try:
            record = self._store.claim(task_id)
            if record is None:
                return  # cancelled while queued
            if record.cancel_requested:
                self.cancel(task_id)
            if self._stopping.is_set():
                self._store.requeue(task_id)
                return
            try:  # the submitted row carries the spec validated and the run built by its check (the same spec)
                outcome = self._work.run(record if stored is None else stored, run)
            except ValueError as error:  # the spec passed the checks at submission (a file named has gone since)
                outcome = Outcome("failed", str(error))
            if outcome.status == "cancelled" and run.interrupted:
                self._store.requeue(task_id)
            else:
                self._store.finish(task_id, outcome.status, error=outcome.error, progress=outcome.progress,
                                   **outcome.result)
        finally:
            with self._lock:
                self._active.pop(task_id, None)
            self._retention_wake.set()
