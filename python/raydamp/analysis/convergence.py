"""Convergence studies: global error against step size, and the fitted order."""

from __future__ import annotations

from collections.abc import Iterable
from typing import NamedTuple

import numpy as np

from .._validation import _short, real, vector
from ..run.integrate import integrate
from ..systems.models import Model
from .energy import _model, reference_solution


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
    n = _model(model).dim
    hs = _step_sizes(hs)
    t_end = real("t_end", t_end, positive=True)  # t_end = 0 was an AttributeError from the reference
    if reference is None:
        ref = reference_solution(model, q0, p0, [0.0, t_end])
        reference = (ref.q[-1], ref.p[-1])
    # Checked, not broadcast: a (q, p) of another length gave errors, and an order, that meant nothing.
    pair = _items(reference)
    if pair is None or len(pair) != 2:
        raise ValueError(f"reference must be a pair (q, p), the exact state at t_end, got {_short(reference)}")
    q_ref, p_ref = vector("reference[0]", pair[0], n), vector("reference[1]", pair[1], n)
    errors = []
    for h in hs:
        sol = integrate(model, q0, p0, method=method, tableau=tableau, h=h, t_end=t_end, save_every=2**62)
        if sol.status != "completed":
            raise RuntimeError(f"{method} at h = {h}: {sol.message}")
        errors.append(max(np.abs(sol.q[-1] - q_ref).max(), np.abs(sol.p[-1] - p_ref).max()))
    errors = np.array(errors)
    return ConvergenceResult(hs, errors, fitted_order(hs, errors))


def _step_sizes(hs) -> np.ndarray:
    """Any iterable of step sizes (a list, an array, a generator), each a number > 0."""
    items = _items(hs)
    if items is None:
        raise ValueError(f"hs must be an iterable of step sizes, got {_short(hs)}")
    values = [real(f"hs[{i}]", h, positive=True) for i, h in enumerate(items)]
    if len(values) < 2:
        raise ValueError("hs must hold at least two step sizes")
    return np.array(values)


def _items(value) -> list | None:
    """The items of an iterable (read once: a generator too), None for a string or a non-iterable."""
    if isinstance(value, (str, bytes)) or not isinstance(value, Iterable):
        return None
    try:
        return list(value)
    except TypeError:  # a 0-d array
        return None
