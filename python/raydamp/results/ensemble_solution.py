"""The result of raydamp.integrate_ensemble: every member's saved points on one save grid."""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..jobs.statuses import STATUSES
from ..loads.load import set_load_parameters
from .solution import Solution

__all__ = ["EnsembleSolution", "STATUSES"]



@dataclass(frozen=True, repr=False)
class EnsembleSolution:
    """Saved points of every member of an ensemble, and why each stopped.

    Rows lie on the run's save grid ``t`` (every ``save_every`` steps from 0, and the
    last step): ``q[i, k]`` is member i at ``t[k]``. A member that stopped early (any status
    but "completed": see raydamp.jobs.statuses) keeps its first ``rows[i]`` rows, the
    rest NaN; its last finite state, saved or not by the grid, is in ``q_final[i]``
    (at ``t_final[i]``), as for every member.

    Attributes
    ----------
    t : (R,) the save grid.
    q, p : (members, R, n); energy : (members, R); momentum : (members, R, m).
    rows : (members,) rows of the grid each member reached.
    t_final, q_final, p_final, energy_final, momentum_final : each member's last state.
    spring_forces, spring_deformations : (members, R, springs), a Structure's springs in its order (None
        without springs): sigma_s (from the row's material state) and d_s, as ``Solution.spring_forces``;
        spring_forces_final, spring_deformations_final : (members, springs) at each member's last state.
    status, message : per member (tuples of str); steps, failed_step (-1: none),
        max_momentum_drift : (members,) arrays.
    q0, p0 : (members, n) initial states; parameters : {name: per-member values}.
    method, tableau, composition, h : shared by every member; threads : threads used.
    provenance : the job JSON of member 0 (the system with member 0's parameter values; the
        initial states are the arrays q0 and p0), plus ``ensemble``: the member count and
        ``parameters``, {name: [one value per member]} of the parameters that vary (so member i
        is the job JSON with member i's values), and ``raydamp_version``.

    dense : with ``dense=True``, each member's dense output (a tuple of
        :class:`raydamp.results.dense.DenseOutput`, one per member, each up to that member's last step
        end); ``at(t)`` reads every member at t, ``member(i).at(t)`` one.

    ``member(i)`` is member i as a :class:`raydamp.Solution`, equal bit for bit to a single
    ``raydamp.integrate`` run of it (to rounding when the ensemble ran with ``vector_sine``).
    ``to_xarray()`` gives a Dataset with dims (member, time, dof); ``save(path)`` writes NetCDF
    (.nc) or Zarr (.zarr); ``raydamp.load`` reads both back.
    """

    t: np.ndarray
    q: np.ndarray
    p: np.ndarray
    energy: np.ndarray
    momentum: np.ndarray
    rows: np.ndarray
    t_final: np.ndarray
    q_final: np.ndarray
    p_final: np.ndarray
    energy_final: np.ndarray
    momentum_final: np.ndarray
    status: tuple[str, ...]
    steps: np.ndarray
    failed_step: np.ndarray
    message: tuple[str, ...]
    max_momentum_drift: np.ndarray
    q0: np.ndarray
    p0: np.ndarray
    parameters: dict[str, np.ndarray]
    method: str
    tableau: str | None
    composition: str | None
    h: float
    wall_time: float = field(default=0.0)
    threads: int = field(default=1)
    # (system, options) of the run, or the provenance dict itself for a loaded ensemble.
    origin: Any = field(default=None, compare=False)
    events: Any = field(default=None, compare=False)  # run/events.py's EventTable (with member), with events=
    envelope: Any = field(default=None, compare=False)  # a Dataset (member, dof | spring) of peaks, with envelope=
    dense: Any = field(default=None, compare=False)  # a DenseOutput per member (results/dense.py), with dense=True
    spring_forces: np.ndarray | None = field(default=None)
    spring_deformations: np.ndarray | None = field(default=None)
    spring_forces_final: np.ndarray | None = field(default=None)
    spring_deformations_final: np.ndarray | None = field(default=None)

    @property
    def members(self) -> int:
        return int(self.q.shape[0])

    @property
    def success(self) -> bool:
        """True when every member completed."""
        return all(s == "completed" for s in self.status)

    @property
    def provenance(self) -> dict[str, Any] | None:
        if self.origin is None or isinstance(self.origin, dict):
            return None if self.origin is None else copy.deepcopy(self.origin)
        from .provenance import job_spec

        system, options = self.origin
        options = dict(options)
        vector_sine = options.pop("vector_sine", False)
        listed = options.pop("loads", None)  # a load per member
        spec = job_spec(system, self.q0[0], self.p0[0], **options)
        del spec["initial_state"]  # per member: the q0, p0 arrays
        spec["coordinates"] = list(system.coordinates)
        spec["momentum_names"] = list(system.momentum_names)
        # The system as member 0 ran it: the base model's values of the varied parameters (its
        # eps, say) are no member's unless a member has them.
        _set_parameters(spec, {name: values[0].tolist() for name, values in self.parameters.items()})
        spec["ensemble"] = {"members": self.members,
                            "parameters": {name: values.tolist() for name, values in self.parameters.items()}}
        if vector_sine:
            spec["ensemble"]["vector_sine"] = True
        if listed is not None:  # each distinct load once, and which one each member ran
            distinct: dict[int, int] = {}
            plain, of_member = [], []
            for load in listed:
                if id(load) not in distinct:
                    distinct[id(load)] = len(plain)
                    plain.append(load.to_dict())
                of_member.append(distinct[id(load)])
            spec["ensemble"]["loads"] = plain
            spec["ensemble"]["load_of_member"] = of_member
        return spec

    @property
    def vector_sine(self) -> bool:
        """Whether the run used raydamp's SIMD sine (``integrate_ensemble(vector_sine=True)``)."""
        if isinstance(self.origin, tuple):
            return bool(self.origin[1].get("vector_sine", False))
        return bool(((self.origin or {}).get("ensemble") or {}).get("vector_sine", False))

    @property
    def coordinates(self) -> tuple[str, ...]:
        if isinstance(self.origin, tuple):
            return tuple(self.origin[0].coordinates)
        names = (self.origin or {}).get("coordinates")
        return tuple(names) if names else tuple(f"q{i}" for i in range(self.q.shape[2]))

    @property
    def momentum_names(self) -> tuple[str, ...]:
        if isinstance(self.origin, tuple):
            return tuple(self.origin[0].momentum_names)
        names = (self.origin or {}).get("momentum_names")
        return tuple(names) if names else tuple(f"J{i}" for i in range(self.momentum.shape[2]))

    def member(self, i: int) -> Solution:
        """Member i as a Solution: its rows on the grid, then its last state if off the grid."""
        if not isinstance(i, (int, np.integer)) or not -self.members <= i < self.members:
            raise ValueError(f"i: expected a member index in [0, {self.members}), got {i!r}")
        i = int(i) % self.members
        g = int(self.rows[i])
        extra = g == 0 or self.t_final[i] != self.t[g - 1]

        def rows(grid, final):
            if grid is None:
                return None
            part = grid[i, :g]
            return np.concatenate([part, final[i][None]]) if extra else part.copy()

        t = np.concatenate([self.t[:g], [self.t_final[i]]]) if extra else self.t[:g].copy()
        failed = int(self.failed_step[i])
        return Solution(t=t, q=rows(self.q, self.q_final), p=rows(self.p, self.p_final),
                        energy=rows(self.energy, self.energy_final),
                        momentum=rows(self.momentum, self.momentum_final), status=self.status[i],
                        spring_forces=rows(self.spring_forces, self.spring_forces_final),
                        spring_deformations=rows(self.spring_deformations, self.spring_deformations_final),
                        steps=int(self.steps[i]), failed_step=None if failed < 0 else failed,
                        message=self.message[i], method=self.method, tableau=self.tableau,
                        composition=self.composition, h=self.h,
                        max_momentum_drift=float(self.max_momentum_drift[i]), origin=self._member_spec(i),
                        events=None if self.events is None else self.events.of_member(i),
                        envelope=None if self.envelope is None else self.envelope.isel(member=i),
                        dense=None if self.dense is None else self.dense[i])

    def at(self, t) -> tuple[np.ndarray, np.ndarray]:
        """(q, p) of every member at time(s) t by its dense output: shape (members, n) each for a scalar t,
        (members, len(t), n) for an array; each member's values are ``member(i).at(t)``'s, bit for bit. A
        member whose run ended before t (a terminal event, a blow-up) has NaN there. Needs
        ``integrate_ensemble(..., dense=True)``; a t outside the run's span [t[0], t[-1]] is a ValueError
        naming t."""
        if self.dense is None:
            raise ValueError("at: this ensemble kept no dense output; run integrate_ensemble with dense=True")
        times = np.asarray(t, dtype=float)
        flat = np.atleast_1d(times)
        if flat.ndim != 1 or flat.size == 0 or not np.all(np.isfinite(flat)) or flat.min() < self.t[0] \
                or flat.max() > self.t[-1]:
            raise ValueError(f"t must be a time or a 1-d array of times inside the run [{self.t[0]}, {self.t[-1]}], "
                             f"got {t!r}")
        n = self.q.shape[2]
        q = np.full((self.members, flat.size, n), np.nan)
        p = np.full((self.members, flat.size, n), np.nan)
        for i, member in enumerate(self.dense):
            inside = (flat >= member.t[0]) & (flat <= member.t[-1]) if len(member.t) else np.zeros(flat.size, bool)
            if inside.any():
                q[i, inside], p[i, inside] = member.at(flat[inside])
        if times.ndim == 0:
            return q[:, 0], p[:, 0]
        return q, p

    def _member_spec(self, i: int) -> dict[str, Any] | None:
        """Member i's job JSON: the base spec with its parameters and initial state."""
        spec = self.provenance
        if spec is None:
            return None
        ensemble = spec.pop("ensemble", None) or {}
        if "loads" in ensemble:  # member i's own load, before its load.amplitude is set on it
            spec["load"] = ensemble["loads"][ensemble["load_of_member"][i]]
        _set_parameters(spec, {name: array[i].tolist() for name, array in self.parameters.items()})
        spec["initial_state"] = {"q": self.q0[i].tolist(), "p": self.p0[i].tolist()}
        if "seed" in spec:  # member i drew stream first_stream + i
            stream = spec.pop("stream", 0) + i
            if stream:
                spec["stream"] = stream
        return spec

    def to_xarray(self):
        """An xarray.Dataset with dims (member, time, dof[, momentum_map]), the swept parameters as
        member coordinates and the provenance in attrs (needs the ``io`` extra: xarray)."""
        from .io.ensemble import ensemble_to_xarray

        return ensemble_to_xarray(self)

    def save(self, path) -> None:
        """Write to ``path``: .nc (NetCDF via h5netcdf) or .zarr (a Zarr store), by its suffix."""
        from .io.ensemble import save_ensemble

        save_ensemble(self, path)

    def __repr__(self) -> str:
        counts = {s: self.status.count(s) for s in dict.fromkeys(self.status)}
        return (f"EnsembleSolution(members={self.members}, method={self.method!r}, h={self.h}, "
                f"saved={self.t.size}, status={counts})")


def _set_parameters(spec: dict[str, Any], values: dict[str, Any]) -> None:
    """Put parameter values into a job JSON: a System's eps and expression parameters, or a built-in
    model's parameters."""
    values = dict(values)
    load_values = {k[5:]: values.pop(k) for k in list(values) if k.startswith("load.")}
    if load_values and spec.get("load") is not None:
        spec["load"] = set_load_parameters(spec["load"], load_values)
    if "system" in spec and spec["system"] is not None:
        system = spec["system"]
        if "eps" in values:
            system["eps"] = values.pop("eps")
        if values:
            system["parameters"] = {**system.get("parameters", {}), **values}
    elif values:
        spec["parameters"] = {**spec.get("parameters", {}), **values}
