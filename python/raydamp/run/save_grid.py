"""The save grid: the rows a completed run keeps and their times, as the core counts them (the step loop
reserves its rows and the ensemble lays out its arrays by the same function), for the size checks of
integrate, integrate_ensemble, sweep and the service."""

from __future__ import annotations

import numpy as np

from .. import _core
from .._validation import MAX_STEPS, integer

__all__ = ["save_rows", "save_grid"]


def save_rows(n_steps: int, save_every: int) -> int:
    """Rows a completed run of ``n_steps`` steps keeps at ``save_every``: step 0, every ``save_every``-th
    step and the last step. A ValueError names an argument out of integrate's range."""
    return _core.save_rows(integer("n_steps", n_steps, minimum=0, maximum=MAX_STEPS),
                           integer("save_every", save_every, maximum=MAX_STEPS))


def save_grid(h: float, n_steps: int, h_last: float, save_every: int) -> np.ndarray:
    """The times of those rows, the last step of size ``h_last`` (as ``span`` gives it)."""
    return _core.save_grid(h, n_steps, h_last, save_every)
