"""Energy diagnostics: a high-accuracy reference, the energy error, the modified energy."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .._validation import vector
from ..results.solution import Solution
from ..systems.models import Model


class ReferenceSolution(NamedTuple):
    t: np.ndarray
    q: np.ndarray
    p: np.ndarray
    energy: np.ndarray


def reference_solution(model: Model, q0, p0, t_eval, *, rtol: float = 1e-13, atol: float = 1e-13) -> ReferenceSolution:
    """Integrate the full damped system with SciPy's DOP853, independent of raydamp's
    methods, and return the states and energies at the times ``t_eval``."""
    from scipy.integrate import solve_ivp

    n = model.dim
    t_eval = np.asarray(t_eval, dtype=float)
    core = model._core_model

    def rhs(_t, z):
        q, p = z[:n], z[n:]
        qdot = np.asarray(core.velocity(p)).reshape(n)
        pdot = -np.asarray(core.gradient(q)).reshape(n) - np.asarray(core.damping_rate(q, p)).reshape(n)
        return np.concatenate([qdot, pdot])

    z0 = np.concatenate([vector("q0", q0, n), vector("p0", p0, n)])
    sol = solve_ivp(rhs, (0.0, float(t_eval[-1])), z0, method="DOP853", t_eval=t_eval, rtol=rtol, atol=atol)
    if not sol.success:
        raise RuntimeError(f"reference solver failed: {sol.message}")
    q, p = sol.y[:n].T.copy(), sol.y[n:].T.copy()
    energy = np.array([core.energy(qi, pi) for qi, pi in zip(q, p)])
    return ReferenceSolution(sol.t, q, p, energy)


def energy_error(model: Model, solution: Solution, reference: ReferenceSolution | None = None) -> np.ndarray:
    """H_num(t) - H_ref(t) at the solution's saved times."""
    if reference is None:
        reference = reference_solution(model, solution.q[0], solution.p[0], solution.t)
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
