"""raydamp.Structure: a structure whose storeys or members yield, as hysteretic springs on a linear structure.

    M q'' + C q' + K q + sum_s r_s sigma_s(d_s) = f,   d_s = r_s^T q,

each spring s acting on a deformation d = q_j - q_i (``dofs=(i, j)``) or d = q_j relative to the ground
(``dofs=(j,)``) with a material of :mod:`raydamp.materials` (ElasticPlastic, Bilinear, BoucWen).

How it relates to :class:`raydamp.LinearStructure`: a Structure without springs *is* a LinearStructure
(the same compiled kind, so it steps bit for bit as one, with every method, ensembles included); ``K`` may
then be given as for a LinearStructure. With springs, it is the linear structure of the initial stiffness
K0 = K + sum_s k_s r_s r_s^T plus, in each kick, each spring's departure from its initial stiffness.
``LinearStructure`` stays the name (and the JSON kind ``"linear_structure"``) of the springless case;
``Structure`` writes the JSON kind ``"structure"`` with its ``"springs"``.

Damping. Rayleigh's C = alpha M + beta K0 uses the initial stiffness by default (``damping_stiffness=
"initial"``): the damping sub-flows stay the exact flows of a constant matrix, so the splittings keep them
exact. What it costs in energy: once a spring yields, its damping force beta k_s d_s' keeps the initial
stiffness's size while the spring's own stiffness has dropped to b k_s (or 0), so the viscous work is larger
than a tangent-stiffness damping's (the spurious damping of Charney 2008 and Hall 2006).

``damping_stiffness="tangent"`` damps with C_t = alpha M + beta K_t, K_t = K + sum_s k_t,s r_s r_s^T with each
spring's tangent on its branch (k_s elastic, b k_s yielding), so a yielded storey's damping force drops with
its stiffness. A branch (which springs yield) is constant between two kinks, and on it C_t is a constant
matrix: every damping sub-flow is the exact flow of the branch's C_t, made from the branch's modes (one
eigendecomposition per branch met, cached; cpp/include/raydamp/models/structure_damping.hpp). Which branch a
step uses: with ``locate_kinks=True`` each spring's phase, which holds over each piece between two kinks, so
the run is an exact flow of one linear system per piece and each method keeps its order; without, the branch
of the last step (a spring that yielded at that step's last kick), frozen over the next step, so a branch
change is seen up to one step late and every method is of order 1. Measured on Chopra's SDOF with 5% split
between alpha M and beta K (tests/test_tangent_damping.py, against solve_ivp at rtol 1e-12 with events at the
yield points): with kinks located 3s 2.00, 3s + yoshida4 and + suzuki4 4.00 (suzuki4 2.8e-10 u_max at h =
0.0025); without, 0.93 and 0.98. The energy: W is the viscous work of C_t (``Solution.work``); the damping
power jumps where a spring changes branch (by beta (k_s - k_t,s) d_s'^2), and the step loop's trapezoid
restarts from the new branch's power after each located kink, so W and the budget H - H(0) + W + sum_s W_h,s -
W_f close to O(h^2) as with the initial stiffness (measured slope 2.00 for both, tests/test_tangent_damping.py).
The initial stiffness's spurious damping there: W 3.72 against the tangent's 3.21, and a peak
4.5% lower. Offered where the damping flows are the modes' (n <= 32
coordinates), for ElasticPlastic and Bilinear springs with b >= 0 on a K whose every-spring-yielded tangent is
positive semidefinite: a Bouc-Wen spring's tangent changes at every step, and a negative tangent (softening,
P-Delta) would make the damping feed energy in. No temperature (its noise flow would change with the branch).

Methods. The splittings (3s, 2s, rks, baoab, and sv undamped; their compositions) apply the springs in the
kick, at the kick's q; each material answers from the state committed at the step's start and commits once
per full step, so a composition's backward sub-steps never create plastic flow. The implicit methods
(midpoint, gauss4) step a linear system and refuse a Structure with springs. ``method="newmark"``
(:func:`raydamp.methods.catalogue.structure_methods`; this kind only) is Newmark's average acceleration as
OpenSees runs it: the trapezoidal rule on q' = v and on the forces, springs included, with Newton's iteration on
the springs' consistent tangent at every step (one sparse solve with M + (h/2) C + (h^2/4) K0, factorised once
per run, and a dense solve over the springs off their initial stiffness, per iteration; a step that raises the
residual is halved). It is of order 2 (1.99 measured); on Chopra's SDOF at the textbook h = 0.1 its peak is
6.2% low, and every step equals OpenSees' Newmark (ElasticPP, Newton) to 1e-15 at h = 0.01
(tests/test_newmark_springs.py); 3s errs 0.43 to 0.49 times as much at h = 0.01 to 0.000625. A step that does
not converge in 50 iterations ends the run with status "not_converged", its message naming the step, keeping
the rows before it. It takes the initial stiffness's damping, whole steps (no composition, no located kinks)
and no temperature.

Kinks. A kink of sigma (yield, unloading; for Bouc-Wen its reversals and z = 0) or of the load (a harmonic
term's ``t_end``, a series' samples) inside a step makes a derivative of q jump there, and limits every
fixed-step method to order 2, whatever its order on smooth problems. ``locate_kinks=True`` splits the steps
there (cpp/include/raydamp/materials/kinks.hpp): between two kinks each spring follows one smooth law, its
phase (elastic, or yielding in one direction), which every kick of the step reads, extended past its range, so
a composition's stages, backward and overshooting ones included, all see one smooth force; after each step the
deformations' cubic Hermite interpolants (fourth order) give the first time a phase ends, and the step is run
again to that time, the spring changes phase, and the rest of the step is a new piece. A load's kinks end
pieces too, unless they lie on a step end (to 1e-9 h), as a record's samples do when h divides its dt. Each
method then keeps its order. It is an option of the Structure, not of ``integrate``, because it is a property
of how this system's forces are stepped: every run of it (``integrate``, ``integrate_ensemble``, sweeps, a
job's ``"locate_kinks": true``) honours it without an argument of its own. Its cost: a step without a kink
reads each spring's d and d' at the step's end and scans a cubic (a mass solve and a few dozen flops per
spring); a kink costs the rest of its step again; steps run whole (no first-same-as-last merging); a
temperature is refused (a piece run again would draw its noise twice). Off (the default), the springs' return
maps are read at each kick, as above.

Measured on Chopra's elastic-perfectly-plastic SDOF (tests/test_structure_springs.py without,
tests/test_structure_kinks.py with kink location): the fitted order over h = 0.04 .. 0.005 (0.01/2 .. 0.01/16
for the order-2 methods without), and the worst error over every step at h = 0.01/9, 0.01/10, 0.01/11 over 40 s:

==================  ================  ===============  ====================
method              order without     order with       worst error with
==================  ================  ===============  ====================
3s                  1.93              1.99             8.6e-6 u_max
2s                  1.93              1.99             8.4e-6 u_max
rks                 1.93              1.99             8.3e-6 u_max
baoab               2.02              2.01             6.0e-6 u_max
3s + yoshida4       2.10              4.00             6.2e-10 u_max
3s + suzuki4                          3.99             4.1e-11 u_max
==================  ================  ===============  ====================

Without kink location the worst error is 6.0e-6 (baoab) to 9.5e-6 u_max (3s): the order-2 splittings' error is
their own, not the kinks'; what kink location buys is a composition's higher order. Bilinear and Bouc-Wen show
order 4 with yoshida4 too (about 2 without). Newmark's average acceleration (with Newton) errs about twice as
much as 3s at the same h (its peak 6.2% low at h = 0.1).

Energy. With ``work=True`` a run records, besides the damping work W (the viscous work of C, initial stiffness
included: the spurious part a yielded spring's beta k_s d_s' adds is in it) and the load's work W_f, each spring's
hysteretic work W_h,s = int sigma_s dd_s - stored_s (``Solution.hysteretic_work``, record/spring_work.hpp), so that
H - H(0) + W + sum_s W_h,s - W_f closes to O(h^2) for the splittings (``Solution.energy_balance``; H = T + the
stored energy, ``kinetic_energy`` and ``stored_energy``). Measured in tests/test_spring_work.py.

P-Delta. K may carry a constant geometric stiffness (negative: K = -sum_s (P_s / h_s) r_s r_s^T for gravity loads
P_s over storeys of height h_s). K0 = K + the springs' initial stiffness is what is checked positive semidefinite
(``allow_indefinite_stiffness=True`` lifts the check); after yield a storey's tangent b k_s - P_s / h_s may be
negative, and the frame can then collapse (raydamp.ida stops such runs).

Cost. A spring adds a return map per kick to the linear structure's step: on the 10-storey frame
(benchmarks/bench_springs.py, in CPU time: 124 ns a springless 3s step) 1.14-1.23x the springless step for
ElasticPlastic and Bilinear, 1.49-1.61x for BoucWen. Kink location costs a step run whole plus, per step, the
deformations' read and the cubics' scan, and per kink the rest of its step again: `--kinks` measured 4.0-4.8x
(ElasticPlastic, Bilinear) and 11-14x (BoucWen, whose reversals and z = 0 crossings are kinks) the springless
step before the scan's fast rejection and root finder; a C++ run of a like frame after them (10 storeys, a
harmonic ground motion, 3s, 8,000 steps, about 0.16 kinks a step) gives 800 ns a step for ElasticPlastic
(1,020 before), 690 for Bilinear and 1,280 for BoucWen (1,460 before), against 135-190 without.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import _core
from .._validation import _short, flag, real
from .kinds import MemberModels
from .materials import Material, material_from_dict
from .structure import (
    _DENSE_LIMIT,
    LinearStructure,
    _is_diagonal,
    _matrix_from_plain,
    _read_matrix,
    _require_semidefinite,
    _require_symmetric,
    _scipy_sparse,
    load_vector,
)

__all__ = ["Spring", "Structure"]

PLAIN_KEYS = ("kind", "M", "K", "springs", "alpha", "beta", "f", "damping_stiffness", "allow_indefinite_stiffness",
              "locate_kinks")
_CORE_ORDER = ("elastic_plastic", "bilinear", "bouc_wen")  # the core keeps springs by kind, in this order


@dataclass(frozen=True)
class Spring:
    """A hysteretic spring on ``dofs``: ``(i, j)`` acts on d = q_j - q_i, ``(j,)`` on d = q_j (to the
    ground), with a ``material`` of :mod:`raydamp.materials`."""

    dofs: tuple
    material: Material

    def __post_init__(self):
        object.__setattr__(self, "dofs", _dofs("dofs", self.dofs))
        if not isinstance(self.material, Material):
            raise ValueError(f"material: expected raydamp.materials.ElasticPlastic, Bilinear or BoucWen, got "
                             f"{_short(self.material)}")

    def to_dict(self) -> dict[str, Any]:
        return {"dofs": list(self.dofs), "material": self.material.to_dict()}


def _dofs(where: str, value) -> tuple[int, ...]:
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        value = (value,)
    if (not isinstance(value, (tuple, list)) or len(value) not in (1, 2)
            or not all(isinstance(x, (int, np.integer)) and not isinstance(x, bool) for x in value)):
        raise ValueError(f"{where}: must be (j,) (to the ground) or (i, j), coordinates as integers, got "
                         f"{_short(value)}")
    dofs = tuple(int(x) for x in value)
    if len(dofs) == 2 and dofs[0] == dofs[1]:
        raise ValueError(f"{where}: the two coordinates are the same ({dofs[0]})")
    return dofs


def _springs(value, n: int, mass_diagonal: np.ndarray) -> tuple[Spring, ...]:
    if isinstance(value, (str, bytes, dict)) or not isinstance(value, Sequence):
        raise ValueError(f"springs: must be a list of raydamp.Spring, got {_short(value)}")
    out = []
    for s, spring in enumerate(value):
        if not isinstance(spring, Spring):
            raise ValueError(f"springs[{s}]: expected a raydamp.Spring(dofs, material), got {_short(spring)}")
        for c in spring.dofs:
            if not 0 <= c < n:
                raise ValueError(f"springs[{s}].dofs: coordinate {c} outside 0..{n - 1}")
            if not mass_diagonal[c] > 0:
                raise ValueError(f"springs[{s}].dofs: coordinate {c} has no mass (M[{c}, {c}] = "
                                 f"{float(mass_diagonal[c])!r}); a spring must act on coordinates with mass")
        out.append(spring)
    return tuple(out)


class Structure(LinearStructure):
    """A structure with hysteretic springs, M q'' + (alpha M + beta K0) q' + K q + sum_s r_s sigma_s = f.

    Parameters
    ----------
    M : mass matrix, as for :class:`raydamp.LinearStructure` (n x n, symmetric positive definite).
    K : the linear stiffness besides the springs (a frame's elastic members, a P-Delta geometric stiffness);
        None for none (a shear frame whose storeys are all springs).
    springs : a list of :class:`raydamp.Spring` (dofs, material).
    alpha, beta : Rayleigh coefficients of C = alpha M + beta K0, K0 = K + sum_s k_s r_s r_s^T.
    f : constant load vector, or None.
    damping_stiffness : "initial" (K0, the default) or "tangent" (each spring's tangent on its branch; exact per
        branch, order 1 unless ``locate_kinks``; see the module docstring).
    allow_indefinite_stiffness : as for LinearStructure, checked on K0.
    locate_kinks : False (default): each kick reads the springs' return maps, and a kink inside a step limits
        every method to order 2. True: every run of this structure splits its steps at the springs' kinks
        (yield, unloading) and at its load's (a harmonic term's ``t_end``, a series' sample times), so each
        method keeps its order (see the module docstring, "Kinks").

    ``help(raydamp.systems.yielding)`` says how the springs are stepped and what the damping costs.
    """

    name = "structure"

    def __init__(self, M, K=None, *, springs=(), alpha: float = 0.0, beta: float = 0.0, f=None,
                 damping_stiffness: str = "initial", allow_indefinite_stiffness: bool = False,
                 locate_kinks: bool = False):
        alpha = real("alpha", alpha, nonnegative=True)
        beta = real("beta", beta, nonnegative=True)
        if damping_stiffness not in ("initial", "tangent"):
            raise ValueError(f"damping_stiffness: 'initial' (C = alpha M + beta K0) or 'tangent' (beta times each "
                             f"spring's tangent on its branch), got {_short(damping_stiffness)}")
        mass = _read_matrix("M", M)
        n = mass.shape[0]
        sparse = _scipy_sparse()
        stiffness = sparse.csc_matrix((n, n)) if K is None else _read_matrix("K", K)
        if stiffness.shape != mass.shape:
            raise ValueError(f"K must have the shape of M, {mass.shape}, got {stiffness.shape}")
        _require_symmetric("M", mass)
        springs = _springs(springs, n, np.asarray(mass.diagonal(), dtype=float))
        tangent = damping_stiffness == "tangent" and bool(springs)
        if tangent:
            _check_tangent(springs, n)
        load = np.zeros(n) if f is None else load_vector(f, n)
        lumped = _is_diagonal(mass)
        object.__setattr__(self, "alpha", alpha)
        object.__setattr__(self, "beta", beta)
        object.__setattr__(self, "_mass", mass)
        object.__setattr__(self, "_linear_stiffness", stiffness)
        object.__setattr__(self, "springs", springs)
        object.__setattr__(self, "damping_stiffness", damping_stiffness)
        initial = stiffness + _spring_stiffness(springs, n)
        initial.sum_duplicates()
        object.__setattr__(self, "_stiffness", initial.tocsc())  # K0: frequencies, modes, spectral bound
        object.__setattr__(self, "_load", load)
        diagonal = np.asarray(mass.diagonal(), dtype=float)
        try:
            if not springs:  # a LinearStructure: the same compiled kind
                core = (_core.LinearStructure_lumped(diagonal, stiffness, load, alpha, beta, dense_limit=_DENSE_LIMIT)
                        if lumped else
                        _core.LinearStructure_consistent(mass, stiffness, load, alpha, beta, dense_limit=_DENSE_LIMIT))
            else:
                columns = _core_columns(springs)
                kind = _core.Structure_lumped if lumped else _core.Structure_consistent
                core = kind(diagonal if lumped else mass, stiffness, *columns, load, alpha, beta,
                            dense_limit=_DENSE_LIMIT, tangent_damping=tangent)
        except ValueError as error:
            raise ValueError(str(error)) from None
        locate_kinks = flag("locate_kinks", locate_kinks)
        if locate_kinks and not springs:
            raise ValueError("locate_kinks: a Structure without springs has no kinks of its own (it is a "
                             "LinearStructure); give it springs, or leave locate_kinks False")
        if springs:
            core.locate_kinks = locate_kinks
        object.__setattr__(self, "locate_kinks", locate_kinks)
        object.__setattr__(self, "_core_model", core)
        allow_indefinite_stiffness = flag("allow_indefinite_stiffness", allow_indefinite_stiffness)
        object.__setattr__(self, "allow_indefinite_stiffness", allow_indefinite_stiffness)
        if not allow_indefinite_stiffness:
            _require_semidefinite(self._stiffness, mass, core.spectral_bound)
        self._freeze()

    # -- what it is ---------------------------------------------------------
    @property
    def K(self):
        """The linear stiffness besides the springs (scipy.sparse CSC); ``initial_stiffness`` is K0."""
        return self._linear_stiffness.copy()

    @property
    def initial_stiffness(self):
        """K0 = K + sum_s k_s r_s r_s^T (scipy.sparse CSC): what the damping and the frequencies use."""
        return self._stiffness.copy()

    def member_models(self, parameters, members: int) -> MemberModels:
        """Members differ by initial state only when there are springs; without, as a LinearStructure."""
        if self.springs and parameters:
            raise ValueError(f"parameters: a Structure with springs takes no per-member parameters (got "
                             f"{', '.join(sorted(parameters))}); build one Structure per member")
        return super().member_models(parameters, members)

    # -- the plain form -------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """The JSON form: ``{"kind": "structure", "M", "K", "springs": [{"dofs", "material"}], "alpha",
        "beta", "f"}``; ``Structure.from_dict`` inverts it."""
        from .structure import _coo_plain

        mass = ({"diagonal": self._mass.diagonal().tolist()} if self.mass_kind == "lumped"
                else {"coo": _coo_plain(self._mass)})
        return {"kind": "structure", "M": mass,
                "K": {"coo": _coo_plain(self._linear_stiffness)} if self._linear_stiffness.nnz else None,
                "springs": [s.to_dict() for s in self.springs], "alpha": self.alpha, "beta": self.beta,
                "f": self._load.tolist() if self._load.any() else None,
                **({"damping_stiffness": "tangent"} if self.damping_stiffness == "tangent" else {}),
                **({"allow_indefinite_stiffness": True} if self.allow_indefinite_stiffness else {}),
                **({"locate_kinks": True} if self.locate_kinks else {})}

    @classmethod
    def from_dict(cls, data, *, files=None) -> Structure:
        """Build from ``to_dict()``'s form; a bad field raises ValueError starting with its path
        (``springs[2].material.fy``)."""
        if not isinstance(data, dict):
            raise ValueError("a structure must be an object with the keys " + ", ".join(PLAIN_KEYS))
        unknown = [k for k in data if k not in PLAIN_KEYS]
        if unknown:
            raise ValueError(f"{unknown[0]}: unknown key (known: {', '.join(PLAIN_KEYS)})")
        if data.get("kind") != "structure":
            raise ValueError(f"kind: expected 'structure', got {data.get('kind')!r}")
        if "M" not in data:
            raise ValueError("M: missing")
        mass = _matrix_from_plain("M", data["M"], None, files)
        n = mass.shape[0]
        stiffness = None if data.get("K") is None else _matrix_from_plain("K", data["K"], n, files)
        springs_plain = data.get("springs", [])
        if not isinstance(springs_plain, list):
            raise ValueError("springs: must be a list of {\"dofs\": [...], \"material\": {...}}")
        springs = []
        for s, item in enumerate(springs_plain):
            if not isinstance(item, dict) or set(item) != {"dofs", "material"}:
                raise ValueError(f"springs[{s}]: must be an object with exactly the keys dofs, material")
            dofs = _dofs(f"springs[{s}].dofs", item["dofs"])
            springs.append(Spring(dofs, material_from_dict(item["material"], f"springs[{s}].material")))
        f = data.get("f")
        if f is not None and (not isinstance(f, list) or len(f) != n
                              or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in f)):
            raise ValueError(f"f: must be null or a list of {n} numbers")
        return cls(mass, stiffness, springs=springs, alpha=data.get("alpha", 0.0), beta=data.get("beta", 0.0), f=f,
                   damping_stiffness=data.get("damping_stiffness", "initial"),
                   allow_indefinite_stiffness=data.get("allow_indefinite_stiffness", False) is True,
                   locate_kinks=data.get("locate_kinks", False))

    def replace(self, **changes) -> Structure:
        known = {"M", "K", "springs", "alpha", "beta", "f", "damping_stiffness", "allow_indefinite_stiffness",
                 "locate_kinks"}
        unknown = set(changes) - known
        if unknown:
            raise ValueError(f"{sorted(unknown)[0]}: Structure has no such argument ({', '.join(sorted(known))})")
        args = {"M": self._mass, "K": self._linear_stiffness, "springs": self.springs, "alpha": self.alpha,
                "beta": self.beta, "f": self._load, "damping_stiffness": self.damping_stiffness,
                "allow_indefinite_stiffness": self.allow_indefinite_stiffness, "locate_kinks": self.locate_kinks,
                **changes}
        return Structure(args.pop("M"), args.pop("K"), **args)

    def __repr__(self) -> str:
        return (f"Structure(n={self.dim}, mass={self.mass_kind}, springs={len(self.springs)}, "
                f"alpha={self.alpha!r}, beta={self.beta!r})")


def _check_tangent(springs: Sequence[Spring], n: int) -> None:
    """Refuses, naming the spring, what a tangent-stiffness damping cannot follow by exact flows per branch."""
    if n > _DENSE_LIMIT:
        raise ValueError(f"damping_stiffness: 'tangent' is offered for structures of at most {_DENSE_LIMIT} "
                         f"coordinates (their damping flows are made from their modes, once per branch of the "
                         f"springs), got {n}; use 'initial'")
    for s, spring in enumerate(springs):
        if spring.material.kind == "bouc_wen":
            raise ValueError(f"springs[{s}].material: damping_stiffness 'tangent' needs springs whose tangent is "
                             "constant between kinks (ElasticPlastic, Bilinear); a Bouc-Wen spring's changes at "
                             "every step")
        if spring.material.kind == "bilinear" and spring.material.b < 0:
            raise ValueError(f"springs[{s}].material.b: damping_stiffness 'tangent' needs b >= 0 (a softening "
                             "spring's negative tangent would make its damping feed energy in), got "
                             f"{spring.material.b!r}")


def _spring_stiffness(springs: Sequence[Spring], n: int):
    """sum_s k_s r_s r_s^T as a scipy.sparse matrix."""
    sparse = _scipy_sparse()
    rows, cols, values = [], [], []
    for spring in springs:
        k = spring.material.k
        if len(spring.dofs) == 1:
            rows.append(spring.dofs[0]), cols.append(spring.dofs[0]), values.append(k)
        else:
            i, j = spring.dofs
            rows += [i, j, i, j]
            cols += [i, j, j, i]
            values += [k, k, -k, -k]
    return sparse.csc_matrix((values, (rows, cols)), shape=(n, n))


def _core_columns(springs: Sequence[Spring]) -> tuple[list, list, list, list]:
    """(kinds, i, j, parameters) as the core takes them (i = -1: to the ground)."""
    kinds, first, second, parameters = [], [], [], []
    for spring in springs:
        kinds.append(spring.material.kind)
        first.append(spring.dofs[0] if len(spring.dofs) == 2 else -1)
        second.append(spring.dofs[-1])
        parameters.append(spring.material.core_parameters())
    return kinds, first, second, parameters


def core_order(springs: Sequence[Spring]) -> np.ndarray:
    """The index of each spring in the core's order (springs grouped by kind, stable within a kind)."""
    order = sorted(range(len(springs)), key=lambda s: _CORE_ORDER.index(springs[s].material.kind))
    return np.asarray(order, dtype=np.int64)
