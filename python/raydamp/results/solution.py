"""The result of raydamp.integrate."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["Solution"]


@dataclass(frozen=True, repr=False)
class Solution:
    """Saved points of a run and why it stopped.

    Arrays have one row per saved point: the initial state, every ``save_every``
    steps, and always the final (last finite) state.

    Attributes
    ----------
    t : (N,) times.
    q, p : (N, n) positions and momenta (N, k with ``save_dofs``: the coordinates in ``dofs``).
    energy : (N,) H(q, p).
    momentum : (N, m) the model's momentum maps (m = 0 for a model without symmetry).
    status : why the run stopped, one of raydamp.jobs.statuses.STATUSES (documented there):
        "completed", "non_finite" (``failed_step`` is the first step whose result was not finite and
        every saved row is finite), "diverged" (the energy blew up while the state stayed finite;
        ``failed_step`` is the step after which the test found it), "cancelled" or "out_of_memory".
    steps : steps taken (all with finite results).
    max_momentum_drift : the largest distance, over every step, of the momentum maps from the
        law the exact flow gives them: max_j |J_j(t) - J_j(0) e^{-a t}|. a = eps c when the
        damping is D = c M (a System's ``{"scalar": c}``: A = eps D M^{-1} = a I scales p, and
        so every momentum map J = p . xi(q) of a symmetry of V); a = 0 for every other model and
        damping form, whose momentum maps are those of symmetries of both V and D, which the
        flow conserves (the elastic pendulum's J3, L under a radial dashpot, a chain's total
        momentum). 3s, 2s and rks keep it at rounding (rks with an explicit tableau plus its
        stability function's error against e^{-a h} per step); a method that does not keep
        momentum maps (heun, rk4) shows its error. 0 for a model without momentum maps.
        A System's ``momenta`` under non-scalar
        damping that breaks their symmetry follow no such law: there the figure includes the
        damping's real change of J.
    work : (N,) damping work W(t) if the run was asked for it (``work=True``), else None.
    load_work : (N,) the load's work W_f(t) = int f . qdot dt for a run with a load and ``work=True``,
        else None.
    hysteretic_work : (N, springs) each spring's hysteretic (dissipated) work W_h,s(t) = int sigma_s dd_s -
        stored_s(t), for a run of a :class:`raydamp.Structure` with springs and ``work=True`` (springs in the
        Structure's order), else None. ``kinetic_energy`` and ``stored_energy`` (H - T: the linear part's and
        the springs' recoverable energy) split H; ``energy_balance`` subtracts the springs' work too.
    spring_forces, spring_deformations : (N, springs) each spring's force sigma_s, from the material state of
        that row, and its deformation d_s = q_j - q_i (q_j to the ground) at the saved rows (springs in the
        Structure's order), for a run of a :class:`raydamp.Structure` with springs, else None: each spring's
        force-deformation loop. ``absolute_acceleration()`` reads the forces (a model rebuilt after the run
        has only its virgin materials). Files keep them (and ``hysteretic_work``) with dims (time, spring).
    multipliers : (N, k) a constrained System's Lagrange multipliers lambda at each saved row (None for
        other models, and for a run with ``save_dofs``). The constraint force on the coordinates is
        -G(q)^T lambda, G = dg/dq, so lambda_i has the units of a force divided by those of dg_i/dq (a rod
        written g = x^2 + y^2 - l^2 pulls with the tension 2 l lambda, lambda > 0 pulling inwards). It is
        the multiplier of the continuous equations at the saved (q, p): (G M^-1 G^T) lambda = G M^-1 F +
        (v^T Hess g_i v)_i, v = M^-1 p, F = -grad V + f(t) - eps D M^-1 p; so as accurate as the saved state
        (the method's order), not the discrete impulse of a step. At a temperature, F is the deterministic
        force (the noise has no value at an instant).
    load : the run's :class:`raydamp.Load` (or GroundMotion), or None; a loaded file's and an
        ensemble member's is rebuilt from the provenance by ``load_values()``, ``absolute_acceleration()`` and
        ``raydamp.analysis.energy_error``, which need it.
    dofs : the indices of the saved coordinates when the run saved only some (``save_dofs``),
        else None.
    composition : the composition the method was raised to higher order with, or None.
    provenance : what produced it, as the job JSON the service and ``raydamp run`` take
        (model or system, initial state, method, tableau, step size, span, save_every)
        plus ``raydamp_version``; ``raydamp.integrate(*raydamp.run.job.job_arguments(...))``
        runs it again.
    plot : ``sol.plot.energy()``, ``.phase()``, ``.projection()`` (matplotlib axes).

    ``to_xarray()`` gives an xarray Dataset (dims time, dof); ``save(path)`` writes
    NetCDF (.nc), NumPy (.npz) or CSV (.csv), and ``raydamp.load`` reads the first
    two back with their provenance.
    """

    t: np.ndarray
    q: np.ndarray
    p: np.ndarray
    energy: np.ndarray
    momentum: np.ndarray
    status: str
    steps: int
    failed_step: int | None
    message: str
    method: str
    tableau: str | None
    h: float
    max_momentum_drift: float
    work: np.ndarray | None = field(default=None)
    wall_time: float = field(default=0.0)
    composition: str | None = field(default=None)
    dofs: np.ndarray | None = field(default=None)
    load_work: np.ndarray | None = field(default=None)
    hysteretic_work: np.ndarray | None = field(default=None)
    spring_forces: np.ndarray | None = field(default=None)
    spring_deformations: np.ndarray | None = field(default=None)
    load: Any = field(default=None, compare=False)
    events: Any = field(default=None, compare=False)  # run/events.py's EventTable, with events=
    dense: Any = field(default=None, compare=False)  # results/dense.py's DenseOutput, with dense=True
    envelope: Any = field(default=None, compare=False)  # an xarray Dataset of peaks (run/envelope.py), with envelope=
    # A constrained System's residuals over the run (raydamp.jobs.JobSummary describes both), else None.
    constraint_residual: float | None = field(default=None)
    constraint_velocity_residual: float | None = field(default=None)
    multipliers: np.ndarray | None = field(default=None)
    # (model, q0, p0, options) of the run, turned into `provenance` when asked for (cheap
    # runs stay cheap); or the provenance dict itself, for a loaded solution.
    origin: Any = field(default=None, compare=False)

    def at(self, t):
        """(q, p) at time(s) t inside the run, by dense output (:mod:`raydamp.results.dense`): needs a run
        with ``dense=True``."""
        if self.dense is None:
            raise ValueError("at: this run kept no dense output; integrate with dense=True")
        return self.dense.at(t)

    def _run_load(self, what: str):
        """The run's load, None if it had none: its own, or (a loaded file, an ensemble member) rebuilt from the
        provenance when first asked, as _model rebuilds the model (load_values() gave zeros and
        absolute_acceleration() said "no ground motion"). Not at construction: a member or a file opened for its
        arrays would compile an expression load, or read a record path the file names, for nothing. A ValueError
        names ``what`` when the load cannot be rebuilt (an uploaded record's id, a record file gone)."""
        origin = self.origin
        if self.load is not None or not isinstance(origin, dict) or not (origin.get("load")
                                                                         or origin.get("ground_motion")):
            return self.load
        from ..jobs.build import load_from

        try:
            load = load_from(origin.get("load"), origin.get("ground_motion"))
        except (ValueError, OSError) as error:
            raise ValueError(f"{what}: the run's load could not be rebuilt from its provenance "
                             f"({type(error).__name__}: {error})") from None
        object.__setattr__(self, "load", load)  # once: a frozen dataclass's field, filled as a cache
        return load

    @property
    def provenance(self) -> dict[str, Any] | None:
        if self.origin is None or isinstance(self.origin, dict):
            return None if self.origin is None else dict(self.origin)
        from .provenance import job_spec

        model, q0, p0, options = self.origin
        return job_spec(model, q0, p0, **options)

    @property
    def coordinates(self) -> tuple[str, ...]:
        """The names of the coordinates (q0, q1, ... when the model does not name them)."""
        if isinstance(self.origin, tuple):
            names = self.origin[0].coordinates
            return tuple(names) if self.dofs is None else tuple(names[int(i)] for i in self.dofs)
        names = (self.provenance or {}).get("coordinates")
        if names:
            return tuple(names)
        return tuple(f"q{i}" for i in (range(self.q.shape[1]) if self.dofs is None else self.dofs))

    @property
    def momentum_names(self) -> tuple[str, ...]:
        if isinstance(self.origin, tuple):
            return tuple(self.origin[0].momentum_names)
        names = (self.provenance or {}).get("momentum_names")
        return tuple(names) if names else tuple(f"J{i}" for i in range(self.momentum.shape[1]))

    @property
    def plot(self):
        """Plots of this solution: ``energy()``, ``phase()``, ``projection()``."""
        from .plotting import SolutionPlots

        return SolutionPlots(self)

    def to_xarray(self):
        """An xarray.Dataset with dims (time, dof[, momentum]) and the provenance in attrs."""
        from .io.dataset import to_xarray

        return to_xarray(self)

    def save(self, path) -> None:
        """Write to ``path``: .nc (NetCDF, via xarray), .npz or .csv, by its suffix
        (``raydamp.results.io.write_solution``, which also writes rows read a slice at a time)."""
        from .io.writer import save

        save(self, path)

    @property
    def success(self) -> bool:
        return self.status == "completed"

    @property
    def initial_energy(self) -> float:
        return float(self.energy[0])

    @property
    def final_energy(self) -> float:
        return float(self.energy[-1])

    @property
    def _driven(self) -> bool:
        """Whether energy entered the run from outside: a load (or ground motion) or thermal noise."""
        if isinstance(self.origin, tuple):
            options = self.origin[3]
            return options.get("load") is not None or options.get("thermal") is not None
        origin = self.origin if isinstance(self.origin, dict) else {}
        return bool(self.load is not None or self.load_work is not None or origin.get("load")
                    or origin.get("ground_motion") or origin.get("temperature"))

    @property
    def energy_dissipated(self) -> float:
        """The energy the damping took out: H(0) - H(t_final) for a free run (positive when energy was lost).
        A driven run (a load, a ground motion or a temperature) gains energy from outside, so there
        H(0) - H(t_final) says nothing of the damping: its figure is the damping work W(t_final)
        (``work[-1]``), and nan when the run did not record W (``work=False``)."""
        if not self._driven:
            return self.initial_energy - self.final_energy
        return float(self.work[-1]) if self.work is not None else math.nan

    @property
    def mean_dissipation_rate(self) -> float:
        """``energy_dissipated`` per unit time over the run (nan if no time elapsed, or if it is nan)."""
        elapsed = float(self.t[-1] - self.t[0])
        return self.energy_dissipated / elapsed if elapsed > 0 else math.nan

    @property
    def energy_balance(self) -> np.ndarray:
        """H(t) - H(0) + W(t) + sum_s W_h,s(t) - W_f(t): zero for the exact flow; needs ``work=True``.
        (H is the unforced energy, the springs' stored energy in it; W the damping's work, W_h,s each spring's
        hysteretic work, W_f the load's.)"""
        if self.work is None:
            raise ValueError("work: this run did not record the damping work; pass work=True to integrate")
        balance = self.energy - self.energy[0] + self.work
        if self.hysteretic_work is not None:
            balance = balance + self.hysteretic_work.sum(axis=1)
        return balance if self.load_work is None else balance - self.load_work

    @property
    def kinetic_energy(self) -> np.ndarray:
        """T = 1/2 p^T M^-1 p at the saved points (a run saving every coordinate)."""
        if self.dofs is not None:
            raise ValueError("kinetic_energy: needs every coordinate saved (save_dofs=None)")
        core = self._model("kinetic_energy")._core_model
        return np.array([0.5 * float(np.dot(p, np.asarray(core.velocity(p)).ravel())) for p in self.p])

    @property
    def stored_energy(self) -> np.ndarray:
        """H - T: the potential energy, the springs' recoverable energy in it (a run saving every coordinate)."""
        return self.energy - self.kinetic_energy

    def load_values(self) -> np.ndarray:
        """f(t) at the saved times, (N, n) over every coordinate (zeros without a load)."""
        model = self._model("load_values")
        load = self._run_load("load_values")
        if load is None:
            return np.zeros((self.t.size, model.dim))
        return load.values(model, self.t)

    def absolute_acceleration(self) -> np.ndarray:
        """Under a ground motion: the absolute acceleration q''(t) + r a_g(t) at the saved times,
        (N, n), with q'' = M^{-1} (f(t) - grad V(q) - eps D M^{-1} p) from the saved state (a run
        saving every coordinate). A Structure's springs add their forces at each row (``spring_forces``, from
        the material state of that row), so a yielded storey's force is its hysteretic one."""
        model = self._model("absolute_acceleration")
        load = self._run_load("absolute_acceleration")
        if load is None or not getattr(load, "is_ground_motion", False):
            raise ValueError("absolute_acceleration: this run had no ground motion")
        if self.dofs is not None:
            raise ValueError("absolute_acceleration: needs every coordinate saved (save_dofs=None)")
        core = model._core_model
        gradient = self._gradient_at_rows(model, "absolute_acceleration")
        f = load.values(model, self.t)
        out = np.empty_like(self.q)
        for k in range(self.t.size):
            force = f[k] - gradient(k) - np.asarray(core.damping_rate(self.q[k], self.p[k])).ravel()
            out[k] = np.asarray(core.velocity(force)).ravel()
        return out + load.ground_part().values(model, self.t)

    def _gradient_at_rows(self, model, what: str):
        """grad V(q_k) of saved row k: the model's, or for springs the one with each spring's force of that row.
        Refused (naming ``what``) where those forces were not kept: the materials' state after a yield is the
        run's, and the model's virgin one would give an elastic force."""
        core = model._core_model
        springs = tuple(getattr(model, "springs", ()) or ())
        if not springs:
            return lambda k: np.asarray(core.gradient(self.q[k])).ravel()
        if self.spring_forces is None:
            raise ValueError(f"{what}: the springs' forces at the saved rows were not kept (an ensemble's member, "
                             "or a file written without them); run raydamp.integrate on the structure for them")
        from ..systems.yielding import core_order

        in_core = np.ascontiguousarray(self.spring_forces[:, core_order(springs)])
        return lambda k: np.asarray(core.gradient_with_spring_forces(self.q[k], in_core[k])).ravel()

    def _model(self, what: str):
        """The run's model: its own, or rebuilt from the provenance (a loaded file, an ensemble's member)."""
        if isinstance(self.origin, tuple):
            return self.origin[0]
        if not isinstance(self.origin, dict):
            raise ValueError(f"{what}: needs the model of the run (a solution from integrate, or one with its "
                             "provenance)")
        from ..jobs.build import model_from_spec
        from ..jobs.spec import ModelSpec

        try:
            return model_from_spec({key: self.origin[key] for key in ModelSpec.model_fields if key in self.origin})
        except ValueError as error:
            raise ValueError(f"{what}: the run's model could not be rebuilt from its provenance: {error}") from None

    def summary(self) -> dict[str, Any]:
        """The scalar results as plain JSON-ready values, the fields of :class:`raydamp.jobs.JobSummary`
        (which describes each): non-finite numbers are None; ``momentum_drift`` is ``max_momentum_drift``
        (None for a model without momentum maps); ``kinetic_temperature`` is <p^T M^-1 p> / n over the second
        half of the saved points (at most 2000 of them, evenly spaced) for a run at a temperature, to compare
        with its kT (None otherwise, and for a run that saved only some coordinates)."""
        from ..jobs.summary import envelope_summary, summary_values
        from .temperature import summary_kinetic_temperature

        def num(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None

        kinetic = summary_kinetic_temperature(self)
        return summary_values(
            status=self.status, message=self.message, method=self.method, tableau=self.tableau,
            composition=self.composition, h=self.h,
            step_size=self.h,  # h's former name, kept for one release
            steps=self.steps, failed_step=self.failed_step, t_final=float(self.t[-1]), saved_points=int(self.t.size),
            energy_initial=num(self.initial_energy), energy_final=num(self.final_energy),
            energy_dissipated=num(self.energy_dissipated), mean_dissipation_rate=num(self.mean_dissipation_rate),
            momentum_drift=num(self.max_momentum_drift) if self.momentum.shape[1] else None,
            # with work recorded: W and W_f at the end, and max |H - H0 + W - W_f| (the energy budget's error)
            work_final=num(float(self.work[-1])) if self.work is not None else None,
            load_work_final=num(float(self.load_work[-1])) if self.load_work is not None else None,
            energy_balance_max=num(float(np.max(np.abs(self.energy_balance)))) if self.work is not None else None,
            kinetic_temperature=None if kinetic is None else num(kinetic),
            events=None if self.events is None else self.events.summary(),
            envelope=None if self.envelope is None else envelope_summary(self.envelope),
            constraint_residual=getattr(self, "constraint_residual", None),
            constraint_velocity_residual=getattr(self, "constraint_velocity_residual", None),
            wall_time=self.wall_time,
        )

    def __repr__(self) -> str:
        return (f"Solution(status={self.status!r}, method={self.method!r}, steps={self.steps}, "
                f"saved={self.t.size}, t_final={self.t[-1]:.6g}, energy {self.initial_energy:.6g} -> "
                f"{self.final_energy:.6g})")

