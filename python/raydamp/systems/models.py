"""The mechanical systems raydamp integrates.

Each model is H(q, p) = 1/2 p^T M^{-1} p + V(q) perturbed by Rayleigh damping
-eps D(q) M^{-1} p. The numbers live in the compiled core; these classes own the
names, the defaults and the documentation.
"""

from __future__ import annotations

import functools
import inspect
from typing import Any, ClassVar

import numpy as np

from .. import _core
from .._validation import real, vector

__all__ = ["Model", "DampedPendulum", "ElasticPendulum", "MODELS", "describe_models", "make_model"]


@functools.cache
def _parameter_names(cls: type) -> tuple[str, ...]:
    """A model class's constructor parameters (inspect.signature costs ~50 us; every job asks)."""
    return tuple(inspect.signature(cls).parameters)


class Model:
    """Base class: a model wraps one compiled model struct.

    Models are immutable: the compiled struct is built from the parameters once, so
    changing a parameter afterwards could only change the repr, not the run.
    ``model.replace(eps=0.5)`` builds a new model instead.
    """

    name: ClassVar[str]
    momentum_names: ClassVar[tuple[str, ...]] = ()
    parameter_docs: ClassVar[dict[str, str]] = {}
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

    @property
    def coordinates(self) -> tuple[str, ...]:
        """The names of the coordinates (q0, q1, ... unless the model names them)."""
        return tuple(f"q{i}" for i in range(self.dim))

    @property
    def dim(self) -> int:
        """Configuration dimension n (the state is (q, p) in R^n x R^n)."""
        return self._core_model.dim

    @property
    def parameters(self) -> dict[str, Any]:
        """The parameters this model was built with, by name."""
        return {name: getattr(self, name) for name in _parameter_names(type(self))}

    def check_configuration(self, name: str, q: np.ndarray) -> np.ndarray:
        """Refuse a configuration outside the model's configuration space; returns q."""
        return q

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

    def vector_field(self, q, p) -> tuple[np.ndarray, np.ndarray]:
        """(q', p') = (M^{-1} p, -grad V(q) - eps D(q) M^{-1} p): for reference solvers."""
        core = self._core_model
        qdot = np.asarray(core.velocity(p)).reshape(self.dim)
        pdot = -np.asarray(core.gradient(q)).reshape(self.dim) - np.asarray(core.damping_rate(q, p)).reshape(self.dim)
        return qdot, pdot

    def flow(self, name: str, q, p, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Apply one exact sub-flow ('drift', 'kick', 'damp' or 'kick_damp') for time t."""
        q1, p1 = self._core_model.flow(name, vector("q", q, self.dim), vector("p", p, self.dim), real("t", t))
        return np.asarray(q1).reshape(self.dim), np.asarray(p1).reshape(self.dim)

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.parameters.items())
        return f"{type(self).__name__}({args})"


class DampedPendulum(Model):
    """The damped pendulum of the paper's section 4.3.

    q' = p, p' = -sin q - eps p (n = 1, M = 1, V = 1 - cos q, D = 1).
    The paper's data: q0 = 0.9 pi, p0 = 0, eps = 0.01, t in [0, 200].
    """

    name = "damped_pendulum"
    coordinates = ("q",)
    parameter_docs = {"eps": "damping coefficient, >= 0"}

    def __init__(self, eps: float = 0.01):
        self.eps = real("eps", eps, nonnegative=True)
        self._core_model = _core.DampedPendulum(self.eps)
        self._freeze()


class ElasticPendulum(Model):
    """The elastic 3-D pendulum of the paper's section 6.2.

    q' = p/m, p' = -k (1 - l/|q|) q + m g - eps (q q^T / |q|^2) p / m: a mass m on a
    spring of stiffness k and rest length l under gravity g, damped only along the
    spring. With g vertical, rotation about the z axis is a symmetry and its
    momentum map J3 = q_x p_y - q_y p_x is conserved by the flow and by 3s, 2s, rks.
    The paper's data: q0 = (0, 1.55884573, -0.6), p0 = (1.34164079, 0, 0).
    """

    name = "elastic_pendulum"
    coordinates = ("x", "y", "z")
    momentum_names = ("J3",)
    parameter_docs = {
        "eps": "damping coefficient along the spring, >= 0",
        "m": "mass, > 0",
        "k": "spring stiffness, >= 0",
        "l": "spring rest length, >= 0",
        "g": "gravity vector (3 components)",
    }

    def __init__(self, eps: float = 0.1, m: float = 1.0, k: float = 1.0, l: float = 1.0,  # noqa: E741
                 g=(0.0, 0.0, -1.0)):
        self.eps = real("eps", eps, nonnegative=True)
        self.m = real("m", m, positive=True)
        self.k = real("k", k, nonnegative=True)
        self.l = real("l", l, nonnegative=True)
        self.g = tuple(float(x) for x in vector("g", g, 3))
        self._core_model = _core.ElasticPendulum(self.eps, self.m, self.k, self.l, list(self.g))
        self._freeze()

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


MODELS: dict[str, type[Model]] = {cls.name: cls for cls in (DampedPendulum, ElasticPendulum)}


def describe_models() -> list[dict[str, Any]]:
    """Every model with its dimension, momentum maps, and parameters with defaults."""
    out = []
    for name, cls in MODELS.items():
        params = inspect.signature(cls).parameters
        default = cls()
        out.append({
            "name": name,
            "description": inspect.getdoc(cls).split("\n")[0],
            "dim": default.dim,
            "momenta": list(cls.momentum_names),
            "parameters": [
                {"name": p, "default": list(v) if isinstance(v := params[p].default, tuple) else v,
                 "description": cls.parameter_docs.get(p, "")}
                for p in params
            ],
        })
    return out


def make_model(name: str, parameters: dict[str, Any] | None = None) -> Model:
    """Build a model by name; unknown names and parameters raise ValueError naming them."""
    if name not in MODELS:
        raise ValueError(f"model: unknown model {name!r} (known: {', '.join(MODELS)})")
    cls = MODELS[name]
    parameters = dict(parameters or {})
    known = _parameter_names(cls)
    for key in parameters:
        if key not in known:
            raise ValueError(f"parameters.{key}: {name} has no parameter {key!r} (known: {', '.join(known)})")
    return cls(**parameters)
