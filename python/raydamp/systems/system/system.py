"""raydamp.System: a mechanical system of the paper's class, defined by expressions,
run by every method at compiled speed."""

from __future__ import annotations

import copy
import dataclasses
import json
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ... import _core
from ..._validation import real
from ..kinds import MemberModels
from ..models import Model
from .compile import compile_key, compile_system, evaluate
from .errors import SpecError
from .spec import KEYS, SystemSpec, normalise

__all__ = ["System"]


class System(Model):
    """A mechanical system H = 1/2 p^T M^{-1} p + V(q) with damping -eps D(q) M^{-1} p.

    The class of the paper's section 2 with a constant mass matrix: any potential
    V(q), a constant symmetric positive definite M, and a symmetric positive
    semi-definite dissipation tensor D(q). (A mass matrix that depends on q, such as
    a double pendulum's in joint angles, is outside the class: write such a system in
    Cartesian coordinates with its rigid links as ``constraints``.)

    Parameters
    ----------
    coordinates : list of names, or an int n (names q0 .. q{n-1}).
    potential : V(q) as an expression in the coordinates and parameters: numbers,
        names, ``+ - * / ^`` (or ``**``), parentheses, ``pi`` and the functions sin
        cos tan asin acos atan atan2 sinh cosh tanh asinh acosh atanh exp log sqrt
        cbrt. Parsed by raydamp's own parser (never evaluated as Python),
        differentiated symbolically and compiled to machine code.
    parameters : {name: number} used in the expressions.
    mass : a number m (M = m I), a list of n numbers (diagonal M) or an n x n
        symmetric positive definite matrix.
    damping : None (undamped; then "sv" may be used), or exactly one of
        ``{"scalar": c}`` (D = c M: every momentum decays at rate eps c),
        ``{"diagonal": [...]}`` or ``{"matrix": [[...]]}`` (a constant symmetric
        PSD D, e.g. Rayleigh damping alpha M + beta K), or
        ``{"dampers": [{"on": "<g(q)>", "c": c}, ...]}`` (dashpots resisting the
        rate of change of each g_i: D(q) = sum_i c_i grad g_i grad g_i^T). Each form
        has its exact damping flows: one dashpot a closed-form rank-one flow,
        several the exact flow of their sum (they need not commute). The constant
        and dashpot forms are dense n x n computations meant for n <= 32. A single
        dashpot on a distance (``sqrt(x^2+y^2)``, the length of a spring between two
        particles, a coordinate difference) with the same mass on every coordinate
        of a particle has a constant rate a = grad g^T M^{-1} grad g; raydamp proves that symbolically
        when the System is built and then takes the flow's phi functions once per
        sub-step length instead of at every step, as the built-in models do.
    eps : damping strength, >= 0.
    momenta : {name: expression} quantities to track at every step (momentum maps
        of symmetries); momenta are named ``p_<coordinate>``.
    name : an optional label.
    constraints : a list of expressions g_i(q), each held at g_i(q) = 0 (rods, rigid links, a particle on a
        surface): ``["x^2 + y^2 - l^2"]`` makes (x, y) a pendulum of length l. Parsed by the same parser,
        their Jacobian G(q) derived symbolically, compiled. Every method without a Runge-Kutta stage that
        moves q runs with them (sv, 3s, 2s, baoab, rks and their compositions): each drift is SHAKE (the
        position constraint solved by Newton for the multipliers, p corrected by the same impulse) then
        RATTLE's projection of p onto the tangent space G M^{-1} p = 0, and every kick, damping and noise flow
        is followed by that projection. For D = c M (damping ``{"scalar": c}``, or any D with D M^{-1} a
        multiple of I) the damping and noise flows are then exact on the tangent space, and the noise's
        stationary law is the constrained Boltzmann one; for another constant D the damping sub-flow is the
        exact flow of the frozen-q operator eps D M^{-1} followed by the projection (consistent, the method's
        order, not the exact projected flow). Dashpots take the exact flow of the projected operator
        P eps D(q) M^{-1} (P the M-orthogonal projector onto the tangent space), their noise in the same
        space; rks's Runge-Kutta step stays the free one, then the projection, which makes rks first order
        with dashpots (slope 1.1 on a double pendulum): use 3s, 2s or baoab there. The solve's matrices G M^-1 G^T
        are band matrices in an order found once (a chain's rods: tridiagonal), so a step costs O(k) for a
        chain of k links. ``Solution.multipliers`` holds the multipliers at each saved row. An ensemble runs
        each member as its single run (member i equals raydamp.integrate of its state bit for bit); a member
        whose constraint solve failed reports "non_finite" there.
    constraint_tol : the constraint solve's tolerance, relative to each constraint's scale (the sum of the
        absolute values of its top-level terms: |r - l| <= tol l for a rod written ``x^2 + y^2 - l^2``);
        default 1e-12.
    project_initial : False (default): a q0 off the constraints or a p0 off their tangent space is refused,
        naming the constraint and its residual. True: they are projected onto them before the run.

    A System is immutable: to change it, build another (``system.replace(eps=...)``).
    ``to_dict()``/``from_dict()`` give the plain form, which is also the JSON the
    job service takes as ``"system"``.
    """

    name = "system"

    def __init__(self, coordinates, potential: str, *, parameters: Mapping[str, float] | None = None,
                 mass=1.0, damping: Mapping[str, Any] | None = None, eps: float = 0.0,
                 momenta: Mapping[str, str] | None = None, name: str | None = None, constraints=None,
                 constraint_tol: float = 1e-12, project_initial: bool = False):
        spec = normalise(coordinates=coordinates, potential=potential, parameters=parameters, mass=mass,
                         damping=damping, eps=eps, momenta=momenta, name=name, constraints=constraints,
                         constraint_tol=constraint_tol, project_initial=project_initial)
        object.__setattr__(self, "_spec", spec)
        object.__setattr__(self, "momentum_names", tuple(spec.momenta))
        object.__setattr__(self, "label", spec.name)
        compiled = compile_system(spec)
        object.__setattr__(self, "_compiled", compiled)
        object.__setattr__(self, "_python", None)
        object.__setattr__(self, "_core_model", _build_core(spec, compiled.addresses, [d.c for d in spec.dampers],
                                                            len(spec.momenta), compiled, compiled.damper_norm))
        self._freeze()

    @classmethod
    def from_functions(cls, n: int, *, potential, gradient, mass=1.0, damping=None, eps: float = 0.0,
                       momenta=None, hessian_product=None, coordinates=None, name: str | None = None) -> System:
        """A System from NumPy callables instead of expressions: the slower path.

        ``potential(q) -> float`` and ``gradient(q) -> (n,)`` take the whole vector q;
        ``momenta`` is {name: f(q, p) -> float}; ``damping`` takes the same forms as
        System, with dashpots given by their gradient: ``{"dampers": [{"gradient":
        g(q) -> (n,), "c": c}]}``. ``hessian_product(q, v)`` is optional (only the
        modified-energy diagnostic uses it; by default a central difference of the
        gradient).

        Each call from the step loop runs Python under the GIL (microseconds per call
        instead of nanoseconds), so prefer expressions where you can. A callable that
        raises stops the run at that step with status "non_finite", keeping every
        finite point, and the message names the function and the exception. Such a
        System has no plain form (``to_dict`` raises).
        """
        from .functions import build_from_functions

        spec, addresses, python, coefficients, momentum_names, direct = build_from_functions(
            n, potential=potential, gradient=gradient, mass=mass, damping=damping, eps=eps, momenta=momenta,
            hessian_product=hessian_product, coordinates=coordinates, name=name)
        self = object.__new__(cls)
        object.__setattr__(self, "_spec", spec)
        object.__setattr__(self, "momentum_names", momentum_names)
        object.__setattr__(self, "label", name)
        object.__setattr__(self, "_compiled", None)
        object.__setattr__(self, "_python", (python, direct))
        object.__setattr__(self, "_core_model", _build_core(spec, addresses, coefficients, len(momentum_names),
                                                            python))
        self._freeze()
        return self

    # -- the plain form ------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """The system as plain JSON-ready data; ``System.from_dict`` inverts it."""
        if self._python is not None:
            raise ValueError("to_dict: a System built from Python functions has no plain form; "
                             "write its potential as an expression to send it to the service or save it")
        s = self._spec
        out: dict[str, Any] = {
            "coordinates": len(s.coordinates) if s.coordinates_given_as_count else list(s.coordinates),
            "potential": s.potential.text,
            "parameters": dict(s.parameters),
            "mass": _mass_plain(s),
            "damping": _damping_plain(s),
            "eps": s.eps,
            "momenta": {k: e.text for k, e in s.momenta.items()},
        }
        if s.name is not None:
            out["name"] = s.name
        if s.constraints:
            from .constraints import describe
            out.update(describe(s))
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> System:
        """Build a System from ``to_dict()``'s form (or the service's JSON)."""
        if not isinstance(data, Mapping):
            raise SpecError((), f"a system must be an object with the keys {', '.join(KEYS)}")
        unknown = [k for k in data if k not in KEYS]
        if unknown:
            raise SpecError((str(unknown[0]),), f"unknown key (known: {', '.join(KEYS)})")
        for required in ("coordinates", "potential"):
            if required not in data:
                raise SpecError((required,), "missing")
        kwargs = {k: v for k, v in data.items() if k not in ("coordinates", "potential")}
        return cls(data["coordinates"], data["potential"], **kwargs)

    def replace(self, **changes) -> System:
        """A new System with some fields changed (System is immutable)."""
        return System.from_dict({**self.to_dict(), **changes})

    def _with_eps(self, eps: float) -> System:
        """This system with another eps, sharing its compiled functions (no recompilation):
        what an ensemble over eps builds once per distinct value."""
        if eps == self._spec.eps:
            return self
        if self._spec.damping_form is None:
            raise ValueError("parameters.eps: this system has no damping, so eps has nothing to act on")
        if self._python is not None:
            raise ValueError("system: a System built from Python functions cannot be rebuilt per member; "
                             "write its potential as an expression")
        spec = dataclasses.replace(self._spec, eps=real("parameters.eps", eps, nonnegative=True))
        other = object.__new__(System)
        for key in ("momentum_names", "label", "_compiled", "_python"):
            object.__setattr__(other, key, getattr(self, key))
        object.__setattr__(other, "_spec", spec)
        object.__setattr__(other, "_core_model", _build_core(spec, self._compiled.addresses,
                                                             [d.c for d in spec.dampers], len(self.momentum_names),
                                                             self._compiled, self._compiled.damper_norm))
        other._freeze()
        return other

    def compiled_form(self) -> tuple[str, bytes]:
        """(key, bytes): this system's compiled functions as bytes, for another process of ours on this
        machine to load (``raydamp.systems.system.load_compiled(key, bytes)``) so that a System built there
        from the same expressions needs no compile: the service's check processes compile, the server loads.
        The bytes carry machine code: load them only from a process you started."""
        if self._compiled is None:
            raise ValueError("compiled_form: a System built from Python functions has no compiled functions")
        return compile_key(self._spec), self._compiled.to_bytes()

    # -- the kind protocol (kinds.SystemKind) ---------------------------------
    def describe(self) -> dict[str, Any]:
        try:
            return {"system": self.to_dict()}
        except ValueError:  # built from Python functions: no plain form
            return {"system": None, "label": repr(self)}

    def member_parameters(self) -> dict[str, int]:
        # eps (when there is damping for it to scale) and the expressions' parameters.
        return {**({"eps": 1} if self._spec.damping_form is not None else {}), **{k: 1 for k in self._spec.parameters}}

    def member_models(self, parameters: Mapping[str, np.ndarray], members: int) -> MemberModels:
        # One model per distinct parameter set, built here before the run (eps alone reuses the
        # compiled functions; the expressions' parameters recompile them).
        if self._python is not None:
            raise ValueError("system: a System built from Python functions runs Python in its step loop and "
                             "cannot run as an ensemble; write its potential as an expression")
        if not parameters:
            return MemberModels.shared(self, members)
        names = list(parameters)
        table = np.column_stack([parameters[name] for name in names])
        distinct, index = np.unique(table, axis=0, return_inverse=True)
        models = []
        expression_names = [name for name in names if name != "eps"]
        for row in distinct:
            values = dict(zip(names, row.tolist()))
            model = self
            if expression_names:
                model = self.replace(parameters={**self.parameters, **{k: values[k] for k in expression_names}})
            if "eps" in values:
                model = model._with_eps(values["eps"])
            models.append(model)
        return MemberModels(models, np.ascontiguousarray(index.reshape(-1), dtype=np.int64), [],
                            np.zeros((members, 0)))

    # -- Model ---------------------------------------------------------------
    @property
    def coordinates(self) -> tuple[str, ...]:
        return self._spec.coordinates

    @property
    def parameters(self) -> dict[str, float]:
        """The parameters' values, by name."""
        return dict(self._spec.parameters)

    @property
    def eps(self) -> float:
        return self._spec.eps

    @property
    def mass_matrix(self) -> np.ndarray:
        return self._spec.mass.copy()

    def check_configuration(self, name: str, q: np.ndarray) -> np.ndarray:
        # The compiled functions at q0: a non-finite value (a division by zero, a
        # log of a negative) would otherwise turn the run's first step into NaN.
        if self._python is not None:
            return self._check_functions(name, q)
        c = self._compiled
        if self._spec.constraints:  # on g = 0 (or moved there) before V is checked there
            q = self._constraint_checks().check_configuration(name, q)
        for label, fn, path in (("V", c.potential, "potential"), ("grad V", c.gradient, "potential")):
            if not np.isfinite(evaluate(fn, q)).all():
                raise SpecError((path,), f"{label} is not finite at {name} = {q.tolist()} (a division by zero or a "
                                         "function outside its domain there)")
        if c.damper_gradients is not None:
            rows = evaluate(c.damper_gradients, q).reshape(len(self._spec.dampers), -1)
            for i, row in enumerate(rows):
                if not np.isfinite(row).all():
                    raise SpecError(("damping", "dampers", i, "on"),
                                    f"the gradient of {self._spec.dampers[i].on.text!r} is not finite at {name} = "
                                    f"{q.tolist()} (a division by zero or a function outside its domain there)")
        return q

    def check_momenta(self, name: str, q: np.ndarray, p: np.ndarray) -> np.ndarray:
        """p on the constraints' tangent space at q (or projected there with project_initial); returns p."""
        if not self._spec.constraints:
            return p
        return self._constraint_checks().check_momenta(name, q, p)

    def _constraint_checks(self):
        from .constraints import ConstraintChecks
        return ConstraintChecks(self._spec, self._compiled, np.linalg.inv(self._spec.mass))

    @property
    def constraints(self) -> tuple[str, ...]:
        """The constraints g_i(q) = 0, as written."""
        return tuple(c.text for c in self._spec.constraints)

    def constraint_values(self, q) -> np.ndarray:
        """g(q), the constraints' values at q."""
        if not self._spec.constraints:
            return np.zeros(0)
        return self._constraint_checks().values(np.asarray(q, dtype=float))[0]

    def constraint_jacobian(self, q) -> np.ndarray:
        """G(q) = dg/dq, k x n."""
        if not self._spec.constraints:
            return np.zeros((0, len(self.coordinates)))
        return self._constraint_checks().jacobian(np.asarray(q, dtype=float))

    def check_configurations(self, name: str, qs: np.ndarray) -> None:
        # The compiled functions broadcast over rows: one call each for every member (an
        # ensemble of 10^4 members spent 0.3 s here, one Python call per member). The first
        # member with a non-finite value is then checked alone, for its message.
        if self._python is not None:
            super().check_configurations(name, qs)
            return
        c = self._compiled
        functions = [c.potential, c.gradient] + ([c.damper_gradients] if c.damper_gradients is not None else [])
        block = 4096  # rows per call: bounded temporaries (dampers x n values per row)
        for start in range(0, len(qs), block):
            rows = np.ascontiguousarray(qs[start:start + block], dtype=float)
            finite = np.ones(len(rows), dtype=bool)
            for fn in functions:
                finite &= np.isfinite(np.asarray(fn(rows), dtype=float).reshape(len(rows), -1)).all(axis=1)
            if not finite.all():
                i = start + int(np.argmin(finite))
                self.check_configuration(f"{name}[{i}]", qs[i])

    def _check_functions(self, name: str, q: np.ndarray) -> np.ndarray:
        _, direct = self._python
        pieces = [(("potential",), lambda x: [direct["potential"](x)], 1), (("gradient",), direct["gradient"], q.size)]
        pieces += [(("damping", "dampers", i, "gradient"), g, q.size) for i, (g, _) in enumerate(direct["dampers"])]
        for path, fn, size in pieces:
            try:
                value = fn(q.copy())
                if np.iscomplexobj(value):  # float() would drop the imaginary part, with only a warning
                    raise SpecError(path, f"returned complex numbers at {name} = {q.tolist()}; it must return real "
                                          "ones")
                value = np.asarray(value, dtype=float).reshape(-1)
            except SpecError:
                raise
            except Exception as error:  # noqa: BLE001 - the user's code; say what it raised
                raise SpecError(path, f"raised {type(error).__name__} at {name} = {q.tolist()}: {error}") from error
            if value.size != size:
                raise SpecError(path, f"returned {value.size} values at {name}, expected {size}")
            if not np.isfinite(value).all():
                raise SpecError(path, f"is not finite at {name} = {q.tolist()}")
        return q

    def _explain_failure(self) -> str | None:
        """Why a run stopped early, when a Python callable of from_functions raised."""
        return self._python[0].take_error() if self._python is not None else None

    def __repr__(self) -> str:
        if self._python is not None:
            return f"System.from_functions(n={len(self.coordinates)}, name={self.label!r})"
        return f"System({json.dumps(self.to_dict())})"

    def __eq__(self, other) -> bool:
        if self._python is not None or not isinstance(other, System) or other._python is not None:
            return self is other
        return self.to_dict() == other.to_dict()

    def __hash__(self) -> int:
        if self._python is not None:
            return id(self)
        return hash(json.dumps(self.to_dict(), sort_keys=True))

    def __copy__(self) -> System:
        return self  # immutable

    def __deepcopy__(self, memo) -> System:
        return self

    def __reduce__(self):
        return (System.from_dict, (copy.deepcopy(self.to_dict()),))  # to_dict refuses function systems


def _mass_plain(s: SystemSpec):
    if s.mass_form == "scalar":
        return float(s.mass[0, 0])
    if s.mass_form == "diagonal":
        return np.diag(s.mass).tolist()
    return s.mass.tolist()


def _damping_plain(s: SystemSpec):
    if s.damping_form is None:
        return None
    if s.damping_form == "scalar":
        return {"scalar": s.damping_scalar}
    if s.damping_form == "diagonal":
        return {"diagonal": np.diag(s.damping_matrix).tolist()}
    if s.damping_form == "matrix":
        return {"matrix": s.damping_matrix.tolist()}
    return {"dampers": [{"on": d.on.text, "c": d.c} for d in s.dampers]}


def _build_core(spec: SystemSpec, addresses, damper_coefficients, n_momenta: int, owner,
                damper_norm: float | None = None):
    mass_kind = "scalar" if spec.mass_form == "scalar" else "dense"
    damping_kind = {None: "isotropic", "scalar": "isotropic", "diagonal": "constant", "matrix": "constant",
                    "dampers": "dampers"}[spec.damping_form]
    # Undamped: eps has nothing to act on, and the core's eps decides whether sv may run.
    eps = 0.0 if spec.damping_form is None else spec.eps
    if spec.constraints:
        cls = getattr(_core, f"ConstrainedSystem_{mass_kind}_{damping_kind}")
        rows, cols = owner.constraint_pattern
        try:
            return cls(spec.n, eps, spec.mass, spec.damping_scalar if spec.damping_form == "scalar" else 0.0,
                       spec.damping_matrix if spec.damping_matrix.size else np.zeros((spec.n, spec.n)),
                       list(addresses), n_momenta, owner, len(spec.constraints), list(owner.constraint_addresses),
                       list(rows), list(cols), spec.constraint_tol, 50, list(damper_coefficients))
        except ValueError as err:
            field, _, message = str(err).partition(": ")
            raise SpecError(tuple(field.split(".")), message or str(err)) from None
    cls = getattr(_core, f"System_{mass_kind}_{damping_kind}")
    try:
        return cls(spec.n, eps, spec.mass, spec.damping_scalar if spec.damping_form == "scalar" else 0.0,
                   spec.damping_matrix if spec.damping_matrix.size else np.zeros((spec.n, spec.n)),
                   list(damper_coefficients), list(addresses), n_momenta, owner,
                   math.nan if damper_norm is None else damper_norm)
    except ValueError as err:  # the core's own checks name the field first
        field, _, message = str(err).partition(": ")
        raise SpecError(tuple(field.split(".")), message or str(err)) from None
