"""raydamp.advise: which method, at which step, reaches a tolerance on a linear structure fastest.

Before a long run, from the structure and (when given) the start and the load:

- the natural frequencies and modes (a dense eigensolver below 500 DOF: all of them; shift-invert Lanczos
  beyond: the lowest _LANCZOS_MODES, and the largest frequency omega_max);
- each explicit method's stability limit h_max, from the step matrix itself: one step of the method on a
  modal copy of the structure (one uncoupled mode per frequency on a grid up to omega_max, each with its
  Rayleigh rate alpha + beta omega^2) gives each mode's 2 x 2 step matrix, and h_max is the largest h at
  which none has an eigenvalue outside the unit circle (steps up to t_end tried, then bisection to 1e-7).
  2s is not A-stable: with beta K damping that overdamps the top modes its step grows past about h = 2 beta;
- each method's step for the tolerance, from the modal error model (:mod:`raydamp.run.advise_modal`): the
  motion is split into modes, q = sum phi_i x_i, and each mode is stepped by the method's own 2 x 2 step
  matrix (taken from the core on the modal copy) against its exact damped motion. The error is

      max over the steps of || q_method(t_n) - q_exact(t_n) || / scale,

  the Euclidean norm over the DOF, scale = ||q0|| (or, from rest, the peak of the response). So each mode
  counts by its share of the motion, with its own frequency and its damping decay over t_end, and a
  method's error past h omega = 1 (an overdamped top mode that midpoint and gauss4 keep at amplitude about
  1, by design) is in it. The step is the fewest whole steps whose predicted error is within 0.99 of the
  tolerance (rounding, and a maximum between the sampled steps). An explicit method steps at most at
  0.95 h_max, and its error is then below the tolerance.
- what the motion is: ``q0`` and ``p0`` give the modal coordinates x_i = phi_i^T M q0, v_i = phi_i^T p0. A
  ``load`` adds to each mode the peak of its exact forced response (modal forces linear between the load's
  samples), as an amplitude at the start: a model of the free-vibration part of the error the forced
  motion carries, not an exact error. With none of them, one mode at ``omega`` (default omega_1, the
  lowest natural frequency) of unit amplitude: the model of the issue-25 advise.
- under a record (a load series sampled at a constant dt), the step is h = dt / k for an integer k: a longer
  step, or one that does not divide dt, puts the record's kinks inside steps (a 10-storey building under a
  record at dt = 0.01: gauss4 at h = 0.7 dt is 9.6e-4 off, against 2.2e-8 at h = dt). The table's "by" column
  then says "record".
- each method's cost: the steps times its cost per step, measured by trial steps at that h on the structure
  itself (3s's and 2s's Chebyshev degree, the implicit methods' sparse solve and factorisation are all in
  the figure), plus its set-up. The trial runs are repeated and the median taken, never below a floor
  from an operation count (products with K per step times nnz(K) times _FLOOR_SECONDS_PER_NONZERO); the
  recommended row is then run for a few steps, and when its prediction is more than 3x off all rows are
  re-timed (``Advice.retimed``).

What the model assumes: a linear structure with Rayleigh damping (so the modes decouple; a Chebyshev
series' own error, 1e-13, is not modelled); the motion is the start's (and the load's) modes, all of them
below 500 DOF, the lowest _LANCZOS_MODES beyond (``Advice.unresolved`` is the share of ||q0|| outside
them, not modelled); the error is measured at the step times. A random start is not a fair case: midpoint
and gauss4 keep its overdamped top modes at amplitude about 1, so only a very small step meets a tight
tolerance, and the model says so.

``Advice.recommended`` is the row of least predicted time; ``recommended.options`` are
:func:`raydamp.integrate`'s method, tableau and h for it.
"""

from __future__ import annotations

import math
import statistics
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .._validation import MAX_STEPS, flag, real, vector
from ..loads import Load
from ..systems.models import Model
from ..systems.series import ChebyshevDegreeError
from ..systems.structure import LinearStructure
from . import advise_modal as modal
from .integrate import integrate

__all__ = ["advise", "Advice", "MethodAdvice", "ERROR_MODEL", "STABILITY_MARGIN"]

# (method, tableau, order p, error constant C, explicit in the stiffness): the leading phase error of a mode,
# C (h omega)^p omega t, which gives the modal model's first guess of the step.
ERROR_MODEL = (
    ("3s", None, 2, 1 / 24, True),
    ("2s", None, 2, 1 / 24, True),
    ("rks", "heun", 2, 1 / 24, True),
    ("rks", "midpoint", 2, 1 / 24, True),
    ("heun", None, 2, 1 / 6, True),
    ("rk4", None, 4, 1 / 120, True),
    ("midpoint", None, 2, 1 / 12, False),
    ("gauss4", None, 4, 1 / 720, False),
)
_CONSTANTS = {(method, tableau): (order, constant) for method, tableau, order, constant, _ in ERROR_MODEL}
_MODEL_STEPS = 10**8        # beyond this many steps the error model is the leading phase-error term alone
# Products with K (or solves) per step, for the floor of a measured time per step: (fixed, per Chebyshev degree).
_OPERATIONS = {("3s", None): (1, 2), ("2s", None): (1, 1), ("rks", "heun"): (3, 0), ("rks", "midpoint"): (3, 0),
               ("heun", None): (2, 0), ("rk4", None): (4, 0), ("midpoint", None): (3, 0), ("gauss4", None): (8, 0)}
_FLOOR_SECONDS_PER_NONZERO = 2e-10   # a product with a sparse K costs at least this per nonzero (measured 1-2 ns)
_FLOOR_SECONDS_PER_STEP = 5e-8       # the step loop's own overhead, at least
# Below this, rounding over a run sets the error, whatever the method and its step (an audit: 1e-14 measured).
MIN_TOLERANCE = 1e-13
# An explicit method steps at most at this fraction of its stability limit.
STABILITY_MARGIN = 0.95
_AIM = 0.85                 # the modal model aims at this fraction of the tolerance first
_MARGIN = 0.99              # and accepts a step up to this fraction (rounding; a maximum between samples)
_DENSE_BELOW = 500          # DOF: all modes from a dense eigensolver below this
_LANCZOS_MODES = 40         # beyond: this many of the lowest modes weight the error model
_MODAL_GRID = 48            # frequencies of the modal copy that stability limits are computed on
_TRIAL_SECONDS = 0.005      # about this long of trial steps per method and repetition
_REPEATS = 3                # trial runs per figure, the median taken
_RETIME_FACTOR = 3.0        # a recommendation this far off its first measured steps gets all rows re-timed
_UNSTABLE = 1e-9            # a step matrix eigenvalue above 1 + this is growth
_clock = time.perf_counter  # the trial timings' clock (a test freezes it)


@dataclass(frozen=True)
class MethodAdvice:
    """One method's row: its stability limit, the step it would take, and what that predicts."""

    method: str
    tableau: str | None
    order: int
    h_max: float              # stability limit (inf: stable at every step up to t_end; 0: unstable at every step)
    h: float                  # the step it would take for the tolerance (nan when it cannot run)
    limited_by: str           # "tolerance", "stability", "record" (h = dt / k of a load record), "unstable",
    #                           "steps" (more than integrate runs, or the tolerance is out of reach) or "series"
    #                           (its damping flow over h needs a Chebyshev series past degree 8192: not run)
    steps: int
    error: float              # predicted error at h (the modal model)
    h_rho: float              # h (alpha + beta L): the damping's stiffness over one step
    chebyshev_degree: int | None
    seconds_per_step: float
    setup_seconds: float
    seconds: float            # predicted time of the whole run

    @property
    def label(self) -> str:
        return self.method if self.tableau is None else f"{self.method}-{self.tableau}"

    @property
    def options(self) -> dict[str, Any]:
        """raydamp.integrate's keyword arguments for this row: method, tableau, h."""
        return {"method": self.method, "tableau": self.tableau, "h": self.h}


@dataclass(frozen=True)
class Advice:
    """What ``raydamp.advise`` found; ``str()`` is a table, ``recommended`` the fastest row."""

    dim: int
    nnz: int
    omega_max: float
    omega_1: float
    omega: float              # the mode the error model weights (weighting "mode"), else the lowest weighted one
    rho: float                # the damping rate bound alpha + beta L
    t_end: float
    tolerance: float
    rows: tuple[MethodAdvice, ...] = field(default_factory=tuple)
    weighting: str = "mode"   # "mode": one mode at omega; "start": q0/p0's modes; "start and load"
    modes: int = 1            # the modes the error model sums
    unresolved: float = 0.0   # the share of ||q0|| outside the modes computed (Lanczos only): not modelled
    record_dt: float | None = None   # the load record's sampling step: h = record_dt / k
    retimed: bool = False     # the first timings disagreed with the recommended run's first steps: re-timed

    @property
    def recommended(self) -> MethodAdvice:
        return min(self.rows, key=lambda r: r.seconds)

    def row(self, label: str) -> MethodAdvice:
        """The row of a method by label ("3s", "rks-midpoint", ...)."""
        for r in self.rows:
            if r.label == label:
                return r
        raise KeyError(label)

    def __str__(self) -> str:
        motion = {"mode": f"one mode at omega = {self.omega:.6g}",
                  "start": f"the start's {self.modes} modes",
                  "start and load": f"the start's and the load's {self.modes} modes"}[self.weighting]
        head = (f"linear structure: {self.dim} DOF, nnz(K) = {self.nnz}; omega_max = {self.omega_max:.6g} "
                f"(explicit h < {2 / self.omega_max:.4g}), omega_1 = {self.omega_1:.6g}; damping rate bound "
                f"rho = {self.rho:.4g}\n"
                f"to t_end = {self.t_end:g} within {self.tolerance:g} (modal error model, weighting {motion}"
                + (f"; {self.unresolved:.2g} of ||q0|| outside them, not modelled" if self.unresolved > 1e-3 else "")
                + (f"; h = dt/k of the load record, dt = {self.record_dt:g}" if self.record_dt else "")
                + "):\n")
        columns = ("method", "order", "h_max", "h", "by", "steps", "error", "h rho", "cheb", "s/step", "setup s",
                   "total s")
        table = [columns]
        for r in sorted(self.rows, key=lambda r: r.seconds):
            table.append((r.label, str(r.order), "inf" if math.isinf(r.h_max) else f"{r.h_max:.4g}",
                          _g(r.h), r.limited_by, "-" if r.limited_by == "unstable" else _count(r.steps), _g(r.error),
                          _g(r.h_rho), "-" if r.chebyshev_degree is None else str(r.chebyshev_degree),
                          _g(r.seconds_per_step), _g(r.setup_seconds), _g(r.seconds)))
        widths = [max(len(row[i]) for row in table) for i in range(len(columns))]
        lines = ["  ".join(cell.ljust(w) if i == 0 else cell.rjust(w) for i, (cell, w) in enumerate(zip(row, widths)))
                 for row in table]
        best = self.recommended
        return (head + "\n".join(lines) + f"\nrecommended: {best.label} at h = {best.h:.6g} "
                f"({best.steps} steps, about {best.seconds:.3g} s)"
                + (" (timings re-measured: the first ones disagreed with its first steps)" if self.retimed else ""))

    def _repr_pretty_(self, printer, cycle) -> None:  # IPython
        printer.text(str(self))

    def __repr__(self) -> str:
        return str(self)


def _g(x: float) -> str:
    return "-" if not math.isfinite(x) else f"{x:.3g}"


def _count(steps: int) -> str:
    return str(steps) if steps < 10**12 else f"{float(steps):.3g}"


def advise(structure: Model, t_end: float, tolerance: float, *, omega: float | None = None,
           measure: bool = True, q0=None, p0=None, load: Load | None = None) -> Advice:
    """Each method's stability limit, step and predicted cost to reach ``tolerance`` by ``t_end``.

    Parameters
    ----------
    structure : a :class:`raydamp.LinearStructure` (other kinds have no M and K to bound the spectrum
        with, and are refused with a ValueError).
    t_end : the span of the run, > 0.
    tolerance : the error allowed, max over the run of ``||q - q_exact|| / ||q0||`` (Euclidean norms; from
        rest, ``||q0|| = 0``, relative to the peak of ``||q_exact||`` instead), in (0, 1).
    omega : without q0, p0 and load: the frequency of the one mode the error model weights; default the
        lowest natural frequency omega_1. Ignored when the start or the load is given.
    measure : time trial steps of each method on the structure (default); False leaves the time
        columns nan and recommends by steps alone.
    q0, p0 : the start the run will take (vectors over the DOF): the error model weights each mode by its
        share of it, and accounts for each mode's damping decay over t_end.
    load : the :class:`raydamp.Load` (or GroundMotion) the run will take: each mode also counts with the peak
        of its forced response; a record sampled at dt makes the step dt / k.

    The model, what it assumes and its constants are in :mod:`raydamp.run.advise`'s docstring.
    """
    if not isinstance(structure, LinearStructure):
        kind = type(structure).__name__
        raise ValueError(f"structure: advise needs a raydamp.LinearStructure (its M and K bound the spectrum); "
                         f"got a {kind}, whose frequencies depend on the state: compare methods on it with "
                         "raydamp.analysis (convergence) instead")
    t_end = real("t_end", t_end, positive=True)
    tolerance = real("tolerance", tolerance, positive=True)
    measure = flag("measure", measure)
    if tolerance >= 1:
        raise ValueError(f"tolerance must be below 1 (an error relative to the initial amplitude), got {tolerance}")
    if tolerance < MIN_TOLERANCE:  # a run of doubles does not get closer: asked for 1e-20, gauss4 gave 1.4e-14
        raise ValueError(f"tolerance must be at least {MIN_TOLERANCE:g}: below it rounding, not the method, sets "
                         f"the error, got {tolerance:g}")
    n = structure.dim
    q0 = None if q0 is None else vector("q0", q0, n)
    p0 = None if p0 is None else vector("p0", p0, n)
    if load is not None and not isinstance(load, Load):
        raise ValueError(f"load must be a raydamp.Load or raydamp.GroundMotion or None, got {type(load).__name__}")
    if load is not None and not load.terms:
        load = None
    if omega is not None:
        omega = real("omega", omega, positive=True)

    frequencies, shapes, omega_max = _modes(structure)
    positive = frequencies[frequencies > 0]
    if positive.size == 0 or omega_max <= 0:
        raise ValueError("structure: K has no positive eigenvalue (nothing vibrates); there is nothing to advise on")
    omega_1 = float(positive[0])
    motion, weighting, unresolved, record_dt = _motion(structure, frequencies, shapes, t_end, tolerance,
                                                       omega if omega is not None else omega_1, q0, p0, load)
    if weighting == "mode":
        omega_shown = motion.omega[0]
    else:
        weighted = motion.omega[motion.omega > 0]
        omega_shown = float(weighted[0]) if weighted.size else omega_1
    limits = _stability_limits(structure, omega_1, omega_max, t_end)
    copies: list = []           # the motion's modal copies, made when first needed

    def error(method, tableau, h, steps):
        if steps > _MODEL_STEPS:  # past what the powers of a step matrix resolve in doubles: the leading term
            return modal.leading_error(motion, _CONSTANTS[(method, tableau)], h, t_end)
        if not copies:
            copies.extend(_modal_copies(structure, motion.omega))
        return modal.predicted_error(motion, _step_matrices(copies, method, tableau, h), h, steps)

    plans = [_plan(method, tableau, order, constant, limits[(method, tableau)] if explicit else math.inf,
                   t_end, tolerance, motion, record_dt, error)
             for method, tableau, order, constant, explicit in ERROR_MODEL]
    rows = [_row(structure, plan, measure) for plan in plans]
    if all(math.isinf(row.seconds) for row in rows):
        raise ValueError(f"tolerance: no method reaches {tolerance:g} by t_end = {t_end:g} in at most {MAX_STEPS:.3g} "
                         "steps (the most integrate runs); raise the tolerance or shorten t_end")
    retimed = False
    if measure and _off(structure, min(rows, key=lambda r: r.seconds)):
        rows = [_row(structure, plan, measure, repeats=2 * _REPEATS + 1) for plan in plans]
        retimed = True
    return Advice(n, int(structure._stiffness.nnz), omega_max, omega_1, float(omega_shown),
                  structure.damping_rate_bound, t_end, tolerance, tuple(rows), weighting, int(motion.omega.size),
                  unresolved, record_dt, retimed)


# ---- the modes and the motion ------------------------------------------------------------------------------

def _modes(structure: LinearStructure) -> tuple[np.ndarray, np.ndarray, float]:
    """(frequencies, M-normalised shapes, omega_max): all modes below _DENSE_BELOW DOF, else the lowest few."""
    n = structure.dim
    if n < _DENSE_BELOW:
        frequencies, shapes = structure.modes()
        return frequencies, shapes, float(frequencies[-1])
    import scipy.sparse.linalg as sla

    top = sla.eigsh(structure._stiffness, k=1, M=structure._mass, which="LA", tol=1e-8, return_eigenvectors=False)
    frequencies, shapes = structure.modes(min(_LANCZOS_MODES, n - 2))
    return frequencies, shapes, math.sqrt(max(float(top[0]), float(frequencies[-1]) ** 2))


def _record_step(load: Load | None) -> float | None:
    """The sampling step of the load's record (a series at a constant dt); the finest when there are several."""
    if load is None:
        return None
    steps = []
    for term in load.terms:
        t = getattr(term, "t", None)
        if t is not None and t.size > 2:
            dt = (t[-1] - t[0]) / (t.size - 1)
            if dt > 0 and np.max(np.abs(t - (t[0] + np.arange(t.size) * dt))) <= 1e-10 * dt:
                steps.append(float(dt))
    return min(steps) if steps else None


def _motion(structure, frequencies, shapes, t_end, tolerance, omega, q0, p0, load):
    """The modal motion the error is weighted by, its name, the unresolved share of q0 and the record's dt."""
    record_dt = _record_step(load)
    if q0 is None and p0 is None and load is None:
        one = np.array([float(omega)])
        with np.errstate(over="ignore"):  # omega = 1e300: a rate of inf, and steps past what integrate runs
            rate = structure.alpha + structure.beta * one ** 2
        motion = modal.ModalMotion(one, rate, np.ones((1, 1)), np.ones(1), np.zeros(1), 1.0)
        return motion, "mode", 0.0, record_dt
    n = structure.dim
    q = np.zeros(n) if q0 is None else q0
    p = np.zeros(n) if p0 is None else p0
    x0 = shapes.T @ (structure._mass @ q)
    v0 = shapes.T @ p
    size = float(np.linalg.norm(q))
    unresolved = float(np.linalg.norm(q - shapes @ x0)) / size if size > 0 and shapes.shape[1] < n else 0.0
    scale = size
    if scale == 0:  # from rest: relative to the response's peak
        if v0.any():
            free = modal.select_modes(frequencies, shapes, x0, v0, 1.0, 1e-12, structure.alpha, structure.beta)
            scale = modal.free_peak(free, t_end)
    if load is not None:
        dt = record_dt if record_dt is not None else t_end / 4000
        times = np.arange(0.0, t_end + dt, dt)
        forces = np.asarray(load.values(structure, times)) @ shapes
        rate = structure.alpha + structure.beta * frequencies ** 2
        response = modal.forced_response(frequencies, rate, forces, dt)
        peak = np.max(np.abs(response), axis=0)
        x0 = x0 + np.where(x0 < 0, -peak, peak)
        if size == 0:
            scale = max(scale, float(np.max(np.linalg.norm(response @ shapes.T, axis=1))))
    if not scale > 0:
        raise ValueError("q0, p0, load: the start is at rest and the load does nothing: there is no motion to "
                         "advise on")
    motion = modal.select_modes(frequencies, shapes, x0, v0, scale, tolerance, structure.alpha, structure.beta)
    return motion, "start" if load is None else "start and load", unresolved, record_dt


# ---- one method's step ----------------------------------------------------------------------------------

@dataclass(frozen=True)
class _Plan:
    method: str
    tableau: str | None
    order: int
    h_max: float
    h: float
    steps: int
    limited_by: str
    error: float


def _plan(method, tableau, order, constant, h_max, t_end, tolerance, motion, record_dt, error) -> _Plan:
    """The fewest steps (of t_end / N, or dt / k under a record) whose modal error is within the tolerance."""
    if h_max == 0:
        return _Plan(method, tableau, order, 0.0, math.nan, 0, "unstable", math.nan)
    unit = record_dt if record_dt is not None else t_end       # h = unit / k
    k_min = max(1, math.ceil(unit / (STABILITY_MARGIN * h_max) * (1 - 1e-12))) if math.isfinite(h_max) else 1

    def steps_of(k: int) -> int:
        ratio = t_end * k / unit
        return max(1, math.ceil(ratio * (1 - 1e-12))) if math.isfinite(ratio) else MAX_STEPS + 1

    # the first guess: the leading phase error of the lowest weighted mode
    w = float(motion.omega[motion.omega > 0][0]) if (motion.omega > 0).any() else 1.0
    with np.errstate(all="ignore"):
        h_guess = float(np.float64(tolerance) / (constant * w * t_end)) ** (1 / order) / w
    k = max(k_min, math.ceil(unit / h_guess) if h_guess > 0 and math.isfinite(unit / h_guess) else MAX_STEPS)
    tried: dict[int, float] = {}

    def within(k: int) -> bool:
        if k not in tried:
            tried[k] = error(method, tableau, unit / k, steps_of(k))
        return tried[k] <= _MARGIN * tolerance

    # a step count within the tolerance: from the guess, aimed at _AIM of it
    best = None
    for _ in range(10):
        if steps_of(k) > MAX_STEPS:
            break
        if within(k):
            best = k
            break
        e = tried[k]
        grow = (e / (_AIM * tolerance)) ** (1 / order) if math.isfinite(e) and e > 0 else 4.0
        k = max(k + 1, math.ceil(k * grow * (1 - 1e-12)))
    if best is None:
        return _Plan(method, tableau, order, h_max, unit / k, steps_of(k), "steps", math.nan)
    # the fewest: predicted from the error's order, bisection where the prediction falls short
    failed = max([j for j, e in tried.items() if e > _MARGIN * tolerance and j < best], default=k_min - 1)
    for _ in range(12):
        if best - failed <= 1 or best - failed <= best // 200:  # within 0.5% of the fewest
            break
        e = tried[best]
        guess = math.ceil(best * (e / (_MARGIN * tolerance)) ** (1 / order) * (1 - 1e-12)) if e > 0 else failed + 1
        if guess >= best:       # predicted at the fewest already: is one fewer still within?
            guess = best - 1
        elif guess <= failed:
            guess = (failed + best) // 2
        if within(guess):
            best = guess
        else:
            failed = guess
    k, e = best, tried[best]
    limited = ("stability" if k == k_min and k > 1 and math.isfinite(h_max)
               else "record" if record_dt is not None and e < _AIM * tolerance / 2 else "tolerance")
    return _Plan(method, tableau, order, h_max, unit / k, steps_of(k), limited, e)


def _row(structure: LinearStructure, plan: _Plan, measure: bool, repeats: int = _REPEATS) -> MethodAdvice:
    """The plan's row: its Chebyshev degree and its cost, measured or not."""
    method, tableau, order, h_max, h, steps = plan.method, plan.tableau, plan.order, plan.h_max, plan.h, plan.steps
    if plan.limited_by in ("unstable", "steps"):
        return MethodAdvice(method, tableau, order, h_max, h if plan.limited_by == "steps" else math.nan,
                            plan.limited_by, steps, math.nan, math.nan, None, math.nan, math.nan, math.inf)
    try:
        degree = max(structure.chebyshev_degrees(h)) if method in ("3s", "2s") and structure.eps else None
    except ChebyshevDegreeError:  # the damping flow over h is past the series' degree bound: 3s and 2s refuse it
        return MethodAdvice(method, tableau, order, h_max, h, "series", steps, math.nan, math.nan, None,
                            math.nan, math.nan, math.inf)
    if measure:
        per_step, setup = _trial(structure, method, tableau, h, repeats, _floor(structure, method, tableau, degree))
        seconds = setup + steps * per_step
    else:
        per_step, setup, seconds = math.nan, math.nan, float(steps)
    return MethodAdvice(method, tableau, order, h_max, h, plan.limited_by, steps, plan.error,
                        h * structure.damping_rate_bound, degree, per_step, setup, seconds)


def _floor(structure: LinearStructure, method: str, tableau: str | None, degree: int | None) -> float:
    """A time per step no run of the method on this structure beats: its products with K times nnz(K)."""
    fixed, per_degree = _OPERATIONS[(method, tableau)]
    products = fixed + per_degree * (degree or 0)
    return _FLOOR_SECONDS_PER_STEP + products * structure._stiffness.nnz * _FLOOR_SECONDS_PER_NONZERO


# ---- stability from the step matrix ------------------------------------------------------------------------

def _stability_limits(structure: LinearStructure, omega_1: float, omega_max: float, t_end: float) -> dict:
    """Each explicit method's h_max on modal copies of the structure (one uncoupled mode per frequency): the
    first step on a grid up to max(100 / omega_max, t_end) at which a mode grows, then bisection."""
    omegas = np.unique(np.concatenate([np.geomspace(min(omega_1, 1e-3 * omega_max), omega_max, _MODAL_GRID),
                                       [omega_1, omega_max]]))
    modals = _modal_copies(structure, omegas)

    def stable(method: str, tableau: str | None, h: float) -> bool:
        return all(_stable_copy(modal_copy, method, tableau, h) for modal_copy, _ in modals)

    limits = {}
    top = max(1e2 / omega_max, t_end)
    grid = np.geomspace(1e-3 / omega_max, top, max(61, int(12 * math.log10(top * omega_max / 1e-3)) + 1))
    for method, tableau, _order, _constant, explicit in ERROR_MODEL:
        if not explicit:
            limits[(method, tableau)] = math.inf
            continue
        last_stable = 0.0
        for h in grid:
            if not stable(method, tableau, h):
                break
            last_stable = h
        else:
            limits[(method, tableau)] = math.inf
            continue
        if last_stable == 0.0:
            limits[(method, tableau)] = 0.0
            continue
        lo, hi = last_stable, h
        while hi - lo > 1e-7 * hi:
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if stable(method, tableau, mid) else (lo, mid)
        limits[(method, tableau)] = lo
    return limits


def _modal_copies(structure: LinearStructure, frequencies: np.ndarray) -> list[tuple[LinearStructure, np.ndarray]]:
    """Modal copies (M = I, K = diag(omega^2), the structure's alpha and beta) of these frequencies (ascending),
    each with a core bound L that covers its spectrum, and the positions of its frequencies. The core's bound
    min(1.05 Lanczos, Gershgorin) came out at 1.6% and 29% of omega_max^2 on a 48-frequency grid from 0.05 to
    3.8e5 in some processes (the same grid in others: exact), and the damping flows over [0, L] are wrong
    above L: a copy not covered is split in two (one frequency is always covered)."""
    return _copies(structure, np.asarray(frequencies, dtype=float), 0)


def _copies(structure, frequencies, offset):
    import scipy.sparse as sparse

    modal_copy = LinearStructure(sparse.identity(frequencies.size, format="csc"),
                                 sparse.diags(frequencies ** 2).tocsc(), alpha=structure.alpha, beta=structure.beta)
    if frequencies.size == 1 or modal_copy.spectral_bound >= frequencies[-1] ** 2 * (1 - 1e-12):
        return [(modal_copy, np.arange(offset, offset + frequencies.size))]
    half = frequencies.size // 2
    return _copies(structure, frequencies[:half], offset) + _copies(structure, frequencies[half:], offset + half)


def _step_matrices(copies, method: str, tableau: str | None, h: float) -> np.ndarray:
    """Each mode's 2 x 2 step matrix over (x, v) (modes, 2, 2): one step from (1, 0) and one from (0, 1).
    A step the method cannot take (a Chebyshev series past its bound, a failed run) is an infinite matrix."""
    size = sum(index.size for _, index in copies)
    S = np.empty((size, 2, 2))
    for modal_copy, index in copies:
        ones, zeros = np.ones(modal_copy.dim), np.zeros(modal_copy.dim)
        try:
            a = integrate(modal_copy, ones, zeros, method=method, tableau=tableau, h=h, n_steps=1)
            b = integrate(modal_copy, zeros, ones, method=method, tableau=tableau, h=h, n_steps=1)
        except ChebyshevDegreeError:
            S[index] = np.inf
            continue
        if not (a.success and b.success):
            S[index] = np.inf
            continue
        S[index, 0, 0], S[index, 1, 0] = a.q[-1], a.p[-1]
        S[index, 0, 1], S[index, 1, 1] = b.q[-1], b.p[-1]
    return S


def _stable_copy(modal_copy, method: str, tableau: str | None, h: float) -> bool:
    """No mode of the modal copy grows over one step of method at h."""
    S = _step_matrices([(modal_copy, np.arange(modal_copy.dim))], method, tableau, h)
    if not np.all(np.isfinite(S)):
        return False
    # eigenvalues (a + d)/2 +- sqrt(((a - d)/2)^2 + b c), written so (not from trace^2/4 - det) to keep a step
    # close to the identity accurate
    a, b, c, d = S[:, 0, 0], S[:, 0, 1], S[:, 1, 0], S[:, 1, 1]
    mean = (a + d) / 2
    root = np.sqrt((((a - d) / 2) ** 2 + b * c).astype(complex))
    radius = np.maximum(np.abs(mean + root), np.abs(mean - root))
    return bool(np.all(radius <= 1 + _UNSTABLE))


# ---- timings ---------------------------------------------------------------------------------------------

def _trial(structure: LinearStructure, method: str, tableau: str | None, h: float, repeats: int,
           floor: float) -> tuple[float, float]:
    """(seconds per step, set-up seconds) of method at h on the structure: the medians of ``repeats`` pairs of
    short runs (a machine's noise made single figures collapse to 1e-9 s a step), never below ``floor``."""
    rng = np.random.default_rng(0)
    q0 = 1e-3 * rng.standard_normal(structure.dim)
    p0 = np.zeros(structure.dim)

    def run(steps: int) -> float:
        start = _clock()
        integrate(structure, q0, p0, method=method, tableau=tableau, h=h, n_steps=steps, save_every=steps)
        return _clock() - start

    first = run(2)
    k = int(min(1000, max(1, _TRIAL_SECONDS / max(first, floor, 1e-7))))
    per_steps, setups = [], []
    for _ in range(repeats):
        shorter = run(1 + k)
        longer = run(1 + 2 * k)
        per_steps.append((longer - shorter) / k)
        setups.append(shorter)
    per_step = max(statistics.median(per_steps), floor)
    return per_step, max(statistics.median(setups) - (1 + k) * per_step, 0.0)


def _off(structure: LinearStructure, best: MethodAdvice) -> bool:
    """Whether the recommended row's predicted time is more than _RETIME_FACTOR off its first steps, run."""
    if not math.isfinite(best.seconds) or best.steps < 1:
        return False
    steps = int(min(best.steps, max(2, 3 * _TRIAL_SECONDS / best.seconds_per_step)))
    rng = np.random.default_rng(1)
    q0 = 1e-3 * rng.standard_normal(structure.dim)
    start = _clock()
    integrate(structure, q0, np.zeros(structure.dim), method=best.method, tableau=best.tableau, h=best.h,
              n_steps=steps, save_every=steps)
    measured = _clock() - start
    predicted = best.setup_seconds + steps * best.seconds_per_step
    return not (predicted / _RETIME_FACTOR <= measured <= predicted * _RETIME_FACTOR)
