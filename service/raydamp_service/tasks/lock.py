"""One service per database: a second would re-queue the first's running jobs, and two writers through two names
of one file corrupt it. The lock is a flock on a file named by the database's (device, inode), beside it, so every
name finds the same lock; never on the database, as closing any descriptor of it drops the process's POSIX locks,
SQLite's included. Holds within a process are counted."""

from __future__ import annotations

import fcntl
import os
import threading
from pathlib import Path

__all__ = ["DatabaseInUse", "hold", "release"]

_lock = threading.Lock()
_held: dict[tuple[int, int], tuple[int, int]] = {}  # (device, inode) -> (descriptor, holders in this process)


class DatabaseInUse(RuntimeError):
    """Another process serves this database; the message names its pid and what to do."""


def _identity(db: Path | str, create: bool = True) -> tuple[tuple[int, int], Path]:
    """The database's (device, inode) and its lock file, creating the database (empty) if it is not there yet."""
    path = Path(db).resolve()
    path.parent.mkdir(parents=True, exist_ok=True)
    if create and not path.exists():
        os.close(os.open(path, os.O_RDWR | os.O_CREAT, 0o644))  # before SQLite has opened it: no lock to drop
    found = path.stat()
    return (found.st_dev, found.st_ino), path.with_name(f".raydamp-{found.st_dev}-{found.st_ino}.lock")


def hold(db: Path | str) -> None:
    """Take the database's lock (again, if this process has it); DatabaseInUse if another process has it."""
    with _lock:
        key, path = _identity(db)
        if key in _held:
            fd, count = _held[key]
            _held[key] = (fd, count + 1)
            return
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
        _held[key] = (fd, 1)


def release(db: Path | str) -> None:
    """Give back one hold; the lock goes with the last."""
    with _lock:
        try:
            key, _ = _identity(db, create=False)
        except FileNotFoundError:  # removed while served: its lock goes with the process
            return
        fd, count = _held.get(key, (-1, 0))
        if count > 1:
            _held[key] = (fd, count - 1)
        elif count == 1:
            del _held[key]
            os.close(fd)
