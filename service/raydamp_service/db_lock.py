"""One service per database: a second one on the same file took over the first's running jobs (its recovery
re-queued them: one job ran twice at once, attempts 2) before its own bind failed.

The lock is an exclusive flock on "<db>.lock", held while the process serves. flock belongs to the open file,
so a process takes it once per path and counts its holders (the command line takes it before the lifespan
does, to refuse with one line); the kernel drops it when the process dies, however it dies.
"""

from __future__ import annotations

import fcntl
import os
import threading
from pathlib import Path

__all__ = ["DatabaseInUse", "hold", "release"]

_lock = threading.Lock()
_held: dict[Path, tuple[int, int]] = {}  # lock file -> (descriptor, holders in this process)


class DatabaseInUse(RuntimeError):
    """Another process serves this database; the message names its pid and what to do."""


def _lock_path(db: Path | str) -> Path:
    path = Path(db).resolve()
    return path.with_name(path.name + ".lock")


def hold(db: Path | str) -> None:
    """Take the database's lock (again, if this process has it); DatabaseInUse if another process has it."""
    path = _lock_path(db)
    with _lock:
        if path in _held:
            fd, count = _held[path]
            _held[path] = (fd, count + 1)
            return
        path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            owner = os.pread(fd, 32, 0).decode(errors="replace").strip() or "unknown"
            os.close(fd)
            raise DatabaseInUse(f"another raydamp service (pid {owner}) is serving the job database {Path(db)}: two "
                                "would run each other's jobs; stop it, or set RAYDAMP_DB to another file") from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, str(os.getpid()).encode(), 0)
        _held[path] = (fd, 1)


def release(db: Path | str) -> None:
    """Give back one hold; the lock goes with the last."""
    path = _lock_path(db)
    with _lock:
        fd, count = _held.get(path, (-1, 0))
        if count > 1:
            _held[path] = (fd, count - 1)
        elif count == 1:
            del _held[path]
            os.close(fd)  # closes the flock with it
