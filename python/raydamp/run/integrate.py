"""raydamp.integrate: fixed-step integration of a damped mechanical model."""

from __future__ import annotations

import dataclasses
import functools
import math
import re
import time
import weakref
from collections.abc import Callable, Mapping

import numpy as np

from .. import _core
from .._validation import MAX_STEPS, _short, flag, integer, real, span, steps_for, thermal, vector
from ..loads import Load
from ..methods.user_tableau import resolve_user_tableau
from ..results.solution import Solution
from ..systems.models import Model
from . import correctors as _correctors
from . import envelope as _envelope
from . import events as _events
from .choose_method import choose_method

__all__ = ["integrate", "steps_for", "row_bytes", "CancelToken", "MAX_SAVED_BYTES", "MAX_STEPS", "MAX_AMPLIFICATION"]

# Refuse runs whose saved points alone would not fit in memory comfortably.
MAX_SAVED_BYTES = 4 * 2**30
# The amplification guard's limit for compositions (see integrate's ``composition``), from the core.
MAX_AMPLIFICATION: float = _core.MAX_AMPLIFICATION
# The divergence test's default factor (see integrate's ``divergence``), from the core.
DEFAULT_DIVERGENCE: float = _core.DEFAULT_DIVERGENCE


class CancelToken(_core.CancelToken):
    """Pass as ``cancel=`` to integrate; call ``cancel()`` from any thread to stop the run.

    The run stops within a few hundred steps with status "cancelled", keeping the
    points saved so far.
    """


def row_bytes(model: Model, save_dofs=None, *, work: bool = False, load: Load | None = None) -> int:
    """Bytes of one saved point of ``integrate(model, ..., save_dofs=, work=, load=)``, all float64: t and the
    energy, q and p of the saved coordinates, the momentum maps, W with ``work``, and W_f with ``work`` and a
    load that has terms; a Structure's springs add each spring's force and deformation, and its hysteretic work
    with ``work``. A run keeps ``raydamp.run.save_grid.save_rows(n_steps, save_every)`` points at most."""
    saved = model.dim if save_dofs is None else len(save_dofs)
    recorded = (1 + _loaded(load)) if work else 0
    springs = len(getattr(model, "springs", ()) or ())
    return 8 * (2 + 2 * saved + len(model.momentum_names) + recorded + springs * (2 + work))


def _loaded(load: Load | None) -> bool:
    return load is not None and bool(load.terms)


@functools.cache
def _catalogue() -> tuple[tuple[str, ...], frozenset[str]]:
    """Method names, and the methods that take a tableau (read once from the core)."""
    rows = _core.methods()
    names = tuple(dict.fromkeys(row["name"] for row in rows))
    return names, frozenset(row["name"] for row in rows if row["tableau"] is not None)


@functools.lru_cache(maxsize=256)
def _resolved(method: str, tableau_name: str, composition: str) -> tuple[str, str]:
    """(the tableau's name as the core resolves it, the composition's): the core's ValueErrors name the
    tableau or the composition (unknown, or a base that is not symmetric). A pure function of the names,
    asked once per triple: a short call pays for no lookup in the catalogue."""
    resolved_tableau = _core.resolve(method, tableau_name)
    resolved_composition, _order = _core.resolve_composition(method, tableau_name, composition)
    return resolved_tableau, resolved_composition


def _state(name: str, value, dim: int) -> np.ndarray:
    """vector(name, value, dim) as an array of the run's own (the Solution's provenance keeps it: a caller's array
    changed after the call must not change it). A short call's state (a list or a float64 vector of a few
    finite floats) is checked in Python: at a few coordinates that is cheaper than NumPy's conversions and
    reductions. Anything else, and every refusal, goes through vector(), which words the error."""
    if dim <= 16:
        if type(value) is list:
            values = value
        elif type(value) is np.ndarray and value.dtype == np.float64 and value.shape == (dim,):
            values = value.tolist()
        else:
            values = None
        if values is not None and len(values) == dim:
            for x in values:
                if type(x) is not float or x - x != 0.0:  # x - x is nan for inf and nan
                    break
            else:
                return np.array(values) if values is value else value.copy()
    return vector(name, value, dim).copy()  # vector() may hand back the caller's array, or a view of it


# What a short call reads of a model, asked once per model (models are immutable): id(model) -> (a weak reference
# to the model, (its dimension, the most bytes a saved point can take: every coordinate, the momentum maps, W
# and W_f)). An entry leaves with its model.
_FACTS: dict[int, tuple[weakref.ref, tuple[int, int]]] = {}


def _facts(model: Model) -> tuple[int, int]:
    key = id(model)
    entry = _FACTS.get(key)
    if entry is not None and entry[0]() is model:
        return entry[1]
    facts = (model.dim, 8 * (2 + 2 * model.dim + len(model.momentum_names) + 2))
    try:
        _FACTS[key] = (weakref.ref(model, lambda _, key=key: _FACTS.pop(key, None)), facts)
    except TypeError:  # a model without weak references is asked each time
        pass
    return facts


# integrate makes its Solution by filling the instance's __dict__ in one update: the frozen dataclass's __init__
# sets each of 20 fields by object.__setattr__, a quarter of a 10-step call's Python. A field left out reads its
# default from the class, as a dataclass keeps it there; where Solution needs its __init__ (a field with a
# default factory, a __post_init__), it is called.
_SOLUTION_BY_INIT = hasattr(Solution, "__post_init__") or any(
    f.default_factory is not dataclasses.MISSING for f in dataclasses.fields(Solution))


def _solution(fields: dict) -> Solution:
    if _SOLUTION_BY_INIT:
        return Solution(**fields)
    solution = object.__new__(Solution)
    solution.__dict__.update(fields)
    return solution


def _tableau(tableau) -> tuple[str, str | dict | None]:
    """(the name the core knows it by, "" for the default; the tableau as provenance keeps it)."""
    if tableau is None or isinstance(tableau, str):
        return tableau or "", tableau
    if isinstance(tableau, Mapping):
        name, plain = resolve_user_tableau(tableau)
        return name, plain
    raise ValueError(f"tableau must be a tableau name, a dict with A, b, c, or None, got {_short(tableau)}")


def integrate(model: Model, q0, p0, *, method: str | None = None, h: float, t_end: float | None = None,
              n_steps: int | None = None, save_every: int = 1, tableau: str | Mapping | None = None,
              composition: str | None = None, work: bool = False, save_dofs=None,
              progress: bool | Callable[[int, int], object] | None = None,
              cancel: CancelToken | None = None, load: Load | None = None, temperature: float | None = None,
              seed: int | None = None, stream: int = 0, divergence: float = DEFAULT_DIVERGENCE,
              events=None, dense: bool = False, envelope=None, collapse=None, corrector: int | None = None) -> Solution:
    """Integrate ``model`` from (q0, p0) with fixed steps of size ``h``.

    Parameters
    ----------
    model : a model from :mod:`raydamp.models`.
    q0, p0 : initial positions and momenta, length ``model.dim``.
    method : None (default) chooses: "3s", except for a :class:`raydamp.LinearStructure` on which 3s
        is a trap (h omega_max >= 2: "midpoint"; 3s's damping flow a long Chebyshev series: "rks" with
        tableau "midpoint"), recorded with the reason in ``provenance["method_reason"]``
        (:mod:`raydamp.run.choose_method`; :func:`raydamp.advise` compares every method). At a
        temperature "3s" (a LinearStructure at h omega_max >= 2, where every method with exact noise
        flows is unstable, is a ValueError naming h). Or "3s", "2s", "rks", "rksb", "sv", "heun", "rk4" or "rk" (any
        explicit tableau on the whole system, default "rk4"); for a
        :class:`raydamp.LinearStructure` also the implicit, unconditionally stable
        "midpoint" (order 2; Newmark average acceleration) and "gauss4" (order 4), which
        step the whole linear system with one sparse solve per step; see :func:`raydamp.methods`.
    h : step size, > 0.
    t_end, n_steps : give exactly one. With ``t_end`` not a whole multiple of ``h``
        the last step is shortened to land on ``t_end``.
    save_every : save every this many steps (the final state is always saved).
    tableau : Runge-Kutta tableau for "rks" (default "heun"; also "euler", "rk4",
        "midpoint"), "rksb" and "rk" (explicit tableaux only); or your own,
        ``{"A": [[...]], "b": [...], "c": [...], "order": k}`` (order optional): each
        row of A must sum to c, the order is computed from the order conditions (up
        to 4) and a claimed ``order`` must hold; rks takes diagonally implicit
        tableaux, and a fully implicit one is refused with the reason.
    composition : raise a symmetric order-2 method ("sv", "3s", "2s", "rks" with
        ``tableau="midpoint"``, or "midpoint") to higher order by composing its steps:
        "yoshida4", "suzuki4", "kahan_li6", "mclachlan8" or "kahan_li8" (see
        :func:`raydamp.compositions`); None (default) runs the method itself.
        Every composition of order above 2 has negative coefficients, so some
        damping sub-step runs backward and multiplies the mode of eps D M^{-1}
        with eigenvalue lambda by e^{|tau| lambda} (tau < 0 its duration as the
        step loop runs it, merged sub-steps summed). Before the run the bound
        e^{|tau| rho} (rho: the spectral radius of eps D M^{-1} at q0, or for a
        LinearStructure its guaranteed upper bound ``damping_rate_bound``; for an
        rks Runge-Kutta sub-step its stability function where larger) is
        computed, and a run whose bound passes ``MAX_AMPLIFICATION`` (10: one
        decimal digit of a damped mode per backward sub-step) is refused with a
        ValueError that names the sub-step, its coefficient c (tau = c h), the
        formula evaluated on it and its value, and the largest h that passes.
        Order 2 (no composition) has no backward sub-step. 3s composes most
        gently: its backward damping is only the merged
        c = (gamma_i + gamma_{i+1}) / 2 between stages.
        Over "midpoint" a backward sub-step s < 0 solves with M - (|s|/2) C + (s^2/4) K: refused, with
        the reason, where that is not positive definite (beta K damping with |s| < 2 beta) or amplifies
        a mode more than ``MAX_AMPLIFICATION``-fold.
    save_dofs : save q and p of these coordinates only (indices, in the order given); None
        (default) saves all. Energy, W and the momentum maps are still computed from the whole
        state at each saved point, so a 10^6-site chain run keeps a few numbers per row.
        ``Solution.dofs`` holds the indices.
    progress : True for a tqdm bar (as :func:`raydamp.sweep`'s), or a callable, called as
        ``progress(steps_done, n_steps)`` about 100 times per run (never once per step), from the
        integrating thread; None or False for none.
    cancel : a :class:`CancelToken`; cancelling it stops the run.
    work : also record the damping work W(t) = eps int qdot^T D(q) qdot dt at the saved
        points (``Solution.work``), integrated in the step loop with a quadrature of
        the method's order, so that H(t) - H(0) + W(t) measures the energy error; with a
        load also its work W_f(t) = int f(t) . qdot dt (``Solution.load_work``), and
        ``Solution.energy_balance`` is H - H(0) + W - W_f.
    load : a time-dependent force f(t) (:class:`raydamp.Load`, or a :class:`raydamp.GroundMotion`,
        whose solution is the motion relative to the ground), added to p' = -grad V - eps D M^{-1} p.
        The splittings apply it in their kicks at the time their drifts have reached (t + h/2 for
        3s, 2s and rks), so they keep order 2 and compositions their order; "midpoint" samples
        it at t + h/2, "gauss4" at its two Gauss points, "rk"/"heun"/"rk4" at their stage times.

    temperature : kT (energy units) of thermal noise, or None / 0 for none. Each damping sub-flow of
        3s, 2s and "baoab" becomes its exact Ornstein-Uhlenbeck flow: p -> E p + sqrt(kT (M - E M E^T)) xi,
        E = exp(-t eps D(q) M^{-1}) at the frozen q (fluctuation-dissipation: the Boltzmann density
        exp(-H/kT) is what the exact flow keeps). Isotropic (D = c M), radial and constant-matrix
        damping take it, and a LinearStructure's alpha M + beta K (with alpha = 0 only for a
        positive definite K: ``help(raydamp.systems.structure)``), a Chain's friction and
        dashpots and a System's dashpots (the noise at the frozen q); Runge-Kutta and
        implicit methods and compositions refuse it with the reason.
    seed : the noise's seed, an integer in [0, 2^64); None draws one from the operating system.
        Either way ``Solution.provenance`` keeps it, so the run repeats bit for bit.
    stream : which stream of the seed (Philox-4x32-10, counter-based): ensemble member i uses
        stream i, so ``integrate(..., seed=s, stream=i)`` is that member alone.
    divergence : the divergence test's factor G (default 1e6; 0 turns the test off). A run whose state is
        still finite but whose energy H = T + V has gained more than G times everything its start, its
        load and its temperature can give it stops with status "diverged", keeping its rows. Damping only
        takes energy away, so the gain is bounded by the load's work and the thermal input; the test
        compares H(t) - H(0) with G S(t), S(t) = T(0) + |V(0)| + (t F)^2 + n kT, F the largest
        |f(t)|_{M^-1} of the load, and requires the gain to be at least half of T(t) + |V(t)| (so the
        rounding of a large T and V that cancel, an orbit escaping to infinity, never trips it). It runs
        every 256 steps and at the end; a blow-up that overflows before a check ends "non_finite". An
        expression load's F is sampled (4096 times over the run and at each check): a pulse narrower
        than that from rest can go unseen, so such a run may want ``divergence=0``.
    events : a list of :class:`raydamp.Event` (g an expression, direction, terminal, name): their crossings,
        located on each step's dense output, are ``Solution.events``; a terminal one ends the run there
        (status "event"). The run steps whole steps (see :mod:`raydamp.run.events`).
    dense : keep what ``Solution.at(t)`` needs at every step end: t, q, p, M^-1 p and pdot, 8 (n_steps + 1)
        (1 + 4 dim) bytes whatever ``save_every`` (:mod:`raydamp.results.dense`). Whole steps, as events.
    envelope : a list of quantities whose peaks (max |x| and its time) are taken at every step's end, not
        only at saved rows: "displacement", "velocity", "acceleration", "abs_acceleration" (relative plus the
        ground's), "residual_displacement" per coordinate; "drift" (a spring's deformation: a shear frame's
        interstorey drift), "force", "residual_drift" per spring of a :class:`raydamp.Structure`.
        ``Solution.envelope`` is an xarray Dataset (:mod:`raydamp.run.envelope` documents each). Whole steps.
    collapse : a limit of |drift| for every spring (a number, or one per spring in the Structure's order), or
        None: the first step's end at which a spring's drift passes its limit ends the run, status
        "collapsed" (its message names the spring), keeping its rows and envelope (raydamp.ida's collapse).
    corrector : 4, 6, 8 or 10, or None: a symplectic corrector for a :class:`raydamp.Planets` without drag
        stepped by the leapfrog (sv, 2s or 3s, no composition). The run starts from C^{-1}(q0, p0) and its
        saved rows are read through C, which leaves the error linear in the planets' mass ratio eps at
        O(eps h^corrector) in place of O(eps h^2) (:mod:`raydamp.run.correctors`).

    The step loop runs in C++ with the GIL released.
    """
    if not isinstance(model, Model):
        raise ValueError(f"model must be a raydamp model (e.g. raydamp.models.DampedPendulum()), got {model!r}")
    names, with_tableau = _catalogue()
    # Each check below has a fast path for the common value and falls back on the checker that words the error.
    thermal_run = temperature is not None and real("temperature", temperature, nonnegative=True) > 0
    if method is None:
        method, tableau, method_reason = choose_method(model, method, tableau, composition, h, thermal=thermal_run)
    else:
        method_reason = None  # what choose_method gives for a named method
    if not isinstance(method, str) or method not in names:
        raise ValueError(f"method: unknown method {method!r} (known: {', '.join(names)})")
    tableau_name, tableau = ("", None) if tableau is None else _tableau(tableau)
    if composition is not None and not isinstance(composition, str):
        _core.resolve(method, tableau_name)  # a bad tableau is named first, as before
        raise ValueError(f"composition must be a composition name or None, got {composition!r}")
    resolved_tableau, resolved_composition = _resolved(method, tableau_name, composition or "")
    if not (type(h) is float and 0.0 < h < math.inf):
        h = real("h", h, positive=True)
    dim, most_row_bytes = _facts(model)
    q0 = model.check_configuration("q0", _state("q0", q0, dim))
    p0 = model.check_momenta("p0", q0, _state("p0", p0, dim))  # a constrained System: on the tangent space
    if not (type(save_every) is int and 1 <= save_every <= MAX_STEPS):
        save_every = integer("save_every", save_every, maximum=MAX_STEPS)
    if divergence is not DEFAULT_DIVERGENCE:
        divergence = real("divergence", divergence, nonnegative=True)
    if t_end is None and type(n_steps) is int and 1 <= n_steps <= MAX_STEPS and n_steps * h < math.inf:
        h_last = h  # what span() gives for n_steps
    else:
        n_steps, h_last = span(h, t_end, n_steps)
    if corrector is not None:
        corrector = _correctors.check(model, corrector, method=method, composition=composition, load=load,
                                      temperature=temperature, save_dofs=save_dofs, events=events, dense=dense,
                                      envelope=envelope, collapse=collapse, h=h, h_last=h_last)
    bar = None
    if progress is True or progress is False:
        bar, progress = _bar(n_steps) if progress else (None, None)
    elif progress is not None and not callable(progress):
        raise ValueError(f"progress must be callable, True or None, got {progress!r}")
    if work is not False and work is not True:
        work = flag("work", work)
    if cancel is not None and not isinstance(cancel, _core.CancelToken):
        raise ValueError(f"cancel must be a raydamp.CancelToken or None, got {cancel!r}")
    if load is not None and not isinstance(load, Load):
        raise ValueError(f"load must be a raydamp.Load or raydamp.GroundMotion or None, got {_short(load)}")
    core_load = load.bind(model) if _loaded(load) else None  # raises naming load.direction etc.
    if temperature is None and seed is None and type(stream) is int and stream == 0:
        kT, seed = 0.0, 0  # no noise: what thermal() gives, without its checks
    else:
        kT, seed, stream = thermal(temperature, seed, stream)
    dofs = None if save_dofs is None else _save_dofs(save_dofs, dim)
    # The saved points' size is counted only where it could pass the limit: save_rows <= n_steps // save_every + 2
    # and a point takes at most most_row_bytes.
    if (n_steps // save_every + 2) * most_row_bytes > MAX_SAVED_BYTES:
        rows = _core.save_rows(n_steps, save_every)  # run/save_grid.py
        size = rows * row_bytes(model, dofs, work=work, load=load)
        if size > MAX_SAVED_BYTES:
            raise ValueError(f"save_every: {rows} saved points would take {size / 2**30:.1f} GiB "
                             f"(limit {MAX_SAVED_BYTES / 2**30:.0f} GiB); raise save_every")
    watch = None if events is None and dense is False else _events.prepare(model, events, dense, temperature=kT)
    peaks = None if envelope is None and collapse is None else _envelope.prepare(
        model, envelope, collapse=_envelope.limits(model, collapse), given_collapse=collapse)
    if peaks is not None and dofs is not None and set(peaks.names) & set(_envelope.RESIDUALS):
        raise ValueError("envelope: a residual is read from the final state of every coordinate, and save_dofs "
                         "keeps only some; leave save_dofs None, or drop the residual")
    if watch is not None and watch.dense and _events.dense_bytes(n_steps, dim) > MAX_SAVED_BYTES:
        raise ValueError(f"dense: {_events.dense_bytes(n_steps, dim) / 2**30:.1f} GiB of dense output (limit "
                         f"{MAX_SAVED_BYTES / 2**30:.0f} GiB); take fewer steps")

    q_run, p_run = (q0, p0) if corrector is None else _correctors.start(model, corrector, h, q0, p0)
    start = time.perf_counter()
    try:
        # positional: pybind11 matches keyword arguments by name, a microsecond of a short call
        out = model._core_model.integrate(method, tableau_name, composition or "", q_run, p_run, h, n_steps, h_last,
                                          save_every, work, progress, cancel, [] if dofs is None else dofs,
                                          core_load, kT, seed, stream, divergence,
                                          *((watch.core, watch.dense) if watch else ()),
                                          *(() if peaks is None else ((None, False) if watch is None else ()) +
                                            (peaks.core,)))
    except ValueError as error:  # the core names the method it runs ("rk" for "rk4"): the caller's name here
        named = re.sub(r"^temperature: method '[^']*'", f"temperature: method {method!r}", str(error))
        if named == str(error):
            raise  # as it came (a ChebyshevDegreeError stays one, a progress callback's own error its own)
        raise ValueError(named) from None
    finally:
        if bar is not None:
            bar.close()
    if corrector is not None:
        _correctors.rows(model, corrector, h, out)
    wall = time.perf_counter() - start
    message = out["message"]
    explain = getattr(model, "_explain_failure", None)
    if explain is not None and (why := explain()) is not None:
        message = f"{message}: {why}"
    composition = None if resolved_composition == "none" else resolved_composition
    loaded = load if core_load is not None else None
    options = {
        "method": method, "tableau": tableau, "composition": composition, "h": h,
        "t_end": t_end, "n_steps": None if t_end is not None else n_steps,
        "save_every": save_every, "work": work, "save_dofs": dofs, "load": loaded,
        "thermal": (kT, seed, stream) if kT > 0 else None, "method_reason": method_reason,
        "divergence": None if divergence == DEFAULT_DIVERGENCE else divergence}
    if corrector is not None:
        options["corrector"] = corrector
    fields = {
        "t": out["t"], "q": out["q"], "p": out["p"], "energy": out["energy"], "momentum": out["momentum"],
        "status": out["status"], "steps": out["steps"], "failed_step": out["failed_step"], "message": message,
        "method": method, "tableau": resolved_tableau if method in with_tableau else None,
        "composition": composition, "h": h, "max_momentum_drift": out["max_momentum_drift"], "work": out["work"],
        "wall_time": wall, "load_work": out["load_work"], "load": loaded,
        "hysteretic_work": _envelope.users_springs(model, out.get("spring_work")),
        "spring_forces": _envelope.users_springs(model, out.get("spring_force")),
        "spring_deformations": _envelope.users_springs(model, out.get("spring_deformation")),
        "dofs": None if dofs is None else np.asarray(dofs, dtype=np.int64),
        "constraint_residual": out.get("constraint_residual"),
        "constraint_velocity_residual": out.get("constraint_velocity_residual"),
        "multipliers": out.get("multipliers"),
        # q0 and p0 are the run's own arrays (_state), so the provenance keeps them uncopied
        "origin": (model, q0, p0, options)}
    if watch:
        fields.update(_events.results(watch, out))
        options.update(events=[e.to_dict() for e in watch.events], dense=dense)
    if peaks is not None:
        fields["envelope"] = _envelope.dataset(peaks, out, out["q"][-1])
        options.update(envelope=list(peaks.names), collapse=peaks.collapse)
    return _solution(fields)


def _bar(n_steps: int):
    """A tqdm bar over the run's steps and the progress callback that moves it."""
    from tqdm.auto import tqdm

    bar = tqdm(total=n_steps, unit="step", desc="integrate")

    def progress(done: int, total: int) -> None:
        bar.update(done - bar.n)
    return bar, progress


def _save_dofs(save_dofs, dim: int) -> list[int] | None:
    """The coordinates to save, checked: distinct integers in [0, dim)."""
    if save_dofs is None:
        return None
    # Ordered sequences only: a set's or dict's order is not one the caller chose; a 0-d array has no len().
    if isinstance(save_dofs, (str, bytes, set, frozenset, Mapping)) or not hasattr(save_dofs, "__len__") \
            or np.ndim(save_dofs) != 1:
        raise ValueError(f"save_dofs must be a list of coordinate indices or None, got {_short(save_dofs)}")
    if len(save_dofs) == 0:  # the core reads an empty list as "all": refused rather than saving every coordinate
        raise ValueError("save_dofs: an empty list saves no coordinate; give at least one index, or None for all")
    out = []
    for i, x in enumerate(save_dofs):
        if isinstance(x, bool) or not isinstance(x, (int, np.integer)):
            raise ValueError(f"save_dofs[{i}] must be an integer, got {_short(x)}")
        if not 0 <= int(x) < dim:
            raise ValueError(f"save_dofs[{i}]: {int(x)} is not a coordinate (0..{dim - 1})")
        out.append(int(x))
    if len(set(out)) != len(out):
        raise ValueError("save_dofs: an index appears twice")
    return out
