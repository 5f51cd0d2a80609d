"""Momentum maps along a trajectory."""

from __future__ import annotations

import numpy as np

from ..results.solution import Solution


def momentum_drift(solution: Solution) -> np.ndarray:
    """|J(t) - J(0)| at the saved points, one column per momentum map (shape (N, m))."""
    return np.abs(solution.momentum - solution.momentum[0])
