"""The exact response of a linear system to a piecewise-linear load: the reference that the loads'
tests and the ground-motion benchmark measure raydamp's methods against.

M q'' + C q' + K q = d a(t), with a(t) linear between samples (t_k, a_k), is solved exactly per
sample interval (Nigam and Jennings, 1969, "Calculation of response spectra from strong-motion
earthquake records", BSSA 59(2)): on [t_k, t_k + dt] the forcing is d (a_k + s_k tau), so the
state x = (q, q') together with (a_k + s_k tau, s_k) obeys a linear ODE with constant coefficients,
whose flow over dt is one matrix exponential of the augmented matrix (Van Loan's construction instead
of Nigam and Jennings' closed-form SDOF coefficients: it serves any n and any damping matrix).
"""

from __future__ import annotations

import numpy as np

from .._validation import real_array

__all__ = ["piecewise_linear_response"]


def _square(name: str, value, n: int | None) -> np.ndarray:
    matrix = np.atleast_2d(real_array(name, value))  # a scipy.sparse matrix made dense, as LinearStructure takes
    if matrix.ndim != 2 or matrix.shape[0] != matrix.shape[1] or (n is not None and matrix.shape[0] != n):
        size = "a square matrix" if n is None else f"an {n} x {n} matrix (or a number when n = 1)"
        raise ValueError(f"{name} must be {size}, got shape {np.shape(value)}")
    if not np.isfinite(matrix).all():
        raise ValueError(f"{name} must be finite")
    return matrix


def _vector(name: str, value, n: int) -> np.ndarray:
    out = np.atleast_1d(real_array(name, value))
    if out.shape != (n,) or not np.isfinite(out).all():
        raise ValueError(f"{name} must be {n} finite numbers, got shape {np.shape(value)}")
    return out


def piecewise_linear_response(M, C, K, direction, t, values, q0=None, p0=None) -> tuple[np.ndarray, np.ndarray]:
    """Exact (q, p) at the sample times of M q'' + C q' + K q = direction a(t), a(t) the straight
    lines through the samples (t_k, values_k), from (q0, p0) (default: rest) at t_0.

    Parameters
    ----------
    M, C, K : (n, n) mass, damping and stiffness matrices (numbers for one coordinate); M invertible.
        For raydamp's damping eps D this is C = eps D, e.g. alpha M + beta K for a ``LinearStructure``.
    direction : (n,) the load's direction d: f(t) = d a(t) (a ``Load.series``'s ``direction``; for a
        ground motion -M r, r the influence vector).
    t, values : (T,) sample times (increasing; the intervals may differ) and a(t) there.
    q0, p0 : (n,) initial positions and momenta, p = M q' as in raydamp (default zero).

    Returns
    -------
    q, p : (T, n) arrays at the sample times; p = M q' (raydamp's momentum). Exact up to the
    rounding of one matrix exponential per distinct interval length and of the recurrence.
    """
    import scipy.linalg

    M = _square("M", M, None)
    n = M.shape[0]
    C, K = _square("C", C, n), _square("K", K, n)
    d = _vector("direction", direction, n)
    t = real_array("t", t)
    a = real_array("values", values)
    if t.ndim != 1 or t.size < 2 or not np.isfinite(t).all():
        raise ValueError(f"t must be at least two finite sample times, got shape {t.shape}")
    if a.shape != t.shape or not np.isfinite(a).all():
        raise ValueError(f"values must be {t.size} finite numbers (one per sample time), got shape {a.shape}")
    dts = np.diff(t)
    if not (dts > 0).all():
        raise ValueError(f"t must increase: t[{int(np.argmin(dts > 0)) + 1}] <= the time before it")
    try:
        Minv = np.linalg.inv(M)
    except np.linalg.LinAlgError:
        raise ValueError("M must be invertible") from None
    q0 = np.zeros(n) if q0 is None else _vector("q0", q0, n)
    p0 = np.zeros(n) if p0 is None else _vector("p0", p0, n)

    # x' = A x + [0; M^-1 d] s0, s0' = s1, s1' = 0: over an interval, s0 is a(t_k) + s_k tau.
    aug = np.zeros((2 * n + 2, 2 * n + 2))
    aug[:n, n:2 * n] = np.eye(n)
    aug[n:2 * n, :n] = -Minv @ K
    aug[n:2 * n, n:2 * n] = -Minv @ C
    aug[n:2 * n, 2 * n] = Minv @ d
    aug[2 * n, 2 * n + 1] = 1.0
    # One exponential per interval length: a record's intervals (k dt - (k-1) dt in floating point) differ
    # in their last bits only, which moves the response by as little.
    keys = np.round(dts / dts.max(), 12)
    flows = {key: scipy.linalg.expm(dts[np.argmax(keys == key)] * aug) for key in np.unique(keys)}
    slopes = np.diff(a) / dts
    x = np.concatenate([q0, Minv @ p0])
    states = np.empty((t.size, 2 * n))
    states[0] = x
    for k in range(t.size - 1):
        x = (flows[keys[k]] @ np.concatenate([x, [a[k], slopes[k]]]))[:2 * n]
        states[k + 1] = x
    return states[:, :n], states[:, n:] @ M.T
