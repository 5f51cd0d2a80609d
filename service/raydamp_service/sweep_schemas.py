"""Bodies of /v1/sweeps: a job spec (the grid's base point), a grid of axes, a chunk size; and what
the service answers. The grid's rules (which names an axis may have, what a range means) are
raydamp.sweep's; the schema bounds sizes so that an oversized grid fails at parsing."""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Literal

from pydantic import BaseModel, Discriminator, Field, Tag

from .schemas import FiniteFloat, JobSpec, JobStatus, _Input

__all__ = ["SweepSpec", "GridRange", "SweepCreated", "SweepView", "SweepListItem", "SweepList", "GRID_TAGS",
           "MAX_AXIS", "MAX_AXES"]

MAX_AXIS = 10_000  # values of one axis
MAX_AXES = 8


class GridRange(_Input):
    """num values from start to stop, both included: evenly spaced, or geometric with scale "log"."""

    start: FiniteFloat
    stop: FiniteFloat
    num: int = Field(ge=1, le=MAX_AXIS)
    scale: Literal["linear", "log"] = "linear"


GridValues = Annotated[list[FiniteFloat | Annotated[str, Field(max_length=100)]],
                       Field(min_length=1, max_length=MAX_AXIS)]


def _axis_form(value: object) -> str:
    return "range" if isinstance(value, (dict, GridRange)) else "values"


GRID_TAGS = frozenset({"range", "values"})
GridAxis = Annotated[Annotated[GridRange, Tag("range")] | Annotated[GridValues, Tag("values")],
                     Discriminator(_axis_form)]
AxisName = Annotated[str, Field(min_length=1, max_length=64)]


class SweepSpec(_Input):
    """Every combination of the grid's axes, each run as the job with that point's values."""

    job: JobSpec = Field(description="the grid's base point: a job spec as for POST /v1/jobs (sweeps do not "
                                     "record W: leave work out or false; save_dofs is not supported)")
    grid: dict[AxisName, GridAxis] = Field(
        min_length=1, max_length=MAX_AXES,
        description="axis name -> values (a list, or {start, stop, num, scale}). A name is a model or system "
                    "parameter (eps, k, ...), step_size, method, composition, tableau, or an initial-state "
                    "component q0[i] / p0[i]; the first axis varies slowest")
    chunk_size: int = Field(1000, ge=1, le=100_000, description="members per Dask task (one compiled ensemble "
                                                               "call each); progress is reported per chunk")


class SweepCreated(BaseModel):
    id: str
    status: JobStatus
    members: int


class SweepView(BaseModel):
    id: str
    status: JobStatus
    members: int
    members_done: int = Field(description="members whose chunk has finished")
    progress: float
    cancel_requested: bool
    attempts: int
    error: str | None
    outcomes: dict[str, int] | None = Field(description="members per status (completed, non_finite, cancelled, "
                                                        "...), once finished")
    result: str | None = Field(description="URL of the NetCDF result, once stored")
    result_bytes: int | None
    spec: SweepSpec
    created_at: datetime
    started_at: datetime | None
    finished_at: datetime | None


class SweepListItem(BaseModel):
    id: str
    status: JobStatus
    members: int
    progress: float
    created_at: datetime
    finished_at: datetime | None
    url: str


class SweepList(BaseModel):
    sweeps: list[SweepListItem]
