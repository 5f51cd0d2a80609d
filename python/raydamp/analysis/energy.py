"""Energy diagnostics: a high-accuracy reference, the energy error, the modified energy."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .._validation import _short, instance, real, real_array, vector
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

    n = _model(model).dim
    t_eval = _times(t_eval)
    # SciPy takes them unchecked: a NaN, an inf or rtol = atol = 0 ran forever.
    rtol, atol = real("rtol", rtol, positive=True), real("atol", atol, nonnegative=True)
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


def _model(model) -> Model:
    return instance("model", model, Model, "a raydamp model (e.g. raydamp.models.DampedPendulum())")


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
    _model(model)
    instance("solution", solution, Solution, "a raydamp.Solution")
    if reference is None:
        if solution.dofs is not None:  # its first row is not the whole initial state
            raise ValueError("solution: the reference needs every coordinate saved (save_dofs=None), or give "
                             "reference=")
        reference = reference_solution(model, solution.q[0], solution.p[0], solution.t,
                                       load=solution._run_load("energy_error"))
    instance("reference", reference, ReferenceSolution, "a ReferenceSolution (from reference_solution) or None")
    if reference.t.shape != solution.t.shape or not np.allclose(reference.t, solution.t, rtol=0, atol=1e-9):
        raise ValueError("reference: its times differ from the solution's saved times")
    return solution.energy - reference.energy


def modified_energy(model: Model, q, p, h: float) -> np.ndarray:
    """The modified Hamiltonian of Stormer-Verlet (drift-kick-drift) truncated after h^2,

        H_h = H + h^2 (grad V^T M^{-1} grad V / 12 - v^T V''(q) v / 24),  v = M^{-1} p,

    from the symmetric BCH formula (paper Lemma 4.4 gives the form). Stormer-Verlet
    conserves it to O(h^4); 3s makes it decay monotonically at small h (Theorem 4.6).
    Rows of q and p are states."""
    n = _model(model).dim
    h = real("h", h, nonnegative=True)  # a NaN gave NaNs back
    q, p = _states("q", q, n), _states("p", p, n)
    if q.shape != p.shape:
        raise ValueError(f"p: {p.shape[0]} rows of momenta for {q.shape[0]} rows of positions")
    return np.asarray(model._core_model.modified_energy_sv(q, p, h))


def _states(name: str, value, n: int) -> np.ndarray:
    """Rows of ``n`` finite numbers ((rows, n), or one state (n,))."""
    array = np.atleast_2d(real_array(name, value))
    if array.ndim != 2 or array.shape[1] != n:
        raise ValueError(f"{name} must have rows of {n} numbers for this model, got shape {np.shape(value)}")
    if not np.isfinite(array).all():
        raise ValueError(f"{name} must be finite")
    return array
