"""The mechanical systems raydamp integrates.

Each model is H(q, p) = 1/2 p^T M^{-1} p + V(q) perturbed by Rayleigh damping
-eps D(q) M^{-1} p. The numbers live in the compiled core, and so does each built-in
model's parameter table (name, size, default, rule, description: the C++ struct's
``parameters``, exported as ``_core.models()``); these classes own the coordinates'
names and the documentation, and read everything about their parameters from that table.
"""

from __future__ import annotations

import inspect
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from .. import _core
from .._validation import _short, real, vector
from .kinds import MemberModels, plain

__all__ = ["Model", "SharedModel", "BuiltinModel", "DampedPendulum", "ElasticPendulum", "MODELS", "describe_models",
           "make_model"]

# The core's catalogue of built-in models, by name (cpp/include/raydamp/models/*.hpp, each
# struct's `parameters` table).
_CATALOGUE: dict[str, dict[str, Any]] = {entry["name"]: entry for entry in _core.models()}


class Model:
    """Base class of every kind of system: a model wraps one compiled model struct, and answers
    the questions of the kind protocol (:class:`raydamp.systems.kinds.SystemKind`).

    Models are immutable: the compiled struct is built from the parameters once, so
    changing a parameter afterwards could only change the repr, not the run.
    ``model.replace(eps=0.5)`` builds a new model instead.
    """

    name: ClassVar[str]
    momentum_names: ClassVar[tuple[str, ...]] = ()
    _core_model: Any
    _frozen: bool = False

    def _freeze(self) -> None:
        object.__setattr__(self, "_frozen", True)

    def __setattr__(self, name: str, value) -> None:
        if self._frozen:
            raise AttributeError(f"{type(self).__name__} is immutable: build a new one, e.g. "
                                 f"model.replace({name}=...), instead of setting {name!r}")
        object.__setattr__(self, name, value)

    def __delattr__(self, name: str) -> None:
        raise AttributeError(f"{type(self).__name__} is immutable: cannot delete {name!r}")

    def replace(self, **changes) -> Model:
        """A new model of the same kind with some parameters changed."""
        return type(self)(**{**self.parameters, **changes})

    # -- the kind protocol (kinds.SystemKind); each kind implements these -----------------------
    def describe(self) -> dict[str, Any]:
        """The JSON form (kinds.SystemKind.describe)."""
        raise NotImplementedError

    def member_parameters(self) -> Mapping[str, int]:
        """The parameters an ensemble may vary per member, with their sizes (kinds.SystemKind)."""
        raise NotImplementedError

    def member_models(self, parameters: Mapping[str, np.ndarray], members: int) -> MemberModels:
        """What the compiled ensemble runs (kinds.SystemKind.member_models)."""
        raise NotImplementedError

    @property
    def coordinates(self) -> tuple[str, ...]:
        """The names of the coordinates (q0, q1, ... unless the model names them)."""
        return tuple(f"q{i}" for i in range(self.dim))

    @property
    def dim(self) -> int:
        """Configuration dimension n (the state is (q, p) in R^n x R^n)."""
        return self._core_model.dim

    def check_configuration(self, name: str, q: np.ndarray) -> np.ndarray:
        """Refuse a configuration outside the model's configuration space; returns q."""
        return q

    def check_momenta(self, name: str, q: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Refuse momenta the model cannot start from at q (a constrained System: off the tangent space);
        returns p."""
        return p

    def check_configurations(self, name: str, qs: np.ndarray) -> None:
        """check_configuration on every row of qs (members, n), naming the first bad one
        ``name[i]``. Kinds whose check is not the identity vectorise it where they can."""
        if type(self).check_configuration is Model.check_configuration:
            return
        for i, q in enumerate(qs):
            self.check_configuration(f"{name}[{i}]", q)

    def energy(self, q, p) -> float:
        """H(q, p)."""
        return self._core_model.energy(vector("q", q, self.dim), vector("p", p, self.dim))

    def potential(self, q) -> float:
        """V(q)."""
        return self._core_model.potential(vector("q", q, self.dim))

    def gradient(self, q) -> np.ndarray:
        """grad V(q)."""
        return np.asarray(self._core_model.gradient(vector("q", q, self.dim))).reshape(self.dim)

    def momenta(self, q, p) -> np.ndarray:
        """The momentum maps of the model's symmetries (empty if it has none)."""
        return np.asarray(self._core_model.momenta(vector("q", q, self.dim), vector("p", p, self.dim)), dtype=float)

    def mass_product(self, r) -> np.ndarray:
        """M r (a ground motion's load is -M r a_g(t)). Here from the core's M^{-1}, column by
        column, for a model of a few coordinates; the large kinds give their own."""
        if self.dim > 2048:
            raise ValueError(f"mass_product: {type(self).__name__} of {self.dim} coordinates gives no mass matrix")
        r = vector("r", r, self.dim)
        inverse = np.column_stack([np.asarray(self._core_model.velocity(e)).reshape(self.dim)
                                   for e in np.eye(self.dim)])
        return np.linalg.solve(inverse, r)

    def vector_field(self, q, p) -> tuple[np.ndarray, np.ndarray]:
        """(q', p') = (M^{-1} p, -grad V(q) - eps D(q) M^{-1} p): for reference solvers."""
        core = self._core_model
        q, p = vector("q", q, self.dim), vector("p", p, self.dim)  # as energy() does: else the binding's TypeError
        qdot = np.asarray(core.velocity(p)).reshape(self.dim)
        pdot = -np.asarray(core.gradient(q)).reshape(self.dim) - np.asarray(core.damping_rate(q, p)).reshape(self.dim)
        return qdot, pdot

    def flow(self, name: str, q, p, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Apply one exact sub-flow ('drift', 'kick', 'damp' or 'kick_damp') for time t."""
        if not isinstance(name, str):  # the core names an unknown string; anything else was the binding's TypeError
            raise ValueError(f"name must be a sub-flow's name (drift, kick, damp, kick_damp), got {_short(name)}")
        q1, p1 = self._core_model.flow(name, vector("q", q, self.dim), vector("p", p, self.dim), real("t", t))
        return np.asarray(q1).reshape(self.dim), np.asarray(p1).reshape(self.dim)

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.parameters.items())
        return f"{type(self).__name__}({args})"


class SharedModel(Model):
    """A kind given as data, with a JSON form of its own (``to_dict``, the job's ``system``), whose ensemble
    members share one model and differ by initial state only (and, in a sweep, by run arguments): another
    value of one of its parameters is another model, because the model builds its compiled parts with them
    (a Chain's damping blocks with eps and the bond's parameters, a LinearStructure's Chebyshev bounds with
    alpha and beta). Chain and LinearStructure."""

    def to_dict(self) -> dict[str, Any]:
        """The JSON form, ``{"kind": ..., ...}``."""
        raise NotImplementedError

    @classmethod
    def _from_form(cls, spec: Mapping[str, Any], kind: str, label: str, known: tuple[str, ...],
                   required: Mapping[str, str] | None = None):
        """cls(**spec) from ``to_dict()``'s form, checked key by key so that each error names its key:
        ``known`` the keys besides "kind", ``required`` a message per key that must be present."""
        if not isinstance(spec, Mapping):
            raise ValueError(f"system: a {label} must be an object with kind \"{kind}\"")
        known = ("kind", *known)
        for key in spec:
            if key not in known:
                raise ValueError(f"{key}: unknown key of a {label} (known: {', '.join(known)})")
        if spec.get("kind") != kind:
            raise ValueError(f"kind: expected \"{kind}\", got {_short(spec.get('kind'))}")
        for key, message in (required or {}).items():
            if key not in spec:
                raise ValueError(f"{key}: {message}")
        return cls(**{k: v for k, v in spec.items() if k != "kind"})

    # -- the kind protocol (kinds.SystemKind) ---------------------------------------------------
    def describe(self) -> dict[str, Any]:
        return {"system": self.to_dict()}

    def member_parameters(self) -> dict[str, int]:
        return {}

    def member_models(self, parameters: Mapping[str, np.ndarray], members: int) -> MemberModels:
        return MemberModels.shared(self, members)


def _checked(parameter: Mapping[str, Any], value) -> float | tuple[float, ...]:
    """A value for a catalogue row: a real number, or a vector of its size, obeying its rule;
    the errors name the parameter as the row does ("eps must be >= 0, got -0.1")."""
    name, rule = parameter["name"], parameter["rule"]
    if parameter["size"] == 1:
        return real(name, value, nonnegative=rule == ">= 0", positive=rule == "> 0")
    components = tuple(float(x) for x in vector(name, value, parameter["size"]))
    for i, x in enumerate(components):
        if (rule == ">= 0" and not x >= 0) or (rule == "> 0" and not x > 0):
            raise ValueError(f"{name}[{i}] must be {rule}, got {x!r}")
    return components


def _annotation(size: int) -> Any:
    """A parameter's annotation in the signature: a float, or a tuple of ``size`` floats."""
    return float if size == 1 else tuple[(float,) * size]


class BuiltinModel(Model):
    """A model compiled into the core. Its parameters (names, sizes, defaults, rules and
    descriptions) are the core's table for the model named ``name`` (``_core.models()``): the
    signature, the checks, ``parameters``, ``describe_models()`` and the ensemble's per-member
    parameters all read that table, so a parameter is added in the C++ struct alone."""

    parameter_docs: ClassVar[dict[str, str]] = {}
    _parameter_table: ClassVar[tuple[dict[str, Any], ...]] = ()
    _core_class: ClassVar[Any]

    def __init_subclass__(cls, **kwargs) -> None:
        super().__init_subclass__(**kwargs)
        entry = _CATALOGUE[cls.name]
        cls._parameter_table = tuple(entry["parameters"])
        cls._core_class = getattr(_core, entry["class_name"])
        cls.momentum_names = tuple(entry["momenta"])
        cls.parameter_docs = {p["name"]: p["description"] for p in cls._parameter_table}
        for p in cls._parameter_table:  # a parameter is an attribute: it must not hide one of Model's
            if hasattr(cls, p["name"]):
                raise TypeError(f"{cls.__name__}: parameter {p['name']!r} would hide the attribute of that name")
        # The signature help() and inspect.signature show: the table's names, defaults and sizes.
        signature = inspect.Signature([
            inspect.Parameter(p["name"], inspect.Parameter.POSITIONAL_OR_KEYWORD,
                              default=p["default"] if p["size"] == 1 else tuple(p["default"]),
                              annotation=_annotation(p["size"]))
            for p in cls._parameter_table])
        cls.__signature__ = signature

        names = tuple(p["name"] for p in cls._parameter_table)
        class_name = cls.__name__

        def __init__(self, *args, **kwargs):
            # Python's own argument binding, written out (Signature.bind costs a few microseconds).
            if len(args) > len(names):
                raise TypeError(f"{class_name}() takes at most {len(names)} arguments ({len(args)} given)")
            given = dict(zip(names, args))
            for key in kwargs:
                if key not in names:
                    raise TypeError(f"{class_name}() got an unexpected keyword argument {key!r}")
                if key in given:
                    raise TypeError(f"{class_name}() got multiple values for argument {key!r}")
            given.update(kwargs)
            BuiltinModel._build(self, given)

        __init__.__signature__ = signature.replace(parameters=[
            inspect.Parameter("self", inspect.Parameter.POSITIONAL_OR_KEYWORD), *signature.parameters.values()])
        __init__.__doc__ = "Parameters (defaults): " + "; ".join(
            f"{p['name']} ({plain(p['default'])}): {p['description']}" for p in cls._parameter_table)
        __init__.__qualname__ = f"{cls.__qualname__}.__init__"
        cls.__init__ = __init__

    def _build(self, given: Mapping[str, Any]) -> None:
        values: list[float] = []
        for p in self._parameter_table:
            name = p["name"]
            if name in given:
                value = _checked(p, given[name])
            else:
                value = p["default"] if p["size"] == 1 else tuple(p["default"])
            object.__setattr__(self, name, value)
            if p["size"] == 1:
                values.append(value)
            else:
                values.extend(value)
        object.__setattr__(self, "_core_model", self._core_class(values))
        self._freeze()

    @property
    def parameters(self) -> dict[str, Any]:
        """The parameters this model was built with, by name, in the table's order."""
        return {p["name"]: getattr(self, p["name"]) for p in self._parameter_table}

    # -- the kind protocol ----------------------------------------------------------------------
    def describe(self) -> dict[str, Any]:
        return {"model": self.name, "parameters": {k: plain(v) for k, v in self.parameters.items()}}

    def member_parameters(self) -> dict[str, int]:
        # Every parameter: the core rebuilds each member's model from the table (run_ensemble.hpp's
        # with_parameters), so an ensemble over them costs no Python per member.
        return {p["name"]: p["size"] for p in self._parameter_table}

    def member_models(self, parameters: Mapping[str, np.ndarray], members: int) -> MemberModels:
        # A vector parameter goes to the core as its components' columns, "g[0]", "g[1]", ...
        names, columns = [], []
        for name, array in parameters.items():
            if array.ndim == 1:
                names.append(name)
                columns.append(array)
            else:
                names += [f"{name}[{i}]" for i in range(array.shape[1])]
                columns += list(array.T)
        values = np.column_stack(columns) if columns else np.zeros((members, 0))
        return MemberModels([self], np.zeros(members, dtype=np.int64), names, values)


class DampedPendulum(BuiltinModel):
    """The damped pendulum of the paper's section 4.3.

    q' = p, p' = -sin q - eps p (n = 1, M = 1, V = 1 - cos q, D = 1).
    The paper's data: q0 = 0.9 pi, p0 = 0, eps = 0.01, t in [0, 200].
    """

    name = "damped_pendulum"
    coordinates = ("q",)


class ElasticPendulum(BuiltinModel):
    """The elastic 3-D pendulum of the paper's section 6.2.

    q' = p/m, p' = -k (1 - l/|q|) q + m g - eps (q q^T / |q|^2) p / m: a mass m on a
    spring of stiffness k and rest length l under gravity g, damped only along the
    spring. With g vertical, rotation about the z axis is a symmetry and its
    momentum map J3 = q_x p_y - q_y p_x is conserved by the flow and by 3s, 2s, rks.
    The paper's data: q0 = (0, 1.55884573, -0.6), p0 = (1.34164079, 0, 0).
    """

    name = "elastic_pendulum"
    coordinates = ("x", "y", "z")

    def check_configuration(self, name: str, q: np.ndarray) -> np.ndarray:
        # Configuration space R^3 minus the origin (paper section 6.2): at q = 0 neither
        # grad V nor D(q) = q q^T / |q|^2 is defined.
        if not q.any():
            raise ValueError(f"{name} must not be the origin: the elastic pendulum's grad V and damping "
                             "D(q) = q q^T/|q|^2 are undefined at q = 0")
        return q

    def check_configurations(self, name: str, qs: np.ndarray) -> None:
        origin = ~qs.any(axis=1)
        if origin.any():
            i = int(np.argmax(origin))
            self.check_configuration(f"{name}[{i}]", qs[i])


MODELS: dict[str, type[BuiltinModel]] = {cls.name: cls for cls in (DampedPendulum, ElasticPendulum)}


def describe_models() -> list[dict[str, Any]]:
    """Every model with its dimension, momentum maps, and parameters with defaults (the core's
    catalogue, with each class's first docstring line as its description)."""
    return [{
        "name": name,
        "description": inspect.getdoc(cls).split("\n")[0],
        "dim": _CATALOGUE[name]["dim"],
        "momenta": list(cls.momentum_names),
        "parameters": [{"name": p["name"], "default": plain(p["default"]), "description": p["description"]}
                       for p in cls._parameter_table],
    } for name, cls in MODELS.items()]


def make_model(name: str, parameters: dict[str, Any] | None = None) -> Model:
    """Build a model by name; unknown names and parameters raise ValueError naming them."""
    if not isinstance(name, str) or name not in MODELS:  # a list was dict lookup's TypeError (unhashable)
        raise ValueError(f"model: unknown model {_short(name)} (known: {', '.join(MODELS)})")
    cls = MODELS[name]
    if parameters is not None and not isinstance(parameters, Mapping):  # dict('eps') said "dictionary update ..."
        raise ValueError(f"parameters must be a dict of parameter values (e.g. {{'eps': 0.1}}), got "
                         f"{_short(parameters)}")
    parameters = dict(parameters or {})
    known = [p["name"] for p in cls._parameter_table]
    for key in parameters:
        if key not in known:
            raise ValueError(f"parameters.{key}: {name} has no parameter {key!r} (known: {', '.join(known)})")
    return cls(**parameters)
