"""raydamp.integrate_ensemble: many runs of one system in one compiled call, on threads."""

from __future__ import annotations

import numbers
import time
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from .. import _core
from .._validation import MAX_SEED, _short, flag, integer, numeric_array, real, thermal
from ..loads import Load
from ..results.ensemble_solution import EnsembleSolution
from ..systems.models import Model
from . import envelope as _envelope
from . import events as _events
from .choose_method import choose_method
from .integrate import MAX_SAVED_BYTES, MAX_STEPS, CancelToken, _catalogue, span
from .save_grid import save_rows

__all__ = ["integrate_ensemble", "member_parameters"]


def member_parameters(system: Model) -> tuple[str, ...]:
    """The names ``integrate_ensemble``'s ``parameters`` may vary for ``system``."""
    return tuple(system.member_parameters())


def _states(name: str, value, members: int | None, n: int) -> np.ndarray:
    """(members, n) finite floats; a single state (n,) is repeated for every member."""
    array = numeric_array(value)
    if array is None:
        raise ValueError(f"{name} must be an array of shape (members, {n}) of real numbers")
    array = array.astype(float)
    if array.ndim == 1 and array.shape == (n,) and members is not None:
        array = np.broadcast_to(array, (members, n))
    if array.ndim != 2 or array.shape[1] != n or array.shape[0] < 1:
        raise ValueError(f"{name} must have shape (members, {n}) with members >= 1, got shape {array.shape}")
    if members is not None and array.shape[0] != members:
        raise ValueError(f"{name} has {array.shape[0]} members, expected {members}")
    bad = ~np.isfinite(array)
    if bad.any():
        i, j = np.argwhere(bad)[0]
        raise ValueError(f"{name} must be finite, got {name}[{i}, {j}] = {array[i, j]!r}")
    return np.ascontiguousarray(array)


def _parameter_arrays(system: Model, parameters, members: int) -> dict[str, np.ndarray]:
    """{name: (members,) floats}, (members, size) for a vector parameter (the elastic pendulum's g)."""
    if parameters is None:
        return {}
    if not isinstance(parameters, Mapping):
        raise ValueError("parameters must be a dict of name: per-member values, e.g. {'eps': [0.1, 0.2]}")
    known = system.member_parameters()
    out = {}
    for name, values in parameters.items():
        if name not in known:
            raise ValueError(f"parameters.{name}: not a parameter of this model that can vary per member "
                             f"(known: {', '.join(known) or 'none'}"
                             f"{'' if known else '; its members differ by initial state: build one model per value'})")
        shape = (members,) if known[name] == 1 else (members, known[name])
        array = _floats(f"parameters.{name}", values, "an array of real numbers")
        if array.ndim == len(shape) - 1 and array.shape == shape[1:]:
            array = np.broadcast_to(array, shape)
        if array.shape != shape:
            raise ValueError(f"parameters.{name} must have shape {shape}, got {array.shape}")
        if not np.isfinite(array).all():
            raise ValueError(f"parameters.{name} must be finite")
        out[name] = np.ascontiguousarray(array)
    return out


def integrate_ensemble(system: Model, q0, p0, *, parameters: Mapping[str, Any] | None = None, method: str | None = None,
                       h: float, t_end: float | None = None, n_steps: int | None = None, save_every: int = 1,
                       tableau: str | None = None, composition: str | None = None, threads: int | None = None,
                       progress: Callable[[int, int], object] | None = None,
                       cancel: CancelToken | None = None, vector_sine: bool = False,
                       load: Load | None = None, temperature: float | None = None, seed: int | None = None,
                       first_stream: int = 0, events=None, envelope=None, collapse=None,
                       dense: bool = False) -> EnsembleSolution:
    """Integrate many members of one system in one compiled call, spread over threads.

    Parameters
    ----------
    system : a built-in model, a :class:`raydamp.System` (one built from expressions), a
        :class:`raydamp.Chain` or a :class:`raydamp.LinearStructure`.
    q0, p0 : (members, n) initial states; a single state of length n is used for every member.
    parameters : {name: per-member values} of the parameters :func:`member_parameters` names:
        every parameter of a built-in model (``eps``; for the elastic pendulum also ``m``, ``k``,
        ``l`` and ``g``, a vector given as (members, 3)), ``eps`` of a damped System and its
        expression parameters; a LinearStructure's ``alpha``, ``beta`` and ``K_scale`` (member i
        runs K_scale[i] K, e.g. one SDOF per period of a response spectrum). A Chain takes none (its
        members differ by initial state; build one model per eps). Built-in models are rebuilt per
        member in C++ from their parameter tables, a LinearStructure once per distinct parameter set
        (in C++, from the shared M, f and spectral bound); a System is rebuilt once per distinct
        parameter set before the run (a change of eps alone reuses its compiled functions; other
        parameters recompile it). ``method=None`` chooses for ``system`` itself, not for each member.
    method, h, t_end, n_steps, save_every, tableau, composition : as :func:`raydamp.integrate`,
        shared by every member (method None chooses as integrate does, the reason in the provenance).
        A LinearStructure's implicit "midpoint" and "gauss4" factorise
        M + c C + c^2 K once per sub-step length for the whole ensemble (once, twice with a
        shortened last step), before the members run; the members share the factors read-only,
        each solving in buffers of its own.
    threads : threads to spread the members over (None: one per hardware thread).
    progress : called as ``progress(members_finished, members)`` about 100 times.
    cancel : a :class:`raydamp.CancelToken`; cancelling it stops every member within a few
        hundred steps (status "cancelled").

    load : a :class:`raydamp.Load` every member feels (see :func:`raydamp.integrate`); its parameters
        (``Load.parameters``: ``amplitude``, ``omega``, ``phase``, an expression's) vary per member
        as ``parameters={"load.amplitude": [...], "load.omega": [...]}``. Members share the load's
        data (a record is held once); each distinct set of expression parameters is compiled once.
        Or a list of loads, one per member (an incremental dynamic analysis: records of different
        lengths, each scaled, ``[motion * s for motion in records for s in scales]``, or the records
        repeated with ``parameters={"load.amplitude": scales}``); a load object listed for several
        members is bound once and its data shared. A record is zero past its end (``hold=False``), so a
        member whose record is shorter than the run goes on in free vibration. Only ``load.amplitude``
        varies per member then (each listed load has its own other parameters).
    temperature, seed : thermal noise as in :func:`raydamp.integrate`; member i draws stream
        ``first_stream + i`` of the seed, so it equals ``integrate(..., seed=seed, stream=first_stream + i)``
        bit for bit, whatever ``threads`` is.
    vector_sine : damped pendulums only (3s, 2s, sv), off by default. The members run as the
        SIMD lanes of one step loop either way; with this set their sines run as SIMD too
        (raydamp's own sine, within 1 ulp; four lanes per register where the processor has AVX2,
        else two), two to four times the throughput (README). That sine differs from libm's in
        the last bit for about 3% of arguments, so members then agree with their single runs to
        rounding (about 1e-15 relative over 10^3 steps), not bit for bit; each member's result
        still does not depend on ``threads``, on the other members or on the machine. Other
        systems and methods refuse it with a ValueError. Recorded in ``provenance``.

    envelope, collapse : each member's peaks and collapse limits, as :func:`raydamp.integrate`'s;
        ``EnsembleSolution.envelope`` is a Dataset with dims (member, dof | spring), its
        ``collapsed_spring`` per member (-1: none). A collapsed member stops alone ("collapsed").
        A Structure with springs records each member's spring forces and deformations at its saved rows
        (``EnsembleSolution.spring_forces``, ``spring_deformations``: (members, R, springs)), as a single
        run's ``Solution.spring_forces`` holds them.

    dense : keep each member's dense output, as :func:`raydamp.integrate`'s ``dense=True`` does for one run
        (whole steps; ``8 (n_steps + 1) (1 + 4 dim)`` bytes per member, refused past the saved-data limit):
        ``EnsembleSolution.at(t)`` reads every member at t, ``member(i).at(t)`` one, both equal to the single
        run's ``Solution.at(t)`` bit for bit.

    Member i's result equals ``raydamp.integrate`` of that member alone, bit for bit, whatever
    ``threads`` is: each member runs the same compiled step loop. (Kepler members that share mu, mass
    and eps run by 3s, 2s or sv as the particles of one model, in batches: their rows and outcome are
    still their single runs' bit for bit, but ``max_momentum_drift`` is the largest of their batch's.)
    A member that blows up stops alone, with its status and the rows it saved. The GIL is released during the run.
    """
    if not isinstance(system, Model):
        raise ValueError(f"system must be a raydamp model or System, got {system!r}")
    names, with_tableau = _catalogue()
    method, tableau, method_reason = choose_method(system, method, tableau, composition, h,
                                                   thermal=temperature is not None
                                                   and real("temperature", temperature, nonnegative=True) > 0)
    if not isinstance(method, str) or method not in names:
        raise ValueError(f"method: unknown method {method!r} (known: {', '.join(names)})")
    if tableau is not None and not isinstance(tableau, str):
        raise ValueError(f"tableau must be a tableau name or None, got {tableau!r}")
    resolved_tableau = _core.resolve(method, tableau or "")
    if composition is not None and not isinstance(composition, str):
        raise ValueError(f"composition must be a composition name or None, got {composition!r}")
    resolved_composition, _order = _core.resolve_composition(method, tableau or "", composition or "")
    h = real("h", h, positive=True)
    n = system.dim
    members = None
    for name, value in (("q0", q0), ("p0", p0)):
        try:
            shape = np.shape(value)
        except ValueError:  # ragged: NumPy's "inhomogeneous shape" named no argument
            raise ValueError(f"{name} must be an array of shape (members, {n}) of real numbers, got rows of "
                             "different lengths") from None
        if len(shape) == 2:
            members = shape[0]
            break
    listed = isinstance(load, (list, tuple))
    if load is not None and not listed and not isinstance(load, Load):
        raise ValueError(f"load must be a raydamp.Load or None, got {type(load).__name__}")
    if listed and not load:
        raise ValueError("load: an empty list; give one load per member, or one raydamp.Load for all, or None")
    parameters, load_parameters = _split_load_parameters(parameters, load)
    if members is None:
        members = _parameter_members(system, parameters, load_parameters)
    if members is None and listed:
        members = len(load)
    q0 = _states("q0", q0, members, n)
    members = q0.shape[0]
    p0 = _states("p0", p0, members, n)
    if getattr(system, "constraints", ()):  # a constrained System: each member on g = 0 and its tangent space
        q0 = np.array([system.check_configuration(f"q0[{i}]", q) for i, q in enumerate(q0)])
        p0 = np.array([system.check_momenta(f"p0[{i}]", q, p) for i, (q, p) in enumerate(zip(q0, p0))])
    system.check_configurations("q0", q0)
    params = _parameter_arrays(system, parameters, members)
    if listed:
        loads, load_index, load_arrays = _listed_loads(system, load, load_parameters, members)
    else:
        loads, load_index, load_arrays = _member_loads(system, load, load_parameters, members)
    kT, seed, first_stream = thermal(temperature, seed, first_stream, "first_stream")
    if kT > 0 and first_stream + members - 1 > MAX_SEED:  # the core's stream counter would wrap to stream 0
        raise ValueError(f"first_stream: members draw streams first_stream + i for i < {members}, which passes "
                         f"2^64 - 1 from first_stream = {first_stream}")
    save_every = integer("save_every", save_every, maximum=MAX_STEPS)
    n_steps, h_last = span(h, t_end, n_steps)
    if threads is None:
        threads = 0
    else:
        threads = integer("threads", threads, maximum=4096)
    if progress is not None and not callable(progress):
        raise ValueError(f"progress must be callable or None, got {progress!r}")
    if cancel is not None and not isinstance(cancel, _core.CancelToken):
        raise ValueError(f"cancel must be a raydamp.CancelToken or None, got {cancel!r}")
    vector_sine = flag("vector_sine", vector_sine)
    rows = save_rows(n_steps, save_every)
    springs = len(getattr(system, "springs", ()) or ())  # a Structure's springs add sigma_s and d_s per row
    row_bytes = 8 * (1 + 2 * n + len(system.momentum_names) + 2 * springs)
    if members * rows * row_bytes > MAX_SAVED_BYTES:
        raise ValueError(f"save_every: {members} members x {rows} saved points would take "
                         f"{members * rows * row_bytes / 2**30:.1f} GiB (limit {MAX_SAVED_BYTES / 2**30:.0f} GiB); "
                         "raise save_every or split the ensemble")

    watch = _events.prepare(system, events, dense, temperature=kT, callables=False)  # each member's (events.py)
    if watch is not None and watch.dense and vector_sine:
        raise ValueError("dense: the SIMD lanes of vector_sine keep no dense output; leave vector_sine off")
    if watch is not None and watch.dense and members * _events.dense_bytes(n_steps, n) > MAX_SAVED_BYTES:
        raise ValueError(f"dense: {members} members x {_events.dense_bytes(n_steps, n) / 2**20:.1f} MiB of dense "
                         f"output would take {members * _events.dense_bytes(n_steps, n) / 2**30:.1f} GiB (limit "
                         f"{MAX_SAVED_BYTES / 2**30:.0f} GiB); run fewer members or steps per call")
    peaks = None if envelope is None and collapse is None else _envelope.prepare(
        system, envelope, collapse=_envelope.limits(system, collapse), given_collapse=collapse)
    models, index, core_names, core_values = system.member_models(params, members)
    start = time.perf_counter()
    cores = [m._core_model for m in models]
    out = type(cores[0]).integrate_ensemble(cores, index, core_names, core_values, method, tableau or "",
                                            composition or "", q0, p0, h, n_steps, h_last, save_every, threads,
                                            progress, cancel, vector_sine=vector_sine, loads=loads,
                                            load_index=load_index, temperature=kT, seed=seed,
                                            first_stream=first_stream,
                                            **({"events": watch.core} if watch and watch.core is not None else {}),
                                            **({"dense": True} if watch and watch.dense else {}),
                                            **({"envelope": peaks.core} if peaks else {}))
    wall = time.perf_counter() - start
    composition_name = None if resolved_composition == "none" else resolved_composition
    options = {"method": method, "tableau": tableau, "composition": composition_name, "h": h, "t_end": t_end,
               "n_steps": None if t_end is not None else n_steps, "save_every": save_every, "work": False}
    if method_reason is not None:
        options["method_reason"] = method_reason
    if vector_sine:
        options["vector_sine"] = True
    if listed:
        options["loads"] = tuple(load)
    elif loads:
        options["load"] = load
    if kT > 0:
        options["thermal"] = (kT, seed, first_stream)
    if peaks is not None:
        options.update(envelope=list(peaks.names), collapse=peaks.collapse)
    if watch is not None and watch.dense:
        options["dense"] = True
    return EnsembleSolution(
        t=out["t"], q=out["q"], p=out["p"], energy=out["energy"], momentum=out["momentum"], rows=out["rows"],
        t_final=out["t_final"], q_final=out["q_final"], p_final=out["p_final"], energy_final=out["energy_final"],
        momentum_final=out["momentum_final"], status=tuple(out["status"]), steps=out["steps"],
        failed_step=out["failed_step"], message=tuple(out["message"]), max_momentum_drift=out["max_momentum_drift"],
        q0=q0, p0=p0, parameters={**params, **load_arrays}, method=method,
        tableau=resolved_tableau if method in with_tableau else None, composition=composition_name, h=h,
        wall_time=wall, threads=out["threads"], origin=(system, options),
        **{name: _envelope.users_springs(system, out.get(key)) for name, key in _SPRING_KEYS.items()},
        **(_events.results(watch, out, ensemble=True) if watch else {}),
        **({"envelope": _envelope.dataset(peaks, out, out["q_final"], ensemble=True)} if peaks else {}))


# EnsembleSolution's per-spring arrays and the core's keys for them (core order; users_springs reorders).
_SPRING_KEYS = {"spring_forces": "spring_force", "spring_deformations": "spring_deformation",
                "spring_forces_final": "spring_force_final", "spring_deformations_final": "spring_deformation_final"}


def _split_load_parameters(parameters, load: Load | None) -> tuple[Any, dict[str, Any]]:
    """(the model's parameters, {name: values} of the "load.<name>" ones)."""
    if not isinstance(parameters, Mapping):
        return parameters, {}
    mine = {k[5:]: v for k, v in parameters.items() if isinstance(k, str) and k.startswith("load.")}
    if mine and load is None:
        raise ValueError(f"parameters.load.{next(iter(mine))}: the ensemble has no load")
    rest = {k: v for k, v in parameters.items() if not (isinstance(k, str) and k.startswith("load."))}
    return (rest or None), mine


def _member_loads(system: Model, load: Load | None, varied: dict[str, Any], members: int):
    """(core loads, (members,) index into them, {"load.<name>": (members,) values}): one core load per
    distinct set of the varied parameters other than the amplitude, scaled per member (data shared)."""
    if load is None:
        return [], np.zeros(0, dtype=np.int64), {}
    arrays = _load_parameter_arrays(load, varied, members)
    if not load.terms:  # no force to run, but its parameters were checked and are recorded per member
        return [], np.zeros(0, dtype=np.int64), {f"load.{k}": v for k, v in arrays.items()}
    others = [k for k in arrays if k != "amplitude"]
    base: dict[tuple, int] = {}
    bound = []
    index = np.empty(members, dtype=np.int64)
    for i in range(members):
        key = tuple(float(arrays[k][i]) for k in others)
        if key not in base:
            base[key] = len(bound)
            unit = {"amplitude": 1.0} if "amplitude" in arrays else {}
            bound.append(load.with_parameters(**unit, **dict(zip(others, key))).bind(system))
        index[i] = base[key]
    if "amplitude" in arrays:
        scaled = [bound[index[i]].scaled(float(arrays["amplitude"][i]), 1.0) for i in range(members)]
        bound, index = scaled, np.arange(members, dtype=np.int64)
    return bound, index, {f"load.{k}": v for k, v in arrays.items()}


def _listed_loads(system: Model, loads, varied: dict[str, Any], members: int):
    """_member_loads for a list of loads, one per member: each distinct load object bound once, scaled per
    member by "load.amplitude" (the one parameter every load has)."""
    if len(loads) != members:
        raise ValueError(f"load: {len(loads)} loads for {members} members; give one load per member")
    for i, load in enumerate(loads):
        if not isinstance(load, Load):
            raise ValueError(f"load[{i}] must be a raydamp.Load or raydamp.GroundMotion, got {_short(load)}")
    for name in varied:
        if name != "amplitude":
            raise ValueError(f"parameters.load.{name}: with a load per member only load.amplitude varies per "
                             f"member; give each member's load its own {name}")
    arrays = _load_parameter_arrays(loads[0], varied, members)
    arrays = {f"load.{k}": v for k, v in arrays.items()}
    if not any(load.terms for load in loads):
        return [], np.zeros(0, dtype=np.int64), arrays
    bound, index, seen = [], np.empty(members, dtype=np.int64), {}
    for i, load in enumerate(loads):
        if id(load) not in seen:
            seen[id(load)] = len(bound)
            bound.append(load.bind(system))  # a load without terms binds to none: the member runs unforced
        index[i] = seen[id(load)]
    if "load.amplitude" in arrays:
        amplitude = arrays["load.amplitude"]
        bound = [bound[index[i]].scaled(float(amplitude[i]), 1.0) for i in range(members)]
        index = np.arange(members, dtype=np.int64)
    return bound, index, arrays


def _load_parameter_arrays(load: Load, varied: dict[str, Any], members: int) -> dict[str, np.ndarray]:
    """{name: (members,) finite floats} of the "load.<name>" parameters, each a name of ``load.parameters``."""
    known = load.parameters
    arrays: dict[str, np.ndarray] = {}
    for name, values in varied.items():
        if name not in known:
            raise ValueError(f"parameters.load.{name}: this load has no parameter {name!r} (it has: "
                             f"{', '.join(sorted(known))})")
        array = _floats(f"parameters.load.{name}", values, f"{members} real numbers")
        try:
            array = np.broadcast_to(array, (members,))
        except ValueError:
            raise ValueError(f"parameters.load.{name} must be {members} real numbers, "
                             f"got shape {array.shape}") from None
        if not np.isfinite(array).all():
            raise ValueError(f"parameters.load.{name} must be finite")
        arrays[name] = np.ascontiguousarray(array)
    return arrays


def _floats(name: str, values, expected: str) -> np.ndarray:
    """``values`` as a float array. Bools and strings are refused, as integrate refuses eps=True and
    eps="0.1": np.asarray would read True as 1.0 (a mask passed by mistake would run as parameters) and
    "0.1" as 0.1."""
    odd = _first_non_number(values)
    if odd is not _ALL_NUMBERS:
        raise ValueError(f"{name} must be {expected}, got {'the bool ' if isinstance(odd, (bool, np.bool_)) else ''}"
                         f"{_short(odd)}")
    try:
        return np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be {expected}") from None


_ALL_NUMBERS = object()


def _first_non_number(values):
    """The first element of ``values`` (a scalar, a nested list or an array) that is a bool or not a real
    number (None among them), or _ALL_NUMBERS. A list mixing bools and floats converts to floats, so the
    elements are looked at, not the converted dtype."""
    if isinstance(values, np.ndarray) and values.dtype != object:
        return values.flat[0].item() if values.dtype.kind not in "iuf" and values.size else _ALL_NUMBERS
    try:
        elements = np.asarray(values, dtype=object)
    except (TypeError, ValueError):
        return _ALL_NUMBERS  # ragged: the float conversion refuses it with the argument's name
    odd = next((x for x in elements.flat if isinstance(x, (bool, np.bool_)) or not isinstance(x, numbers.Real)),
               _ALL_NUMBERS)
    return odd.item() if isinstance(odd, np.generic) else odd


def _parameter_members(system: Model, parameters, load_parameters: dict[str, Any]) -> int | None:
    """The member count the parameters give when q0 and p0 are single states: the longest per-member
    list. A scalar counts as one member (broadcast to the others), as does a vector parameter given as
    its k components: only a 2-D (members, k) array lists one vector per member. None: no parameters."""
    sizes = system.member_parameters()
    given = [(sizes.get(k, 1), v) for k, v in parameters.items()] if isinstance(parameters, Mapping) else []
    given += [(1, v) for v in load_parameters.values()]
    counts = [_rows(values, 1 if size == 1 else 2) for size, values in given]
    return max(counts) if counts else None


def _rows(values, per_member_ndim: int) -> int:
    """len(values) when it has the dimensions of a per-member list, else 1 (one value for every member).
    Ragged or odd values count as 1 here; converting them to floats refuses them by name."""
    try:
        shape = np.shape(np.asarray(values, dtype=object))
    except (TypeError, ValueError):
        return 1
    return shape[0] if len(shape) >= per_member_ndim else 1
