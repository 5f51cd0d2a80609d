"""Events: the times at which g(t, q, p) crosses zero, located on each step's dense output.

``raydamp.integrate(..., events=[raydamp.Event("q[0]", direction=-1, terminal=True, name="vertical")])``
evaluates every g at every step end. Where g changes sign over a step, or its rate dg/dt does (an
extremum inside the step: a touch, or two crossings within one step), the crossing is located on the
step's cubic Hermite interpolant (``Solution.at``: q on (q, M^-1 p), p on (p, pdot)) by a bracketing
root finder, to a few roundings of t. The interpolant is fourth order in h, so an event's time has
the method's order up to 4 (order-6 and order-8 compositions give order 4 here).

Events never change the stepped trajectory: they run whole steps (as ``dense=True`` does), and
watching a step reads its end without touching it. A run that merges sub-flows between steps (3s,
2s, sv and their compositions, when nothing is saved in between) differs from its whole-step run by
rounding only. ``events=[]`` runs whole steps and watches nothing: a run with events equals it bit for
bit (and equals the run without events for methods that step whole steps anyway: rk, heun, rk4, the
implicit methods).

An ensemble (``integrate_ensemble(..., events=[...])``) locates each member's events as its single run
does; a terminal event stops that member only. g's parameters take the base model's values.

g is an expression, parsed by raydamp's own parser (never evaluated as Python) and compiled like a
System's functions, in the names:

- ``t``; the model's parameters (numbers);
- a System's coordinate names and ``p_<name>`` for their momenta;
- ``q[i]`` and ``p[i]`` for any model (a Chain's site i, a LinearStructure's degree of freedom i).

Its rate dg/dt is derived symbolically, and every event's g and rate are compiled into one function,
which the step loop calls once per step end, without Python. A step where every g and its rate keep
their signs costs that call and a branch-free scan; the root finder runs only where one changes sign.
An affine g (a level of q, a drift, a clock) needs no call: levels of one form share one sum, and where
no g reads p only the steps that may hold a crossing are observed: on a model of fixed size (the damped
pendulum) the loop stores each step's end and a block of them is screened at once, four to a vector;
elsewhere the loop screens each step inline.
"""

from __future__ import annotations

import functools
import math
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import _core
from ..results.event_table import EventTable

__all__ = ["Event", "EventTable", "event_list", "prepare", "results", "dense_bytes"]

_DIRECTIONS = (-1, 0, 1)
_REFINES = (None, "henon")
# q[3] -> q_3_: the same length, so the parser's columns still point into the text as written.
_INDEXED = re.compile(r"\b([qp])\[\s*(\d+)\s*\]")
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_SLOT_KINDS = {"t": 0, "q": 1, "p": 2, "v": 3, "f": 4}  # events/types.hpp, EventSlot::Kind


@dataclass(frozen=True)
class Event:
    """An event: the zeros of ``g``.

    Parameters
    ----------
    g : an expression in ``t``, the model's parameters, a System's coordinate names and ``p_<name>``,
        and ``q[i]``, ``p[i]`` (see :mod:`raydamp.run.events`). Or a Python callable ``g(t, q, p)``, slower:
        called after the run on its dense output with every step end at once (t (K,), q and p (K, n)),
        returning (K,) values; see :mod:`raydamp.run.events_python`. Not terminal, not refined, not in
        ensembles; a touch inside one step is not found (there is no rate to check).
    direction : +1 counts only g rising through 0, -1 only falling, 0 (default) both.
    terminal : the run ends at the first such crossing, its last step shortened to land on it
        (status "event", the event's name in the message).
    name : the name in ``Solution.events`` (default ``event<i>``, i its place in the list).
    refine : None (default): the crossing is where g is zero on the step's interpolant. ``"henon"``: Hénon's
        step for a section (a Poincaré section): from the stepped state at an end of the crossing step, the
        system is integrated with g itself as the independent variable (classical Runge-Kutta in g, four
        sub-steps, then polished), landing on g = 0 to rounding. The point (t, q, p) is then the flow's own
        crossing from a stepped state, within a few 1e-13 relative at h = 0.01 on a smooth flow: not the
        interpolant's (fourth order in h whatever the method). It costs about 20 force evaluations per
        crossing, none per step. Not with ``terminal=True`` (a terminal event's run ends on its
        interpolated time); where dg/dt vanishes on the way (a touch) the interpolant's point is kept.
    """

    g: str | Callable[[np.ndarray, np.ndarray, np.ndarray], Any]
    direction: int = 0
    terminal: bool = False
    name: str | None = None
    refine: str | None = None

    def __post_init__(self) -> None:
        if isinstance(self.direction, bool) or self.direction not in _DIRECTIONS:
            raise ValueError(f"direction must be -1, 0 or +1, got {self.direction!r}")
        if not isinstance(self.terminal, bool):
            raise ValueError(f"terminal must be True or False, got {self.terminal!r}")
        if self.name is not None and (not isinstance(self.name, str) or not self.name):
            raise ValueError(f"name must be a non-empty string or None, got {self.name!r}")
        if callable(self.g):
            if self.terminal:
                raise ValueError("terminal: a Python callable g is found after the run, on its dense output, so "
                                 "it cannot end the run; write g as an expression, e.g. \"q[0] - 0.1\"")
            if self.refine is not None:
                raise ValueError("refine: Hénon's step needs g compiled; write g as an expression")
        elif not isinstance(self.g, str):
            raise ValueError(f"g must be an expression (a string) or a callable g(t, q, p), got "
                             f"{type(self.g).__name__}")
        if self.refine not in _REFINES:
            raise ValueError(f"refine must be None or 'henon', got {self.refine!r}")
        if self.refine is not None and self.terminal:
            raise ValueError("refine: Hénon's step refines the points of a section (terminal=False); a terminal "
                             "event ends the run on its interpolated time")

    def to_dict(self) -> dict[str, Any]:
        """The event as the job JSON writes it (a callable g as its name only: no JSON runs it again)."""
        g = f"<Python callable {getattr(self.g, '__name__', 'g')}>" if callable(self.g) else self.g
        out: dict[str, Any] = {"g": g, "direction": self.direction, "terminal": self.terminal}
        if self.name is not None:
            out["name"] = self.name
        if self.refine is not None:
            out["refine"] = self.refine
        return out


@dataclass(frozen=True)
class Prepared:
    """What integrate hands the core (``core``: an EventSet or None; ``dense``), and what it keeps to read
    the results: the names, and the compiled functions that the core's set points into."""

    core: Any
    dense: bool
    names: tuple[str, ...]
    events: tuple[Event, ...]
    owners: tuple[Any, ...]
    compiled: tuple[int, ...] = ()  # the core's event i is events[compiled[i]]
    kept_dense: bool = False  # whether the caller asked for dense output (else kept for a callable g only)

    @property
    def callables(self) -> tuple[int, ...]:
        """The events whose g is a Python callable (found after the run: run/events_python.py)."""
        return tuple(i for i, e in enumerate(self.events) if callable(e.g))


def dense_bytes(n_steps: int, dim: int) -> int:
    """Bytes of dense output over n_steps steps: t, q, p, M^-1 p and pdot at every step end (float64)."""
    return 8 * (n_steps + 1) * (1 + 4 * dim)


def prepare(model, events, dense, *, temperature: float, callables: bool = True) -> Prepared | None:
    """The run's events and dense output checked and compiled, or None when it asks for neither. A callable
    g makes the run keep dense output (found on it after the run); callables=False refuses one."""
    if events is None and dense is False:
        return None
    if not isinstance(dense, bool):
        raise ValueError(f"dense must be True or False, got {dense!r}")
    asked = events is not None
    if events is None:
        events = ()
    checked = event_list(events)
    if temperature > 0 and (checked or dense):
        what = "events" if checked else "dense"
        raise ValueError(f"{what}: a run at a temperature has no dense output (its path is not differentiable "
                         "between step ends, so no interpolant has an order); run without temperature")
    names = tuple(e.name or f"event{i}" for i, e in enumerate(checked))
    if len(set(names)) != len(names):
        raise ValueError("events: two events share a name")
    refined = [i for i, e in enumerate(checked) if e.refine]
    if refined and getattr(model, "springs", None):
        # Hénon's step evaluates the force off the stepped path, where the springs' materials have no state.
        raise ValueError(f"events[{refined[0]}].refine: Hénon's step on a Structure with springs is not supported; "
                         "leave refine unset (the crossing on the step's interpolant)")
    python = [i for i, e in enumerate(checked) if callable(e.g)]
    if python and not callables:
        raise ValueError(f"events[{python[0]}].g: an ensemble takes no Python callable g (it is found on a single "
                         "run's dense output); write g as an expression")
    terminal = [i for i, e in enumerate(checked) if e.terminal]
    if terminal and getattr(model, "springs", None):
        # The shortened last step would run again from the step's start, but the springs' materials have
        # committed the whole step by then: their state would not be the step's start.
        raise ValueError(f"events[{terminal[0]}].terminal: a terminal event on a Structure with springs is not "
                         "supported yet; watch the event without terminal=True and stop at its time")
    # An empty list still hands the core a set: the run steps whole steps with nothing watched (the
    # baseline events are compared with, bit for bit and in time).
    core = _core.EventSet() if asked else None
    owners = []
    compiled = tuple(i for i, e in enumerate(checked) if not callable(e.g))
    if compiled:
        keys = tuple(_key(model, checked[i].g, f"events[{i}].g") for i in compiled)
        fn, address, data, slots, affine = _compile(keys)
        owners.append(fn)
        core.set_function(address, data, slots)
        for k, i in enumerate(compiled):
            e = checked[i]
            terms, constant = affine[k] or (None, 0.0)
            core.add(e.direction, e.terminal, names[i], terms=terms, constant=constant,
                     **({"henon": True} if e.refine == "henon" else {}))
    return Prepared(core, dense or bool(python), names, checked, tuple(owners), compiled, dense)


def event_list(events) -> tuple[Event, ...]:
    """events (a list of Event, or of dicts with g, direction, terminal, name, refine) as Events; a ValueError
    names events[i] (the expressions are checked against a model by prepare)."""
    if isinstance(events, (str, Event, Mapping)) or not isinstance(events, Sequence):
        raise ValueError("events must be a list of raydamp.Event (or of dicts with g, direction, terminal, name)")
    return tuple(_event(i, e) for i, e in enumerate(events))


def _event(i: int, e) -> Event:
    if isinstance(e, Event):
        return e
    if isinstance(e, Mapping):
        unknown = sorted(set(e) - {"g", "direction", "terminal", "name", "refine"})
        if unknown:
            raise ValueError(f"events[{i}]: unknown key(s) {', '.join(map(repr, unknown))} (g, direction, terminal, "
                             "name, refine)")
        if "g" not in e:
            raise ValueError(f"events[{i}].g: required")
        try:
            return Event(e["g"], e.get("direction", 0), e.get("terminal", False), e.get("name"), e.get("refine"))
        except ValueError as error:
            raise ValueError(f"events[{i}].{error}") from None
    raise ValueError(f"events[{i}] must be a raydamp.Event or a dict, got {type(e).__name__}")


def _key(model, g: str, field: str):
    """What g compiles from on model: its text (q[i] written q_i_), its names' kinds, the slot of each
    coordinate, momentum or t, and the parameters' values; a hashable tuple (compiled once per tuple)."""
    text = _INDEXED.sub(lambda m: f"{m.group(1)}_{m.group(2)}_", g) if isinstance(g, str) else g
    dim = model.dim
    kinds: dict[str, str] = {}
    index: dict[str, tuple[str, int]] = {}
    constants: dict[str, float] = {}
    coordinates = model.coordinates if dim <= 10_000 else ()
    positions = {c: i for i, c in enumerate(coordinates)} if coordinates else {}
    parameters = {k: v for k, v in _parameters(model).items() if _is_number(v)}
    for name in set(_NAME.findall(text)):
        found = _INDEXED_NAME.fullmatch(name)
        if name == "t":
            kinds[name], index[name] = "time", ("t", 0)
        elif found and int(found.group(2)) < dim:
            kinds[name], index[name] = "coordinate", (found.group(1), int(found.group(2)))
        elif name in positions:
            kinds[name], index[name] = "coordinate", ("q", positions[name])
        elif name.startswith("p_") and name[2:] in positions:
            kinds[name], index[name] = "momentum", ("p", positions[name[2:]])
        elif name in parameters:
            kinds[name], constants[name] = "parameter", float(parameters[name])
    for name in set(_NAME.findall(text)):
        found = _INDEXED_NAME.fullmatch(name)
        if found and int(found.group(2)) >= dim:
            raise ValueError(f"{field}: {found.group(1)}[{found.group(2)}] is not a coordinate (0..{dim - 1})")
    return text, field, tuple(sorted(kinds.items())), tuple(sorted(index.items())), tuple(sorted(constants.items()))


_INDEXED_NAME = re.compile(r"([qp])_(\d+)_")


@functools.lru_cache(maxsize=128)
def _compile(keys):
    """Every event's g and dg/dt in one compiled function (one call per step end however many events):
    (the function, its address and data, its slots: (kind, index) per input, events/types.hpp)."""
    import symengine as se

    from ..systems.expressions import parse
    from ..systems.system.compile import _jit, number

    parsed = []
    used: dict[tuple[str, int], se.Symbol] = {}
    for text, field, kinds, index, constants in keys:
        index, constants = dict(index), dict(constants)
        expr = parse(text, field=field, names=dict(kinds))
        symbols: dict[str, Any] = {}
        for name in expr.names:
            if name in constants:
                symbols[name] = number(constants[name])
            else:
                kind, i = index[name]
                symbols[name] = used.setdefault((kind, i), se.Symbol(f"_{kind}{i}"))
        if not any(name not in constants for name in expr.names):
            raise ValueError(f"{field}: g is a constant; it names no coordinate, momentum or t")
        parsed.append(expr.to_symengine(symbols))
    inputs, slots, rates = [], [], {}
    for (kind, i), symbol in sorted(used.items()):
        inputs.append(symbol)
        slots.append((_SLOT_KINDS[kind], i))
        if kind != "t":  # q's rate is v = M^-1 p, p's the force f
            rate_kind = "v" if kind == "q" else "f"
            rates[symbol] = se.Symbol(f"_{rate_kind}{i}")
            inputs.append(rates[symbol])
            slots.append((_SLOT_KINDS[rate_kind], i))
    kind_of = {symbol: key for key, symbol in used.items()}
    outputs, affine = [], []
    for g in parsed:
        derivative = se.Integer(0)
        slopes = {}
        for symbol in g.free_symbols:
            slopes[symbol] = se.diff(g, symbol)
            derivative += slopes[symbol] * rates.get(symbol, se.Integer(1))  # t's rate is 1
        outputs += [g, derivative]
        affine.append(_affine(g, slopes, kind_of))
    try:
        fn, address, data = _jit(inputs, outputs, ("events",))
    except ValueError as error:  # SpecError: named by the path given
        raise ValueError(str(error)) from None
    return fn, address, data, slots, tuple(affine)


def _affine(g, slopes, kind_of):
    """g's (terms, constant) where g = constant + sum of coefficient * input, each term (slot kind, index,
    coefficient) with the input t, q_i or p_i; None where g is not affine (a slope that is not a number).
    The core then evaluates g without the compiled call and bounds it inside a step (events/watcher.hpp)."""
    if any(slope.free_symbols for slope in slopes.values()):
        return None
    terms = []
    for symbol, slope in slopes.items():
        kind, index = kind_of[symbol]
        terms.append((_SLOT_KINDS[kind], index, float(slope)))
    constant = float(g.subs({symbol: 0 for symbol in slopes}))
    if not all(math.isfinite(c) for c in (constant, *(c for *_, c in terms))):
        return None
    return tuple(sorted(terms)), constant


def _parameters(model) -> Mapping[str, Any]:
    try:
        return model.parameters
    except (AttributeError, ValueError):
        return {}


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(float(v))


def results(prepared: Prepared, out: Mapping[str, Any], *, ensemble: bool = False) -> dict[str, Any]:
    """The Solution's events table and dense output from the core's answer (an ensemble's: a dense output
    per member)."""
    found = {}
    if prepared.core is not None:
        e = out["events"]
        index = np.asarray(prepared.compiled, dtype=np.int64)[np.asarray(e["event"], dtype=np.int64)]
        found["events"] = EventTable(prepared.names, index, e["direction"], e["t"], e["q"], e["p"], e.get("member"))
    if prepared.dense:
        from ..results.dense import DenseOutput

        found["dense"] = (tuple(DenseOutput(**d) for d in out["dense"]) if ensemble
                          else DenseOutput(**out["dense"]))
    if prepared.callables:
        from .events_python import with_callables

        found["events"] = with_callables(found["events"], prepared, found["dense"])
        if not prepared.kept_dense:
            del found["dense"]
    return found
