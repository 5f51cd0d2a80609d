"""The heavy checks (a system's compile and trial step, an upload's parse, a plot) in a pebble ProcessPool forked
warm from a forkserver. A task's budgets: CPU (check_seconds, a profiling timer that ends even a compile holding the
GIL: 422), memory (check_memory_bytes, RLIMIT_AS: 422), wall time (_WALL_FACTOR budgets: a loaded machine, 429). A
check answers with the machine code it compiled, which the server loads: only this pool's processes send it."""

from __future__ import annotations

import ctypes
import logging
import multiprocessing
import os
import resource
import signal
import sqlite3
import sys
import threading
import time
from concurrent.futures import TimeoutError as FutureTimeout
from pathlib import Path
from typing import Any

from pebble import ProcessExpired, ProcessPool

from raydamp.jobs import JobSpec, SweepSpec
from raydamp.systems.system import NotCompiled, compiled_elsewhere, load_compiled

from ..config import Settings
from .limits import JobError, RaydampCall, build_call, check_spec, check_sweep_spec
from .uploads import ParsedFiles, UploadError

__all__ = ["CheckPool", "ChecksBusy", "PlotOverBudget", "build_for_run", "checked_inline", "isolated"]

log = logging.getLogger("raydamp_service.checks")

_BYTES_PER_PARSED_ENTRY = 12  # a CSC matrix: a float64 value and an int32 row index per stored entry
_WALL_FACTOR = 4  # the wall-clock ceiling, in CPU budgets
_MEMORY_EXIT = 3  # a worker's exit status after a MemoryError (its heap is not trusted afterwards)
_START_SECONDS = 60.0  # how long a task waits for a process (one replacing a killed one warms up first)


class ChecksBusy(Exception):
    """No place for a check now (max_pending_checks, or the machine too loaded to finish it): retry later."""


class PlotOverBudget(Exception):
    """A plot's drawing passed a check's CPU or memory budget; the message says which settings."""


def isolated(spec: JobSpec) -> bool:
    """Whether a job's check runs in a check process: a user-defined system, or a load with an expression."""
    return spec.system is not None or spec.compiles()


def checked_inline(spec: JobSpec) -> bool:
    """Whether a job's check is light enough for the event loop: a built-in model, no load, a numeric initial state."""
    state = spec.initial_state
    return (spec.system is None and spec.load is None and spec.ground_motion is None
            and isinstance(getattr(state, "q", None), list) and isinstance(getattr(state, "p", None), list))


# ---- in a check process ----

_files: ParsedFiles | None = None  # the uploads as this process has parsed them


class _StoredFiles:
    """The uploads as ParsedFiles reads them, through a read-only connection of the check process's own."""

    def __init__(self, db: str):
        self._db = db
        self._connection: sqlite3.Connection | None = None

    def _read(self, sql: str, file_id: str):
        if self._connection is None:
            self._connection = sqlite3.connect(Path(self._db).as_uri() + "?mode=ro", uri=True)
        return self._connection.execute(sql, (file_id,)).fetchone()

    def file_content(self, file_id: str) -> bytes | None:
        row = self._read("SELECT content FROM files WHERE id = ?", file_id)
        return bytes(row[0]) if row else None

    def file_exists(self, file_id: str) -> bool:
        return self._read("SELECT 1 FROM files WHERE id = ?", file_id) is not None


def _start_worker(settings: Settings) -> None:
    """A check process's start: dies with the forkserver, then takes its memory budget (forked warm: warm.py)."""
    global _files
    try:  # a check busy compiling never reads the pipe that would tell it the service has gone
        ctypes.CDLL(None).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass
    from . import warm  # forked with it done (the forkserver's preload); else its import warms up here

    warm.touch(settings)
    _, hard = resource.getrlimit(resource.RLIMIT_AS)
    size = int(Path("/proc/self/statm").read_text().split()[0]) * resource.getpagesize()  # VmSize
    limit = size + settings.check_memory_bytes
    resource.setrlimit(resource.RLIMIT_AS, (limit if hard == resource.RLIM_INFINITY else min(limit, hard), hard))
    _files = ParsedFiles(_StoredFiles(str(Path(settings.db).resolve())),
                         settings.check_memory_bytes // 4 // _BYTES_PER_PARSED_ENTRY)


def _task(function, args: tuple, cpu_seconds: float) -> tuple[str, Any]:
    """function(*args) within the CPU budget: ("ok" | "invalid" | "refused" | "error" | "cpu", value)."""
    started = time.process_time()
    signal.setitimer(signal.ITIMER_PROF, cpu_seconds)  # SIGPROF, whose default action ends the process
    try:
        answer: tuple[str, Any] = ("ok", function(*args))
    except JobError as error:
        answer = ("invalid", (error.loc, error.message))
    except UploadError as error:
        answer = ("refused", str(error))
    except MemoryError:
        os._exit(_MEMORY_EXIT)
    except Exception as error:  # noqa: BLE001 - reported to the server, which logs it as its own
        answer = ("error", f"{type(error).__name__}: {error}")
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0)
    used = time.process_time() - started
    return ("cpu", used) if used > cpu_seconds else answer


def _warm_up_failures() -> int | None:
    """In a check process: how many of its forkserver's warm-up steps failed (warm.py); None if none ran."""
    warm = sys.modules.get(f"{__package__}.warm")
    return None if warm is None else warm.FAILED


def _check_job(spec: JobSpec, settings: Settings) -> tuple[str, bytes] | None:
    check_spec(spec, settings, files=_files)
    return spec.compiled_form()


def _check_sweep(spec: SweepSpec, settings: Settings) -> tuple[int, tuple[str, bytes] | None]:
    return check_sweep_spec(spec, settings).members, spec.job.compiled_form()


# ---- in the server ----


def _load(compiled: tuple[str, bytes] | None) -> None:
    """Load what a check process compiled (its answer, over our pipe: never from a client)."""
    if compiled is not None:
        load_compiled(*compiled)


class CheckPool:
    """check_workers processes that run the heavy checks, each task within the budgets."""

    def __init__(self, settings: Settings):
        self._settings = settings
        self._pending = threading.BoundedSemaphore(settings.max_pending_checks)
        self._pool: ProcessPool | None = None
        self._starting: threading.Thread | None = None
        self.closed = False  # stop() was called: the processes are ended

    def start(self) -> None:
        """Start the processes; the service answers while they warm up (a check waits for them)."""
        # On a thread: the first fork waits for the forkserver's preload (about a second); the service's start need not.
        self._starting = threading.Thread(target=self._start_pool, name="raydamp-check-pool", daemon=True)
        self._starting.start()

    def _start_pool(self) -> None:
        context = multiprocessing.get_context("forkserver")
        # Each process forks with raydamp imported and warmed up once, in the forkserver (warm.py).
        context.set_forkserver_preload([__name__, f"{__package__}.warm"])
        pool = ProcessPool(self._settings.check_workers, initializer=_start_worker, initargs=(self._settings,),
                           context=context)
        pool.schedule(int)  # the processes start now: the first check need not wait for the forks
        self._pool = pool

    def _started(self) -> ProcessPool | None:
        """The pool, once built (waiting up to _START_SECONDS for it); None if it was not."""
        if self._starting is not None:
            self._starting.join(timeout=_START_SECONDS)
        return self._pool

    def stop(self) -> None:
        self.closed = True
        pool = self._started()
        if pool is not None:
            pool.stop()
            pool.join(timeout=10)

    def job(self, spec: JobSpec, files=None) -> RaydampCall | None:
        """Every check of a job (limits.check_spec), loading what it compiled: the call if built here, else None."""
        if not isolated(spec):
            return check_spec(spec, self._settings, files=files)
        _load(self._run(_check_job, (spec, self._settings), ("system",)))
        return None

    def sweep(self, spec: SweepSpec) -> int:
        """Every check of a sweep (limits.check_sweep_spec); its number of members."""
        if not isolated(spec.job):
            return check_sweep_spec(spec, self._settings).members
        members, compiled = self._run(_check_sweep, (spec, self._settings), ("job", "system"))
        _load(compiled)
        return members

    def plot(self, read, draw, *args: Any) -> bytes:
        """A plot's PNG, draw(record, read(), *args) in a check process, read() once a place is taken."""
        try:
            refused, png = self._run(draw, args, ("query", "width"), read=read)
        except JobError:
            raise PlotOverBudget(f"drawing this plot took more than check_seconds = {self._settings.check_seconds:g}"
                                 f" s or check_memory_bytes = {self._settings.check_memory_bytes / 2**20:.0f} MiB; "
                                 "ask for fewer pixels (width, height)") from None
        if refused is not None:
            raise ValueError(refused)
        return png

    def compile(self, spec: JobSpec) -> None:
        """Compile a job's functions in a check process, waiting up to check_seconds for a place; load them here."""
        _load(self._run(JobSpec.compiled_form, (spec,), ("system",), wait=True))

    def call(self, function, *args: Any, where: tuple[str, ...] = ("body",)) -> Any:
        """function(*args) in a check process (an upload's parse); JobError at `where` past a budget, ChecksBusy."""
        return self._run(function, args, where)

    def _run(self, function, args: tuple, where: tuple[str, ...], wait: bool = False, read=None) -> Any:
        """read(), if given, is read once a place is taken and goes first among args."""
        budget = self._settings.check_seconds
        pool = self._started()
        if pool is None or not self._pending.acquire(blocking=wait, timeout=budget if wait else None):
            raise ChecksBusy
        try:
            if read is not None:  # what the task needs from the server, read only once it has its place
                args = (args[0], read(), *args[1:])
            future = pool.schedule(_task, (function, args, budget), timeout=_WALL_FACTOR * budget)
            try:
                status, value = future.result(timeout=max(budget, _START_SECONDS))  # waiting for a process
            except FutureTimeout:
                if not future.running() and future.cancel():
                    raise ChecksBusy from None
                status, value = future.result(timeout=_WALL_FACTOR * budget + _START_SECONDS)  # pebble's ceiling
        except FutureTimeout:  # pebble's: the wall-clock ceiling, the CPU budget not reached
            raise ChecksBusy(f"the check took longer than {_WALL_FACTOR} x check_seconds = {_WALL_FACTOR * budget:g}"
                             " s of wall-clock time, within its CPU budget: the service is loaded; retry later"
                             ) from None
        except ProcessExpired as error:
            status, value = ("cpu", None) if error.exitcode == -signal.SIGPROF else ("died", error.exitcode)
        finally:
            self._pending.release()
        if status == "ok":
            return value
        if status == "invalid":
            raise JobError(*value)
        if status == "refused":
            raise JobError(where, value)
        if status == "error":
            raise RuntimeError(f"a check failed: {value}")
        path = ".".join(map(str, where[1:] if where[0] in ("body", "query") else where))
        memory = self._settings.check_memory_bytes / 2**20
        advice = ("upload a smaller file" if where[-1] == "file" else
                  "write it with fewer couplings, or use a Chain or LinearStructure for a large system")
        if status == "cpu":
            raise JobError(where, f"{path}: checking this (compiling its functions, one trial step, or parsing it) "
                           f"used more CPU than the time budget of {budget:g} s (check_seconds); {advice}")
        ended = "" if value == _MEMORY_EXIT else f" (its check process ended with exit code {value})"
        raise JobError(where, f"{path}: checking this needed more than the memory budget of {memory:.0f} MiB "
                       f"(check_memory_bytes){ended}; {advice}")


def build_for_run(checks: CheckPool | None, spec: JobSpec, run, files=None) -> RaydampCall | None:
    """A run's call, its functions compiled by a check process (at submission, else now); None if the service stops."""
    if checks is None:
        return build_call(spec, files=files)
    try:
        with compiled_elsewhere():
            return build_call(spec, files=files)
    except NotCompiled:
        pass
    while not (run.stopping.is_set() or checks.closed):
        try:
            checks.compile(spec)
            break
        except ChecksBusy:
            continue
        except JobError:
            if checks.closed:  # its process was ended by the shutdown, not by a budget
                return None
            raise
    else:
        return None
    with compiled_elsewhere():  # NotCompiled now would be a bug, reported as an internal error
        return build_call(spec, files=files)
