"""The save grid: the rows a completed run keeps and their times, as the core counts them (the step loop
reserves its rows and the ensemble lays out its arrays by the same function), for the size checks of
integrate, integrate_ensemble, sweep and the service."""

from __future__ import annotations

import numpy as np

from .. import _core

__all__ = ["save_rows", "save_grid"]


def save_rows(n_steps: int, save_every: int) -> int:
    """Rows a completed run of ``n_steps`` steps keeps at ``save_every``: step 0, every ``save_every``-th
    step and the last step."""
    return _core.save_rows(n_steps, save_every)


def save_grid(h: float, n_steps: int, h_last: float, save_every: int) -> np.ndarray:
    """The times of those rows, the last step of size ``h_last`` (as ``span`` gives it)."""
    return _core.save_grid(h, n_steps, h_last, save_every)
