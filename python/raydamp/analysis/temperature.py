"""Temperatures of a trajectory at thermal equilibrium (fluctuation-dissipation checks).

- kinetic: kT_kin = <p^T M^{-1} p> / n (equipartition of the kinetic energy: <p^T M^{-1} p> = n kT);
- configurational: kT_conf = <|grad V|^2> / <Laplacian V> (Jepps, Ayton and Evans 2000), which
  holds for the Boltzmann density exp(-V/kT) of the positions alone.

Both are averages over the saved rows given (drop a burn-in first); a run at temperature kT whose
sampled density is right gives both equal to kT up to its sampling error and the method's bias.
"""

from __future__ import annotations

import numpy as np

from .._validation import real
from ..results.temperature import kinetic_temperature_of

__all__ = ["kinetic_temperature", "configurational_temperature"]


def _rows(solution, burn_in: float):
    if solution.dofs is not None:
        raise ValueError("solution: temperatures need every coordinate saved (save_dofs=None)")
    burn_in = real("burn_in", burn_in, nonnegative=True)  # a string was NumPy's UFuncTypeError
    keep = solution.t >= solution.t[0] + burn_in
    if not keep.any():
        raise ValueError(f"burn_in: {burn_in} leaves no saved row")
    return solution.q[keep], solution.p[keep]


def _model(solution):
    if not hasattr(solution, "_model"):
        raise ValueError(f"solution: expected a raydamp.Solution, got {type(solution).__name__}")
    return solution._model("solution")


def kinetic_temperature(solution, burn_in: float = 0.0) -> float:
    """<p^T M^{-1} p> / n over the saved rows at t >= t0 + burn_in."""
    model = _model(solution)
    _, p = _rows(solution, burn_in)
    return kinetic_temperature_of(model, p)


def configurational_temperature(solution, burn_in: float = 0.0) -> float:
    """<|grad V|^2> / <tr Hess V> over the saved rows at t >= t0 + burn_in."""
    model = _model(solution)
    q, _ = _rows(solution, burn_in)
    core = model._core_model
    n = model.dim
    eye = np.eye(n)
    grad2, laplacian = 0.0, 0.0
    for row in q:
        g = np.asarray(core.gradient(row)).ravel()
        grad2 += g @ g
        laplacian += sum(np.asarray(core.hessian_product(row, eye[i])).ravel()[i] for i in range(n))
    return float(grad2 / laplacian)
