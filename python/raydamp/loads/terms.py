"""The terms a load is the sum of: each a scalar history s(t) times a direction over the
coordinates (or, a series given as a vector per time, the interpolated vector itself).

A direction is an array of n numbers, or :class:`Ground` (the direction -M r of a uniform
base excitation, known once the model is). Terms are checked when made; the direction's
length when the load meets its model (:meth:`raydamp.Load.bind`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from .._validation import _short, numeric_array, real

__all__ = ["Ground", "Harmonic", "Series", "ExpressionTerm", "times", "history", "direction"]


@dataclass(frozen=True, eq=False)
class Ground:
    """The influence vector r of a ground motion: the term's force is -M r a_g(t)."""

    r: np.ndarray


def times(name: str, t) -> np.ndarray:
    """Sample times: finite, strictly increasing, at least one."""
    array = _floats(name, t, ndim=1)
    if array.size == 0:
        raise ValueError(f"{name}: needs at least one time")
    steps = np.diff(array)
    if steps.size and not np.all(steps > 0):
        k = int(np.flatnonzero(~(steps > 0))[0]) + 1
        raise ValueError(f"{name}: times must increase, but {name}[{k}] = {float(array[k])!r} <= {name}[{k - 1}] = "
                         f"{float(array[k - 1])!r}")
    return array


def history(name: str, values, count: int) -> np.ndarray:
    """Values at ``count`` times: (count,) or (count, n), all finite."""
    array = _floats(name, values, ndim=(1, 2))
    if array.shape[0] != count:
        raise ValueError(f"{name}: {array.shape[0]} values for {count} times")
    return array


def direction(name: str, value) -> np.ndarray | Ground | None:
    if value is None or isinstance(value, Ground):
        return value
    array = np.atleast_1d(_floats(name, value, ndim=(0, 1)))  # a number: the direction of a 1-coordinate model
    if array.size == 0:
        raise ValueError(f"{name}: empty")
    return array


def _floats(name: str, value, ndim) -> np.ndarray:
    array = numeric_array(value)
    if array is None:
        raise ValueError(f"{name} must be an array of numbers, got {_short(value)}")
    allowed = (ndim,) if isinstance(ndim, int) else ndim
    if array.ndim not in allowed:
        raise ValueError(f"{name} must have {' or '.join(str(d) for d in allowed)} dimension(s), got shape "
                         f"{array.shape}")
    array = array.astype(float)
    if not np.all(np.isfinite(array)):
        bad = np.argwhere(~np.isfinite(array))[0]
        at = ", ".join(str(int(i)) for i in bad)
        raise ValueError(f"{name}[{at}] is not finite ({float(array[tuple(bad)])!r})")
    return array


@dataclass(frozen=True, eq=False)
class Harmonic:
    """s(t) = sin(omega t + phase) times ``direction`` (the amplitude vector), for t <= t_end and 0 after
    (a pulse: ``t_end`` = inf, the default, for a load that never ends)."""

    direction: Any
    omega: float
    phase: float = 0.0
    scale: float = 1.0
    t_end: float = math.inf

    def core(self, vector: np.ndarray) -> dict:
        out = {"shape": "harmonic", "omega": self.omega, "phase": self.phase, "scale": self.scale}
        if self.t_end != math.inf:
            out["t_end"] = self.t_end
        return _with_direction(out, vector)

    def plain(self) -> dict:
        return {"harmonic": {"amplitude": _plain_direction(self.direction), "omega": self.omega, "phase": self.phase,
                             **({"scale": self.scale} if self.scale != 1.0 else {}),
                             **({"t_end": self.t_end} if self.t_end != math.inf else {})}}


@dataclass(frozen=True, eq=False)
class Series:
    """Piecewise-linear in t through (t[k], values[k]); zero outside [t[0], t[-1]], or the end
    value there with ``hold``. values (T,) times ``direction``, or (T, n) a vector per time."""

    t: np.ndarray
    values: np.ndarray
    direction: Any = None
    hold: bool = False
    scale: float = 1.0
    source: str | None = None  # the file it was read from, for provenance and messages

    def core(self, vector: np.ndarray | None) -> dict:
        t = self.t
        step = 0.0
        if t.size > 2:
            dt = (t[-1] - t[0]) / (t.size - 1)
            if dt > 0 and np.max(np.abs(t - (t[0] + np.arange(t.size) * dt))) <= 1e-10 * dt:
                step = dt  # a record sampled at dt: located by one division in the step loop
        out = {"shape": "series", "times": t, "values": self.values.ravel(), "scale": self.scale,
               "width": 1 if self.values.ndim == 1 else int(self.values.shape[1]), "hold": self.hold, "step": step}
        if self.values.ndim == 2 and self.values.shape[1] == 1:  # one coordinate: a scalar history along it
            out["width"] = 1
            return _with_direction(out, np.ones(1))
        return out if self.values.ndim == 2 else _with_direction(out, vector)

    def plain(self) -> dict:
        body: dict[str, Any] = {"t": self.t.tolist(), "values": self.values.tolist()}
        if self.direction is not None:
            body["direction"] = _plain_direction(self.direction)
        if self.hold:
            body["hold"] = True
        if self.scale != 1.0:
            body["scale"] = self.scale
        return {"series": body}


@dataclass(frozen=True, eq=False)
class ExpressionTerm:
    """s(t) = the user's expression of t with its parameters, times ``direction``."""

    expression: Any            # raydamp.systems.expressions.Expression
    parameters: dict = field(default_factory=dict)
    direction: Any = None
    scale: float = 1.0

    def core(self, vector: np.ndarray, function: tuple[int, int]) -> dict:
        return _with_direction({"shape": "expression", "function": function, "scale": self.scale}, vector)

    def plain(self) -> dict:
        return {"expression": {"expression": self.expression.text, "parameters": dict(self.parameters),
                               "direction": _plain_direction(self.direction),
                               **({"scale": self.scale} if self.scale != 1.0 else {})}}


def scaled(term, factor: float):
    return replace(term, scale=term.scale * factor)


def _with_direction(out: dict, vector: np.ndarray) -> dict:
    nonzero = np.flatnonzero(vector)
    out["index"] = nonzero.astype(np.int32)
    out["value"] = vector[nonzero]
    return out


def _plain_direction(d) -> Any:
    if isinstance(d, Ground):
        return {"ground": d.r.tolist()}
    return None if d is None else d.tolist()


def end_time(name: str, value) -> float:
    """A term's end time: a finite number, or None for a term that never ends (inf)."""
    return math.inf if value is None else real(name, value)


def phase_value(value) -> float:
    x = real("phase", value)
    return math.remainder(x, 2 * math.pi) if abs(x) > 1e6 else x
