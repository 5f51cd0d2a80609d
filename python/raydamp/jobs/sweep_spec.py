"""A sweep as JSON: a job (the grid's base point), a grid of axes and a chunk size. The grid's rules
(which names an axis may have, what a range means) are raydamp.sweep's; the schema bounds sizes so
that an oversized grid fails at parsing."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import Discriminator, Field, Tag, model_validator

from .build import error_at
from .errors import JobError
from .forms import FiniteFloat, Input, bounded
from .spec import JobSpec

__all__ = ["SweepSpec", "GridRange", "MAX_AXIS", "MAX_AXES"]

MAX_AXIS = 10_000  # values of one axis
MAX_AXES = 8


class GridRange(Input):
    """num values from start to stop, both included: evenly spaced, or geometric with scale "log"."""

    start: FiniteFloat
    stop: FiniteFloat
    num: int = Field(ge=1, le=MAX_AXIS)
    scale: Literal["linear", "log"] = "linear"


GridValues = bounded(FiniteFloat | Annotated[str, Field(max_length=100)], MAX_AXIS, min_length=1)


def _axis_form(value: object) -> str:
    return "range" if isinstance(value, (dict, GridRange)) else "values"


GridAxis = Annotated[Annotated[GridRange, Tag("range")] | Annotated[GridValues, Tag("values")],
                     Discriminator(_axis_form)]
AxisName = Annotated[str, Field(min_length=1, max_length=64)]


class SweepSpec(Input):
    """Every combination of the grid's axes, each run as the job with that point's values."""

    job: JobSpec = Field(description="the grid's base point: a job spec as for POST /v1/jobs (sweeps do not "
                                     "record W: leave work out or false; save_dofs is not supported)")
    grid: dict[AxisName, GridAxis] = Field(
        min_length=1, max_length=MAX_AXES,
        description="axis name -> values (a list, or {start, stop, num, scale}). A name is a model or system "
                    "parameter (eps, k, ...), h (or step_size, its former name), method, composition, tableau, "
                    "or an initial-state component q0[i] / p0[i]; the first axis varies slowest")
    chunk_size: int = Field(1000, ge=1, le=100_000, description="members per Dask task (one compiled ensemble "
                                                               "call each); progress is reported per chunk")

    @model_validator(mode="after")
    def _no_work_by_default(self) -> SweepSpec:
        # A sweep does not record W: its job's work is false unless asked for (job_form refuses that).
        if "work" not in self.job.model_fields_set:
            self.job.work = False
        return self

    def uploads(self) -> tuple[str, ...]:
        """The ids of the uploaded files the sweep reads (its job's: a grid names no file)."""
        return self.job.uploads()

    def grid_arguments(self) -> dict[str, Any]:
        """The grid as raydamp.sweep takes it: ranges as {start, stop, num, scale}, lists as lists."""
        return {name: axis.model_dump() if isinstance(axis, GridRange) else list(axis)
                for name, axis in self.grid.items()}

    def job_form(self) -> dict[str, Any]:
        """The base point as raydamp.sweep takes a job: without work, which a sweep does not record."""
        if self.job.work:
            raise JobError(("job", "work"), "job.work: sweeps do not record the damping work W; leave work out or "
                                            "set it false")
        if self.job.save_dofs is not None:
            raise JobError(("job", "save_dofs"), "job.save_dofs: a sweep saves every coordinate; leave save_dofs out")
        if self.job.corrector is not None:
            raise JobError(("job", "corrector"), "job.corrector: a sweep's members run uncorrected; run each point as "
                                                 "a job of its own with the corrector")
        job = self.job.model_dump(mode="json", exclude_none=True, exclude={"work"})
        if self.job.system is not None:  # as the client wrote it: the compile cache's key
            job["system"] = self.job.system.model_dump(mode="json", exclude_unset=True)
        return job

    def error_at(self, error: ValueError) -> JobError:
        """A ValueError of raydamp.sweep or raydamp.check_sweep for this sweep, at the JSON path of what its
        message starts with: a grid axis, a member (the grid made it), chunk_size, else the job."""
        message = str(error)
        if message.startswith("grid."):
            return JobError(self._grid_path(message[len("grid."):]), message)
        head = message.replace(":", " ").split(" ", 1)[0]
        if head in self.grid:
            return JobError(("grid", head), message)
        if head in ("grid", "member"):  # the grid as a whole (its size), or a member's run (the amplification bound)
            return JobError(("grid",), message)
        if head == "chunk_size":
            return JobError(("chunk_size",), message)
        return error_at(self.job, error).within("job")

    def _grid_path(self, rest: str) -> tuple[str, ...]:
        """The JSON path of a message about an axis, from its text after "grid.": the axis is the key the
        client wrote, matched whole (a key may hold a dot, "load.omega", or brackets, "q0[1]"); then a
        range's key (".num") is a part of the path, and a value's index ("[2]") is not (a range's values
        have no path of their own)."""
        keys = [key for key in self.grid
                if rest.startswith(key) and rest[len(key):len(key) + 1] in ("", ":", " ", ".", "[")]
        if not keys:  # not one of the client's keys: the name up to the message's text, as one part
            return ("grid", rest.replace(":", " ").split(" ", 1)[0])
        key = max(keys, key=len)
        tail = rest[len(key):]
        if tail.startswith("."):
            return ("grid", key, tail[1:].replace(":", " ").split(" ", 1)[0])
        return ("grid", key)
