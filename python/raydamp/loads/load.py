"""raydamp.Load: a time-dependent force f(t) on the coordinates, as data.

A load is a sum of terms (harmonic, piecewise-linear series, expression of t), each a
scalar history times a direction. The step loop applies it in the kicks at the time the
drifts leave (the load's time is a coordinate the drift advances), so every splitting
keeps its order and the implicit methods sample it at their stage times.
"""

from __future__ import annotations

import ctypes
import functools
from collections.abc import Iterable, Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import symengine as se

from .. import _core
from .._validation import _short, flag, real
from ..systems.expressions import parse
from . import terms as T
from .forms import load_input
from .records import read_record

__all__ = ["Load", "set_load_parameters"]

_TERMS = (T.Harmonic, T.Series, T.ExpressionTerm)


class Load:
    """A force f(t) = sum of terms s_k(t) d_k over the coordinates; ``integrate(..., load=...)``.

    Made by :meth:`harmonic`, :meth:`series`, :meth:`expression`, :meth:`from_file` (or
    :class:`raydamp.GroundMotion`); loads add (``a + b``) and scale (``2.0 * a``).
    Immutable. Its sweepable parameters (:attr:`parameters`): ``amplitude`` (a factor on the
    whole load, 1), ``omega`` and ``phase`` when its harmonic terms share one, and the
    parameters of its expressions; :meth:`with_parameters` sets them.
    """

    __slots__ = ("terms", "amplitude")

    def __init__(self, terms=(), amplitude: float = 1.0):
        # Checked here: Load([1, 2]) or Load("ab") was an AttributeError only when integrated, Load(None) a TypeError.
        if isinstance(terms, (str, bytes, Mapping)) or not isinstance(terms, Iterable):
            raise ValueError(f"terms must be a sequence of load terms (build a load with Load.harmonic, Load.series, "
                             f"Load.expression or Load.from_file), got {_short(terms)}")
        terms = tuple(terms)
        for i, term in enumerate(terms):
            if not isinstance(term, _TERMS):
                raise ValueError(f"terms[{i}]: expected a load term (the terms of a Load made by Load.harmonic, "
                                 f"Load.series, Load.expression or Load.from_file), got {_short(term)}")
        object.__setattr__(self, "terms", terms)
        object.__setattr__(self, "amplitude", real("amplitude", amplitude))

    def __setattr__(self, name, value):
        raise AttributeError("Load is immutable: use with_parameters")

    # -- the shapes ---------------------------------------------------------------------

    @classmethod
    def harmonic(cls, amplitude, omega: float, phase: float = 0.0, *, t_end: float | None = None) -> Load:
        """f(t) = amplitude * sin(omega t + phase); ``amplitude`` a vector over the coordinates. With ``t_end``
        the term acts for t <= t_end only and is 0 after (a pulse such as p0 sin(pi t / t_d) for t <= t_d). Where
        sin(omega t_end + phase) != 0 the load jumps at t_end, and a jump limits every fixed-step method to order
        1 (baoab, whose kicks sit at the step ends, even where t_end is a step end); end it at a zero of the sine
        for a kink only (order 2)."""
        return cls([T.Harmonic(T.direction("amplitude", amplitude), real("omega", omega), T.phase_value(phase),
                               t_end=T.end_time("t_end", t_end))])

    @classmethod
    def series(cls, t, values, direction=None, *, hold: bool = False) -> Load:
        """Piecewise-linear through (t[k], values[k]): ``values`` a scalar history (T,) times
        ``direction``, or a vector per time (T, n) with no direction. Zero outside [t[0], t[-1]],
        or the end values there with ``hold=True``."""
        t = T.times("t", t)
        values = T.history("values", values, t.size)
        if values.ndim == 2 and direction is not None:
            raise ValueError("direction: values given as a vector per time (shape (T, n)) take no direction")
        hold = flag("hold", hold)
        return cls([T.Series(t, values, T.direction("direction", direction), hold)])

    @classmethod
    def expression(cls, text: str, parameters: Mapping[str, float] | None = None, direction=None) -> Load:
        """s(t) from ``text``, an expression of ``t`` and the ``parameters`` (parsed by raydamp's own
        parser, compiled to machine code), times ``direction``."""
        if parameters is not None and not isinstance(parameters, Mapping):  # dict([1]): "dictionary update ..."
            raise ValueError(f"parameters must be a dict of parameter values (e.g. {{'a': 1.0}}), got "
                             f"{_short(parameters)}")
        parameters = dict(parameters or {})
        for name, value in parameters.items():
            if not isinstance(name, str) or not name.isidentifier() or name in ("t", "pi"):
                raise ValueError(f"parameters: {_short(name)} is not a parameter name (t and pi are taken)")
            parameters[name] = real(f"parameters.{name}", value)
        expr = parse(text, field="expression", names={"t": "time", **{k: "parameter" for k in parameters}})
        unused = sorted(set(parameters) - expr.names)
        if unused:
            raise ValueError(f"parameters: {', '.join(unused)} not used by the expression")
        _compiled(expr, tuple(sorted(parameters.items())))  # refuses an expression undefined at its parameters
        return cls([T.ExpressionTerm(expr, parameters, T.direction("direction", direction))])

    @classmethod
    def from_file(cls, path, direction=None, factor: float = 1.0, *, dt: float | None = None,
                  hold: bool = False) -> Load:
        """A record read from ``path``: a PEER NGA ``.AT2`` file (NPTS and DT from its header, values
        in the file's units, usually g: give ``factor=9.81`` for m/s^2), a text/CSV file of two
        columns t, value, or a ``.npy`` array of shape (T, 2) (or (T,) with ``dt``). Times ``factor``."""
        t, values = read_record(path, dt=dt)
        load = cls.series(t, values * real("factor", factor), direction, hold=hold)
        term = load.terms[0]
        return cls([T.Series(term.t, term.values, term.direction, term.hold, source=Path(path).name)])

    # -- algebra ------------------------------------------------------------------------

    def __add__(self, other) -> Load:
        if isinstance(other, (int, float)) and other == 0:
            return self  # sum([a, b]) starts from 0
        if not isinstance(other, Load):
            return NotImplemented
        return Load(self._scaled_terms() + other._scaled_terms())

    __radd__ = __add__

    def __mul__(self, factor) -> Load:
        if isinstance(factor, bool) or not isinstance(factor, (int, float, np.floating, np.integer)):
            return NotImplemented
        return Load(self.terms, self.amplitude * real("factor", factor))

    __rmul__ = __mul__

    def _scaled_terms(self) -> tuple:
        return self.terms if self.amplitude == 1.0 else tuple(T.scaled(t, self.amplitude) for t in self.terms)

    # -- parameters ---------------------------------------------------------------------

    @property
    def parameters(self) -> dict[str, float]:
        """The values a sweep or :meth:`with_parameters` may set."""
        out: dict[str, float] = {"amplitude": self.amplitude}
        harmonic = [t for t in self.terms if isinstance(t, T.Harmonic)]
        if harmonic and len({t.omega for t in harmonic}) == 1:
            out["omega"] = harmonic[0].omega
        if harmonic and len({t.phase for t in harmonic}) == 1:
            out["phase"] = harmonic[0].phase
        for term in self.terms:
            if isinstance(term, T.ExpressionTerm):
                out.update(term.parameters)
        return out

    def with_parameters(self, **values) -> Load:
        """The same load with the given parameters (names from :attr:`parameters`)."""
        known = self.parameters
        for name in values:
            if name not in known:
                raise ValueError(f"load.{name}: this load has no parameter {name!r} (it has: "
                                 f"{', '.join(sorted(known))})")
        terms = []
        for term in self.terms:
            if isinstance(term, T.Harmonic):
                changes = {}
                if "omega" in values:
                    changes["omega"] = real("load.omega", values["omega"])
                if "phase" in values:
                    changes["phase"] = T.phase_value(values["phase"])
                term = T.Harmonic(term.direction, changes.get("omega", term.omega), changes.get("phase", term.phase),
                                  term.scale, term.t_end)
            elif isinstance(term, T.ExpressionTerm):
                mine = {k: real(f"load.{k}", v) for k, v in values.items() if k in term.parameters}
                if mine:
                    parameters = {**term.parameters, **mine}
                    _compiled(term.expression, tuple(sorted(parameters.items())))
                    term = T.ExpressionTerm(term.expression, parameters, term.direction, term.scale)
            terms.append(term)
        return Load(terms, real("load.amplitude", values["amplitude"]) if "amplitude" in values else self.amplitude)

    # -- meeting a model ----------------------------------------------------------------

    def bind(self, model) -> Any:
        """The compiled form the core runs with ``model``: each direction checked against its
        coordinates (``load.direction``), a ground motion's -M r computed from its mass."""
        n = model.dim
        core_terms, owners = [], []
        for term in self._scaled_terms():
            d = term.direction
            vector = None
            if isinstance(d, T.Ground):
                vector = -np.asarray(model.mass_product(_length("ground_motion.direction", d.r, n)), dtype=float)
            elif d is not None:
                vector = _length("load.direction" if not isinstance(term, T.Harmonic) else "load.amplitude", d, n)
            elif not (isinstance(term, T.Series) and term.values.ndim == 2):
                raise ValueError("load.direction: needed (a vector over the coordinates) for a scalar history")
            if isinstance(term, T.Series) and term.values.ndim == 2 and term.values.shape[1] != n:
                raise ValueError(f"load.values: rows of {term.values.shape[1]} values, the model has {n} coordinates")
            if isinstance(term, T.ExpressionTerm):
                fn, address = _compiled(term.expression, tuple(sorted(term.parameters.items())))
                owners.append(fn)
                core_terms.append(term.core(vector, address))
            else:
                core_terms.append(term.core(vector))
            if isinstance(d, T.Ground):  # r itself, so that r a_g(t) can be added back (an absolute acceleration)
                r = _length("ground_motion.direction", d.r, n)
                core_terms[-1]["ground_index"] = np.flatnonzero(r).astype(np.int32)
                core_terms[-1]["ground_value"] = np.asarray(r, dtype=float)[np.flatnonzero(r)]
        return _core.Load(n, core_terms, owners)

    def values(self, model, t) -> np.ndarray:
        """f(t) for ``model`` at the times t (a number or a 1-D array): (len(t), n)."""
        try:
            times = np.atleast_1d(np.asarray(t, dtype=float))
        except (TypeError, ValueError):
            times = None
        if times is None or times.ndim != 1:  # a 2-D t reached the binding: its TypeError
            raise ValueError(f"t must be a time or a 1-D array of times, got {_short(t)}")
        return self.bind(model).values(times.tolist())

    # -- JSON ---------------------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        """The JSON form: {"terms": [...], "amplitude": a} with each term {"harmonic"|"series"|"expression": {...}}."""
        out: dict[str, Any] = {"terms": [t.plain() for t in self.terms]}
        if self.amplitude != 1.0:
            out["amplitude"] = self.amplitude
        return out

    def ground_part(self) -> Load:
        """The ground motions' r a_g(t), as a load (what turns a relative acceleration absolute)."""
        return Load([replace(t, direction=t.direction.r) for t in self._scaled_terms()
                     if isinstance(t.direction, T.Ground)])

    @classmethod
    def from_dict(cls, plain: Mapping[str, Any], *, name: str = "load", files=None) -> Load:
        """The load of a JSON form (raydamp.loads.forms.LoadInput): ``{"terms": [term, ...], "amplitude": a}``
        or one term, each ``{"harmonic": {"amplitude", "omega", "phase"}}``, ``{"series": {"t", "values",
        "direction", "hold"}}``, ``{"expression": {"expression", "parameters", "direction"}}`` or ``{"file":
        {"path" | "id", "direction", "factor", "dt", "hold"}}``; a direction ``{"ground": r}`` is a ground
        motion's -M r. ``files`` maps an uploaded file's id to its path or its parsed (t, values) (a service's
        uploads). A ValueError names the path of the bad field, starting with ``name``."""
        return cls.from_form(load_input(plain, name), files, name)

    @classmethod
    def from_form(cls, form, files=None, name: str = "load") -> Load:
        """The load of a validated form (a LoadInput), built through this class's constructors."""
        return form.build(cls, files, name)

    @property
    def is_ground_motion(self) -> bool:
        return any(isinstance(t.direction, T.Ground) for t in self.terms)

    def __repr__(self) -> str:
        kinds = ", ".join(type(t).__name__.replace("Term", "").lower() for t in self.terms)
        extra = f", amplitude={self.amplitude!r}" if self.amplitude != 1.0 else ""
        return f"Load([{kinds}]{extra})"


def set_load_parameters(plain: dict[str, Any], values: Mapping[str, Any]) -> dict[str, Any]:
    """A load's JSON form (Load.to_dict) with parameters set: amplitude, omega and phase of its
    harmonic terms, its expressions' parameters."""
    out = {**plain, "terms": [{kind: dict(body) for kind, body in term.items()} for term in plain["terms"]]}
    for name, value in values.items():
        if name == "amplitude":
            out["amplitude"] = value
            continue
        for term in out["terms"]:
            if "harmonic" in term and name in ("omega", "phase"):
                term["harmonic"][name] = value
            elif "expression" in term and name in term["expression"].get("parameters", {}):
                term["expression"]["parameters"] = {**term["expression"]["parameters"], name: value}
    return out


def _length(name: str, vector: np.ndarray, n: int) -> np.ndarray:
    if vector.size != n:
        raise ValueError(f"{name}: length {vector.size}, the model has {n} coordinates")
    return vector


@functools.lru_cache(maxsize=256)
def _compiled(expr, parameters: tuple[tuple[str, float], ...]) -> tuple[Any, tuple[int, int]]:
    """s(t) compiled (SymEngine's LLVM JIT), with the parameters substituted: (owner, (function, data))."""
    t = se.Symbol("t")
    body = expr.to_symengine({"t": t, **dict(parameters)})
    if not body.free_symbols <= {t}:
        raise ValueError(f"expression: uses {', '.join(sorted(map(str, body.free_symbols - {t})))} "
                         "without a value")
    fn = se.Lambdify([t], [body], backend="llvm", cse=True, real=True)
    cfunc, data = fn.as_ctypes()
    return fn, (ctypes.cast(cfunc, ctypes.c_void_p).value, data.value or 0)
