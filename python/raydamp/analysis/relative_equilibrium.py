"""Relative equilibria of the elastic pendulum (paper section 6.2).

In cylindrical coordinates (rho, phi, z) with momenta (p_rho, p_phi, p_z), rotation
about the vertical axis is a symmetry, p_phi = J3 = mu is conserved, and the reduced
system in (rho, z, p_rho, p_z) has, for each mu, an equilibrium with p_rho = p_z = 0:

    k rho (l/r - 1) + mu^2 / (m rho^3) = 0,     k z (l/r - 1) + m g_z = 0,    r = |(rho, z)|.

(The paper prints the centrifugal term as -mu^2/(m rho^3); differentiating the
Hamiltonian p_rho^2/2m + p_phi^2/(2 m rho^2) + ... gives +, and only + makes the
paper's own equilibrium data an equilibrium.) The pendulum rotates steadily on a
horizontal circle: a relative equilibrium. The splitting methods, which conserve J3
exactly, settle instead on a nearby *modified* relative equilibrium: a fixed point of
their reduced step map, O(h^2) away.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .._validation import instance, real, real_array
from ..results.solution import Solution
from ..run.integrate import integrate
from ..systems.models import ElasticPendulum

# The |mu| relative_equilibrium solves (to rounding) for m, k, l, G near 1: below, mu^2 and rho^4 underflow;
# above, rho passes the bracket's 1e12 (rho grows like sqrt(|mu|)), then mu^2 overflows.
MU_RANGE = (1e-150, 1e20)


class RelativeEquilibrium(NamedTuple):
    """A reduced state (rho, z, p_rho, p_z) at momentum value mu."""

    rho: float
    z: float
    p_rho: float
    p_z: float
    mu: float

    @property
    def reduced(self) -> np.ndarray:
        return np.array([self.rho, self.z, self.p_rho, self.p_z])


def _equilibrium(value, name: str = "equilibrium") -> RelativeEquilibrium:
    return instance(name, value, RelativeEquilibrium, "a RelativeEquilibrium (from relative_equilibrium)")


def _require_vertical_gravity(model: ElasticPendulum) -> float:
    if not isinstance(model, ElasticPendulum):
        raise ValueError(f"model must be an ElasticPendulum, got {model!r}")
    gx, gy, gz = model.g
    if gx != 0.0 or gy != 0.0 or gz >= 0.0:
        raise ValueError(f"g must point straight down (0, 0, -G) for the rotational symmetry, got {model.g}")
    return gz


def reduced_coordinates(q, p) -> np.ndarray:
    """Rows (rho, z, p_rho, p_z, mu) for rows of Cartesian q, p."""
    q, p = _cartesian_rows("q", q), _cartesian_rows("p", p)
    if q.shape != p.shape:
        raise ValueError(f"p: {p.shape[0]} rows of momenta for {q.shape[0]} rows of positions")
    return _reduced(q, p)


def _cartesian_rows(name: str, value) -> np.ndarray:
    """Rows (x, y, z): the elastic pendulum's coordinates (another model's reached an IndexError)."""
    array = np.atleast_2d(real_array(name, value))
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"{name} must be an elastic pendulum's Cartesian (x, y, z), or rows of them, got shape "
                         f"{np.shape(value)}")
    return array


def _reduced(q: np.ndarray, p: np.ndarray) -> np.ndarray:
    rho = np.hypot(q[:, 0], q[:, 1])
    p_rho = (q[:, 0] * p[:, 0] + q[:, 1] * p[:, 1]) / rho
    mu = q[:, 0] * p[:, 1] - q[:, 1] * p[:, 0]
    return np.column_stack([rho, q[:, 2], p_rho, p[:, 2], mu])


def cartesian_state(rho: float, z: float, p_rho: float, p_z: float, mu: float) -> tuple[np.ndarray, np.ndarray]:
    """The Cartesian (q, p) at azimuth phi = 0 with the given reduced coordinates (rho > 0)."""
    rho = real("rho", rho, positive=True)  # rho = 0 was a ZeroDivisionError (mu / rho), and the axis has no phi
    return _cartesian(rho, real("z", z), real("p_rho", p_rho), real("p_z", p_z), real("mu", mu))


def _cartesian(rho: float, z: float, p_rho: float, p_z: float, mu: float) -> tuple[np.ndarray, np.ndarray]:
    # Unchecked, for the root finder's trial states.
    return np.array([rho, 0.0, z]), np.array([p_rho, mu / rho, p_z])


def equilibrium_residual(model: ElasticPendulum, rho: float, z: float, mu: float) -> np.ndarray:
    """The two reduced equilibrium equations at (rho, z): zero at a relative equilibrium."""
    gz = _require_vertical_gravity(model)
    stretch = model.l / math.hypot(rho, z) - 1.0
    return np.array([model.k * rho * stretch + mu**2 / (model.m * rho**3), model.k * z * stretch + model.m * gz])


def relative_equilibrium(model: ElasticPendulum, mu: float) -> RelativeEquilibrium:
    """The exact relative equilibrium at momentum value mu (mu != 0).

    Eliminating the stretch between the two equations gives the depth below the pivot
    Z = m^2 G rho^4 / mu^2 (G = -g_z); the vertical balance k Z (1 - l/r) = m G is then
    one equation in rho, increasing from negative to positive: bracketed and solved by
    Brent's method."""
    from scipy.optimize import brentq

    G = -_require_vertical_gravity(model)
    mu = real("mu", mu)  # a string was math.isfinite's TypeError
    if mu == 0.0:
        raise ValueError(f"mu must be finite and nonzero (mu = 0 is the static equilibrium), got {mu}")
    if not MU_RANGE[0] <= abs(mu) <= MU_RANGE[1]:  # mu^2 overflowed (OverflowError) or was 0 (ZeroDivisionError)
        raise ValueError(f"mu: |mu| = {abs(mu):g} is outside the range this solver reaches, {MU_RANGE[0]:g} <= |mu| "
                         f"<= {MU_RANGE[1]:g}")
    if model.k == 0.0:
        raise ValueError("model: k = 0 has no relative equilibrium (nothing holds the mass up)")
    m, k, length = model.m, model.k, model.l

    def depth(rho):
        return m * m * G * rho**4 / mu**2

    def vertical_balance(rho):
        Z = depth(rho)
        return k * Z * (1.0 - length / math.hypot(rho, Z)) - m * G

    try:
        lo, hi = 1e-6, 1.0
        while vertical_balance(lo) >= 0.0:  # rho grows like sqrt(|mu|): for |mu| below about 1e-12, under 1e-6
            lo /= 16.0
            if lo < 1e-300:
                raise RuntimeError("no relative equilibrium found")
        while vertical_balance(hi) <= 0.0:
            hi *= 2.0
            if hi > 1e12:
                raise RuntimeError("no relative equilibrium found")
        # xtol is absolute: below 1e-6 it shrinks with the bracket, or a rho of 1e-15 came back far off
        # (z = -2.31 instead of -2 at mu = 1e-30, -8e-5 at mu = 1e-140).
        xtol = 1e-15 if lo == 1e-6 else 1e-16 * lo
        rho = brentq(vertical_balance, lo, hi, xtol=xtol, rtol=4 * np.finfo(float).eps, maxiter=500)
        return RelativeEquilibrium(rho, -depth(rho), 0.0, 0.0, mu)
    except (OverflowError, ZeroDivisionError, RuntimeError) as error:  # mu extreme for these m, k, l, g
        raise ValueError(f"mu: no relative equilibrium computable at mu = {mu:g} for this model ({error}); it "
                         f"reaches 1e-300 < rho < 1e12, which {MU_RANGE[0]:g} <= |mu| <= {MU_RANGE[1]:g} gives "
                         "for parameters near 1") from None


def reduced_hessian(model: ElasticPendulum, equilibrium: RelativeEquilibrium) -> np.ndarray:
    """The Hessian of the reduced Hamiltonian

        H_mu(rho, z, p_rho, p_z) = (p_rho^2 + p_z^2) / 2m + mu^2 / (2 m rho^2) + k/2 (r - l)^2 - m g_z z

    at the reduced state of ``equilibrium`` (r = |(rho, z)|), in the order (rho, z, p_rho, p_z).
    Theorem 6.2 needs it positive definite (H_mu strictly convex) at the equilibrium.
    Second derivatives written out by hand, so no finite-difference step enters."""
    _require_vertical_gravity(model)
    _equilibrium(equilibrium)
    m, k, length, mu = model.m, model.k, model.l, equilibrium.mu
    rho, z = equilibrium.rho, equilibrium.z
    r = math.hypot(rho, z)
    stretch = r - length
    # Hessian of k/2 (r - l)^2 is k (x x^T / r^2 + (r - l)(I / r - x x^T / r^3)), x = (rho, z).
    h_rr = 3.0 * mu**2 / (m * rho**4) + k * (rho**2 / r**2 + stretch * z**2 / r**3)
    h_zz = k * (z**2 / r**2 + stretch * rho**2 / r**3)
    h_rz = k * rho * z * (1.0 / r**2 - stretch / r**3)
    return np.array([[h_rr, h_rz, 0.0, 0.0], [h_rz, h_zz, 0.0, 0.0], [0.0, 0.0, 1.0 / m, 0.0],
                     [0.0, 0.0, 0.0, 1.0 / m]])


def distance_from(equilibrium: RelativeEquilibrium, solution_or_q, p=None) -> np.ndarray:
    """Euclidean distance in reduced coordinates (rho, z, p_rho, p_z) from the equilibrium,
    per saved point of a Solution (or per row of q, p)."""
    _equilibrium(equilibrium)
    if isinstance(solution_or_q, Solution):
        if solution_or_q.dofs is not None:  # its columns are not x, y, z: wrong distances, or an IndexError
            raise ValueError("solution: distance_from needs x, y and z saved in order (save_dofs=None)")
        if solution_or_q.q.shape[1] != 3:
            raise ValueError(f"solution: distance_from needs an elastic pendulum's solution (x, y, z), got one of "
                             f"{solution_or_q.q.shape[1]} coordinates")
        q, p = solution_or_q.q, solution_or_q.p
    elif p is None:
        raise ValueError("p: give the momenta with the positions, or pass a Solution")
    else:
        try:
            q = _cartesian_rows("solution_or_q", solution_or_q)
        except ValueError as error:  # "... must be a Solution or ...": the argument is either
            raise ValueError(f"{error} (or a raydamp.Solution)") from None
    reduced = reduced_coordinates(q, p)[:, :4]
    return np.linalg.norm(reduced - equilibrium.reduced, axis=1)


def modified_relative_equilibrium(model: ElasticPendulum, method: str, h: float, mu: float, *,
                                  tableau: str | None = None,
                                  start: RelativeEquilibrium | None = None) -> RelativeEquilibrium:
    """The relative equilibrium of the numerical method: a reduced state that one step
    of ``method`` maps to itself (rotated about the axis). Found by Newton-type root
    finding on the reduced step map, from the exact equilibrium."""
    from scipy.optimize import root

    mu = real("mu", mu)  # with start given, a string reached the step as a TypeError
    start = relative_equilibrium(model, mu) if start is None else _equilibrium(start, "start")

    def residual(x):
        q0, p0 = _cartesian(x[0], x[1], x[2], x[3], mu)
        sol = integrate(model, q0, p0, method=method, tableau=tableau, h=h, n_steps=1)
        return _reduced(sol.q[-1:], sol.p[-1:])[0, :4] - x

    found = root(residual, start.reduced, method="hybr", options={"xtol": 1e-13})
    # hybr may report that it cannot improve on a point that is already a fixed
    # point to rounding: judge by the residual, not by the flag.
    if np.abs(residual(found.x)).max() > 1e-11:
        raise RuntimeError(f"no modified relative equilibrium found for {method} at h = {h}: {found.message}")
    rho, z, p_rho, p_z = found.x
    return RelativeEquilibrium(float(rho), float(z), float(p_rho), float(p_z), mu)
