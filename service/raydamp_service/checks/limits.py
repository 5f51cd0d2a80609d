"""The checks of a job and a sweep before they are queued: the service's limits (sizes, steps, bytes), then
raydamp's (raydamp.jobs builds the call, naming every error by its JSON path; one step runs it)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import raydamp
from raydamp.jobs import JobCall, JobError, JobSpec, SweepSpec, build_job, error_at, planned_steps
from raydamp.run.integrate import row_bytes
from raydamp.run.save_grid import save_rows
from raydamp.run.sweep import GridTooLarge

from ..config import Settings

__all__ = ["JobError", "RaydampCall", "build_call", "check_spec", "check_sweep_spec", "planned_steps"]


@dataclass(frozen=True)
class RaydampCall:
    call: JobCall

    def run(self, **extra: Any) -> raydamp.Solution:
        return raydamp.integrate(self.call.model, self.call.q0, self.call.p0, **{**self.call.options, **extra})


def build_call(spec: JobSpec, files=None) -> RaydampCall:
    """The run of a job; files(id) opens an uploaded matrix (FileStore.parsed_files)."""
    return RaydampCall(build_job(spec, files))


def _check_sizes(spec: JobSpec, settings: Settings) -> None:
    """The operator's bounds on what a job carries, before raydamp builds or allocates anything."""
    for loc, unit, count in spec.sizes():
        where = ".".join(map(str, loc))
        if unit == "components" and count > settings.max_dim:
            raise JobError(loc, f"{where} has {count} components; this service accepts at most max_dim = "
                           f"{settings.max_dim}")
        if unit == "entries" and count > settings.max_structure_nnz:
            raise JobError(loc, f"{where}: {count} entries; this service accepts at most max_structure_nnz = "
                           f"{settings.max_structure_nnz} per matrix (upload larger ones as Matrix Market files: "
                           "POST /v1/files)")
        if unit == "coordinates" and count > settings.max_structure_dim:
            raise JobError(loc, f"{where}: n = {count}; this service runs structures of at most "
                           f"max_structure_dim = {settings.max_structure_dim} coordinates")


def check_spec(spec: JobSpec, settings: Settings, files=None) -> RaydampCall:
    """Every check a job must pass before it is queued; raises JobError naming the field."""
    found = next(iter(spec.local_paths()), None)
    if found is not None:  # uploaded files by id only: a {"file": {"path": ...}} would read the server's files
        raise JobError(found, ".".join(map(str, found)) + ": the service reads no paths; upload the file (POST "
                       "/v1/files) and give its id")
    _check_sizes(spec, settings)
    steps = planned_steps(spec)
    if steps > settings.max_steps:
        field = "n_steps" if spec.n_steps is not None else "t_end"
        raise JobError((field,), f"{field}: the run would take {steps} steps; this service runs at most "
                       f"max_steps = {settings.max_steps} (raise {spec.h_key} or shorten the run)")
    try:
        saved_points = save_rows(steps, spec.save_every)
    except ValueError as error:  # past integrate's range: the error names save_every
        raise error_at(spec, error) from None
    if saved_points > settings.max_saved_points:
        raise JobError(("save_every",), f"save_every: {saved_points} saved points exceed max_saved_points = "
                       f"{settings.max_saved_points}; raise save_every")
    call = build_call(spec, files)
    model = call.call.model
    stored = saved_points * row_bytes(model, spec.save_dofs, work=spec.work, load=call.call.options.get("load"))
    if stored > settings.max_trajectory_bytes:
        saved = model.dim if spec.save_dofs is None else len(spec.save_dofs)
        raise JobError(("save_every",), f"save_every: the stored trajectory would take {stored / 2**20:.0f} MiB "
                       f"({saved_points} saved points x {saved} saved coordinates); the limit is max_trajectory_bytes "
                       f"= {settings.max_trajectory_bytes / 2**20:.0f} MiB: raise save_every, or save fewer "
                       "coordinates with save_dofs")
    # One step validates method, tableau, model, h and initial state as the real run will, in microseconds.
    try:
        call.run(n_steps=1, t_end=None)
    except ValueError as error:
        raise error_at(spec, error) from None
    return call


def check_sweep_spec(spec: SweepSpec, settings: Settings) -> raydamp.SweepPlan:
    """Every check of a sweep: the job's, the grid's size (before raydamp builds a member), raydamp's, the result's."""
    try:
        check_spec(spec.job, settings)
        job, grid = spec.job_form(), spec.grid_arguments()
    except JobError as error:
        raise error.within("job") if error.loc[:1] != ("job",) else error from None
    steps = planned_steps(spec.job)

    def too_large(members: int) -> JobError | None:
        if members > settings.max_sweep_members:
            return JobError(("grid",), f"grid: {members} members (the product of the axes' lengths); this service "
                            f"runs at most max_sweep_members = {settings.max_sweep_members}")
        if members * steps > settings.max_sweep_steps:
            return JobError(("grid",), f"grid: {members} members x {steps} steps = {members * steps} steps; "
                            f"this service runs at most max_sweep_steps = {settings.max_sweep_steps} per sweep")
        return None

    # Both bounds as one on the members, which raydamp applies before it builds any.
    bound = min(settings.max_sweep_members, max(1, settings.max_sweep_steps // max(steps, 1)))
    try:
        plan = raydamp.check_sweep(job, grid, chunk_size=spec.chunk_size, max_members=bound)
    except GridTooLarge as error:
        raise too_large(error.members) or spec.error_at(error) from None
    except ValueError as error:
        raise spec.error_at(error) from None
    refused = too_large(plan.members)
    if refused is not None:
        raise refused
    size = plan.values * 8
    if size > settings.max_sweep_bytes:
        raise JobError(("job", "save_every"), f"job.save_every: the result would hold {size / 2**20:.0f} MiB "
                       f"({plan.members} members x {plan.rows} saved points); the limit is max_sweep_bytes = "
                       f"{settings.max_sweep_bytes / 2**20:.0f} MiB: raise save_every or shrink the grid")
    return plan
