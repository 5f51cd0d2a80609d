"""The checks of a submission that can be heavy, run in worker processes under a budget (issue 27, F1).

A system's check compiles its functions (SymEngine's LLVM JIT holds the interpreter lock all the while:
a 790-byte potential took 34 s, and the whole service stood still), parses the matrix files it names and
takes one trial step. Here those checks run in a small pool of processes forked from a forkserver that has
raydamp imported, never in the server's interpreter. Each check has a time budget (check_seconds) and a
memory budget (check_memory_bytes: address space its process may add to what it holds at start, by
RLIMIT_AS); past either the process is killed and replaced, and the submission gets 422 on `system` naming
the budget. At most max_pending_checks run or wait for a process at once; more get 429.

The server never compiles a user's system itself. A check answers with the functions it compiled, as
bytes (System.compiled_form: SymEngine's LLVM object code, a few kB per function), which the server loads
(raydamp.systems.system.load_compiled, a fraction of a millisecond) into raydamp's cache of compiled
functions by the system's canonical form; the job's run then builds its System from that cache, within
compiled_elsewhere(), which refuses to compile. A run that finds nothing there (evicted, or queued before a
restart) asks a check process to compile it (CheckPool.compile). The bytes carry machine code that the
server will run: they are loaded only from this pool's own processes, over the pipes the server made with
them; nothing a client sends reaches load_compiled.
A built-in model's check costs microseconds and runs in the server itself.
"""

from __future__ import annotations

import ctypes
import logging
import multiprocessing
import queue
import resource
import signal
import sqlite3
import threading
import time
from pathlib import Path
from typing import Any

from raydamp.systems.system import NotCompiled, compiled_elsewhere, load_compiled

from .config import Settings
from .files import ParsedFiles
from .problems import JobError, RaydampCall, build_call, check_spec, check_sweep_spec
from .schemas import JobSpec, SweepSpec

__all__ = ["CheckPool", "ChecksBusy", "PlotOverBudget", "build_for_run", "checked_inline", "isolated"]

log = logging.getLogger("raydamp_service.checks")

_BYTES_PER_PARSED_ENTRY = 12  # a CSC matrix: a float64 value and an int32 row index per stored entry
# A check process's first message, once warmed up (_serve), and how long the server waits for it: a start is
# not a check, and is not charged to the budget of the check that waits for it.
_READY = ("ready", None)
_START_SECONDS = 60.0


class ChecksBusy(Exception):
    """max_pending_checks checks are running or waiting, or no process came free within the time budget."""


class PlotOverBudget(Exception):
    """A plot's drawing passed a check's time or memory budget; the message says which settings."""


def isolated(spec: JobSpec) -> bool:
    """Whether a job's check runs in a check process: every user-defined system (an expression compiles,
    a chain of expression bonds too, a structure parses its files and factorises M), and every job whose load
    has an expression (compiled like a system's)."""
    return spec.system is not None or spec.compiles()


def checked_inline(spec: JobSpec) -> bool:
    """Whether a job's check is light enough for the event loop: a built-in model without a load, its initial
    state given as numbers (not files): its check (sizes, one trial step) is arithmetic on at most max_dim
    coordinates, and reads no file."""
    return spec.system is None and spec.load is None and spec.ground_motion is None and not spec.uploads()


# ---- in a check process ----


class _StoredFiles:
    """The uploads as ParsedFiles reads them, through a read-only connection of the check process's own."""

    def __init__(self, db: str):
        self._db = db
        self._connection: sqlite3.Connection | None = None

    def file_content(self, file_id: str) -> bytes | None:
        if self._connection is None:
            self._connection = sqlite3.connect(Path(self._db).as_uri() + "?mode=ro", uri=True)
        row = self._connection.execute("SELECT content FROM files WHERE id = ?", (file_id,)).fetchone()
        return bytes(row[0]) if row else None


def _status_bytes(field: str) -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1]) * 1024
    raise LookupError(field)


def _limit_address_space(extra: int) -> None:
    """The memory budget: what the process holds now (raydamp imported) plus extra."""
    _, hard = resource.getrlimit(resource.RLIMIT_AS)
    limit = _status_bytes("VmSize") + extra
    if hard != resource.RLIM_INFINITY:
        limit = min(limit, hard)
    resource.setrlimit(resource.RLIMIT_AS, (limit, hard))


def _die_with_parent() -> None:
    """SIGKILL when the forkserver (which ends with the service) goes: a check busy compiling never reads
    the pipe that would tell it."""
    try:
        ctypes.CDLL(None).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


# One small system of each kind, checked when a check process starts, before its memory budget applies: what
# their checks import or initialise on first use (SciPy's sparse solvers and their BLAS, LLVM) is then in place,
# and is not counted against the budget of the first real check (a library mapped under RLIMIT_AS can fail).
_WARM_UP = (
    {"system": {"coordinates": 2, "potential": "q0^2 + q0*q1^3", "damping": {"dampers": [{"on": "q0 - q1"}]},
                "eps": 0.1}},
    {"system": {"kind": "chain", "n": 4, "bond": "expression", "parameters": {"potential": "r^2/2 + r^4/4"}}},
    {"system": {"kind": "linear_structure", "M": {"diagonal": [1.0, 1.0]},
                "K": {"coo": {"shape": [2, 2], "rows": [0, 0, 1, 1], "cols": [0, 1, 0, 1],
                               "values": [2.0, -1.0, -1.0, 2.0]}},
                "alpha": 0.1, "beta": 0.01}},
)


def _warm_up(settings: Settings) -> None:
    try:  # matplotlib and its fonts, imported and loaded before the memory budget applies (as for the systems)
        import raydamp
        from raydamp.models import DampedPendulum

        raydamp.integrate(DampedPendulum(), [1.0], [0.0], h=0.1, n_steps=2).plot.png("energy", width=200, height=150)
    except Exception:  # noqa: BLE001 - a warm-up only; a real plot reports its own errors
        log.warning("check warm-up: a plot", exc_info=True)
    for system in _WARM_UP:
        spec = {**system, "method": "3s", "h": 0.01, "n_steps": 2, "initial_state": {"rest": True}}
        try:
            check_spec(JobSpec.model_validate(spec), settings)
        except Exception:  # noqa: BLE001 - a warm-up only; a real check reports its own errors
            log.warning("check warm-up: %s", spec, exc_info=True)


def _compiled(spec: JobSpec) -> tuple[str, bytes] | None:
    """(key, bytes) of the compiled functions of a job's expression system (built once by the check before:
    raydamp.jobs caches it), for the server to load; None for other kinds."""
    return spec.compiled_form()


def _plot(task: tuple) -> tuple[str | None, bytes | None]:
    """(None, the PNG) of a stored trajectory's plot, or (raydamp's refusal, None): a plot this run cannot
    have (a projection of one coordinate, an unknown coordinate)."""
    from .downloads import stored_solution

    record, arrays, spec, kind, options = task
    try:
        return None, stored_solution(record, arrays, spec).plot.png(kind, **options)
    except ValueError as error:
        return str(error), None


def _check(kind: str, spec: Any, settings: Settings, files: ParsedFiles) -> Any:
    if kind == "plot":
        return _plot(spec)
    if kind == "job":
        check_spec(spec, settings, files=files)
        return _compiled(spec)
    if kind == "compile":
        return _compiled(spec)
    # The plan holds the compiled model: its size travels, and the base system's functions.
    return check_sweep_spec(spec, settings).members, _compiled(spec.job)


def _serve(connection, settings: Settings) -> None:
    """A check process: says _READY once warmed up, then answers (kind, spec, settings) with ("ok", value),
    ("invalid", (loc, message)), ("error", text), or ("memory", None) and then ends (a fresh process
    replaces it)."""
    _die_with_parent()
    _warm_up(settings)
    db, memory_bytes = str(Path(settings.db).resolve()), settings.check_memory_bytes
    _limit_address_space(memory_bytes)
    files = ParsedFiles(_StoredFiles(db), memory_bytes // 4 // _BYTES_PER_PARSED_ENTRY)
    connection.send(_READY)  # the warm-up is done: a check's budget starts from here (_Process.started)
    while True:
        try:
            kind, spec, settings = connection.recv()
        except (EOFError, OSError):
            return
        try:
            answer = ("ok", _check(kind, spec, settings, files))
        except JobError as error:
            answer = ("invalid", (error.loc, error.message))
        except MemoryError:
            connection.send(("memory", None))
            return
        except Exception as error:  # noqa: BLE001 - reported to the server, which logs it as its own
            answer = ("error", f"{type(error).__name__}: {error}")
        connection.send(answer)


# ---- in the server ----


def _load(compiled: tuple[str, bytes] | None) -> None:
    """Load what a check process compiled (its answer, over our pipe: never from a client)."""
    if compiled is not None:
        load_compiled(*compiled)


class _Process:
    def __init__(self, context, settings: Settings):
        self.connection, child = context.Pipe()
        self.process = context.Process(target=_serve, name="raydamp-check", daemon=True,
                                       args=(child, settings))
        self.process.start()
        child.close()
        self.ready = self.dead = False
        self.warm_by = time.monotonic() + _START_SECONDS

    def started(self, until: float) -> bool:
        """Waits (until that time.monotonic(), or the end of the warm-up's own _START_SECONDS) for the process's
        warm-up to end; whether it did. A check's budget counts from here: a process that replaced a killed one
        is handed out at once and warms up (0.4 s here, more on a loaded machine), and that time is not the
        submitted system's."""
        if not self.ready and not self.dead:
            try:
                seconds = max(0.0, min(until, self.warm_by) - time.monotonic())
                self.ready = self.connection.poll(seconds) and self.connection.recv() == _READY
            except (EOFError, OSError):
                self.dead = True
        return self.ready

    def hung(self) -> bool:
        """Not ready, and never will be: it died, or its warm-up outlasted _START_SECONDS."""
        return not self.ready and (self.dead or time.monotonic() >= self.warm_by)

    def end(self) -> None:
        self.process.kill()
        self.process.join(timeout=10)
        self.connection.close()


class CheckPool:
    """check_workers processes that check submitted systems, each check within the budgets."""

    def __init__(self, settings: Settings):
        self._settings = settings
        self._context = multiprocessing.get_context("forkserver")
        self._idle: queue.Queue[_Process] = queue.Queue()
        self._pending = threading.BoundedSemaphore(settings.max_pending_checks)
        self._lock = threading.Lock()
        self._processes: set[_Process] = set()
        self._closed = False

    def start(self) -> None:
        """Start the processes in the background: the service answers while the forkserver imports raydamp."""
        # Each check process is a fork of a process that has imported this module, raydamp with it.
        self._context.set_forkserver_preload(["raydamp_service.checks"])
        threading.Thread(target=self._add, args=(self._settings.check_workers,), name="raydamp-checks-start",
                         daemon=True).start()

    @property
    def closed(self) -> bool:
        """stop() was called: the processes are ended."""
        return self._closed

    def stop(self) -> None:
        with self._lock:
            self._closed = True
            processes, self._processes = self._processes, set()
        for process in processes:
            process.end()

    def job(self, spec: JobSpec, files=None) -> RaydampCall | None:
        """Every check of a job (problems.check_spec); raises JobError naming the field, or ChecksBusy. The
        functions the check compiled are loaded here, for the run. Returns the run a check made in this
        process built (None for a check process's)."""
        if not isolated(spec):
            return check_spec(spec, self._settings, files=files)
        _load(self._run("job", spec, ("system",)))
        return None

    def sweep(self, spec: SweepSpec) -> int:
        """Every check of a sweep (problems.check_sweep_spec); its number of members."""
        if not isolated(spec.job):
            return check_sweep_spec(spec, self._settings).members
        members, compiled = self._run("sweep", spec, ("job", "system"))
        _load(compiled)
        return members

    def plot(self, record, arrays, spec: JobSpec, kind: str, options: dict[str, Any]) -> bytes:
        """A stored trajectory's plot as PNG, drawn in a check process: matplotlib holds the interpreter lock
        while it draws (a 3000 x 3000 phase plot held /healthz for 2 s, thirty at once for 4.6 s) and the memory
        it took stayed with the server (22.5 GB after thirty; a service audit). Raises ValueError (a plot this
        run cannot have), ChecksBusy, or PlotOverBudget."""
        if not self._pending.acquire(blocking=False):
            raise ChecksBusy
        try:
            status, value = self._answer("plot", (record, arrays, spec, kind, options))
        finally:
            self._pending.release()
        if status == "ok":
            refused, png = value
            if refused is not None:
                raise ValueError(refused)
            return png
        if status == "error":
            raise RuntimeError(f"drawing a plot failed: {value}")
        raise PlotOverBudget(f"drawing this plot took more than check_seconds = {self._settings.check_seconds:g} s "
                             f"or check_memory_bytes = {self._settings.check_memory_bytes / 2**20:.0f} MiB; ask for "
                             "fewer pixels (width, height)")

    def compile(self, spec: JobSpec) -> None:
        """Compile a job's expression system in a check process, within the budgets, and load its functions
        here: for a run that did not find them loaded (raydamp.systems.system.NotCompiled). Waits for a
        place among the pending checks (a run is not refused); raises JobError past a budget, ChecksBusy
        if no process came free within the time budget."""
        _load(self._run("compile", spec, ("system",), wait=True))

    # ----

    def _add(self, count: int = 1) -> None:
        for _ in range(count):
            try:
                process = _Process(self._context, self._settings)
            except Exception:  # noqa: BLE001 - the checks wait for a process, then answer 429
                log.exception("could not start a check process")
                return
            with self._lock:
                if self._closed:
                    process.end()
                    return
                self._processes.add(process)
            self._idle.put(process)

    def _replace(self, process: _Process) -> None:
        with self._lock:
            self._processes.discard(process)
        process.end()
        threading.Thread(target=self._add, name="raydamp-checks-replace", daemon=True).start()

    def _run(self, kind: str, spec: Any, where: tuple[str, ...], wait: bool = False) -> Any:
        if not self._pending.acquire(blocking=wait, timeout=self._settings.check_seconds if wait else None):
            raise ChecksBusy
        try:
            status, value = self._answer(kind, spec)
        finally:
            self._pending.release()
        if status == "ok":
            return value
        if status == "invalid":
            raise JobError(*value)
        if status == "error":
            raise RuntimeError(f"the check of a {kind} failed: {value}")
        raise JobError(where, self._budget_message(where, status, value))

    def _answer(self, kind: str, spec: Any) -> tuple[str, Any]:
        budget = self._settings.check_seconds
        # One wait for warm-ups per check, shared by its tries: processes that hang while warming up (a broken
        # installation) cost a submission _START_SECONDS at most before its 429, not that for each try.
        start_by = time.monotonic() + _START_SECONDS
        for _ in range(3):  # a process found dead when asked is replaced, and the next one asked
            try:
                process = self._idle.get(timeout=budget)
            except queue.Empty:
                raise ChecksBusy from None
            if not process.started(start_by):
                if not process.hung():  # still warming up, within its own time: kept for the next check
                    self._idle.put(process)
                    raise ChecksBusy
                self._replace(process)  # died or hung in its warm-up: the next one is asked
                continue
            try:
                process.connection.send((kind, spec, self._settings))
            except OSError:
                self._replace(process)
                continue
            try:
                answer = process.connection.recv() if process.connection.poll(budget) else ("time", None)
            except (EOFError, OSError):  # it died mid-check: the budget's RLIMIT_AS made an allocation abort
                process.process.join(timeout=1)
                answer = ("died", process.process.exitcode)
            if answer[0] in ("ok", "invalid", "error"):
                self._idle.put(process)
            else:
                self._replace(process)
            return answer
        raise ChecksBusy

    def _budget_message(self, where: tuple[str, ...], status: str, value: Any) -> str:
        path, settings = ".".join(where), self._settings
        if status == "time":
            return (f"{path}: checking this system (compiling its functions, one trial step) took longer than the "
                    f"time budget of {settings.check_seconds:g} s (check_seconds); write it with fewer couplings, "
                    "or use a Chain or LinearStructure for a large system")
        ended = f" (its check process ended with exit code {value})" if status == "died" else ""
        return (f"{path}: checking this system needed more than the memory budget of "
                f"{settings.check_memory_bytes / 2**20:.0f} MiB (check_memory_bytes){ended}; write it with fewer "
                "couplings, or use a Chain or LinearStructure for a large system")


def build_for_run(checks: CheckPool | None, spec: JobSpec, run, files=None) -> RaydampCall | None:
    """A run's call (a job's, or a sweep's base job), its system built from functions a check process
    compiled: those the submission's check loaded, else (a restart lost them, or an eviction) compiled now by
    a check process, waiting for a free one (a JobError past a budget: the run fails with its message), and
    loaded here. Never compiled in the server, where the compile would hold the interpreter lock. None if
    the service stops meanwhile. Without check processes (checks None), built here."""
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
