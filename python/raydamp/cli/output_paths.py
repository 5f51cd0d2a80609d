"""Checks of the paths a command will write, made before the work that fills them: a run or a sweep
that has finished should not then fail on a missing directory and lose its results. Each check
returns why the path cannot be written (one phrase, for "--flag PATH: <phrase>"), or None."""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["file_problem", "directory_problem"]


def _writable_directory(directory: Path) -> str | None:
    if not directory.exists():
        return f"no such directory {directory}"
    if not directory.is_dir():
        return f"{directory} is not a directory"
    if not os.access(directory, os.W_OK | os.X_OK):
        return f"directory {directory} is not writable"
    return None


def file_problem(path: str, *, store: bool = False) -> str | None:
    """Why the file ``path`` cannot be written; ``store``: a Zarr store, which is a directory."""
    target = Path(path)
    if problem := _writable_directory(target.parent):
        return problem
    if store:
        if target.exists() and not target.is_dir():
            return "exists and is not a directory (a Zarr store is one)"
    elif target.is_dir():
        return "is a directory"
    if target.exists() and not os.access(target, os.W_OK):
        return "is not writable"
    return None


def directory_problem(path: str) -> str | None:
    """Why the directory ``path`` cannot be written into (it is created, with its parents, if missing)."""
    target = Path(path).absolute()
    if target.exists():
        return _writable_directory(target) if target.is_dir() else "exists and is not a directory"
    ancestor = next(parent for parent in target.parents if parent.exists())  # the root always exists
    return _writable_directory(ancestor)
