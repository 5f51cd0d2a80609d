"""raydamp.Chain: one-dimensional lattices (FPUT, Toda, Morse, Lennard-Jones, ...) with
dashpots on chosen bonds or friction on chosen sites, up to millions of sites.

n sites of mass m on a line, displacements q_0 .. q_{n-1}; neighbours are joined by
bonds of one family with potential V(r) in the stretch r (V(0) = V'(0) = 0):

    H = sum_i p_i^2 / (2 m) + sum_b V(r_b),   r_b = q_{right(b)} - q_{left(b)}

Bond b joins sites b-1 and b:
    "fixed":    bonds 0..n, walls at both ends (bond 0: wall-site 0, bond n: site n-1-wall);
    "periodic": bonds 0..n-1, bond 0 joins site n-1 and site 0;
    "free":     bonds 1..n-1.

Damping: D = sum_b c_b g_b g_b^T (a dashpot on bond b resists the rate of its stretch)
+ sum_i c_i e_i e_i^T (friction on site i), scaled by ``eps``. A stretch is linear in q,
so D is constant; damped sites fall into blocks (disjoint dashpots: 2x2; adjacent damped
bonds: one tridiagonal block; a site: 1x1) whose exact flows come from each block's own
eigendecomposition. Blocks are capped at 256 sites: damping every bond of a long chain
is refused (use on-site friction, or a few dashpots). Friction alone (every block one site)
is a factor e^{-t eps c_i / m} per site, formed once per sub-step length: on every site the
damping costs one multiply-add per site inside 3s's single pass over the state. Dashpots on bonds alone conserve
the total momentum sum p of a periodic or free chain (the momentum map "P").

Bond families and their parameters (defaults):
    harmonic        V = k r^2/2                                         k=1
    fput            V = k r^2/2 + alpha r^3/3 + beta r^4/4              k=1, alpha=0, beta=0
    toda            V = (a/b)(e^{-b r} - 1 + b r)                        a=1, b=1
    morse           V = depth (1 - e^{-a r})^2                           depth=1, a=1
    lennard_jones   V = depth((s/d)^12 - 2 (s/d)^6 + 1), d = s + r       depth=1, spacing s=1
    expression      V given as text in r: {"potential": "r^2/2 + g*r^6", "g": 0.1}
A Lennard-Jones bond is defined for d = s + r > 0: one squeezed through zero length (a step too long for
the motion) is not finite there, and the run stops "non_finite" at that step, keeping what it computed.
A chain without dampers is undamped whatever its eps (its default 1 scales nothing): sv runs it.
At a temperature the noise enters where the dampers act: a harmonic chain's mode with a node there is never
thermalised (friction on one site of a periodic chain leaves half the modes alone: per-site <p^2>/m then
settles at kT/2), which is the physics, not a sampling error.

On-site potentials U(q_i) (``on_site=``; each site held to its rest position, which breaks
the conservation of sum p):
    {"kind": "harmonic", "k": 1}            U = k q^2/2 (a Klein-Gordon chain with harmonic pinning)
    {"kind": "phi4", "k2": 1, "k4": 1}      U = k2 q^2/2 + k4 q^4/4 (k2 < 0: a double well)
    {"kind": "sine", "g": 1}                U = g (1 - cos q) (Frenkel-Kontorova, discrete sine-Gordon)
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from .. import _core
from .._validation import _short, integer, real, real_array, vector
from .models import SharedModel

__all__ = ["Chain", "BOND_FAMILIES", "chain_mode_energies", "MAX_SITES"]

MAX_SITES = 2**31 - 1  # sites are C++ ints

# Each family's parameters with their defaults, and the rule each must satisfy.
BOND_FAMILIES: dict[str, dict[str, float]] = {
    "harmonic": {"k": 1.0},
    "fput": {"k": 1.0, "alpha": 0.0, "beta": 0.0},
    "toda": {"a": 1.0, "b": 1.0},
    "morse": {"depth": 1.0, "a": 1.0},
    "lennard_jones": {"depth": 1.0, "spacing": 1.0},
    "expression": {},
}
_POSITIVE = {("harmonic", "k"), ("toda", "a"), ("toda", "b"), ("morse", "depth"), ("morse", "a"),
             ("lennard_jones", "depth"), ("lennard_jones", "spacing")}
BOUNDARIES = ("fixed", "periodic", "free")
# On-site forms with their parameters' defaults; each maps onto the core's polynomial or sine kind.
ON_SITE: dict[str, dict[str, float]] = {"harmonic": {"k": 1.0}, "phi4": {"k2": 1.0, "k4": 1.0}, "sine": {"g": 1.0}}


def _bond_range(boundary: str, n: int) -> range:
    return range(1 if boundary == "free" else 0, n + 1 if boundary == "fixed" else n)


class Chain(SharedModel):
    """A one-dimensional lattice with damped bonds or sites (see the module docstring).

    >>> c = Chain(32, bond="fput", parameters={"alpha": 0.25}, dampers={"bonds": [9, 19, 29], "c": 0.1})
    >>> q0, p0 = c.normal_mode(1, amplitude=1.0)
    >>> sol = raydamp.integrate(c, q0, p0, method="3s", h=0.1, t_end=100, save_every=10)
    >>> energies = raydamp.chain_mode_energies(sol)          # (rows, n): the FPUT recurrence
    """

    name = "chain"

    def __init__(self, n: int, bond: str = "fput", parameters: Mapping[str, Any] | None = None, mass: float = 1.0,
                 boundary: str = "fixed", dampers: Mapping[str, Any] | None = None, eps: float = 1.0,
                 on_site: Mapping[str, Any] | None = None):
        n = integer("n", n, minimum=2, maximum=MAX_SITES)
        if not isinstance(bond, str) or bond not in BOND_FAMILIES:
            raise ValueError(f"bond: unknown bond family {_short(bond)} (known: {', '.join(BOND_FAMILIES)})")
        if not isinstance(boundary, str) or boundary not in BOUNDARIES:
            raise ValueError(f"boundary: unknown boundary {_short(boundary)} (known: {', '.join(BOUNDARIES)})")
        self.n = n
        self.bond = bond
        self.boundary = boundary
        self.mass = real("mass", mass, positive=True)
        self.eps = real("eps", eps, nonnegative=True)
        self.bond_parameters, self._expression = _bond_parameters(bond, parameters)
        self.dampers = _dampers(dampers, boundary, n)
        self.on_site = _on_site(on_site)
        functions: list[int] = []
        keep: Any = None
        numeric = {k: v for k, v in self.bond_parameters.items() if k != "potential"}
        if bond == "expression":
            keep = _compile_bond(self._expression, numeric)
            functions = list(keep[1])
            numeric = {}
        self._compiled_bond = keep
        d = self.dampers
        bonds = d.get("bonds", [])
        sites = d.get("sites", [])
        c = d.get("c", 0.0)
        c_list = list(c) if isinstance(c, list) else [c] * (len(bonds) + len(sites))
        core_on_site, core_on_site_parameters = _core_on_site(self.on_site)
        # Without dampers eps has nothing to act on; the core's eps decides whether sv may run (Chain(4) refused
        # it, "eps = 1 > 0", though nothing was damped: the default eps is 1), as for an undamped System.
        core_eps = self.eps if bonds or sites else 0.0
        self._core_model = _core.Chain(n, boundary, bond, numeric, self.mass, core_eps, bonds, c_list[:len(bonds)],
                                       sites, c_list[len(bonds):], functions, keep, core_on_site,
                                       core_on_site_parameters)
        self.momentum_names = ("P",) if self._core_model.n_momenta else ()
        self._freeze()

    # -- plain data ---------------------------------------------------------------------------
    @property
    def parameters(self) -> dict[str, Any]:
        """The constructor's arguments, by name (``replace`` and the JSON form use them)."""
        return {"n": self.n, "bond": self.bond, "parameters": dict(self.bond_parameters), "mass": self.mass,
                "boundary": self.boundary, "dampers": {k: (list(v) if isinstance(v, list) else v)
                                                       for k, v in self.dampers.items()}, "eps": self.eps,
                "on_site": dict(self.on_site) if self.on_site else None}

    def to_dict(self) -> dict[str, Any]:
        """The JSON form: ``{"kind": "chain", "n": ..., "bond": ..., ...}`` (the service's ``system``)."""
        spec = {"kind": "chain", **self.parameters}
        if spec["on_site"] is None:
            del spec["on_site"]  # the form of chains without one stays as it was
        return spec

    @classmethod
    def from_dict(cls, spec: Mapping[str, Any]) -> Chain:
        """Build from ``to_dict()``'s form; errors name the key (``n must be ...``, ``dampers.bonds[2]: ...``)."""
        return cls._from_form(spec, "chain", "chain",
                              ("n", "bond", "parameters", "mass", "boundary", "dampers", "eps", "on_site"),
                              {"n": "missing (the number of sites)"})

    def mass_product(self, r) -> np.ndarray:
        """M r: every site has mass ``mass``."""
        return self.mass * vector("r", r, self.n)  # another length was broadcast, or scaled as it was

    def __repr__(self) -> str:
        return (f"Chain(n={self.n}, bond={self.bond!r}, parameters={self.bond_parameters!r}, mass={self.mass!r}, "
                f"boundary={self.boundary!r}, dampers={self.dampers!r}, eps={self.eps!r}"
                + (f", on_site={self.on_site!r})" if self.on_site else ")"))

    @property
    def coordinates(self) -> tuple[str, ...]:
        return _SiteNames(self.n)

    # -- lattice quantities -------------------------------------------------------------------
    @property
    def harmonic_stiffness(self) -> float:
        """V''(0): the stiffness of the linearised bond, which sets the normal-mode frequencies."""
        p = self.bond_parameters
        if self.bond in ("harmonic", "fput"):
            return p["k"]
        if self.bond == "toda":
            return p["a"] * p["b"]
        if self.bond == "morse":
            return 2.0 * p["depth"] * p["a"] ** 2
        if self.bond == "lennard_jones":
            return 72.0 * p["depth"] / p["spacing"] ** 2
        from .system.compile import evaluate
        return float(evaluate(self._compiled_bond[0][2], np.zeros(1))[0])

    @property
    def on_site_stiffness(self) -> float:
        """U''(0) of the on-site potential (0 without one): it shifts every omega_k^2 by U''(0)/m."""
        u = self.on_site
        if not u:
            return 0.0
        return {"harmonic": lambda: u["k"], "phi4": lambda: u["k2"], "sine": lambda: u["g"]}[u["kind"]]()

    def frequencies(self) -> np.ndarray:
        """omega_k of the linearised chain, one per mode in ``mode_energies``' order: omega_k^2 =
        (V''(0) lambda_k + U''(0)) / m. Imaginary (NaN here) for an unstable mode (phi4 with k2 < 0)."""
        with np.errstate(invalid="ignore"):
            return np.sqrt((self.harmonic_stiffness * _eigenvalues(self.boundary, self.n) + self.on_site_stiffness)
                           / self.mass)

    def normal_mode(self, mode: int = 1, amplitude: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
        """(q0, p0): all energy in one normal mode of the linearised chain, at rest (the FPUT start).

        fixed: q_j = A sin(pi k (j+1)/(n+1)), k = 1..n; periodic: q_j = A cos(2 pi k j/n),
        k = 0..n//2; free: q_j = A cos(pi k (j+1/2)/n), k = 0..n-1."""
        n = self.n
        limit = {"fixed": (1, n), "periodic": (0, n // 2), "free": (0, n - 1)}[self.boundary]
        mode = integer("mode", mode, minimum=limit[0], maximum=limit[1])
        amplitude = real("amplitude", amplitude)
        j = np.arange(n, dtype=float)
        if self.boundary == "fixed":
            q = amplitude * np.sin(math.pi * mode * (j + 1) / (n + 1))
        elif self.boundary == "periodic":
            q = amplitude * np.cos(2 * math.pi * mode * j / n)
        else:
            q = amplitude * np.cos(math.pi * mode * (j + 0.5) / n)
        return q, np.zeros(n)

    def mode_energies(self, q, p) -> np.ndarray:
        """Energy in each normal mode of the linearised chain, for rows of (q, p) (shape (rows, n)
        or (n,)): E_k = P_k^2/(2m) + m omega_k^2 Q_k^2/2 with (Q, P) the orthonormal transform
        (fixed: DST-I, modes k = 1..n; free: DCT-II, k = 0..n-1; periodic: real Fourier, each
        wavenumber k = 0..n//2 with its pair). They sum to the harmonic part of H (with an on-site
        potential, its quadratic part U''(0) q^2/2 included: E_k = P_k^2/(2m) + m omega_k^2 Q_k^2/2)."""
        # Numbers only: None was a 0-d NaN (an IndexError on its shape), "abcd" NumPy's message naming nothing.
        q, p = real_array("q", q), real_array("p", p)
        if q.ndim == 0 or q.shape != p.shape or q.shape[-1] != self.n:
            raise ValueError(f"q, p: expected arrays with last dimension n = {self.n}, got {q.shape} and {p.shape}")
        Q = _transform(self.boundary, q)
        P = _transform(self.boundary, p)
        lam = _eigenvalues(self.boundary, self.n)
        return 0.5 * P**2 / self.mass + 0.5 * (self.harmonic_stiffness * lam + self.on_site_stiffness) * Q**2

    @property
    def damping_blocks(self) -> int:
        """Blocks of sites coupled by damping (each with its own exact flow)."""
        return self._core_model.damping_blocks


class _SiteNames(Sequence):
    """q0, q1, ... without building a million strings up front."""

    def __init__(self, n: int):
        self._n = n

    def __len__(self) -> int:
        return self._n

    def __getitem__(self, i):
        if isinstance(i, slice):
            return tuple(f"q{k}" for k in range(*i.indices(self._n)))
        if not -self._n <= i < self._n:
            raise IndexError(i)
        return f"q{i % self._n}"


def chain_mode_energies(sol, chain: Chain | None = None) -> np.ndarray:
    """Normal-mode energies (rows, modes) of a chain run: ``Chain.mode_energies`` on every saved
    row. The run must have saved every site (no ``save_dofs``)."""
    if chain is None:
        origin = getattr(sol, "origin", None)
        chain = origin[0] if isinstance(origin, tuple) else None
        if chain is None and isinstance(origin, dict) and isinstance(origin.get("system"), Mapping):
            chain = Chain.from_dict(origin["system"])
    if not isinstance(chain, Chain):
        raise ValueError("chain: this solution is not from a raydamp.Chain; pass chain=")
    if getattr(sol, "dofs", None) is not None:
        raise ValueError("save_dofs: mode energies need every site; this run saved only some (save_dofs)")
    return chain.mode_energies(sol.q, sol.p)


# -- helpers ------------------------------------------------------------------------------------

def _eigenvalues(boundary: str, n: int) -> np.ndarray:
    """Eigenvalues of the chain's stiffness pattern (the graph Laplacian), mode by mode."""
    if boundary == "fixed":
        return 4.0 * np.sin(math.pi * np.arange(1, n + 1) / (2 * (n + 1))) ** 2
    if boundary == "free":
        return 4.0 * np.sin(math.pi * np.arange(n) / (2 * n)) ** 2
    return 4.0 * np.sin(math.pi * np.arange(n // 2 + 1) / n) ** 2


def _transform(boundary: str, x: np.ndarray) -> np.ndarray:
    """Orthonormal mode coordinates along the last axis (periodic: the amplitude of each
    wavenumber, its cosine and sine parts together, so squares still sum to |x|^2)."""
    n = x.shape[-1]
    if boundary == "fixed":
        # DST-I from the FFT of the odd extension [0, x, 0, -reversed x].
        zeros = np.zeros(x.shape[:-1] + (1,))
        ext = np.concatenate([zeros, x, zeros, -x[..., ::-1]], axis=-1)
        return -np.fft.rfft(ext, axis=-1).imag[..., 1:n + 1] * math.sqrt(2.0 / (n + 1)) / 2.0
    if boundary == "free":
        # DCT-II from the FFT of the even extension [x, reversed x].
        k = np.arange(n)
        ext = np.concatenate([x, x[..., ::-1]], axis=-1)
        y = (np.fft.fft(ext, axis=-1)[..., :n] * np.exp(-1j * math.pi * k / (2 * n))).real / 2.0
        scale = np.full(n, math.sqrt(2.0 / n))
        scale[0] = math.sqrt(1.0 / n)
        return y * scale
    y = np.abs(np.fft.rfft(x, axis=-1)) / math.sqrt(n)
    weight = np.full(n // 2 + 1, math.sqrt(2.0))
    weight[0] = 1.0
    if n % 2 == 0:
        weight[-1] = 1.0
    return y * weight


def _on_site(on_site: Mapping[str, Any] | None) -> dict[str, Any] | None:
    """The on-site potential with its defaults filled in, checked; None for none."""
    if on_site is None:
        return None
    if not isinstance(on_site, Mapping):
        raise ValueError(f"on_site: expected {{\"kind\": ...}} or None, got {_short(on_site)}")
    kind = on_site.get("kind")
    if not isinstance(kind, str) or kind not in ON_SITE:
        raise ValueError(f"on_site.kind: unknown on-site potential {_short(kind)} (known: {', '.join(ON_SITE)})")
    out: dict[str, Any] = {"kind": kind}
    for key, _value in on_site.items():
        if key != "kind" and key not in ON_SITE[kind]:
            raise ValueError(f"on_site.{key}: the {kind} on-site potential has no parameter {key!r} "
                             f"(known: {', '.join(ON_SITE[kind])})")
    for key, default in ON_SITE[kind].items():
        # k2 may be negative (a double well); the pinning k and the others are >= 0.
        out[key] = real(f"on_site.{key}", on_site.get(key, default), nonnegative=key != "k2")
    return out


def _core_on_site(on_site: dict[str, Any] | None) -> tuple[str, dict[str, float]]:
    """The core's form: ("none" | "polynomial" | "sine", parameters)."""
    if not on_site:
        return "none", {}
    if on_site["kind"] == "harmonic":
        return "polynomial", {"k2": on_site["k"], "k4": 0.0}
    if on_site["kind"] == "phi4":
        return "polynomial", {"k2": on_site["k2"], "k4": on_site["k4"]}
    return "sine", {"g": on_site["g"]}


def _bond_parameters(bond: str, parameters: Mapping[str, Any] | None) -> tuple[dict[str, Any], Any]:
    if parameters is None:
        parameters = {}
    if not isinstance(parameters, Mapping):
        raise ValueError(f"parameters must be an object of name: value, got {_short(parameters)}")
    if bond == "expression":
        return _expression_parameters(parameters)
    defaults = BOND_FAMILIES[bond]
    out = dict(defaults)
    for key, value in parameters.items():
        if key not in defaults:
            raise ValueError(f"parameters.{key}: the {bond} bond has no parameter {key!r} "
                             f"(known: {', '.join(defaults)})")
        out[key] = real(f"parameters.{key}", value, positive=(bond, key) in _POSITIVE)
    return out, None


def _expression_parameters(parameters: Mapping[str, Any]) -> tuple[dict[str, Any], Any]:
    from .expressions import parse

    text = parameters.get("potential")
    if not isinstance(text, str):
        raise ValueError("parameters.potential: the expression bond needs its V(r) as text, e.g. \"r^2/2 + r^4/4\"")
    out: dict[str, Any] = {"potential": text}
    for key, value in parameters.items():
        if key == "potential":
            continue
        if not isinstance(key, str) or not key.isidentifier() or key in ("r", "pi"):
            raise ValueError(f"parameters.{key}: not a usable parameter name (r and pi are taken)")
        out[key] = real(f"parameters.{key}", value)
    names = {"r": "coordinate", **{k: "parameter" for k in out if k != "potential"}}
    return out, parse(text, field="parameters.potential", names=names)


def _compile_bond(expression, numeric: dict[str, float]) -> tuple[tuple[Any, Any, Any], tuple[int, ...]]:
    """V(r), V'(r), V''(r) compiled by the systems' JIT: ((functions), (function, data) x 3)."""
    import symengine as se

    from .system.compile import _jit, number

    r = se.Symbol("_r")
    symbols: dict[str, Any] = {name: number(value) for name, value in numeric.items()}
    symbols["r"] = r
    v = expression.to_symengine(symbols)
    dv = se.diff(v, r)
    d2v = se.diff(dv, r)
    compiled = [_jit([r], [e], ("parameters", "potential")) for e in (v, dv, d2v)]
    functions = tuple(f for f, _, _ in compiled)
    addresses = tuple(x for _, a, d in compiled for x in (a, d))
    return functions, addresses


def _dampers(dampers: Mapping[str, Any] | None, boundary: str, n: int) -> dict[str, Any]:
    if dampers is None:
        return {}
    if not isinstance(dampers, Mapping):
        raise ValueError(f"dampers must be {{\"bonds\": [...], \"c\": ...}} or {{\"sites\": [...], \"c\": ...}}, "
                         f"got {_short(dampers)}")
    for key in dampers:
        if key not in ("bonds", "sites", "c"):
            raise ValueError(f"dampers.{key}: unknown key (known: bonds, sites, c)")
    out: dict[str, Any] = {}
    count = 0
    for key, valid in (("bonds", _bond_range(boundary, n)), ("sites", range(n))):
        if key not in dampers:
            continue
        raw = dampers[key]
        if isinstance(raw, (str, bytes)) or not isinstance(raw, (Sequence, np.ndarray)):
            raise ValueError(f"dampers.{key} must be a list of indices, got {_short(raw)}")
        values = []
        for i, x in enumerate(raw):
            if isinstance(x, bool) or not isinstance(x, (int, np.integer)):
                raise ValueError(f"dampers.{key}[{i}] must be an integer, got {_short(x)}")
            if int(x) not in valid:
                what = "bond" if key == "bonds" else "site"
                raise ValueError(f"dampers.{key}[{i}]: {what} {int(x)} is not in this {boundary} chain "
                                 f"({valid.start}..{valid.stop - 1})")
            values.append(int(x))
        if len(set(values)) != len(values):
            raise ValueError(f"dampers.{key}: an index appears twice")
        out[key] = values
        count += len(values)
    if count and "c" not in dampers:
        raise ValueError("dampers.c: missing (the dashpot coefficient, a number or one per damper)")
    if "c" in dampers:
        c = dampers["c"]
        if isinstance(c, (Sequence, np.ndarray)) and not isinstance(c, (str, bytes)):
            if len(c) != count:
                raise ValueError(f"dampers.c: {len(c)} coefficients for {count} dampers (bonds, then sites)")
            out["c"] = [real(f"dampers.c[{i}]", x, nonnegative=True) for i, x in enumerate(c)]
        else:
            out["c"] = real("dampers.c", c, nonnegative=True)
    return out
