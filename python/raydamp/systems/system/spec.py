"""The validated description of a user's system: the one schema behind
``raydamp.System(...)``, ``System.to_dict()``/``from_dict`` and the service's
``"system"`` JSON. Every check raises SpecError naming the field's path.
"""

from __future__ import annotations

import math
import numbers
import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..expressions import FUNCTIONS, Expression, parse
from .errors import SpecError

__all__ = ["SystemSpec", "normalise", "MAX_COORDINATES", "MAX_PARAMETERS", "MAX_DAMPERS", "MAX_MOMENTA",
           "MAX_DENSE_DAMPING", "MAX_CONSTRAINTS", "KEYS", "DAMPING_FORMS"]

MAX_COORDINATES = 256   # expression systems; large structures are the sparse kinds' business
MAX_PARAMETERS = 256
MAX_DAMPERS = 32        # kMaxDampers in cpp/include/raydamp/system/small_dense.hpp
MAX_DENSE_DAMPING = 32  # kMaxDenseDim: n for a constant-matrix D or dashpots
MAX_MOMENTA = 16
MAX_CONSTRAINTS = 128   # the constraint solve factors a dense k x k matrix (constraints/rattle.hpp)
_SAVED_COLUMNS = frozenset({"t", "energy", "work", "load_work"})
KEYS = ("coordinates", "potential", "parameters", "mass", "damping", "eps", "momenta", "name", "constraints",
        "constraint_tol", "project_initial")
DAMPING_FORMS = ("scalar", "diagonal", "matrix", "dampers")

_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
_RESERVED = frozenset(FUNCTIONS) | {"pi"}

OUTSIDE_CLASS = ("a mass matrix that depends on q (a double pendulum in joint angles, say) is outside the class "
                 "these methods need (the paper's section 2: the drift exp(t X_T) must be explicit, so M is "
                 "constant). Write such a system in Cartesian coordinates, with its rigid links as constraints "
                 "(constraints=['(x2 - x1)^2 + (y2 - y1)^2 - l^2', ...]).")


@dataclass(frozen=True)
class Damper:
    on: Expression
    c: float


@dataclass(frozen=True)
class SystemSpec:
    """A system after validation: names checked, expressions parsed, matrices checked."""

    coordinates: tuple[str, ...]
    coordinates_given_as_count: bool
    potential: Expression
    parameters: dict[str, float]
    mass: np.ndarray            # (n, n), symmetric positive definite
    mass_form: str              # "scalar", "diagonal" or "matrix": how it was given (and is written back)
    damping_form: str | None    # None or one of DAMPING_FORMS
    damping_scalar: float
    damping_matrix: np.ndarray  # (n, n) for "diagonal"/"matrix", else (0, 0)
    dampers: tuple[Damper, ...]
    eps: float
    momenta: dict[str, Expression]
    name: str | None
    constraints: tuple[Expression, ...] = ()
    constraint_tol: float = 1e-12
    project_initial: bool = False

    @property
    def n(self) -> int:
        return len(self.coordinates)


def _real(path, value, *, nonnegative=False, positive=False) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise SpecError(path, f"must be a real number, got {_show(value)}")
    x = float(value)
    if not math.isfinite(x):
        raise SpecError(path, f"must be finite, got {x!r}")
    if positive and not x > 0:
        raise SpecError(path, f"must be > 0, got {x!r}")
    if nonnegative and not x >= 0:
        raise SpecError(path, f"must be >= 0, got {x!r}")
    return x


def _show(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _name(path, value, taken: Mapping[str, str]) -> str:
    if not isinstance(value, str) or not _NAME.match(value):
        raise SpecError(path, f"must be a name (a letter or _ followed by letters, digits or _), got {_show(value)}")
    if value.startswith("__"):
        raise SpecError(path, f"names may not start with '__', got {value!r}")
    if value in _RESERVED:
        raise SpecError(path, f"{value!r} is a built-in name (a function or constant); choose another")
    if value in taken:
        raise SpecError(path, f"{value!r} is already a {taken[value]}")
    return value


def _coordinates(value) -> tuple[tuple[str, ...], bool]:
    path = ("coordinates",)
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        n = int(value)
        if not 1 <= n <= MAX_COORDINATES:
            raise SpecError(path, f"must be between 1 and {MAX_COORDINATES}, got {n}")
        return tuple(f"q{i}" for i in range(n)), True
    if isinstance(value, (str, bytes)) or not isinstance(value, (list, tuple)):
        raise SpecError(path, f"must be a list of names or a number of coordinates, got {_show(value)}")
    if not 1 <= len(value) <= MAX_COORDINATES:
        raise SpecError(path, f"must name between 1 and {MAX_COORDINATES} coordinates, got {len(value)}")
    taken: dict[str, str] = {}
    for i, name in enumerate(value):
        _name(path + (i,), name, taken)
        if name.startswith("p_"):
            raise SpecError(path + (i,), f"{name!r}: names p_<coordinate> are the momenta; choose another")
        taken[name] = "coordinate"
    return tuple(value), False


def _matrix(path, value, n: int, what: str) -> tuple[np.ndarray, str]:
    """A scalar, a list of n (diagonal) or an n x n matrix, as an (n, n) array and its form."""
    if isinstance(value, str):
        raise SpecError(path, f"must be constant: a number, a list of {n} numbers or a {n} x {n} matrix; "
                              + (OUTSIDE_CLASS if what == "mass" else "an expression is not accepted here"))
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        return None, "scalar"  # the caller handles scalars
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise SpecError(path, f"must be a number, a list of {n} numbers or a {n} x {n} matrix of numbers"
                              + (f"; {OUTSIDE_CLASS}" if what == "mass" and _has_text(value) else "")) from None
    if array.shape == (n,):
        form, full = "diagonal", np.diag(array)
    elif array.shape == (n, n):
        form, full = "matrix", array
    else:
        raise SpecError(path, f"must be a number, a list of {n} numbers or a {n} x {n} matrix; got shape "
                              f"{array.shape}")
    if not np.isfinite(full).all():
        raise SpecError(path, "must be finite")
    if not np.allclose(full, full.T, rtol=1e-12, atol=1e-14 * max(1.0, float(np.abs(full).max()))):
        raise SpecError(path, "must be symmetric")
    return 0.5 * (full + full.T), form


def _has_text(value) -> bool:
    if isinstance(value, str):
        return True
    if isinstance(value, (list, tuple)):
        return any(_has_text(v) for v in value)
    return False


def _mass(value, n: int) -> tuple[np.ndarray, str]:
    path = ("mass",)
    full, form = _matrix(path, value, n, "mass")
    if form == "scalar":
        m = _real(path, value, positive=True)
        return m * np.eye(n), "scalar"
    try:
        np.linalg.cholesky(full)
    except np.linalg.LinAlgError:
        eig = np.linalg.eigvalsh(full)
        raise SpecError(path, f"must be positive definite (smallest eigenvalue {eig.min():.3g})") from None
    return full, form


def _expression(path, text, names) -> Expression:
    from .errors import path_text
    field = path_text(path)
    if not isinstance(text, str):
        raise SpecError(path, f"must be an expression (a string), got {_show(text)}")
    try:
        return parse(text, field=field, names=names)
    except ValueError as err:
        message = str(err)
        prefix = field + ": "
        raise SpecError(path, message[len(prefix):] if message.startswith(prefix) else message) from None


def _damping(value, n: int, mass: np.ndarray, names) -> tuple[str | None, float, np.ndarray, tuple[Damper, ...]]:
    path = ("damping",)
    none = (None, 0.0, np.zeros((0, 0)), ())
    if value is None:
        return none
    if not isinstance(value, Mapping):
        raise SpecError(path, f"must be null or an object with one of the keys {', '.join(DAMPING_FORMS)}; "
                              f"got {_show(value)}")
    keys = list(value)
    if len(keys) != 1 or keys[0] not in DAMPING_FORMS:
        raise SpecError(path, f"must have exactly one of the keys {', '.join(DAMPING_FORMS)} (D = c M, a constant "
                              f"diagonal or full D, or dashpots); got {', '.join(map(str, keys)) or 'none'}")
    form = keys[0]
    inner = path + (form,)
    body = value[form]
    if form == "scalar":
        return form, _real(inner, body, nonnegative=True), np.zeros((0, 0)), ()
    if form in ("diagonal", "matrix"):
        if form == "diagonal" and not (isinstance(body, (list, tuple, np.ndarray)) and np.ndim(body) == 1):
            raise SpecError(inner, f"must be a list of {n} numbers")
        if form == "matrix" and not (isinstance(body, (list, tuple, np.ndarray)) and np.ndim(body) == 2):
            raise SpecError(inner, f"must be a {n} x {n} matrix (a list of {n} rows)")
        full, _ = _matrix(inner, body, n, "damping")
        if n > MAX_DENSE_DAMPING:
            raise SpecError(inner, f"a constant D is supported up to n = {MAX_DENSE_DAMPING} coordinates here "
                                   f"(this system has {n})")
        eig = np.linalg.eigvalsh(full)
        if eig.min() < -1e-12 * max(1.0, float(np.abs(eig).max())):
            raise SpecError(inner, f"must be positive semi-definite: D has the eigenvalue {eig.min():.3g} < 0, "
                                   "which would feed energy in instead of dissipating it")
        return form, 0.0, full, ()
    # dampers
    if not isinstance(body, (list, tuple)) or not body:
        raise SpecError(inner, 'must be a non-empty list of dashpots {"on": "<expression g(q)>", "c": c}')
    if len(body) > MAX_DAMPERS:
        raise SpecError(inner, f"at most {MAX_DAMPERS} dashpots, got {len(body)}")
    if n > MAX_DENSE_DAMPING:
        raise SpecError(inner, f"dashpots are supported up to n = {MAX_DENSE_DAMPING} coordinates here "
                               f"(this system has {n})")
    dampers = []
    for i, item in enumerate(body):
        here = inner + (i,)
        if not isinstance(item, Mapping):
            raise SpecError(here, f'must be an object {{"on": "<expression>", "c": c}}, got {_show(item)}')
        extra = set(item) - {"on", "c"}
        if extra:
            raise SpecError(here + (sorted(map(str, extra))[0],), "unknown key (a dashpot has 'on' and 'c')")
        if "on" not in item:
            raise SpecError(here + ("on",), "missing: the function g(q) whose rate of change the dashpot resists")
        on = _expression(here + ("on",), item["on"], names)
        c = _real(here + ("c",), item.get("c", 1.0), nonnegative=True)
        dampers.append(Damper(on, c))
    return form, 0.0, np.zeros((0, 0)), tuple(dampers)


def damping_strength(eps, damping_form: str | None) -> float:
    """eps, >= 0, and 0 for a system without damping: eps > 0 there ran undamped, silently (an ensemble's eps
    on such a system was already refused)."""
    eps = _real(("eps",), eps, nonnegative=True)
    if eps and damping_form is None:
        raise SpecError(("eps",), f"{eps!r} given, but this system has no damping for it to scale (damping is "
                                  'None); give damping, e.g. {"scalar": 1.0} for D = M, or leave eps at 0')
    return eps


def _constraints(value, n: int, names, damping_form) -> tuple[Expression, ...]:
    path = ("constraints",)
    if value is None:
        return ()
    if isinstance(value, (str, bytes)) or not isinstance(value, (list, tuple)):
        raise SpecError(path, f'must be a list of expressions g(q) (each held at 0), e.g. ["x^2 + y^2 - l^2"]; '
                              f"got {_show(value)}")
    if not value:
        return ()
    if len(value) > MAX_CONSTRAINTS:
        raise SpecError(path, f"at most {MAX_CONSTRAINTS} constraints, got {len(value)}")
    if len(value) >= n:
        raise SpecError(path, f"{len(value)} constraints on {n} coordinates leave no motion; give fewer than {n}")
    out = []
    for i, text in enumerate(value):
        expr = _expression(path + (i,), text, names)
        if not expr.names & {key for key, kind in names.items() if kind == "coordinate"}:
            raise SpecError(path + (i,), f"{text!r} uses no coordinate: a constraint g(q) = 0 must depend on q")
        out.append(expr)
    return tuple(out)


def normalise(*, coordinates, potential, parameters=None, mass=1.0, damping=None, eps=0.0, momenta=None,
              name=None, constraints=None, constraint_tol=1e-12, project_initial=False) -> SystemSpec:
    """Validate a system description; raises SpecError naming the field."""
    coords, as_count = _coordinates(coordinates)
    n = len(coords)
    taken = {c: "coordinate" for c in coords}
    params: dict[str, float] = {}
    if parameters is None:
        parameters = {}
    if not isinstance(parameters, Mapping):
        raise SpecError(("parameters",), f"must be an object of name: number, got {_show(parameters)}")
    if len(parameters) > MAX_PARAMETERS:
        raise SpecError(("parameters",), f"at most {MAX_PARAMETERS} parameters, got {len(parameters)}")
    for key, value in parameters.items():
        _name(("parameters", str(key)), key, taken)
        params[key] = _real(("parameters", key), value)
        taken[key] = "parameter"
    names = dict(taken)
    expr = _expression(("potential",), potential, names)
    m, mass_form = _mass(mass, n)
    d_form, d_scalar, d_matrix, dampers = _damping(damping, n, m, names)
    eps = damping_strength(eps, d_form)
    moms: dict[str, Expression] = {}
    if momenta is None:
        momenta = {}
    if not isinstance(momenta, Mapping):
        raise SpecError(("momenta",), f"must be an object of name: expression, got {_show(momenta)}")
    if len(momenta) > MAX_MOMENTA:
        raise SpecError(("momenta",), f"at most {MAX_MOMENTA} momentum maps, got {len(momenta)}")
    with_momenta = dict(names, **{f"p_{c}": "momentum" for c in coords})
    for key, text in momenta.items():
        if not isinstance(key, str) or not _NAME.match(key):
            raise SpecError(("momenta",), f"momentum names must be names, got {_show(key)}")
        if key in _SAVED_COLUMNS or key in {f"{side}_{c}" for side in "qp" for c in coords}:
            # A saved run's columns (a CSV's header, a Dataset's variables) beside the momentum maps.
            raise SpecError(("momenta", key), f"{key!r} names a column of every saved run (t, q_<coordinate>, "
                                              "p_<coordinate>, energy, work, load_work); choose another")
        moms[key] = _expression(("momenta", key), text, with_momenta)
    if name is not None and (not isinstance(name, str) or len(name) > 200):
        raise SpecError(("name",), "must be a string of at most 200 characters")
    cons = _constraints(constraints, n, names, d_form)
    tol = _real(("constraint_tol",), constraint_tol, positive=True)
    if not tol < 1e-2:
        raise SpecError(("constraint_tol",), f"must be < 0.01 (relative to each constraint's scale), got {tol!r}")
    if not isinstance(project_initial, bool):
        raise SpecError(("project_initial",), f"must be true or false, got {_show(project_initial)}")
    used = expr.names.union(*(d.on.names for d in dampers), *(e.names for e in moms.values()),
                            *(c.names for c in cons))
    unused = [key for key in params if key not in used]
    if unused:  # accepted silently (a sweep over it changed nothing), where Load.expression refuses one
        raise SpecError(("parameters", unused[0]), "is used by none of the potential, the dampers, the momenta and "
                                                   "the constraints")
    return SystemSpec(coords, as_count, expr, params, m, mass_form, d_form, d_scalar, d_matrix, dampers, eps, moms,
                      name, cons, tol, project_initial)
