"""Energy diagnostics: a high-accuracy reference, the energy error, the modified energy."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .._validation import _short, vector
from ..loads import Load
from ..results.solution import Solution
from ..systems.models import Model


class ReferenceSolution(NamedTuple):
    t: np.ndarray
    q: np.ndarray
    p: np.ndarray
    energy: np.ndarray


def reference_solution(model: Model, q0, p0, t_eval, *, load: Load | None = None, rtol: float = 1e-13,
                       atol: float = 1e-13) -> ReferenceSolution:
    """Integrate the full damped system (with ``load``'s force f(t), when given) with SciPy's DOP853,
    independent of raydamp's methods, and return the states and energies at the times ``t_eval`` (1-D,
    finite, non-decreasing, from t = 0, ending after it)."""
    from scipy.integrate import solve_ivp

    n = model.dim
    t_eval = _times(t_eval)
    core = model._core_model
    if load is not None and not isinstance(load, Load):
        raise ValueError(f"load must be a raydamp.Load or None, got {type(load).__name__}")
    force = load.bind(model) if load is not None and load.terms else None

    def rhs(t, z):
        q, p = z[:n], z[n:]
        qdot = np.asarray(core.velocity(p)).reshape(n)
        pdot = -np.asarray(core.gradient(q)).reshape(n) - np.asarray(core.damping_rate(q, p)).reshape(n)
        if force is not None:
            pdot += np.asarray(force.values([t])).reshape(n)
        return np.concatenate([qdot, pdot])

    z0 = np.concatenate([vector("q0", q0, n), vector("p0", p0, n)])
    sol = solve_ivp(rhs, (0.0, float(t_eval[-1])), z0, method="DOP853", t_eval=t_eval, rtol=rtol, atol=atol)
    if not sol.success:
        raise RuntimeError(f"reference solver failed: {sol.message}")
    q, p = sol.y[:n].T.copy(), sol.y[n:].T.copy()
    energy = np.array([core.energy(qi, pi) for qi, pi in zip(q, p)])
    return ReferenceSolution(sol.t, q, p, energy)


def _times(t_eval) -> np.ndarray:
    try:
        t = np.asarray(t_eval, dtype=float)
    except (TypeError, ValueError):
        t = None
    if t is None or t.ndim != 1 or t.size == 0 or not np.isfinite(t).all() or (np.diff(t) < 0).any() \
            or t[0] < 0 or t[-1] <= 0:
        raise ValueError("t_eval must be a 1-D array of finite, non-decreasing times from t >= 0 to a time > 0, "
                         f"got {_short(t_eval)}")
    return t


def energy_error(model: Model, solution: Solution, reference: ReferenceSolution | None = None) -> np.ndarray:
    """H_num(t) - H_ref(t) at the solution's saved times; the reference, when not given, is driven by the
    solution's load too (without it, a forced run's "error" was the load's effect)."""
    if reference is None:
        reference = reference_solution(model, solution.q[0], solution.p[0], solution.t, load=solution.load)
    if reference.t.shape != solution.t.shape or not np.allclose(reference.t, solution.t, rtol=0, atol=1e-9):
        raise ValueError("reference: its times differ from the solution's saved times")
    return solution.energy - reference.energy


def modified_energy(model: Model, q, p, h: float) -> np.ndarray:
    """The modified Hamiltonian of Stormer-Verlet (drift-kick-drift) truncated after h^2,

        H_h = H + h^2 (grad V^T M^{-1} grad V / 12 - v^T V''(q) v / 24),  v = M^{-1} p,

    from the symmetric BCH formula (paper Lemma 4.4 gives the form). Stormer-Verlet
    conserves it to O(h^4); 3s makes it decay monotonically at small h (Theorem 4.6).
    Rows of q and p are states."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    p = np.atleast_2d(np.asarray(p, dtype=float))
    return np.asarray(model._core_model.modified_energy_sv(q, p, float(h)))
