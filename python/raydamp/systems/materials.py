"""Hysteretic materials for the springs of a :class:`raydamp.Structure` (public as ``raydamp.materials``).

A material gives the force sigma(d) of a spring's deformation d with an internal state. The numbers live in
the compiled core (cpp/include/raydamp/materials/materials.hpp): each material keeps a committed and a trial
state, answers every kick of a step from the state committed at the step's start, with a return map exact
for the increment, and commits once per full step. So the backward sub-steps of a composition (yoshida4)
never create plastic flow of their own.

- :class:`ElasticPlastic` ``(k, fy)``: sigma = k (d - d_p), |sigma| <= fy.
- :class:`Bilinear` ``(k, fy, b)``: kinematic hardening with post-yield stiffness b k (Steel01's rule
  without isotropic hardening); its loops lie between sigma = b k d +- (1 - b) fy. ``b`` in [0, 1); a
  negative b > -1 softens (the force falls past yield), for collapse studies with a P-Delta stiffness in K:
  a structure with softening springs can lose its stability, and then a run diverges, as it should.
- :class:`BoucWen` ``(k, fy, alpha, n=1, beta=0.5, gamma=0.5)``: smooth hysteresis, sigma = alpha k d +
  (1 - alpha) fy z, dz/dd = (1 / d_y)(1 - (beta sgn(z dd) + gamma)|z|), d_y = fy / k. Only n = 1, whose
  evolution along a drift of one sign has a closed form (taken exactly by the core). Its hysteresis is
  bounded (|z| <= 1 / (beta + gamma)) when beta > 0 and beta + gamma > 0; other values are refused.

Each material's ``to_dict()`` is its JSON form, ``{"kind": "bilinear", "k": ..., "fy": ..., "b": ...}``.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any, ClassVar

from .._validation import real

__all__ = ["Material", "ElasticPlastic", "Bilinear", "BoucWen", "material_from_dict", "MATERIALS"]


class Material:
    """Base of the hysteretic materials: a frozen dataclass with the core's kind name and parameter list."""

    kind: ClassVar[str]

    def core_parameters(self) -> list[float]:
        """The parameters in the order the core takes them."""
        return [float(getattr(self, f.name)) for f in fields(self)]  # type: ignore[arg-type]

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, **{f.name: getattr(self, f.name) for f in fields(self)}}  # type: ignore[arg-type]


def _checked(owner: str, k, fy) -> tuple[float, float]:
    k = real(f"{owner}.k", k)
    if not k > 0:
        raise ValueError(f"{owner}.k: the initial stiffness must be > 0, got {k!r}")
    fy = real(f"{owner}.fy", fy)
    if not fy > 0:
        raise ValueError(f"{owner}.fy: the yield force must be > 0, got {fy!r}")
    return k, fy


@dataclass(frozen=True)
class ElasticPlastic(Material):
    """Elastic-perfectly-plastic: stiffness ``k`` > 0 up to the yield force ``fy`` > 0, then flat."""

    kind: ClassVar[str] = "elastic_plastic"
    k: float
    fy: float

    def __post_init__(self):
        k, fy = _checked("material", self.k, self.fy)
        object.__setattr__(self, "k", k)
        object.__setattr__(self, "fy", fy)


@dataclass(frozen=True)
class Bilinear(Material):
    """Bilinear with kinematic hardening: stiffness ``k``, yield force ``fy``, post-yield stiffness ``b k``.
    ``b`` in [0, 1) hardens (0: elastic-perfectly-plastic); -1 < b < 0 softens (see the module docstring)."""

    kind: ClassVar[str] = "bilinear"
    k: float
    fy: float
    b: float = 0.0

    def __post_init__(self):
        k, fy = _checked("material", self.k, self.fy)
        b = real("material.b", self.b)
        if not -1.0 < b < 1.0:
            raise ValueError(f"material.b: the post-yield stiffness ratio must be in [0, 1) (or in (-1, 0) for a "
                             f"softening spring), got {b!r}")
        object.__setattr__(self, "k", k)
        object.__setattr__(self, "fy", fy)
        object.__setattr__(self, "b", b)


@dataclass(frozen=True)
class BoucWen(Material):
    """Bouc-Wen (n = 1): sigma = alpha k d + (1 - alpha) fy z; ``alpha`` in [0, 1) the post-yield stiffness
    ratio, ``beta`` > 0 and ``beta + gamma`` > 0 for a bounded hysteresis (|z| <= 1 / (beta + gamma))."""

    kind: ClassVar[str] = "bouc_wen"
    k: float
    fy: float
    alpha: float = 0.0
    n: float = 1
    beta: float = 0.5
    gamma: float = 0.5

    def __post_init__(self):
        k, fy = _checked("material", self.k, self.fy)
        alpha = real("material.alpha", self.alpha)
        if not 0.0 <= alpha < 1.0:
            raise ValueError(f"material.alpha: the post-yield stiffness ratio must be in [0, 1), got {alpha!r}")
        n = real("material.n", self.n)
        if n != 1:
            raise ValueError(f"material.n: only n = 1 is supported (its evolution has a closed form), got {n!r}")
        beta = real("material.beta", self.beta)
        gamma = real("material.gamma", self.gamma)
        if not (beta > 0 and beta + gamma > 0):
            raise ValueError(f"material.{'beta' if not beta > 0 else 'gamma'}: the hysteresis is bounded only for "
                             f"beta > 0 and beta + gamma > 0, got beta = {beta!r}, gamma = {gamma!r}")
        for name, value in (("k", k), ("fy", fy), ("alpha", alpha), ("n", 1), ("beta", beta), ("gamma", gamma)):
            object.__setattr__(self, name, value)

    def core_parameters(self) -> list[float]:
        return [self.k, self.fy, self.alpha, self.beta, self.gamma]


MATERIALS: dict[str, type[Material]] = {m.kind: m for m in (ElasticPlastic, Bilinear, BoucWen)}


def material_from_dict(data, where: str = "material") -> Material:
    """A material from its ``to_dict()`` form; errors name ``where`` and the field."""
    if isinstance(data, Material):
        return data
    if not isinstance(data, dict):
        raise ValueError(f"{where}: must be an object with a kind ({', '.join(MATERIALS)})")
    kind = data.get("kind")
    if kind not in MATERIALS:
        raise ValueError(f"{where}.kind: must be one of {', '.join(MATERIALS)}, got {kind!r}")
    cls = MATERIALS[kind]
    names = [f.name for f in fields(cls)]
    unknown = [key for key in data if key != "kind" and key not in names]
    if unknown:
        raise ValueError(f"{where}.{unknown[0]}: unknown parameter of {kind} (known: {', '.join(names)})")
    try:
        return cls(**{key: value for key, value in data.items() if key != "kind"})
    except TypeError as error:  # a missing parameter
        missing = [name for name in names if name not in data]
        raise ValueError(f"{where}.{missing[0] if missing else 'kind'}: missing ({error})") from None
    except ValueError as error:
        raise ValueError(str(error).replace("material.", f"{where}.")) from None
