"""From a SweepSpec to raydamp.sweep's arguments, with the checks a sweep must pass before it is
queued: the job's own (problems.check_spec), then raydamp.check_sweep's (grid names and values,
one step of the first member), then the service's size bounds. Errors name the JSON path."""

from __future__ import annotations

from typing import Any

import raydamp

from .config import Settings
from .problems import SpecError, check_spec, planned_steps
from .sweep_schemas import SweepSpec

__all__ = ["sweep_arguments", "check_sweep_spec"]

# raydamp.sweep's names for the job's fields, as they appear at the start of its messages.
_JOB_FIELD = {"spec.h": ("job", "step_size"), "h": ("job", "step_size"), "spec.q0": ("job", "initial_state", "q"),
              "spec.p0": ("job", "initial_state", "p"), "q0": ("job", "initial_state", "q"),
              "p0": ("job", "initial_state", "p"), "chunk_size": ("chunk_size",)}


def sweep_arguments(spec: SweepSpec) -> tuple[dict[str, Any], dict[str, Any]]:
    """(raydamp's job form of the base point, the grid with ranges as {start, stop, num, scale})."""
    job = spec.job.model_dump(mode="json", exclude_none=True)
    job.pop("work", None)  # refused at submission when asked for; sweeps do not record W
    if spec.job.system is not None:
        job["system"] = spec.job.system.model_dump(mode="json", exclude_unset=True)
    grid = {name: axis.model_dump() if hasattr(axis, "model_dump") else list(axis) for name, axis in spec.grid.items()}
    # The job's step_size is raydamp's h; so is the grid axis of that name.
    if "step_size" in grid:
        grid["h"] = grid.pop("step_size")
    return job, grid


def _loc(message: str, spec: SweepSpec) -> tuple[str | int, ...]:
    """The JSON path a raydamp.sweep message is about: it starts with the argument's name."""
    head = message.split(":", 1)[0].split(" ", 1)[0]
    if head.startswith("grid."):
        parts = head.split(".")[1:]
        name = "step_size" if parts[0] == "h" else parts[0]
        return ("grid", name, *parts[1:])
    if head in spec.grid or (head == "h" and "step_size" in spec.grid):
        return ("grid", "step_size" if head == "h" else head)
    if head in _JOB_FIELD:
        return _JOB_FIELD[head]
    if head == "member":  # a check of one member's run (e.g. the amplification bound): the grid made it
        return ("grid",)
    return ("job",)


def check_sweep_spec(spec: SweepSpec, settings: Settings) -> raydamp.SweepPlan:
    """Every check a sweep must pass before it is queued; raises SpecError (loc without "body")."""
    try:
        check_spec(spec.job, settings)
    except SpecError as error:
        raise SpecError(("job", *error.loc), f"job.{error.message}") from None
    if spec.job.work and "work" in spec.job.model_fields_set:
        raise SpecError(("job", "work"), "job.work: sweeps do not record the damping work W; leave work out or "
                                         "set it false")
    if spec.job.save_dofs is not None:
        raise SpecError(("job", "save_dofs"), "job.save_dofs: a sweep saves every coordinate; leave save_dofs out")
    job, grid = sweep_arguments(spec)
    try:
        plan = raydamp.check_sweep(job, grid, chunk_size=spec.chunk_size)
    except ValueError as error:
        message = str(error)
        if message.startswith("grid.h"):  # raydamp's h is the service's step_size
            message = "grid.step_size" + message[len("grid.h"):]
        raise SpecError(_loc(str(error), spec), message) from None
    if plan.members > settings.max_sweep_members:
        raise SpecError(("grid",), f"grid: {plan.members} members (the product of the axes' lengths); this service "
                        f"runs at most max_sweep_members = {settings.max_sweep_members}")
    steps = planned_steps(spec.job)
    if plan.members * steps > settings.max_sweep_steps:
        raise SpecError(("grid",), f"grid: {plan.members} members x {steps} steps = {plan.members * steps} steps; "
                        f"this service runs at most max_sweep_steps = {settings.max_sweep_steps} per sweep")
    size = plan.values * 8
    if size > settings.max_sweep_bytes:
        raise SpecError(("job", "save_every"), f"job.save_every: the result would hold {size / 2**20:.0f} MiB "
                        f"({plan.members} members x {plan.rows} saved points); the limit is max_sweep_bytes = "
                        f"{settings.max_sweep_bytes / 2**20:.0f} MiB: raise save_every or shrink the grid")
    return plan
