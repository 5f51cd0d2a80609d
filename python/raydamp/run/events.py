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
"""

from __future__ import annotations

import functools
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import _core

__all__ = ["Event", "EventTable", "prepare", "results", "dense_bytes"]

_DIRECTIONS = (-1, 0, 1)
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
        and ``q[i]``, ``p[i]`` (see :mod:`raydamp.run.events`).
    direction : +1 counts only g rising through 0, -1 only falling, 0 (default) both.
    terminal : the run ends at the first such crossing, its last step shortened to land on it
        (status "event", the event's name in the message).
    name : the name in ``Solution.events`` (default ``event<i>``, i its place in the list).
    """

    g: str
    direction: int = 0
    terminal: bool = False
    name: str | None = None

    def __post_init__(self) -> None:
        if isinstance(self.direction, bool) or self.direction not in _DIRECTIONS:
            raise ValueError(f"direction must be -1, 0 or +1, got {self.direction!r}")
        if not isinstance(self.terminal, bool):
            raise ValueError(f"terminal must be True or False, got {self.terminal!r}")
        if self.name is not None and (not isinstance(self.name, str) or not self.name):
            raise ValueError(f"name must be a non-empty string or None, got {self.name!r}")
        if callable(self.g):
            raise ValueError("g: a Python callable is not taken (the step loop runs without Python); write g as "
                             "an expression, e.g. \"q[0] - 0.1\"")
        if not isinstance(self.g, str):
            raise ValueError(f"g must be an expression (a string), got {type(self.g).__name__}")

    def to_dict(self) -> dict[str, Any]:
        """The event as the job JSON writes it."""
        out: dict[str, Any] = {"g": self.g, "direction": self.direction, "terminal": self.terminal}
        if self.name is not None:
            out["name"] = self.name
        return out


class EventTable:
    """Every crossing a run found, in time order: ``name`` (n,), ``event`` (index into the list given),
    ``direction`` (+1 rising, -1 falling), ``t`` (n,), and ``q``, ``p`` (n, dim) on the interpolant there.
    ``table["vertical"]`` is the sub-table of one event; ``len(table)`` the crossings."""

    def __init__(self, names: Sequence[str], event: np.ndarray, direction: np.ndarray, t: np.ndarray,
                 q: np.ndarray, p: np.ndarray, member: np.ndarray | None = None):
        self.member = None if member is None else np.asarray(member, dtype=np.int64)  # an ensemble's table
        self.names = tuple(names)
        self.event = np.asarray(event, dtype=np.int64)
        self.direction = np.asarray(direction, dtype=np.int64)
        self.t, self.q, self.p = t, q, p

    @property
    def name(self) -> np.ndarray:
        return np.array([self.names[i] for i in self.event], dtype=object)

    def __len__(self) -> int:
        return len(self.t)

    def __getitem__(self, name: str) -> EventTable:
        if name not in self.names:
            raise KeyError(f"no event named {name!r} (events: {', '.join(self.names)})")
        return self._rows(self.event == self.names.index(name))

    def of_member(self, i: int) -> EventTable:
        """An ensemble member's crossings (its single run's table)."""
        rows = self._rows(self.member == i)
        rows.member = None
        return rows

    def _rows(self, rows: np.ndarray) -> EventTable:
        return EventTable(self.names, self.event[rows], self.direction[rows], self.t[rows], self.q[rows],
                          self.p[rows], None if self.member is None else self.member[rows])

    def to_dict(self) -> dict[str, list]:
        """Plain lists (JSON): name, t, direction, q, p per crossing."""
        return {"name": [str(n) for n in self.name], "t": self.t.tolist(), "direction": self.direction.tolist(),
                "q": self.q.tolist(), "p": self.p.tolist()}

    def summary(self, limit: int = 1000) -> dict[str, Any]:
        """The summary's form (raydamp.jobs.summary.EventsSummary): count, and name, t, direction of the
        first ``limit`` crossings."""
        return {"count": len(self), "name": [str(n) for n in self.name[:limit]], "t": self.t[:limit].tolist(),
                "direction": self.direction[:limit].tolist()}

    def __repr__(self) -> str:
        return f"EventTable({len(self)} crossings of {', '.join(self.names)})"


@dataclass(frozen=True)
class Prepared:
    """What integrate hands the core (``core``: an EventSet or None; ``dense``), and what it keeps to read
    the results: the names, and the compiled functions that the core's set points into."""

    core: Any
    dense: bool
    names: tuple[str, ...]
    events: tuple[Event, ...]
    owners: tuple[Any, ...]


def dense_bytes(n_steps: int, dim: int) -> int:
    """Bytes of dense output over n_steps steps: t, q, p, M^-1 p and pdot at every step end (float64)."""
    return 8 * (n_steps + 1) * (1 + 4 * dim)


def prepare(model, events, dense, *, temperature: float) -> Prepared | None:
    """The run's events and dense output checked and compiled, or None when it asks for neither."""
    if events is None and dense is False:
        return None
    if not isinstance(dense, bool):
        raise ValueError(f"dense must be True or False, got {dense!r}")
    asked = events is not None
    if events is None:
        events = ()
    if isinstance(events, (str, Event, Mapping)) or not isinstance(events, Sequence):
        raise ValueError("events must be a list of raydamp.Event (or of dicts with g, direction, terminal, name)")
    checked = tuple(_event(i, e) for i, e in enumerate(events))
    if temperature > 0 and (checked or dense):
        what = "events" if checked else "dense"
        raise ValueError(f"{what}: a run at a temperature has no dense output (its path is not differentiable "
                         "between step ends, so no interpolant has an order); run without temperature")
    names = tuple(e.name or f"event{i}" for i, e in enumerate(checked))
    if len(set(names)) != len(names):
        raise ValueError("events: two events share a name")
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
    if checked:
        keys = tuple(_key(model, e.g, f"events[{i}].g") for i, e in enumerate(checked))
        fn, address, data, slots = _compile(keys)
        owners.append(fn)
        core.set_function(address, data, slots)
        for i, e in enumerate(checked):
            core.add(e.direction, e.terminal, names[i])
    return Prepared(core, dense, names, checked, tuple(owners))


def _event(i: int, e) -> Event:
    if isinstance(e, Event):
        return e
    if isinstance(e, Mapping):
        unknown = sorted(set(e) - {"g", "direction", "terminal", "name"})
        if unknown:
            raise ValueError(f"events[{i}]: unknown key(s) {', '.join(map(repr, unknown))} (g, direction, terminal, "
                             "name)")
        if "g" not in e:
            raise ValueError(f"events[{i}].g: required")
        try:
            return Event(e["g"], e.get("direction", 0), e.get("terminal", False), e.get("name"))
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
    outputs = []
    for g in parsed:
        derivative = se.Integer(0)
        for symbol in g.free_symbols:
            derivative += se.diff(g, symbol) * rates.get(symbol, se.Integer(1))  # t's rate is 1
        outputs += [g, derivative]
    try:
        fn, address, data = _jit(inputs, outputs, ("events",))
    except ValueError as error:  # SpecError: named by the path given
        raise ValueError(str(error)) from None
    return fn, address, data, slots


def _parameters(model) -> Mapping[str, Any]:
    try:
        return model.parameters
    except (AttributeError, ValueError):
        return {}


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(float(v))


def results(prepared: Prepared, out: Mapping[str, Any]) -> dict[str, Any]:
    """The Solution's events table and dense output from the core's answer."""
    found = {}
    if prepared.core is not None:
        e = out["events"]
        found["events"] = EventTable(prepared.names, e["event"], e["direction"], e["t"], e["q"], e["p"],
                                     e.get("member"))
    if prepared.dense:
        from ..results.dense import DenseOutput

        found["dense"] = DenseOutput(**out["dense"])
    return found
