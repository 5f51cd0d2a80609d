"""Convergence studies: global error against step size, and the fitted order."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .._validation import real
from ..run.integrate import integrate
from ..systems.models import Model
from .energy import reference_solution


class ConvergenceResult(NamedTuple):
    hs: np.ndarray
    errors: np.ndarray  # max-norm error in (q, p) at t_end
    order: float  # least-squares slope of log(error) against log(h)


def fitted_order(hs, errors) -> float:
    return float(np.polyfit(np.log(hs), np.log(errors), 1)[0])


def convergence(model: Model, method: str, hs, *, q0, p0, t_end: float = 10.0, tableau: str | None = None,
                reference: tuple[np.ndarray, np.ndarray] | None = None) -> ConvergenceResult:
    """Global error at ``t_end`` of ``method`` for each step size in ``hs`` against a
    DOP853 reference (rtol = atol = 1e-13) or the given (q, p) ``reference``."""
    hs = np.asarray(hs, dtype=float)
    if hs.ndim != 1 or hs.size < 2:
        raise ValueError("hs must hold at least two step sizes")
    t_end = real("t_end", t_end, positive=True)  # t_end = 0 was an AttributeError from the reference
    if reference is None:
        ref = reference_solution(model, q0, p0, [0.0, t_end])
        reference = (ref.q[-1], ref.p[-1])
    q_ref, p_ref = reference
    errors = []
    for h in hs:
        sol = integrate(model, q0, p0, method=method, tableau=tableau, h=h, t_end=t_end, save_every=2**62)
        if sol.status != "completed":
            raise RuntimeError(f"{method} at h = {h}: {sol.message}")
        errors.append(max(np.abs(sol.q[-1] - q_ref).max(), np.abs(sol.p[-1] - p_ref).max()))
    errors = np.array(errors)
    return ConvergenceResult(hs, errors, fitted_order(hs, errors))
