"""raydamp.advise: which method, at which step, reaches a tolerance on a linear structure fastest.

Before a long run, from the structure alone:

- omega_max, the largest natural frequency (Lanczos on (K, M); dense below 500 DOF), and omega, the
  frequency the answer must resolve (default the lowest natural frequency, omega_1);
- each explicit method's stability limit h_max, computed by the core itself: one step of the method on
  a modal copy of the structure (one uncoupled mode per frequency on a grid up to omega_max, each with
  its Rayleigh rate alpha + beta omega^2) gives each mode's 2 x 2 step matrix, and h_max is the
  largest h at which none has an eigenvalue outside the unit circle (bisection to 1e-7);
- each method's step for the tolerance from the error model of a mode of frequency omega over t_end,

      error = C (h omega)^p omega t_end      (relative to the initial amplitude),

  C the leading constant of the method's phase error: 1/24 for 3s, 2s and rks (all Stormer-Verlet in
  drift and kick), 1/12 for midpoint, 1/6 for heun, 1/120 for rk4, 1/720 for gauss4. Measured on a
  lightly damped mode (zeta = 5e-4, t_end = 60, h omega = 0.025 to 0.4) they are 0.0391, 0.0783, 0.157,
  0.0078 and 0.0013: each within 7% below the formula, so the model is a slight over-estimate;
  damping only lowers the error (zeta = 0.02: a third). An explicit method steps at
  min(that step, 0.95 h_max);
- each method's cost: the steps t_end / h times its cost per step, measured by a few trial steps at that
  h on the structure itself (3s's and 2s's Chebyshev degree, the implicit methods' sparse solve and
  factorisation are all in the figure), plus its set-up (the factorisations).

``Advice.recommended`` is the row of least predicted time; ``recommended.options`` are
:func:`raydamp.integrate`'s method, tableau and h for it. The error model holds for motion at omega:
a solution with energy in higher modes has a larger error (a shear building's static deflection,
omega = omega_1: measured 1.8 to 2.1 times the prediction), so pass the highest frequency the answer
must resolve as ``omega``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .._validation import MAX_STEPS, flag, real
from ..systems.models import Model
from ..systems.series import ChebyshevDegreeError
from ..systems.structure import LinearStructure
from .integrate import integrate

__all__ = ["advise", "Advice", "MethodAdvice", "ERROR_MODEL", "STABILITY_MARGIN"]

# (method, tableau, order p, error constant C, explicit in the stiffness): err = C (h omega)^p omega t_end.
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
# Below this, rounding over a run sets the error, whatever the method and its step (an audit: 1e-14 measured).
MIN_TOLERANCE = 1e-13
# An explicit method steps at most at this fraction of its stability limit.
STABILITY_MARGIN = 0.95
_DENSE_BELOW = 500          # DOF: frequencies from a dense eigensolver below this
_MODAL_GRID = 48            # frequencies of the modal copy that stability limits are computed on
_TRIAL_SECONDS = 0.03       # about this long of trial steps per method
_UNSTABLE = 1e-9            # a step matrix eigenvalue above 1 + this is growth


@dataclass(frozen=True)
class MethodAdvice:
    """One method's row: its stability limit, the step it would take, and what that predicts."""

    method: str
    tableau: str | None
    order: int
    h_max: float              # stability limit (inf: A-stable; 0: unstable at every step tried)
    h: float                  # the step it would take for the tolerance (nan when it cannot run)
    limited_by: str           # "tolerance", "stability", "unstable", "steps" (more than integrate runs) or "series"
    #                           (its damping flow over h needs a Chebyshev series past degree 8192: not run)
    steps: int
    error: float              # predicted error at h
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
    omega: float
    rho: float                # the damping rate bound alpha + beta L
    t_end: float
    tolerance: float
    rows: tuple[MethodAdvice, ...] = field(default_factory=tuple)

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
        head = (f"linear structure: {self.dim} DOF, nnz(K) = {self.nnz}; omega_max = {self.omega_max:.6g} "
                f"(explicit h < {2 / self.omega_max:.4g}), omega_1 = {self.omega_1:.6g}, resolving omega = "
                f"{self.omega:.6g}; damping rate bound rho = {self.rho:.4g}\n"
                f"to t_end = {self.t_end:g} within {self.tolerance:g} (error = C (h omega)^p omega t_end):\n")
        columns = ("method", "order", "h_max", "h", "by", "steps", "error", "h rho", "cheb", "s/step", "setup s",
                   "total s")
        table = [columns]
        for r in sorted(self.rows, key=lambda r: r.seconds):
            table.append((r.label, str(r.order), "A-stable" if math.isinf(r.h_max) else f"{r.h_max:.4g}",
                          _g(r.h), r.limited_by, "-" if r.limited_by == "unstable" else _count(r.steps), _g(r.error),
                          _g(r.h_rho), "-" if r.chebyshev_degree is None else str(r.chebyshev_degree),
                          _g(r.seconds_per_step), _g(r.setup_seconds), _g(r.seconds)))
        widths = [max(len(row[i]) for row in table) for i in range(len(columns))]
        lines = ["  ".join(cell.ljust(w) if i == 0 else cell.rjust(w) for i, (cell, w) in enumerate(zip(row, widths)))
                 for row in table]
        best = self.recommended
        return (head + "\n".join(lines) + f"\nrecommended: {best.label} at h = {best.h:.6g} "
                f"({best.steps} steps, about {best.seconds:.3g} s)")

    def _repr_pretty_(self, printer, cycle) -> None:  # IPython
        printer.text(str(self))

    def __repr__(self) -> str:
        return str(self)


def _g(x: float) -> str:
    return "-" if not math.isfinite(x) else f"{x:.3g}"


def _count(steps: int) -> str:
    return str(steps) if steps < 10**12 else f"{float(steps):.3g}"


def advise(structure: Model, t_end: float, tolerance: float, *, omega: float | None = None,
           measure: bool = True) -> Advice:
    """Each method's stability limit, step and predicted cost to reach ``tolerance`` by ``t_end``.

    Parameters
    ----------
    structure : a :class:`raydamp.LinearStructure` (other kinds have no M and K to bound the spectrum
        with, and are refused with a ValueError).
    t_end : the span of the run, > 0.
    tolerance : the error allowed, relative to the initial amplitude (max over the run of
        ``|q - q_exact| / |q0|``), in (0, 1).
    omega : the highest circular frequency the answer must resolve; default the lowest natural
        frequency omega_1.
    measure : time trial steps of each method on the structure (default); False leaves the time
        columns nan and recommends by steps alone.

    The model and its constants are in :mod:`raydamp.run.advise`'s docstring.
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
    omega_1, omega_max = _frequency_range(structure)
    if omega is None:
        omega = omega_1
    omega = real("omega", omega, positive=True)
    limits = _stability_limits(structure, omega_1, omega_max)
    rows = []
    for method, tableau, order, constant, explicit in ERROR_MODEL:
        h_max = limits[(method, tableau)] if explicit else math.inf
        with np.errstate(all="ignore"):  # an extreme t_end or omega: a step that under- or overflows
            h_tol = float(np.float64(tolerance) / (constant * omega * t_end)) ** (1 / order) / omega
        h = min(h_tol, STABILITY_MARGIN * h_max, t_end)
        limited = "unstable" if h_max == 0 else "stability" if h < h_tol and h < t_end else "tolerance"
        if limited == "unstable":
            rows.append(MethodAdvice(method, tableau, order, 0.0, math.nan, limited, 0, math.nan, math.nan, None,
                                     math.nan, math.nan, math.inf))
            continue
        ratio = t_end / h if h > 0 else math.inf
        steps = max(1, math.ceil(ratio * (1 - 1e-12))) if math.isfinite(ratio) else MAX_STEPS + 1
        if steps > MAX_STEPS:  # more than integrate runs: the table said 10^75 steps and recommended one
            rows.append(MethodAdvice(method, tableau, order, h_max, h, "steps", steps, math.nan, math.nan, None,
                                     math.nan, math.nan, math.inf))
            continue
        h = t_end / steps
        try:
            degree = max(structure.chebyshev_degrees(h)) if method in ("3s", "2s") and structure.eps else None
        except ChebyshevDegreeError:  # the damping flow over h is past the series' degree bound: 3s and 2s refuse it
            rows.append(MethodAdvice(method, tableau, order, h_max, h, "series", steps, math.nan, math.nan, None,
                                     math.nan, math.nan, math.inf))
            continue
        per_step, setup = _trial(structure, method, tableau, h) if measure else (math.nan, math.nan)
        seconds = setup + steps * per_step if measure else float(steps)
        rows.append(MethodAdvice(method, tableau, order, h_max, h, limited, steps,
                                 constant * (h * omega) ** order * omega * t_end, h * structure.damping_rate_bound,
                                 degree, per_step, setup, seconds))
    if all(math.isinf(row.seconds) for row in rows):
        raise ValueError(f"tolerance: no method reaches {tolerance:g} by t_end = {t_end:g} in at most {MAX_STEPS:.3g} "
                         "steps (the most integrate runs); raise the tolerance or shorten t_end")
    return Advice(structure.dim, int(structure._stiffness.nnz), omega_max, omega_1, omega,
                  structure.damping_rate_bound, t_end, tolerance, tuple(rows))


def _frequency_range(structure: LinearStructure) -> tuple[float, float]:
    """(omega_1, omega_max): the lowest non-zero and the largest natural frequency of (K, M)."""
    K, M = structure._stiffness, structure._mass
    n = structure.dim
    if n < _DENSE_BELOW:
        import scipy.linalg

        w2 = np.sort(scipy.linalg.eigh(K.toarray(), M.toarray(), eigvals_only=True))
        rigid = 1e-13 * w2[-1]            # a free-free structure's rigid modes: zero to rounding
    else:
        import scipy.sparse.linalg as sla

        top = sla.eigsh(K, k=1, M=M, which="LA", tol=1e-8, return_eigenvectors=False)
        k = min(7, n - 2)
        try:  # shift-invert at 0: K definite (a supported structure), no rigid mode to set aside
            low = sla.eigsh(K, k=k, M=M, sigma=0.0, which="LM", tol=1e-8, return_eigenvectors=False)
            rigid = 0.0
        except RuntimeError:  # K singular (free-free): shift just below 0, and set its rigid modes aside
            shift = 1e-12 * float(top[0])
            low = sla.eigsh(K, k=k, M=M, sigma=-shift, which="LM", tol=1e-8, return_eigenvectors=False)
            rigid = shift
        w2 = np.sort(np.concatenate([low, top]))
    top = float(w2[-1])
    positive = w2[w2 > rigid]
    if top <= 0 or positive.size == 0:
        raise ValueError("structure: K has no positive eigenvalue (nothing vibrates); there is nothing to advise on")
    return math.sqrt(float(positive[0])), math.sqrt(top)


def _stability_limits(structure: LinearStructure, omega_1: float, omega_max: float) -> dict:
    """Each explicit method's h_max on modal copies of the structure (one uncoupled mode per frequency)."""
    omegas = np.unique(np.concatenate([np.geomspace(min(omega_1, 1e-3 * omega_max), omega_max, _MODAL_GRID),
                                       [omega_1, omega_max]]))
    modals = _modal_copies(structure, omegas)

    def stable(method: str, tableau: str | None, h: float) -> bool:
        return all(_stable_copy(modal, method, tableau, h) for modal in modals)

    limits = {}
    grid = np.geomspace(1e-3, 1e2, 61) / omega_max
    for method, tableau, _order, _constant, explicit in ERROR_MODEL:
        if not explicit:
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


def _modal_copies(structure: LinearStructure, frequencies: np.ndarray) -> list[LinearStructure]:
    """Modal copies (M = I, K = diag(omega^2), the structure's alpha and beta) of these frequencies, each
    with a core bound L that covers its spectrum. The core's bound min(1.05 Lanczos, Gershgorin) came out
    at 1.6% and 29% of omega_max^2 on a 48-frequency grid from 0.05 to 3.8e5 in some processes (the same
    grid in others: exact), and the damping flows over [0, L] are wrong above L: a copy not covered is
    split in two (one frequency is always covered)."""
    import scipy.sparse as sparse

    modal = LinearStructure(sparse.identity(frequencies.size, format="csc"), sparse.diags(frequencies ** 2).tocsc(),
                            alpha=structure.alpha, beta=structure.beta)
    if frequencies.size == 1 or modal.spectral_bound >= frequencies[-1] ** 2 * (1 - 1e-12):
        return [modal]
    half = frequencies.size // 2
    return _modal_copies(structure, frequencies[:half]) + _modal_copies(structure, frequencies[half:])


def _stable_copy(modal: LinearStructure, method: str, tableau: str | None, h: float) -> bool:
    """No mode of the modal copy grows over one step of method at h."""
    ones, zeros = np.ones(modal.dim), np.zeros(modal.dim)
    try:
        a = integrate(modal, ones, zeros, method=method, tableau=tableau, h=h, n_steps=1)
        b = integrate(modal, zeros, ones, method=method, tableau=tableau, h=h, n_steps=1)
    except ChebyshevDegreeError:  # a damping flow past the Chebyshev series' degree bound: not usable at h
        return False
    if not (a.success and b.success):
        return False
    # mode i's step matrix [[a_q, b_q], [a_p, b_p]]: eigenvalues (a_q + b_p)/2 +- sqrt(((a_q - b_p)/2)^2
    # + b_q a_p), written so (not from trace^2/4 - det) to keep a step close to the identity accurate
    mean = (a.q[-1] + b.p[-1]) / 2
    root = np.sqrt((((a.q[-1] - b.p[-1]) / 2) ** 2 + b.q[-1] * a.p[-1]).astype(complex))
    radius = np.maximum(np.abs(mean + root), np.abs(mean - root))
    return bool(np.all(radius <= 1 + _UNSTABLE))


def _trial(structure: LinearStructure, method: str, tableau: str | None, h: float) -> tuple[float, float]:
    """(seconds per step, set-up seconds) of method at h on the structure, from two short runs."""
    rng = np.random.default_rng(0)
    q0 = 1e-3 * rng.standard_normal(structure.dim)
    p0 = np.zeros(structure.dim)

    def run(steps: int) -> float:
        start = time.perf_counter()
        integrate(structure, q0, p0, method=method, tableau=tableau, h=h, n_steps=steps, save_every=steps)
        return time.perf_counter() - start

    first = run(2)
    k = int(min(1000, max(1, _TRIAL_SECONDS / max(first, 1e-7))))
    shorter = first if k == 1 else run(1 + k)
    longer = run(1 + 2 * k)
    per_step = max((longer - shorter) / k, 1e-9)
    return per_step, max(shorter - (1 + k) * per_step, 0.0)
