"""Group commit: the inserts of concurrent submissions written by one thread and committed together.

A submission on the event loop hands its insert to this thread and awaits it; the inserts of one turn of the
loop are handed over together, at the turn's end (one wake-up of this thread for them all). The thread takes
every write waiting at that moment (runners record their quick runs here too), writes them in one transaction
and commits once, then answers them all with one wake-up of the event loop. A POST is answered only after
that commit (WAL with synchronous=NORMAL: its row survives a crash of the process), so a 202 still means a
stored job. Under load one commit serves several submissions and runs, and a submission costs no hop to the
thread pool and no turn on the store's write lock of its own (together they were about half of the server's
CPU per small job, benchmarks/bench_service_load.py).

What must happen once a row is stored (handing its id to the runner) runs here after the commit, not in the
awaiting coroutine: a client that disconnects cancels its coroutine, and its stored job must still run.
"""

from __future__ import annotations

import asyncio
import logging
import queue
import sqlite3
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .store import Database

__all__ = ["GroupCommit", "Waiter", "Write"]

log = logging.getLogger("raydamp_service.group_commit")

# A write: given the transaction's connection and the batch's scratch (what one write may leave for the next
# in the same transaction, as the count of queued tasks), it writes and returns its result.
Write = Callable[[sqlite3.Connection, dict[Any, Any]], Any]
_MOST = 256  # writes per transaction at most: a commit's latency stays that of a few hundred small inserts


class Waiter:
    """A thread's wait for its write (GroupCommit.post)."""

    def __init__(self):
        self._done = threading.Event()
        self._outcome: tuple[Any, BaseException | None] = (None, None)

    def settle(self, result: Any, error: BaseException | None) -> None:
        self._outcome = (result, error)
        self._done.set()

    def wait(self) -> Any:
        """The write's result once committed; its exception if it raised."""
        self._done.wait()
        result, error = self._outcome
        if error is not None:
            raise error
        return result


@dataclass(frozen=True)
class _Pending:
    write: Write
    after: Callable[[Any], None] | None
    loop: asyncio.AbstractEventLoop | None  # None: a thread's write, settled through its Waiter
    future: asyncio.Future | Waiter


class GroupCommit:
    """The writer thread of one Database, started at its first write and ended by stop()."""

    def __init__(self, database: Database):
        self._db = database
        self._queue: queue.SimpleQueue[list[_Pending] | None] = queue.SimpleQueue()
        self._turn: dict[asyncio.AbstractEventLoop, list[_Pending]] = {}  # what a loop's turn has to hand over
        self._lock = threading.Lock()
        self._stopped = False
        self._thread = threading.Thread(target=self._serve, name="raydamp-group-commit", daemon=True)
        self._thread.start()

    async def write(self, write: Write, after: Callable[[Any], None] | None = None) -> Any:
        """write's result once committed (its exception if it raised); then after(result) has run, on this
        thread, whether or not the caller is still waiting. The writes of one turn of the event loop are
        handed over together at its end: one wake-up of this thread for the requests the turn served."""
        loop = asyncio.get_running_loop()
        future = loop.create_future()
        with self._lock:
            self._refuse_if_stopped()
            turn = self._turn.get(loop)
            if turn is None:
                turn = self._turn[loop] = []
                loop.call_soon(self._hand_over, loop)
            turn.append(_Pending(write, after, loop, future))
        return await future

    def _hand_over(self, loop: asyncio.AbstractEventLoop) -> None:
        with self._lock:
            turn = self._turn.pop(loop, None)
            if turn:  # else stop() has handed it over
                self._queue.put(turn)

    def post(self, write: Write) -> Waiter:
        """Hand a write over from a thread without waiting for it (a runner's record of a quick run, committed
        with the submissions of the moment while the runner goes on to the next)."""
        waiter = Waiter()
        with self._lock:
            self._refuse_if_stopped()
            self._queue.put([_Pending(write, None, None, waiter)])
        return waiter

    def _refuse_if_stopped(self) -> None:
        if self._stopped:
            raise sqlite3.ProgrammingError("the job database is closed (the service is stopping)")

    def stop(self) -> None:
        """Commit what is waiting (the current turns' writes too), then end the thread; writes handed over
        later are refused."""
        with self._lock:
            self._stopped = True
            for turn in self._turn.values():
                self._queue.put(turn)
            self._turn.clear()
            self._queue.put(None)
        self._thread.join(timeout=30)

    def _serve(self) -> None:
        stopping = False
        while not stopping:
            first = self._queue.get()
            if first is None:
                return
            batch = first
            while len(batch) < _MOST:
                try:
                    more = self._queue.get_nowait()
                except queue.Empty:
                    break
                if more is None:
                    stopping = True
                    break
                batch.extend(more)
            self._commit(batch)

    def _commit(self, batch: list[_Pending]) -> None:
        try:
            with self._db.transaction() as db:
                scratch: dict[Any, Any] = {}
                outcomes = [(pending, pending.write(db, scratch), None) for pending in batch]
        except Exception:  # noqa: BLE001 - one failing write must not fail the others: each alone, then
            outcomes = [self._alone(pending) for pending in batch]
        for pending, result, error in outcomes:
            if error is None and pending.after is not None:
                try:
                    pending.after(result)
                except Exception:  # noqa: BLE001 - the row is stored; recovery at the next start runs it
                    log.exception("after a group commit")
        by_loop: dict[asyncio.AbstractEventLoop, list] = {}
        for pending, result, error in outcomes:
            if pending.loop is None:
                pending.future.settle(result, error)
            else:
                by_loop.setdefault(pending.loop, []).append((pending.future, result, error))
        for loop, settled in by_loop.items():
            try:
                loop.call_soon_threadsafe(_settle, settled)  # one wake-up of the loop per commit
            except RuntimeError:  # the loop has closed: nobody waits any more
                pass

    def _alone(self, pending: _Pending) -> tuple[_Pending, Any, BaseException | None]:
        try:
            with self._db.transaction() as db:
                return pending, pending.write(db, {}), None
        except Exception as error:  # noqa: BLE001 - handed to the caller, which raises it
            return pending, None, error


def _settle(settled: list[tuple[asyncio.Future, Any, BaseException | None]]) -> None:
    for future, result, error in settled:
        if future.done():  # cancelled: its client went away
            continue
        if error is not None:
            future.set_exception(error)
        else:
            future.set_result(result)
