"""raydamp.Planets: interacting planets around a central body, with drag on chosen planets, stepped with
the exact Kepler drift in Jacobi coordinates.

Bodies: the central body (mass ``central_mass``) and planets 0..N-1 (``masses``), gravitational constant
``G``. The state is in Jacobi coordinates: planet i's position Q_i relative to the centre of mass of the
central body and the planets inside it (0..i-1), and its momentum P_i = m'_i dQ_i/dt with the reduced
mass m'_i = m_i eta_{i-1} / eta_i (eta_i the mass of the central body and planets 0..i). The centre of
mass is at rest and not part of the state. Then

    H = sum_i |P_i|^2 / (2 m'_i) - sum_{pairs of bodies} G m_a m_b / |x_a - x_b|,
    P_i' = -grad_{Q_i} H - eps_i P_i,

and the splitting methods take H = H_kepler + H_interaction (Wisdom & Holman 1991): their drift is each
planet's exact Kepler flow about a mass eta_i, their kick the planets' interaction (a function of the
positions alone: Jacobi rather than democratic heliocentric coordinates, whose split has a third part,
the central body's kinetic energy, that is neither a drift nor a kick), their damping flow exact.
The error is then O(m / m_0) times that of a kinetic + potential split of the same orbit.

Drag ``eps_i`` on planet i is drag on its Jacobi velocity, relative to the inner bodies' centre of mass
(for the innermost planet, its velocity relative to the central body), the reaction on the inner bodies:
the total momentum is kept and the energy falls by W(t) = int sum_i eps_i |P_i|^2 / m'_i dt
(``work=True`` records it). With one rate for every planet the total angular momentum decays as
L(0) e^{-eps t} and is recorded as the momentum map L (Lx, Ly, Lz in 3-D).

    >>> sys = raydamp.Planets([1e-3, 1e-3], eps=[0.0, 1e-3])
    >>> q0, p0 = sys.jacobi_state([[1, 0], [0, 1.6]], [[0, 1], [-0.79, 0]])
    >>> sol = raydamp.integrate(sys, q0, p0, method="3s", h=0.02, t_end=200, save_every=50, work=True)
    >>> x, v = sys.heliocentric(sol.q, sol.p)     # (rows, planets, dim) each
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from .. import _core
from .._validation import _short, integer, numeric_array, real, real_array
from .kepler import drag_form, drag_json
from .models import SharedModel

__all__ = ["Planets"]

_AXES = ("x", "y", "z")
MAX_PLANETS = 1000  # the interaction is O(N^2) per kick


def _positive_list(name: str, value, *, allow_zero: bool) -> list[float]:
    array = numeric_array(value)
    if array is None or array.ndim != 1 or array.size < 1 or isinstance(value, (str, bytes)):
        raise ValueError(f"{name} must be a list of real numbers, got {_short(value)}")
    return [real(f"{name}[{i}]", x, nonnegative=allow_zero, positive=not allow_zero) for i, x in enumerate(value)]


class Planets(SharedModel):
    """Interacting planets around a central body, in Jacobi coordinates (see the module docstring).

    masses: the planets' masses (> 0), inner to outer as the Jacobi coordinates order them;
    central_mass (> 0); G (> 0); dim: 2 or 3; eps: the drag rate (>= 0), one for every planet or
    a list with one per planet; drag: its direction, "isotropic" (all of P_i), "radial" (P_i's part along
    Q_i: no torque, so L is conserved) or "tangential" (the part across Q_i), or a dim x dim symmetric
    positive semi-definite matrix A of fixed axes, P_i' = ... - eps_i A P_i, as raydamp.Kepler's.
    """

    name = "planets"

    def __init__(self, masses, central_mass: float = 1.0, G: float = 1.0, dim: int = 2,  # noqa: N803
                 eps: float | list[float] = 0.0, drag: str | list[list[float]] | np.ndarray = "isotropic"):
        self.masses = tuple(_positive_list("masses", masses, allow_zero=False))
        if len(self.masses) > MAX_PLANETS:
            raise ValueError(f"masses: at most {MAX_PLANETS} planets, got {len(self.masses)}")
        self.central_mass = real("central_mass", central_mass, positive=True)
        self.G = real("G", G, positive=True)
        self.space_dim = integer("dim", dim, minimum=2, maximum=3)
        planets = len(self.masses)
        if isinstance(eps, (list, tuple, np.ndarray)):
            rates = _positive_list("eps", eps, allow_zero=True)
            if len(rates) != planets:
                raise ValueError(f"eps: expected one drag rate per planet ({planets}), got {len(rates)}")
            self.eps = tuple(rates)
        else:
            self.eps = real("eps", eps, nonnegative=True)
            rates = [self.eps] * planets
        self.planets = planets
        self._rates = np.array(rates)
        self.drag, code, matrix = drag_form(drag, self.space_dim)
        self._core_model = _core.Planets(self.G, self.central_mass, list(self.masses), self.space_dim, rates,
                                         code, matrix)
        self.reduced_masses = np.array(self._core_model.reduced_masses)
        # L is listed when every planet's momentum decays at one rate across its radius (a radial drag at 0);
        # never with fixed axes
        uniform = isinstance(self.drag, str) and (self.drag == "radial" or bool(np.all(self._rates == self._rates[0])))
        self.momentum_names = (() if not uniform else ("L",) if self.space_dim == 2 else ("Lx", "Ly", "Lz"))
        self._freeze()

    # -- plain data ---------------------------------------------------------------------------
    @property
    def parameters(self) -> dict[str, Any]:
        """The constructor's arguments, by name (``replace`` and the JSON form use them)."""
        eps = list(self.eps) if isinstance(self.eps, tuple) else self.eps
        return {"masses": list(self.masses), "central_mass": self.central_mass, "G": self.G, "dim": self.space_dim,
                "eps": eps, "drag": drag_json(self.drag)}

    def to_dict(self) -> dict[str, Any]:
        """The JSON form: ``{"kind": "planets", "masses": [...], "central_mass": ..., "G": ..., "dim": ...,
        "eps": ..., "drag": ...}``."""
        return {"kind": "planets", **self.parameters}

    @classmethod
    def from_dict(cls, spec: Mapping[str, Any]) -> Planets:
        """Build from ``to_dict()``'s form; errors name the key."""
        return cls._from_form(spec, "planets", "Planets system", ("masses", "central_mass", "G", "dim", "eps", "drag"),
                              {"masses": "required (the planets' masses)"})

    @property
    def coordinates(self) -> tuple[str, ...]:
        axes = _AXES[: self.space_dim]
        return tuple(f"{a}{i}" for i in range(self.planets) for a in axes)

    def mass_product(self, r) -> np.ndarray:
        """M r with M = diag(m'_i) per planet's block."""
        return np.repeat(self.reduced_masses, self.space_dim) * real_array("r", r).reshape(self.dim)

    # -- coordinates ------------------------------------------------------------------------------
    def jacobi_state(self, positions, velocities) -> tuple[np.ndarray, np.ndarray]:
        """(q0, p0) in Jacobi coordinates from the planets' positions and velocities relative to the central
        body, each of shape (planets, dim)."""
        shape = (self.planets, self.space_dim)
        x = real_array("positions", positions)
        v = real_array("velocities", velocities)
        for name, a in (("positions", x), ("velocities", v)):
            if a.shape != shape:
                raise ValueError(f"{name}: expected shape {shape}, got {a.shape}")
        self._check_positions("positions", x)
        eta = self.central_mass + np.cumsum(self.masses)
        q, p = np.empty(shape), np.empty(shape)
        centre, velocity = np.zeros(self.space_dim), np.zeros(self.space_dim)  # inner centre of mass, rel. body 0
        for i in range(self.planets):
            q[i] = x[i] - centre
            u = v[i] - velocity  # planet i's Jacobi velocity
            p[i] = self.reduced_masses[i] * u
            centre = centre + self.masses[i] / eta[i] * q[i]
            velocity = velocity + self.masses[i] / eta[i] * u
        return q.reshape(-1), p.reshape(-1)

    def heliocentric(self, q, p) -> tuple[np.ndarray, np.ndarray]:
        """The planets' positions and velocities relative to the central body from Jacobi (q, p) of shape
        (rows, n) or (n,): arrays (..., planets, dim)."""
        q, p = real_array("q", q), real_array("p", p)
        if q.shape != p.shape or q.shape[-1] != self.dim:
            raise ValueError(f"q, p: expected arrays with last dimension n = {self.dim}, got {q.shape} and {p.shape}")
        shape = q.shape[:-1] + (self.planets, self.space_dim)
        jq = q.reshape(shape)
        jv = p.reshape(shape) / self.reduced_masses[:, None]
        eta = self.central_mass + np.cumsum(self.masses)
        x, v = np.empty(shape), np.empty(shape)
        centre = np.zeros(shape[:-2] + (self.space_dim,))
        velocity = np.zeros_like(centre)
        for i in range(self.planets):
            x[..., i, :] = centre + jq[..., i, :]
            v[..., i, :] = velocity + jv[..., i, :]
            centre = centre + self.masses[i] / eta[i] * jq[..., i, :]
            velocity = velocity + self.masses[i] / eta[i] * jv[..., i, :]
        return x, v

    # -- checks ---------------------------------------------------------------------------------
    def _check_positions(self, name: str, x: np.ndarray) -> None:
        """x: heliocentric positions (planets, dim). A planet at the central body or two at one place
        make the potential singular."""
        radii = np.linalg.norm(x, axis=-1)
        bad = np.flatnonzero(~(radii > 0))
        if bad.size:
            raise ValueError(f"{name}: planet {int(bad[0])} is at the central body's position, where the potential "
                             "is singular")
        for i in range(self.planets):
            apart = np.linalg.norm(x[i + 1:] - x[i], axis=-1)
            same = np.flatnonzero(~(apart > 0))
            if same.size:
                raise ValueError(f"{name}: planets {i} and {i + 1 + int(same[0])} are at the same position, where "
                                 "the potential is singular")

    def check_configuration(self, name: str, q: np.ndarray) -> np.ndarray:
        """Refuse a planet at the central body, two planets at one position, or a planet at the centre of
        mass of the bodies inside it (Q_i = 0, where its Kepler drift is singular)."""
        jq = np.asarray(q, dtype=float).reshape(self.planets, self.space_dim)
        zero = np.flatnonzero(~(np.linalg.norm(jq, axis=1) > 0))
        if zero.size:
            raise ValueError(f"{name}: planet {int(zero[0])} is at the centre of mass of the bodies inside it "
                             "(its Jacobi position is 0), where its Kepler drift is singular")
        x, _ = self.heliocentric(jq.reshape(-1), np.ones(self.dim))
        self._check_positions(name, x)
        return q

    def check_configurations(self, name: str, qs: np.ndarray) -> None:
        for i, q in enumerate(qs):
            self.check_configuration(f"{name}[{i}]", q)
