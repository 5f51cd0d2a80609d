"""raydamp.Kepler: test particles around a fixed central body, with drag, stepped with the exact
Kepler flow.

Each particle i (mass m, position q_i, momentum p_i in 2 or 3 dimensions) moves in

    H = sum_i |p_i|^2 / (2 m) - mu m / |q_i|,      p_i' = -grad_i H - eps p_i

(``mu`` is G times the central mass; the drag is D = M, so A = eps D M^{-1} = eps and every
particle's angular momentum decays exactly as L(t) = L(0) e^{-eps t}). The splitting methods take
H = H_kepler + V_interaction: their drift is the exact Kepler flow of each particle (universal
variables with Stumpff functions: elliptic, parabolic and hyperbolic orbits, any step length), their
kick is the interaction (none between test particles) and their damping flow is exact. A splitting
of this kind then errs only by the commutators of the Kepler flow with the drag, O(eps h^2) per unit
time for 3s and 2s (O(eps h^4) and better with a composition), where writing Kepler as kinetic plus
potential errs by O(h^2) whatever eps is.

Methods: sv (eps = 0), 3s, 2s, baoab and rks, with compositions. A method that steps the kinetic
energy as a free drift inside a Runge-Kutta or implicit stage (rksb, heun, rk4, rk, midpoint,
gauss4) would integrate another system, and is refused.

``raydamp.integrate_ensemble`` of one-particle Kepler members (an ensemble of decaying orbits) by 3s, 2s
or sv runs them in batches as the particles of one model, at the cost per orbit of ``Kepler(particles=N)``;
each member's rows equal its single run's, its ``max_momentum_drift`` is the largest of its batch's.

    >>> k = raydamp.Kepler(mu=1.0, eps=1e-3)
    >>> q0, p0 = k.pericentre_state(1.0, e=0.5)
    >>> sol = raydamp.integrate(k, q0, p0, method="3s", h=0.05, t_end=1000, save_every=100)
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from .. import _core
from .._validation import integer, real, real_array, vector
from .models import SharedModel

__all__ = ["Kepler"]

_AXES = ("x", "y", "z")

# The drag's directions (models/planets.hpp's DragDirection): the whole momentum, or its part along the
# radius vector (a radial dashpot) or across it (a tangential one); code 3 is a matrix of fixed axes.
DRAG_DIRECTIONS = {"isotropic": 0, "radial": 1, "tangential": 2}
_AXES_CODE = 3


def drag_form(drag, dim: int) -> tuple[str | tuple[tuple[float, ...], ...], int, np.ndarray]:
    """``drag`` as kept (a direction's name, or the matrix as a tuple of rows), the core's code, and the
    matrix (0 x 0 for a direction). A ValueError naming ``drag`` for anything else; the core checks that a
    matrix is finite, symmetric and positive semi-definite, in errors that name ``drag`` too."""
    if isinstance(drag, str):
        if drag not in DRAG_DIRECTIONS:
            raise ValueError(f"drag: must be one of {', '.join(DRAG_DIRECTIONS)} or a {dim} x {dim} matrix, "
                             f"got {drag!r}")
        return drag, DRAG_DIRECTIONS[drag], np.zeros((0, 0))
    try:
        matrix = np.array(drag, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"drag: must be one of {', '.join(DRAG_DIRECTIONS)} or a {dim} x {dim} matrix of numbers, "
                         f"got {drag!r}") from None
    if matrix.shape != (dim, dim):
        raise ValueError(f"drag: a matrix must be {dim} x {dim} (dim), got shape {matrix.shape}")
    return tuple(tuple(float(x) for x in row) for row in matrix), _AXES_CODE, matrix


def drag_json(drag) -> str | list[list[float]]:
    """The JSON form of a kept ``drag``: the name, or the matrix as a list of rows."""
    return drag if isinstance(drag, str) else [list(row) for row in drag]


class Kepler(SharedModel):
    """Test particles of mass ``mass`` around a fixed central body (see the module docstring).

    mu: G times the central mass (> 0); dim: 2 or 3; particles: how many (>= 1), each with its own
    block of ``dim`` coordinates (x0, y0, x1, y1, ...); eps: the drag rate (>= 0), p' = ... - eps p.
    drag: "isotropic" (the whole momentum), "radial" (only p's part along q_i: a radial dashpot, which
    exerts no torque, so L is conserved) or "tangential" (only the part across q_i; L decays as e^{-eps t}).
    Each is an exact damping flow at the frozen q (its two parts scale by their own factors). Or a
    ``dim`` x ``dim`` symmetric positive semi-definite matrix A of fixed axes: p_i' = ... - eps A p_i (the
    damping matrix D = eps m A). ``[[0, 0, 0], [0, 0, 0], [0, 0, 1]]`` damps the vertical momentum alone, and
    so the inclination, with no torque about z (L_z is kept); its exact flow is e^{-t eps A} per particle,
    by A's eigenvectors. With a matrix no angular momentum is listed: A has no law for all of L.
    """

    name = "kepler"

    def __init__(self, mu: float = 1.0, mass: float = 1.0, dim: int = 2, particles: int = 1, eps: float = 0.0,
                 drag: str | list[list[float]] | np.ndarray = "isotropic"):
        self.mu = real("mu", mu, positive=True)
        self.mass = real("mass", mass, positive=True)
        self.space_dim = integer("dim", dim, minimum=2, maximum=3)
        self.particles = integer("particles", particles, minimum=1, maximum=2**31 // 3 - 1)
        self.eps = real("eps", eps, nonnegative=True)
        self.drag, code, matrix = drag_form(drag, self.space_dim)
        self._core_model = _core.Kepler(self.mu, self.mass, self.space_dim, self.particles, self.eps, code, matrix)
        self.momentum_names = (() if code == _AXES_CODE else ("L",) if self.space_dim == 2 else ("Lx", "Ly", "Lz"))
        self._freeze()

    # -- plain data ---------------------------------------------------------------------------
    @property
    def parameters(self) -> dict[str, Any]:
        """The constructor's arguments, by name (``replace`` and the JSON form use them)."""
        return {"mu": self.mu, "mass": self.mass, "dim": self.space_dim, "particles": self.particles, "eps": self.eps,
                "drag": drag_json(self.drag)}

    def to_dict(self) -> dict[str, Any]:
        """The JSON form: ``{"kind": "kepler", "mu": ..., "mass": ..., "dim": ..., "particles": ..., "eps": ...,
        "drag": ...}``."""
        return {"kind": "kepler", **self.parameters}

    @classmethod
    def from_dict(cls, spec: Mapping[str, Any]) -> Kepler:
        """Build from ``to_dict()``'s form; errors name the key."""
        return cls._from_form(spec, "kepler", "Kepler system", ("mu", "mass", "dim", "particles", "eps", "drag"))

    @property
    def coordinates(self) -> tuple[str, ...]:
        axes = _AXES[: self.space_dim]
        return tuple(f"{a}{i}" for i in range(self.particles) for a in axes)

    def mass_product(self, r) -> np.ndarray:
        """M r: every coordinate has mass ``mass``."""
        return self.mass * vector("r", r, self.dim)

    def check_configuration(self, name: str, q: np.ndarray) -> np.ndarray:
        """Refuse a particle at the central body (|q_i| = 0), where the potential is singular."""
        radii = np.linalg.norm(np.asarray(q, dtype=float).reshape(self.particles, self.space_dim), axis=1)
        bad = np.flatnonzero(~(radii > 0))
        if bad.size:
            raise ValueError(f"{name}: particle {int(bad[0])} is at the central body (|q| = 0), where the "
                             "Kepler potential -mu m / |q| is singular")
        return q

    def check_configurations(self, name: str, qs: np.ndarray) -> None:
        radii = np.linalg.norm(np.asarray(qs, dtype=float).reshape(len(qs), self.particles, self.space_dim), axis=2)
        bad = np.argwhere(~(radii > 0))
        if bad.size:
            member, particle = (int(x) for x in bad[0])
            raise ValueError(f"{name}[{member}]: particle {particle} is at the central body (|q| = 0), where the "
                             "Kepler potential -mu m / |q| is singular")

    # -- orbits ---------------------------------------------------------------------------------
    def pericentre_state(self, rp: float, e: float, *, particle: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(q0, p0) of an orbit at its pericentre: distance ``rp`` (> 0) along x, moving along +y with the
        speed of eccentricity ``e`` (>= 0; 0 circular, < 1 elliptic, 1 parabolic, > 1 hyperbolic),
        v = sqrt(mu (1 + e) / rp). Every particle gets it, or only ``particle`` (the others at rest at
        distance rp along x: set their states yourself)."""
        rp = real("rp", rp, positive=True)
        e = real("e", e, nonnegative=True)
        q = np.zeros((self.particles, self.space_dim))
        p = np.zeros((self.particles, self.space_dim))
        rows = range(self.particles) if particle is None else [integer("particle", particle, minimum=0,
                                                                         maximum=self.particles - 1)]
        q[:, 0] = rp
        for i in rows:
            p[i, 1] = self.mass * math.sqrt(self.mu * (1.0 + e) / rp)
        return q.reshape(-1), p.reshape(-1)

    def elements(self, q, p) -> dict[str, np.ndarray]:
        """Per particle: specific energy, semi-major axis a = -mu / (2 energy) (inf for a parabola,
        negative for a hyperbola), eccentricity e and the angular momentum's size |L| / m, for rows of
        (q, p) of shape (rows, n) or (n,). In 3 dimensions also the inclination to the x-y plane, in
        radians, arctan2(|L_xy|, L_z) (0 to pi; what drag along z, ``drag=[[0, 0, 0], [0, 0, 0], [0, 0, 1]]``,
        damps)."""
        q, p = real_array("q", q), real_array("p", p)
        if q.shape != p.shape or q.shape[-1] != self.dim:
            raise ValueError(f"q, p: expected arrays with last dimension n = {self.dim}, got {q.shape} and {p.shape}")
        shape = q.shape[:-1] + (self.particles, self.space_dim)
        x, v = q.reshape(shape), p.reshape(shape) / self.mass
        r = np.linalg.norm(x, axis=-1)
        energy = 0.5 * np.sum(v * v, axis=-1) - self.mu / r
        extra = {}
        if self.space_dim == 2:
            h = np.abs(x[..., 0] * v[..., 1] - x[..., 1] * v[..., 0])
        else:
            L = np.cross(x, v)
            h = np.linalg.norm(L, axis=-1)
            extra["inclination"] = np.arctan2(np.hypot(L[..., 0], L[..., 1]), L[..., 2])
        with np.errstate(divide="ignore"):
            a = -self.mu / (2.0 * energy)
        e = np.sqrt(np.maximum(0.0, 1.0 + 2.0 * energy * h * h / self.mu**2))
        return {"energy": energy, "a": a, "e": e, "h": h, **extra}
