"""Request and response bodies. Inputs are strict and closed; outputs describe what we return."""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field

__all__ = [
    "FiniteFloat", "InitialState", "JobSpec",
    "JobStatus", "JobCreated", "JobSummary", "JobView", "JobListItem", "JobList", "Trajectory",
    "ParameterInfo", "ModelInfo", "MethodInfo", "Health",
]

# JSON parsing accepts NaN and Infinity (and 1e999 overflows to inf); no run may start from them.
FiniteFloat = Annotated[float, Field(allow_inf_nan=False)]
ParameterValue = FiniteFloat | list[FiniteFloat]
JobStatus = Literal["queued", "running", "completed", "failed", "cancelled"]


# ---- input ------------------------------------------------------------------------------------

class _Input(BaseModel):
    # extra="forbid": a misspelt field is named in the 422 rather than silently ignored.
    # strict: "0.2" is not a number and true is not 1.
    model_config = ConfigDict(extra="forbid", strict=True)


class InitialState(_Input):
    q: list[FiniteFloat] = Field(min_length=1, description="initial positions, length = the model's dim")
    p: list[FiniteFloat] = Field(min_length=1, description="initial momenta, length = the model's dim")


class JobSpec(_Input):
    """One integration problem: a model, a method, a step size and a span. Exactly one of t_end, n_steps."""

    model: str = Field(min_length=1, max_length=100, description="a name from GET /v1/models")
    parameters: dict[str, ParameterValue] = Field(
        default_factory=dict, max_length=64, description="model parameters by name; the rest take their defaults")
    method: str = Field(min_length=1, max_length=100, description="a name from GET /v1/methods")
    tableau: str | None = Field(None, max_length=100, description="Runge-Kutta tableau for rks/rksb")
    step_size: FiniteFloat = Field(gt=0)
    t_end: FiniteFloat | None = Field(None, gt=0)
    n_steps: int | None = Field(None, ge=1)
    initial_state: InitialState
    save_every: int = Field(1, ge=1, description="save every this many steps; the final state is always saved")


# ---- output -----------------------------------------------------------------------------------

class JobCreated(BaseModel):
    id: str
    status: JobStatus


class JobSummary(BaseModel):
    """raydamp's Solution.summary(): the scalar results of a run (non-finite numbers as null)."""

    status: str
    message: str
    method: str
    tableau: str | None
    step_size: float
    steps: int
    failed_step: int | None
    t_final: float
    saved_points: int
    energy_initial: float | None
    energy_final: float | None
    energy_dissipated: float | None
    mean_dissipation_rate: float | None
    momentum_drift: float | None
    wall_time: float


class JobView(BaseModel):
    id: str
    status: JobStatus
    progress: float = Field(description="fraction of the steps done, 0 to 1")
    attempts: int = Field(description="runs started; above 1 when a restart re-ran the job")
    cancel_requested: bool
    error: str | None = Field(description="why a failed job failed (for a blow-up, the solver's message)")
    failed_step: int | None = Field(description="the first step whose result was not finite")
    summary: JobSummary | None
    trajectory: str | None = Field(description="URL of the saved points, once there are any")
    spec: JobSpec
    created_at: datetime
    started_at: datetime | None
    finished_at: datetime | None


class JobListItem(BaseModel):
    id: str
    status: JobStatus
    progress: float
    model: str
    method: str
    created_at: datetime
    finished_at: datetime | None
    url: str


class JobList(BaseModel):
    jobs: list[JobListItem]


class Trajectory(BaseModel):
    """One row per saved point; non-finite values (an overflowed energy) are null."""

    t: list[float | None]
    q: list[list[float | None]]
    p: list[list[float | None]]
    energy: list[float | None]
    momentum: list[list[float | None]] = Field(description="momentum maps per point; [] rows if the model has none")


class ParameterInfo(BaseModel):
    name: str
    default: float | list[float]
    description: str


class ModelInfo(BaseModel):
    name: str
    description: str
    dim: int
    momenta: list[str]
    parameters: list[ParameterInfo]


class MethodInfo(BaseModel):
    name: str
    tableau: str | None
    order: int
    explicit: bool
    default: bool = Field(description="the tableau used when none is given")
    damped: bool = Field(description="False for methods that refuse eps > 0")
    description: str


class Health(BaseModel):
    status: Literal["ok"]
    version: str
    workers: int
