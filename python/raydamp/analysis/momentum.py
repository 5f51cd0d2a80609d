"""Momentum maps along a trajectory."""

from __future__ import annotations

import numpy as np

from .._validation import instance, real
from ..results.solution import Solution


def momentum_drift(solution: Solution, decay_rate: float = 0.0) -> np.ndarray:
    """|J(t) - J(0) e^{-decay_rate t}| at the saved points, one column per momentum map (shape (N, m)).

    With the default 0 that is |J(t) - J(0)|; pass eps c for a system with D = c M (a System's
    ``{"scalar": c}`` damping) to measure the distance from the law its momentum maps follow, as
    ``Solution.max_momentum_drift`` does over every step."""
    instance("solution", solution, Solution, "a raydamp.Solution")
    decay_rate = real("decay_rate", decay_rate)  # a NaN gave NaNs back
    law = np.exp(-decay_rate * solution.t)[:, None]
    return np.abs(solution.momentum - solution.momentum[0] * law)
