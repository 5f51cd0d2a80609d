"""raydamp.sweep: a grid of runs cut into chunks of ensemble members, mapped over a Dask client.

Every chunk is one compiled :func:`raydamp.integrate_ensemble` call on a worker; the chunks
travel as plain data (the job JSON of the system, arrays of initial states and parameters)
and come back as arrays, gathered into one xarray Dataset or written to a Zarr store chunk
by chunk. Needs the ``sweep`` extra (dask[distributed], xarray, zarr).
"""

from __future__ import annotations

import ast
import json
import math
import numbers
import re
import sys
import threading
import uuid
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._core import __version__
from .._validation import MAX_SEED, _short, integer, real, replaceable_store, thermal, vector
from ..jobs import STEP_SIZE_ALIAS, JobSpec, job_arguments, model_from_spec
from ..loads import Load
from ..results.ensemble_solution import STATUSES
from ..systems.kinds import describe_model
from ..systems.models import MODELS, Model
from ..systems.system import System
from .choose_method import choose_method
from .cluster import local_cluster
from .ensemble import integrate_ensemble
from .events import event_list
from .integrate import MAX_SAVED_BYTES, CancelToken, _catalogue, span
from .save_grid import save_grid

__all__ = ["sweep", "check_sweep", "SweepPlan", "GridTooLarge", "parse_grid_item", "SPEC_KEYS", "RUN_ARGUMENTS"]

# The Python form of a sweep's spec: integrate's arguments and the model.
SPEC_KEYS = ("model", "system", "parameters", "q0", "p0", "method", "tableau", "composition", "h", "t_end", "load",
             "temperature", "seed", "stream", "n_steps", "save_every", "events")
# The integrate arguments a grid may vary; members differing in them run in different ensembles.
RUN_ARGUMENTS = ("method", "tableau", "composition", "h")
_STATE_COMPONENT = re.compile(r"^(q0|p0)\[(\d+)\]$")


def _base(spec: Mapping[str, Any]) -> tuple[Model, np.ndarray, np.ndarray, dict[str, Any]]:
    """(model, q0, p0, run options) from either form of the spec."""
    if not isinstance(spec, Mapping):
        raise ValueError("spec must be a dict of integrate's arguments (model, q0, p0, method, h, t_end ...) "
                         "or a job JSON object")
    if "initial_state" in spec:  # the job form (raydamp.jobs)
        if spec.get("work"):
            raise ValueError("work: a sweep does not record the damping work")
        model, q0, p0, options = job_arguments(spec)
        del options["work"]
        if options.get("save_dofs") is not None:
            raise ValueError("save_dofs: a sweep saves every coordinate; leave save_dofs out")
        if options.get("corrector") is not None:
            raise ValueError("corrector: a sweep's members run uncorrected (integrate_ensemble has no corrector); "
                             "run each point with raydamp.integrate(..., corrector=k)")
    else:
        unknown = [k for k in spec if k not in SPEC_KEYS]
        if unknown:
            raise ValueError(f"spec.{unknown[0]}: unknown key (known: {', '.join(SPEC_KEYS)}; or give the job "
                             f"JSON form: {', '.join(JobSpec.model_fields)})")
        model = spec.get("system", spec.get("model"))
        if isinstance(model, str):  # parameters may be left out (the defaults), as in the job JSON
            given = {} if spec.get("parameters") is None else {"parameters": spec["parameters"]}
            model = model_from_spec({"model": model, **given})
        elif isinstance(model, Mapping):
            model = model_from_spec({"system": model})
        elif not isinstance(model, Model):
            raise ValueError(f"spec.model: a built-in model's name ({', '.join(MODELS)}), a model or a System, "
                             f"got {model!r}")
        elif spec.get("parameters"):
            raise ValueError("spec.parameters: give parameters with a model's name, or build the model with them")
        for key in ("q0", "p0", "h"):
            if key not in spec:
                raise ValueError(f"spec.{key}: missing")
        q0, p0 = spec["q0"], spec["p0"]
        options = {k: spec[k] for k in ("method", "tableau", "composition", "h", "t_end", "n_steps", "save_every",
                                        "load", "temperature", "seed", "stream", "events") if spec.get(k) is not None}
        if "load" in options and not isinstance(options["load"], Load):
            raise ValueError(f"spec.load must be a raydamp.Load, got {type(options['load']).__name__}")
    if options.get("events") is not None:  # plain data (the workers rebuild each Event), checked here
        options["events"] = [e.to_dict() for e in event_list(options["events"])]
    if options.get("load") is not None:
        options["load"] = options["load"].to_dict()  # plain data: the workers rebuild it
    if options.get("temperature"):  # one seed for the whole grid: member k draws stream `stream + k`
        kT, seed, stream = thermal(options["temperature"], options.get("seed"), options.get("stream", 0))
        options.update({"temperature": kT, "seed": seed, "stream": stream})
    else:
        options.pop("stream", None)  # no noise: nothing is drawn
    if options.get("method") is None:  # a job without a method: chosen as integrate chooses (3s at a temperature)
        options["method"] = choose_method(model, None, options.get("tableau"), options.get("composition"),
                                          float(options["h"]), thermal=bool(options.get("temperature")))[0]
    options.setdefault("save_every", 1)
    if isinstance(model, System) and model._python is not None:
        raise ValueError("spec.system: a System built from Python functions cannot be sent to workers; "
                         "write its potential as an expression")
    return model, vector("q0", q0, model.dim), vector("p0", p0, model.dim), options


_RANGE_KEYS = ("start", "stop", "num", "scale")
# The axes of names; every other axis holds real numbers.
_NAME_AXES = ("method", "tableau", "composition")


def _range_num(name: str, spec: Mapping[str, Any]) -> int:
    """A range's num, its keys checked: how many values it gives, known before any is made."""
    unknown = [k for k in spec if k not in _RANGE_KEYS]
    if unknown:
        raise ValueError(f"grid.{name}.{unknown[0]}: unknown key (a range has {', '.join(_RANGE_KEYS)})")
    for key in ("start", "stop", "num"):
        if key not in spec:
            raise ValueError(f"grid.{name}.{key}: missing (a range is {{start, stop, num[, scale]}})")
    return integer(f"grid.{name}.num", spec["num"])


def _range(name: str, spec: Mapping[str, Any]) -> np.ndarray:
    """{"start", "stop", "num", "scale": "linear" | "log"}: num values from start to stop, both included."""
    num = _range_num(name, spec)
    start, stop = real(f"grid.{name}.start", spec["start"]), real(f"grid.{name}.stop", spec["stop"])
    scale = spec.get("scale", "linear")
    if scale == "linear":
        return np.linspace(start, stop, num)
    if scale == "log":
        if start <= 0 or stop <= 0:
            raise ValueError(f"grid.{name}: a log range needs start and stop > 0, got {start} and {stop}")
        return np.geomspace(start, stop, num)
    raise ValueError(f"grid.{name}.scale: expected \"linear\" or \"log\", got {scale!r}")


def parse_grid_item(text: str) -> tuple[str, Any]:
    """One command-line grid entry: ``name=start:stop:num`` (num values, ends included; append
    ``:log`` for a geometric range) or ``name=v1,v2,...`` (numbers, or names for method,
    composition and tableau). Returns (name, values) for :func:`sweep`'s ``grid``."""
    if not isinstance(text, str):  # None was an AttributeError (no partition)
        raise ValueError(f"text must be a string name=start:stop:num or name=v1,v2,..., got {_short(text)}")
    name, sep, values = text.partition("=")
    name = name.strip()
    if not sep or not name or not values.strip():
        raise ValueError(f"--grid {text!r}: expected name=start:stop:num or name=v1,v2,...")
    if ":" in values:
        parts = values.split(":")
        if len(parts) not in (3, 4) or (len(parts) == 4 and parts[3] not in ("linear", "log")):
            raise ValueError(f"--grid {text!r}: a range is name=start:stop:num or name=start:stop:num:log")
        try:
            start, stop, num = float(parts[0]), float(parts[1]), int(parts[2])
        except ValueError:
            raise ValueError(f"--grid {text!r}: start and stop must be numbers and num an integer") from None
        return name, {"start": start, "stop": stop, "num": num, "scale": parts[3] if len(parts) == 4 else "linear"}
    items = [v.strip() for v in values.split(",")]
    if name in ("method", "tableau", "composition"):
        return name, items
    try:
        return name, [float(v) for v in items]
    except ValueError:
        raise ValueError(f"--grid {text!r}: expected numbers separated by commas") from None


def _axis_length(name: str, values) -> int:
    """How many values an axis has, read without making them (a range's num), so that a grid's size is
    known before anything is allocated. A malformed axis counts 1 here: _axis then refuses it by name."""
    if isinstance(values, Mapping) and name not in _NAME_AXES:
        return _range_num(name, values)
    try:
        return len(values)
    except TypeError:
        return 1


def _axis(name: str, values) -> np.ndarray:
    if isinstance(values, Mapping) and name not in _NAME_AXES:
        values = _range(name, values)
    if name in _NAME_AXES:
        if isinstance(values, str) or not isinstance(values, (list, tuple, np.ndarray)):
            raise ValueError(f"grid.{name}: expected a list of names")
        out = np.array(["" if v is None else v for v in values], dtype=object)
        if any(not isinstance(v, str) for v in out):
            raise ValueError(f"grid.{name}: expected a list of names (or None)")
    else:
        _refuse_bools(name, values)
        try:
            out = np.asarray(values, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"grid.{name}: expected a list of real numbers") from None
        if out.ndim != 1:
            raise ValueError(f"grid.{name}: expected a 1-D list of values, got shape {out.shape}")
        if not np.isfinite(out).all():
            raise ValueError(f"grid.{name}: every value must be finite")
    if out.ndim != 1 or out.size == 0:
        raise ValueError(f"grid.{name}: expected a non-empty 1-D list of values")
    return out


def _refuse_bools(name: str, values) -> None:
    """A bool or a string in a numeric axis is refused, as integrate refuses h=True and h="0.1": np.asarray
    would read True as 1.0 and "0.1" as 0.1."""
    if isinstance(values, np.ndarray) and values.dtype.kind not in "iufO":
        what = "bools" if values.dtype.kind == "b" else str(values.dtype)
        raise ValueError(f"grid.{name}: expected a list of real numbers, got an array of {what}")
    if isinstance(values, (list, tuple)) or (isinstance(values, np.ndarray) and values.dtype == object):
        for i, v in enumerate(values):
            if isinstance(v, (bool, np.bool_)):
                raise ValueError(f"grid.{name}[{i}]: expected a real number, got the bool {bool(v)}")
            if not isinstance(v, numbers.Real):
                raise ValueError(f"grid.{name}[{i}]: expected a real number, got {_short(v)}")


class GridTooLarge(ValueError):
    """A grid of more members than the caller's ``max_members``, refused before any member was made.
    ``members`` is its count (the product of the axes' lengths), for a caller's own message."""

    def __init__(self, members: int, max_members: int):
        super().__init__(f"grid: {members} members (the product of the axes' lengths); at most max_members = "
                         f"{max_members}")
        self.members, self.max_members = members, max_members


def _member_bytes(model: Model, axes: int) -> int:
    """What the plan holds per member: q0 and p0, and per axis its column and the index that picks it,
    with the group number and the order that sorts the members (8-byte numbers)."""
    return 8 * (2 * model.dim + 2 * axes + 2)


def _check_size(members: int, model: Model, axes: int, max_members: int | None) -> None:
    """The grid's size, from its axes' lengths, before anything is built: a caller's bound, then the
    library's own (a grid whose members alone would not fit in memory comfortably)."""
    if max_members is not None and members > max_members:
        raise GridTooLarge(members, max_members)
    size = members * _member_bytes(model, axes)
    if size > MAX_SAVED_BYTES:
        raise ValueError(f"grid: {members} members (the product of the axes' lengths) would take "
                         f"{size / 2**30:.1f} GiB for their initial states and grid values alone (limit "
                         f"{MAX_SAVED_BYTES / 2**30:.0f} GiB); shrink the grid or split the sweep")


def _axis_names(model: Model, options: dict[str, Any], grid: Mapping[str, Any]) -> dict[str, str]:
    """{axis name: the key the client wrote} with each name checked; h's axis is named "h" whatever
    the client called it."""
    if not isinstance(grid, Mapping) or not grid:
        raise ValueError("grid must be a non-empty dict of name: values")
    known = dict(model.member_parameters())
    if options.get("load") is not None:  # the load's parameters sweep as "load.<name>" (load.omega: a response curve)
        known.update({f"load.{k}": 1 for k in Load.from_dict(options["load"]).parameters})
    labels = {}
    for name in grid:
        label = name
        if name == STEP_SIZE_ALIAS:  # h's former name, accepted for one release; errors say what the client wrote
            if "h" in grid:
                raise ValueError(f"grid.{name}: give the step size's axis once, as h")
            name = "h"
        state = _STATE_COMPONENT.match(name) if isinstance(name, str) else None
        if state and int(state.group(2)) >= model.dim:
            raise ValueError(f"grid.{name}: the model has {model.dim} coordinates")
        if not (state or name in RUN_ARGUMENTS or name in known):
            raise ValueError(f"grid.{name}: not a parameter of the model ({', '.join(known) or 'none'}), a run "
                             f"argument ({', '.join(RUN_ARGUMENTS)}) or an initial-state component (q0[i], p0[i])")
        if known.get(name, 1) > 1:
            raise ValueError(f"grid.{name}: sweep the components of {name} through a model per value instead")
        labels[name] = label
    return labels


def _axes(model: Model, options: dict[str, Any], grid: Mapping[str, Any],
          max_members: int | None) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """The grid's axes, {name: values}, and {name: the key the client wrote}. The member count is the
    product of the axes' lengths, so it is bounded before any axis, let alone any member, is made."""
    labels = _axis_names(model, options, grid)
    members = math.prod(_axis_length(label, grid[label]) for label in labels.values())
    _check_size(members, model, len(labels), max_members)
    return {name: _axis(label, grid[label]) for name, label in labels.items()}, labels


def _groups(axes: dict[str, np.ndarray], index: np.ndarray) -> tuple[np.ndarray, list[tuple]]:
    """Each member's group (the members sharing run arguments) and the groups' run-argument values, in
    the order the members first show them. Found over the combinations of the run axes alone, not
    member by member: a grid of many members and a few run arguments costs a few Python objects."""
    names = list(axes)
    run_names = [name for name in names if name in RUN_ARGUMENTS]
    if not run_names:
        return np.zeros(index.shape[1], dtype=np.intp), [()]
    sizes = [axes[name].size for name in run_names]
    # In lexicographic order, as the members (first axis slowest) first show each combination.
    combos = np.indices(sizes).reshape(len(run_names), -1)
    number: dict[tuple, int] = {}
    combo_group = np.array([number.setdefault(tuple(axes[name][combos[k, c]] for k, name in enumerate(run_names)),
                                              len(number)) for c in range(combos.shape[1])], dtype=np.intp)
    member_combo = np.ravel_multi_index(tuple(index[names.index(name)] for name in run_names), sizes)
    return combo_group[member_combo], list(number)


def _plan(options: dict[str, Any], axes: dict[str, np.ndarray], labels: dict[str, str]):
    """Members of the Cartesian product, ordered group by group (members of a group share the
    run arguments, so a group's chunks are ensembles); returns (columns, groups) with columns
    {grid name: per-member values} in that order and groups [(run options, start, stop)]."""
    names = list(axes)
    index = np.indices([values.size for values in axes.values()]).reshape(len(names), -1)
    group, distinct = _groups(axes, index)
    order = np.argsort(group, kind="stable")
    columns = {name: axes[name][index[k][order]] for k, name in enumerate(names)}
    del index
    counts = np.bincount(group, minlength=len(distinct))
    run_names = [name for name in names if name in RUN_ARGUMENTS]
    groups, start = [], 0
    names_catalogue, _ = _catalogue()
    for key, count in zip(distinct, counts.tolist()):
        run = dict(options)
        for name, value in zip(run_names, key):
            run[name] = (value or None) if name in ("tableau", "composition") else value
        if run["method"] not in names_catalogue:
            raise ValueError(f"method: unknown method {run['method']!r} (known: {', '.join(names_catalogue)})")
        run["h"] = real(f"grid.{labels['h']}" if "h" in run_names else "h", run["h"], positive=True)
        groups.append((run, start, start + count))
        start += count
    return columns, groups


def _grid_times(run: dict[str, Any]) -> np.ndarray:
    """The save grid of a run (the core's, save_grid)."""
    h, save_every = run["h"], integer("save_every", run["save_every"])
    n, h_last = span(h, run.get("t_end"), run.get("n_steps"))
    return save_grid(h, n, h_last, save_every)


# How often a running chunk asks the scheduler whether its sweep was cancelled (one small message).
_STOP_POLL_SECONDS = 0.25


def _watch_stop(name: str | None) -> tuple[CancelToken | None, threading.Event | None]:
    """For a chunk of a sweep: a CancelToken that a thread cancels once the sweep's distributed Event
    ``name`` is set (sweep sets it at a cancel, or when it ends by an error), so a running chunk stops
    within a poll and a few hundred steps instead of running to its end on the worker; and the
    threading.Event that ends the watch. (None, None) for a task without one (no name)."""
    if name is None:
        return None, None
    from distributed import Event, get_client

    stop = Event(name, client=get_client())  # the worker's client, resolved in the task's thread
    token, finished = CancelToken(), threading.Event()

    def watch() -> None:
        while not finished.is_set():
            try:
                if stop.wait(timeout=_STOP_POLL_SECONDS):
                    token.cancel()
                    return
            except BaseException:  # noqa: BLE001 - the client or scheduler closing (CancelledError included): nothing can stop it now
                return

    threading.Thread(target=watch, name="raydamp-sweep-stop", daemon=True).start()
    return token, finished


def _run_chunk(task: dict[str, Any]) -> dict[str, Any]:
    """A worker's part: one ensemble call; plain data in, arrays out."""
    model = model_from_spec(task["model"])
    run = task["run"]
    token, finished = _watch_stop(task.get("stop"))
    try:
        ens = _run_ensemble(model, task, run, token)
    except ValueError as error:
        raise _renumbered(error, task["start"]) from None
    finally:
        if finished is not None:
            finished.set()
    return {"start": task["start"], "t": ens.t, "q": ens.q, "p": ens.p, "energy": ens.energy,
            "momentum": ens.momentum, "rows": ens.rows, "t_final": ens.t_final, "q_final": ens.q_final,
            "p_final": ens.p_final, "energy_final": ens.energy_final, "momentum_final": ens.momentum_final,
            "steps": ens.steps, "failed_step": ens.failed_step,
            "status": np.array([STATUSES.index(s) for s in ens.status], dtype=np.int8),
            "max_momentum_drift": ens.max_momentum_drift,
            "messages": {str(task["start"] + i): m for i, (s, m) in enumerate(zip(ens.status, ens.message))
                         if s != "completed"},
            **(_member_events(ens.events, len(ens.status)) if ens.events is not None else {})}


# Crossings a sweep keeps per member (event_t etc. have this many columns; event_count says how many there were).
MAX_MEMBER_CROSSINGS = 64
_EVENT_VARIABLES = {  # with events: variable: (dims after member, dtype, fill), as _PER_MEMBER
    "event_count": ((), np.int64, 0), "event_t": (("crossing",), float, np.nan),
    "event_index": (("crossing",), np.int8, -1), "event_direction": (("crossing",), np.int8, 0),
}


def _member_events(table, members: int) -> dict[str, np.ndarray]:
    """An ensemble's events table as per-member arrays: each member's first MAX_MEMBER_CROSSINGS crossings'
    times, event indices (into the spec's events) and directions, padded (NaN, -1, 0), and its count."""
    out = {k: np.full((members, *((MAX_MEMBER_CROSSINGS,) if dims else ())), fill, dtype=dtype)
           for k, (dims, dtype, fill) in _EVENT_VARIABLES.items()}
    member = np.asarray(table.member, dtype=np.int64)
    counts = np.bincount(member, minlength=members)
    out["event_count"][:] = counts
    first = np.concatenate([[0], np.cumsum(counts)[:-1]])  # the table is in member order, each in time order
    order = np.argsort(member, kind="stable")
    rank = np.arange(len(member)) - first[member[order]]
    kept = rank < MAX_MEMBER_CROSSINGS
    rows, columns = member[order][kept], rank[kept]
    out["event_t"][rows, columns] = np.asarray(table.t)[order][kept]
    out["event_index"][rows, columns] = np.asarray(table.event)[order][kept]
    out["event_direction"][rows, columns] = np.asarray(table.direction)[order][kept]
    return out


def _renumbered(error: ValueError, start: int) -> ValueError:
    """A chunk's "member i: ..." error with i the member's index in the sweep (the Dataset's member), not in
    the chunk, which the ensemble counts from its own first member."""
    found = re.match(r"member (\d+): ", str(error))
    if found is None:
        return error
    return ValueError(f"member {start + int(found.group(1))}: {str(error)[found.end():]}")


def _run_ensemble(model, task: dict[str, Any], run: dict[str, Any], cancel: CancelToken | None):
    return integrate_ensemble(model, task["q0"], task["p0"], parameters=task["parameters"] or None,
                             method=run["method"], tableau=run.get("tableau"), composition=run.get("composition"),
                             h=run["h"], t_end=run.get("t_end"), n_steps=run.get("n_steps"),
                             save_every=run["save_every"], threads=task["threads"],
                             load=Load.from_dict(run["load"]) if run.get("load") is not None else None,
                             temperature=run.get("temperature"), seed=run.get("seed"),
                             first_stream=run.get("stream", 0) + task["start"] if run.get("temperature") else 0,
                             cancel=cancel, events=run.get("events"))


def _stop_chunks(client, futures, stop: str) -> None:
    """The running chunks told to stop (the distributed Event they watch) and the queued ones
    cancelled on the cluster."""
    from dask.distributed import Event

    Event(stop, client=client).set()
    client.cancel([f for f in futures if not f.done()])


def _finished(client, futures, cancel, stop: str):
    """The futures as they finish; once ``cancel`` is cancelled, the running chunks are told to stop
    (the distributed Event ``stop``, which _watch_stop watches), the queued ones are cancelled on the
    cluster, and none is waited for any more. The Event stays set on the scheduler (a few bytes per
    cancelled sweep): a chunk that has not looked yet still sees it."""
    import time

    from dask.distributed import as_completed

    pending = as_completed(futures)
    while not pending.is_empty():
        if cancel is not None and cancel.cancelled:
            _stop_chunks(client, futures, stop)
            return
        if pending.has_ready():
            yield next(pending)
        else:
            time.sleep(0.02)


_PER_MEMBER = {  # variable: (dims after member, dtype, fill)
    "q": (("time", "dof"), float, np.nan), "p": (("time", "dof"), float, np.nan),
    "energy": (("time",), float, np.nan), "momentum": (("time", "momentum_map"), float, np.nan),
    "rows": ((), np.int64, 0), "t_final": ((), float, np.nan), "q_final": (("dof",), float, np.nan),
    "p_final": (("dof",), float, np.nan), "energy_final": ((), float, np.nan),
    "momentum_final": (("momentum_map",), float, np.nan), "steps": ((), np.int64, 0),
    "failed_step": ((), np.int64, -1), "status": ((), np.int8, -1), "max_momentum_drift": ((), float, np.nan),
}


@dataclass(frozen=True)
class SweepPlan:
    """What a sweep will run, checked: see :func:`check_sweep`."""

    model: Model
    q0: np.ndarray  # (members, n)
    p0: np.ndarray
    options: dict[str, Any]
    columns: dict[str, np.ndarray]  # grid name: per-member values, in run order
    parameters: dict[str, np.ndarray]  # model parameter: per-member values
    groups: list  # [(run options, first member, end)]
    times: list  # each group's save grid
    chunk_size: int
    grid: dict[str, list]  # the axes as values (ranges expanded), for provenance

    @property
    def members(self) -> int:
        return self.groups[-1][2]

    @property
    def rows(self) -> int:
        """Saved points per member (the longest save grid)."""
        return max(t.size for t in self.times)

    @property
    def chunks(self) -> int:
        return sum(-(-(stop - start) // self.chunk_size) for _, start, stop in self.groups)

    @property
    def values(self) -> int:
        """Numbers the result holds: per member and saved point, t, q, p, energy and the momentum maps."""
        return self.members * self.rows * (2 + 2 * self.model.dim + len(self.model.momentum_names))


def check_sweep(spec: Mapping[str, Any], grid: Mapping[str, Any], *, chunk_size: int = 1000,
                max_members: int | None = None) -> SweepPlan:
    """Every check :func:`sweep` makes before it sends anything, without a cluster: the spec, the
    grid (names, values, ranges; its size, the product of its axes' lengths, before anything is built)
    and one step of members that hold every value of every axis (the first member of each group of
    run arguments, and the members one axis away from the first; of an axis over a System's expression
    parameter, whose every value compiles, 64 values spread over it), run here the way a worker will.
    ``max_members`` bounds the members (a :class:`GridTooLarge`, a ValueError, names ``grid``).
    Raises ValueError naming the entry (``grid.eps``, ``grid.eps[2] = -0.5``, ``spec.h`` ...); returns
    the plan, whose ``members``, ``rows`` and ``values`` tell how big the result will be."""
    model, q0, p0, options = _base(spec)
    chunk_size = integer("chunk_size", chunk_size)
    if max_members is not None:
        max_members = integer("max_members", max_members)
    axes, labels = _axes(model, options, grid, max_members)
    columns, groups = _plan(options, axes, labels)
    members = groups[-1][2]
    if options.get("temperature") and options["stream"] + members - 1 > MAX_SEED:
        raise ValueError(f"stream: members draw streams stream + k for k < {members}, which passes 2^64 - 1 from "
                         f"stream = {options['stream']}; give a smaller stream")
    Q0, P0, parameters = _members(q0, p0, columns, members)
    times = [_times(run, grid, "h" in axes) for run, _, _ in groups]
    plan = SweepPlan(model=model, q0=Q0, p0=P0, options=options, columns=columns, parameters=parameters,
                     groups=groups, times=times, chunk_size=chunk_size,
                     grid={labels[name]: values.tolist() for name, values in axes.items()})
    _check_values(plan, axes, labels, q0, p0)
    return plan


def _members(q0: np.ndarray, p0: np.ndarray, columns: dict[str, np.ndarray],
             rows: int) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """(q0, p0, model parameters) of ``rows`` members: the spec's state with the grid's state components
    set, and the grid's parameters, from ``columns`` {grid name: per-member values}."""
    Q0, P0 = np.tile(q0, (rows, 1)), np.tile(p0, (rows, 1))
    parameters = {}
    for name, values in columns.items():
        if state := _STATE_COMPONENT.match(name):
            (Q0 if state.group(1) == "q0" else P0)[:, int(state.group(2))] = values
        elif name not in RUN_ARGUMENTS:
            parameters[name] = values.astype(float)
    return Q0, P0, parameters


def _times(run: dict[str, Any], grid: Mapping[str, Any], h_swept: bool) -> np.ndarray:
    """A group's save grid; a step whose times overflow is refused as a job refuses it (span)."""
    try:
        return _grid_times(run)
    except ValueError as error:
        if not h_swept or "largest float" not in str(error):
            raise
        where = f"grid.{STEP_SIZE_ALIAS if STEP_SIZE_ALIAS in grid else 'h'}"
        raise ValueError(f"{where}: {run.get('n_steps')} steps of {run['h']} end beyond the largest float, so the "
                         "times would not be finite; lower h or the number of steps") from None


# Members per one-step check call: an axis of a System's expression parameter compiles a model per value,
# and those of one call are held at once.
_CHECK_BATCH = 256
# Values of such an axis that the check steps: each compiles (about 5 ms), as the run will, and a check of
# thousands would take longer than a service's check budget; evenly spaced, both ends included.
_COMPILED_VALUES_CHECKED = 64


def _checked_values(model: Model, name: str, size: int) -> np.ndarray:
    """The indices of axis ``name``'s values after the first that the check steps: all of them, but for an
    axis over a System's expression parameter (each value compiles) _COMPILED_VALUES_CHECKED, spread."""
    if not isinstance(model, System) or name == "eps" or size <= _COMPILED_VALUES_CHECKED:
        return np.arange(1, size)
    return np.unique(np.linspace(1, size - 1, _COMPILED_VALUES_CHECKED).round().astype(int))


def _step(model: Model, q0: np.ndarray, p0: np.ndarray, columns: dict[str, np.ndarray], rows: int,
          run: dict[str, Any]) -> None:
    """One step of ``rows`` members (see _members), run here as a worker runs a chunk."""
    Q0, P0, parameters = _members(q0, p0, columns, rows)
    task = {"q0": Q0, "p0": P0, "parameters": parameters, "threads": 1, "start": 0}
    _run_ensemble(model, task, dict(run, n_steps=1, t_end=None), None)


def _show(value) -> str:
    """An axis value as the client wrote it: a number, or a name (None for a name left out)."""
    value = value.item() if isinstance(value, np.generic) else value
    return repr(None if value == "" else value)


def _reason(error: ValueError) -> str:
    """A check run's error without its "member i: " (an index into the check's members, not the grid's)."""
    return re.sub(r"^member \d+: ", "", str(error), count=1)


def _check_values(plan: SweepPlan, axes: dict[str, np.ndarray], labels: dict[str, str], q0: np.ndarray,
                  p0: np.ndarray) -> None:
    """One step of members that together hold every value of every axis, run here before anything is
    sent: the grid's first member, the first member of each other group (each distinct set of run
    arguments) and, with the first group's run arguments, the members one axis away from the first
    member. Costs a step per group and per axis value, not per member. A member failing here would fail
    its chunk on a worker and lose the whole sweep; the error names the axis value (grid.eps[3] = -0.5)."""
    model = model_from_spec(describe_model(plan.model))  # as a worker rebuilds it
    first = {name: values[:1] for name, values in axes.items() if name not in RUN_ARGUMENTS}
    run0 = plan.groups[0][0]
    try:
        _step(model, q0, p0, first, 1, run0)
    except ValueError as error:
        raise _first_member_error(model, q0, p0, plan, axes, labels, error) from None
    for run, start, _ in plan.groups[1:]:  # its first member: the first values of the other axes
        try:
            _step(model, q0, p0, first, 1, run)
        except ValueError as error:
            raise _group_error(plan, axes, labels, start, error) from None
    for name, values in axes.items():
        if name in RUN_ARGUMENTS:
            continue
        checked = _checked_values(plan.model, name, values.size)
        for a in range(0, checked.size, _CHECK_BATCH):
            _check_axis_values(model, q0, p0, first, run0, name, checked[a:a + _CHECK_BATCH], axes, labels)


def _check_axis_values(model: Model, q0, p0, first: dict[str, np.ndarray], run: dict[str, Any], name: str,
                       indices: np.ndarray, axes: dict[str, np.ndarray], labels: dict[str, str]) -> None:
    """One step of the members that take values ``indices`` of axis ``name`` and the first value of every
    other axis; on an error each runs alone, for the first bad value's own message."""
    def columns(picked: np.ndarray) -> dict[str, np.ndarray]:
        return {**{k: np.repeat(v, picked.size) for k, v in first.items()}, name: axes[name][picked]}

    try:
        _step(model, q0, p0, columns(indices), indices.size, run)
        return
    except ValueError as error:
        batch_error = error
    for j in indices.tolist():
        try:
            _step(model, q0, p0, columns(np.array([j])), 1, run)
        except ValueError as error:
            raise ValueError(f"grid.{labels[name]}[{j}] = {_show(axes[name][j])}: {_reason(error)}") from None
    raise ValueError(f"grid.{labels[name]}: {_reason(batch_error)}") from None


def _first_member_error(model: Model, q0, p0, plan: SweepPlan, axes: dict[str, np.ndarray],
                        labels: dict[str, str], error: ValueError) -> ValueError:
    """The grid's first member failed: the spec's own error when the spec fails without the grid, the
    only axis's first value when there is one axis, else member 0 (which of several axes is to blame is
    not known)."""
    try:
        _step(model, q0, p0, {}, 1, plan.options)
    except ValueError as own:
        return ValueError(_reason(own))
    if len(axes) == 1:
        (name, values), = axes.items()
        return ValueError(f"grid.{labels[name]}[0] = {_show(values[0])}: {_reason(error)}")
    return ValueError(f"member 0: {_reason(error)}")


def _group_error(plan: SweepPlan, axes: dict[str, np.ndarray], labels: dict[str, str], start: int,
                 error: ValueError) -> ValueError:
    """The first member of a group (member ``start``) failed where the grid's first member did not: the
    run-argument axes it differs by are to blame; the message names the first, with the others' values."""
    changed = [name for name in axes if name in RUN_ARGUMENTS and plan.columns[name][start] != plan.columns[name][0]]
    name, value = changed[0], plan.columns[changed[0]][start]
    j = int(np.flatnonzero(axes[name] == value)[0])
    also = "".join(f" with {labels[k]} = {_show(plan.columns[k][start])}" for k in changed[1:])
    return ValueError(f"grid.{labels[name]}[{j}] = {_show(value)}{also}: {_reason(error)}")


def _unguarded_main_call() -> tuple[str, str] | None:
    """("file:line", start method) when this call runs as part of importing the main script outside
    ``if __name__ == "__main__":``, where processes started by spawn or forkserver would import the
    script again and run the call once more each (multiprocessing's spawn.get_preparation_data:
    a package's __main__ and an interactive session are not re-imported); else None."""
    import dask

    method = dask.config.get("distributed.worker.multiprocessing-method", "spawn")
    main = sys.modules.get("__main__")
    if method == "fork" or main is None:
        return None
    name = getattr(getattr(main, "__spec__", None), "name", None)
    if name is not None and (name == "__main__" or name.endswith(".__main__")):
        return None
    if name is None and getattr(main, "__file__", None) is None:
        return None
    frame = sys._getframe(1)
    while frame is not None and not (frame.f_globals is main.__dict__ and frame.f_code.co_name == "<module>"):
        frame = frame.f_back
    if frame is None:  # not called while the main module runs (e.g. from a thread, or after it)
        return None
    filename, line = frame.f_code.co_filename, frame.f_lineno
    try:
        with open(filename, encoding="utf-8") as f:
            tree = ast.parse(f.read())
    except (OSError, SyntaxError, ValueError):
        return None  # no source to read: assume the script knows what it does
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and _is_main_test(node.test) and \
                node.body[0].lineno <= line <= (node.body[-1].end_lineno or line):
            return None
    return f"{filename}:{line}", method


def _is_main_test(test: ast.expr) -> bool:
    """Whether ``test`` is ``__name__ == "__main__"`` (either way round)."""
    if not (isinstance(test, ast.Compare) and len(test.ops) == 1 and isinstance(test.ops[0], ast.Eq)):
        return False
    sides = (test.left, test.comparators[0])
    return (any(isinstance(x, ast.Name) and x.id == "__name__" for x in sides)
            and any(isinstance(x, ast.Constant) and x.value == "__main__" for x in sides))


def _task(plan: SweepPlan, model_spec: dict, run: dict, a: int, b: int, threads: int) -> dict[str, Any]:
    return {"model": model_spec, "run": run, "start": a, "q0": plan.q0[a:b], "p0": plan.p0[a:b],
            "parameters": {k: v[a:b] for k, v in plan.parameters.items()}, "threads": threads}


def sweep(spec: Mapping[str, Any], grid: Mapping[str, Any], *, client=None, chunk_size: int = 1000,
          progress: bool | Callable[[int, int], object] | None = None, store=None, threads: int = 1,
          cancel=None, max_members: int | None = None):
    """Run the Cartesian product of ``grid`` over ``spec`` on a Dask client; one Dataset back.

    Parameters
    ----------
    spec : integrate's arguments as a dict: ``model`` (a built-in model's name with
        ``parameters``, a model object or a System) or ``system``, ``q0``, ``p0``, ``method``,
        ``h``, ``t_end`` or ``n_steps``, ``save_every``, ``tableau``, ``composition``, ``load``,
        ``temperature``, ``seed``, ``stream``; or the service's job JSON (``model``/``system``,
        ``initial_state``, ``h`` ...). At a temperature every member uses the one seed (drawn
        here when not given, and kept in the provenance) and member k (its index in the
        Dataset's ``member`` dimension, ordered as described under ``chunk_size``) draws stream
        ``stream + k`` (``stream`` 0 when not given), so it equals
        ``raydamp.integrate(..., seed=seed, stream=stream + k)``.
    grid : {name: values}. A name is a model parameter (``eps``, ``k``, ... or a System's
        parameter: the model is rebuilt per member), a run argument (``h``, ``method``,
        ``composition``, ``tableau``) or an initial-state component (``"q0[1]"``, ``"p0[0]"``).
        The members are every combination, the first name varying slowest.
    client : a ``dask.distributed.Client`` (e.g. ``Client("tcp://scheduler:8786")`` for a
        cluster); None starts a LocalCluster of 2 worker processes on this machine and closes it
        at the end. Those processes start by importing the main script again (multiprocessing's
        "spawn", Dask's default), so a script must call sweep under
        ``if __name__ == "__main__":``; called while the script is being imported, sweep raises
        a RuntimeError saying so instead of starting the cluster.
    chunk_size : members per task; each task is one compiled ensemble call. Members that differ
        in a run argument go in different tasks, so members are ordered group by group (by
        their run arguments) and within a group in grid order.
    progress : True for a tqdm bar, or a callable ``progress(members_done, members)``; called
        once per finished chunk.
    store : a path ending in .zarr: each chunk is written there as it arrives (the sweep need
        not fit in memory) and the returned Dataset reads from it lazily.
    threads : threads per task (1: the workers' processes give the parallelism).
    cancel : a :class:`raydamp.CancelToken`; once cancelled, no further chunk is waited for (chunks
        still queued on the cluster are cancelled there) and the Dataset of the chunks finished so
        far comes back, the other members with status "cancelled" and no rows, ``attrs["cancelled"]``
        true. A chunk already running on a worker stops there too, within a quarter of a second and a
        few hundred steps (it watches a distributed Event the cancel sets), and is not waited for.
    max_members : refuse a grid of more members (a :class:`GridTooLarge`) before anything is built.

    Returns an xarray.Dataset laid out as ``EnsembleSolution.to_xarray()``'s, with a member
    coordinate per grid name; when the groups' save grids differ (a grid over h with t_end),
    ``t`` has dims (member, time) and shorter grids are padded with NaN. Each member equals
    ``raydamp.integrate`` of it alone bit for bit.
    """
    import xarray as xr

    if client is None and (unguarded := _unguarded_main_call()) is not None:
        where, method = unguarded
        raise RuntimeError(f"raydamp.sweep: {where} calls sweep while the script is being imported, and the "
                           f"worker processes of the LocalCluster it would start import the script again "
                           f"({method!r} start method), each running it anew; put the call under "
                           f"`if __name__ == \"__main__\":`, or pass client= (e.g. a "
                           f"distributed.Client(processes=False))")
    threads = integer("threads", threads, maximum=4096)
    if progress is not None and progress is not True and progress is not False and not callable(progress):
        raise ValueError(f"progress must be True, a callable or None, got {progress!r}")
    if store is not None and not str(store).endswith(".zarr"):
        raise ValueError(f"store: expected a path ending in .zarr, got {store!r}")
    if store is not None:
        replaceable_store("store", store)
    if cancel is not None and not hasattr(cancel, "cancelled"):
        raise ValueError(f"cancel must be a raydamp.CancelToken, got {cancel!r}")
    if client is not None and not callable(getattr(client, "map", None)):  # "tcp://x" was 'str' has no 'map'
        raise ValueError(f"client must be a dask.distributed.Client (e.g. Client(\"tcp://scheduler:8786\")) or None, "
                         f"got {_short(client)}")
    # The driver checks everything, every axis value included, before anything is sent: a bad
    # argument is reported here, naming it, rather than from a worker.
    plan = check_sweep(spec, grid, chunk_size=chunk_size, max_members=max_members)
    model, options, columns, groups, times = plan.model, plan.options, plan.columns, plan.groups, plan.times
    members, chunk_size, Q0, P0 = plan.members, plan.chunk_size, plan.q0, plan.p0
    model_spec = describe_model(model)
    R = plan.rows
    shared_times = all(t.shape == times[0].shape and np.array_equal(t, times[0]) for t in times)
    tasks = [_task(plan, model_spec, run, a, min(stop, a + chunk_size), threads)
             for run, start, stop in groups for a in range(start, stop, chunk_size)]
    # Set at a cancel, or when the sweep ends by an error while chunks still run on the client's workers.
    stop_event = f"raydamp-sweep-stop-{uuid.uuid4().hex}"
    for task in tasks:
        task["stop"] = stop_event

    n, m = model.dim, len(model.momentum_names)
    sizes = {"time": R, "dof": n, "momentum_map": m, "crossing": MAX_MEMBER_CROSSINGS}
    events = options.get("events")
    per_member = _PER_MEMBER | (_EVENT_VARIABLES if events is not None else {})
    coords: dict[str, Any] = {"member": np.arange(members), "dof": list(model.coordinates),
                              "momentum_map": list(model.momentum_names)}
    if shared_times:
        coords["t"] = (("time",), times[0])
    else:
        t = np.full((members, R), np.nan)
        for (_run, start, stop), grid_t in zip(groups, times):
            t[start:stop, :grid_t.size] = grid_t
        coords["t"] = (("member", "time"), t)
    for name, values in columns.items():
        coords[name] = (("member",), values.astype(str) if values.dtype == object else values)
    provenance = {**model_spec, **options,
                  "coordinates": list(model.coordinates), "momentum_names": list(model.momentum_names),
                  "grid": plan.grid, "chunk_size": chunk_size}
    provenance["raydamp_version"] = __version__
    attrs = {"kind": "sweep", "provenance": json.dumps(provenance), "grid": json.dumps(list(columns)),
             "raydamp_version": __version__}
    if events is not None:  # event_index i is events[i]
        attrs["event_names"] = json.dumps([e.get("name") or f"event{i}" for i, e in enumerate(events)])
    statics = {"q0": (("member", "dof"), Q0), "p0": (("member", "dof"), P0)}

    def shape(dims):
        return (members, *(sizes[d] for d in dims))

    if store is None:
        arrays = {k: np.full(shape(dims), fill, dtype=dtype) for k, (dims, dtype, fill) in per_member.items()}
    else:
        import dask.array as da

        template = xr.Dataset({k: (("member", *dims), da.full(shape(dims), fill, dtype=dtype,
                                                              chunks=(chunk_size, *shape(dims)[1:])))
                               for k, (dims, dtype, fill) in per_member.items()} | statics,
                              coords=coords, attrs=attrs)
        template.to_zarr(store, mode="w", compute=False, zarr_format=2)  # see results.save_ensemble
        # q0, p0 and the coordinates now; the per-member results as their chunks arrive. Until its chunk is
        # written every member reads "cancelled": a sweep ended any way (a cancel, Ctrl-C, an error, a crash)
        # leaves its unfinished members so, not at the store's fill value, 0, which reads "completed".
        unfinished = np.full(members, STATUSES.index("cancelled"), dtype=np.int8)
        xr.Dataset({**statics, "status": (("member",), unfinished)}).to_zarr(store,
                                                                            region={"member": slice(0, members)})
    messages: dict[str, str] = {}
    finished = np.zeros(members, dtype=bool)
    done = 0

    close = []
    if client is None:
        from dask.distributed import Client

        cluster = local_cluster(2)
        client = Client(cluster)
        close = [client, cluster]
    bar = None
    if progress is True:
        from tqdm.auto import tqdm

        bar = tqdm(total=members, unit="member", desc="sweep")
    futures = []
    try:
        futures = client.map(_run_chunk, tasks, pure=False)
        for future in _finished(client, futures, cancel, stop_event):
            out = future.result()
            a = out["start"]
            b = a + out["q"].shape[0]
            rows = out["q"].shape[1]
            messages.update(out["messages"])
            if store is None:
                for k in per_member:
                    target = arrays[k]
                    if target.ndim >= 2 and per_member[k][0][:1] == ("time",):
                        target[a:b, :rows] = out[k]
                    else:
                        target[a:b] = out[k]
            else:
                part = {}
                for k, (dims, dtype, fill) in per_member.items():
                    value = np.full((b - a, *shape(dims)[1:]), fill, dtype=dtype)
                    if dims[:1] == ("time",):
                        value[:, :rows] = out[k]
                    else:
                        value[:] = out[k]
                    part[k] = (("member", *dims), value)
                # Written from this thread only, one chunk after another: no two writes share a Zarr chunk at once.
                xr.Dataset(part).to_zarr(store, region={"member": slice(a, b)}, safe_chunks=False)
            done += b - a
            finished[a:b] = True
            future.release()
            if bar is not None:
                bar.update(b - a)
            elif callable(progress):
                progress(done, members)
    finally:
        if bar is not None:
            bar.close()
        if not close and any(not f.done() for f in futures):  # an error here or in a chunk: the rest stop too
            try:
                _stop_chunks(client, futures, stop_event)
            except Exception:  # noqa: BLE001 - the client itself failing: the error being raised is the one to see
                pass
        for thing in close:
            thing.close()

    cancelled = not finished.all()  # only a cancel leaves members unfinished (a failed chunk raises)
    attrs["cancelled"] = int(cancelled)  # NetCDF attributes hold no booleans
    if cancelled:
        unfinished = STATUSES.index("cancelled")
        if store is None:  # (a store's unfinished members read "cancelled" from the start)
            arrays["status"][~finished] = unfinished
    attrs["messages"] = json.dumps(messages)
    if store is not None:
        import zarr

        group = zarr.open_group(str(store), mode="a")
        group.attrs["messages"] = attrs["messages"]
        group.attrs["cancelled"] = attrs["cancelled"]
        zarr.consolidate_metadata(str(store))  # open_zarr reads the consolidated copy of the attributes
        return xr.open_zarr(store)
    data = {k: (("member", *dims), arrays[k]) for k, (dims, _, _) in per_member.items()}
    data["status"] = (("member",), arrays["status"], {"flag_values": list(range(len(STATUSES))),
                                                      "flag_meanings": " ".join(STATUSES)})
    return xr.Dataset(data | statics, coords=coords, attrs=attrs)
