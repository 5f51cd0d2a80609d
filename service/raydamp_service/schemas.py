"""Response bodies, and the request bodies of raydamp.jobs (one schema for the service, `raydamp run`, provenance)."""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field
from pydantic_core import core_schema

from raydamp.jobs import JobSpec, SweepSpec
from raydamp.jobs.summary import JobSummary  # the library's: Solution.summary()

__all__ = ["JobSpec", "SweepSpec", "FileInfo", "FileList", "JobStatus", "JobCreated", "JobSummary", "JobView",
           "JobListItem", "JobList", "Trajectory", "SweepCreated", "SweepView", "SweepListItem", "SweepList",
           "ParameterInfo", "ModelInfo", "MethodInfo", "CompositionInfo", "Health"]

JobStatus = Literal["queued", "running", "completed", "failed", "cancelled"]


class _Stored:
    """A spec as the store holds it: validated at submission and kept as the model's normalised JSON, so a view
    sends it as it is; described in /openapi.json as the model itself."""

    def __init__(self, model: type[BaseModel]):
        self.model = model

    def __get_pydantic_core_schema__(self, source: Any, handler: Any) -> core_schema.CoreSchema:
        return core_schema.dict_schema(core_schema.str_schema(), core_schema.any_schema())

    def __get_pydantic_json_schema__(self, schema: core_schema.CoreSchema, handler: Any) -> dict[str, Any]:
        return handler(self.model.__pydantic_core_schema__)


def _spec_as_model(schema: dict[str, Any]) -> None:
    """The view's spec described as a field typed by the model is: a bare reference, without a title."""
    schema["properties"]["spec"].pop("title", None)


class JobCreated(BaseModel):
    id: str
    status: JobStatus


class _TaskView(BaseModel):
    """The lifecycle's fields, the same in a job's and a sweep's view."""

    model_config = ConfigDict(json_schema_extra=_spec_as_model)

    id: str
    status: JobStatus
    progress: float
    attempts: int = Field(description="runs started; above 1 when a restart re-ran it")
    cancel_requested: bool
    error: str | None
    created_at: datetime
    started_at: datetime | None
    finished_at: datetime | None


class JobView(_TaskView):
    progress: float = Field(description="fraction of the steps done, 0 to 1")
    error: str | None = Field(description="why a failed job failed (for a blow-up, the solver's message)")
    failed_step: int | None = Field(description="the first step whose result was not finite")
    summary: JobSummary | None
    trajectory: str | None = Field(description="URL of the saved points, once there are any")
    spec: Annotated[dict[str, Any], _Stored(JobSpec)]


class _ListItem(BaseModel):
    id: str
    status: JobStatus
    progress: float
    created_at: datetime
    finished_at: datetime | None
    url: str


class JobListItem(_ListItem):
    model: str
    method: str


class JobList(BaseModel):
    jobs: list[JobListItem]


class Trajectory(BaseModel):
    """One row per saved point; non-finite values (an overflowed energy) are null."""

    t: list[float | None]
    q: list[list[float | None]]
    p: list[list[float | None]]
    energy: list[float | None]
    spring_forces: list[list[float | None]] | None = Field(
        None, description="each spring's force per point, from the material state of that point (a structure with "
        "springs, in its springs' order); null for a job without springs")
    spring_deformations: list[list[float | None]] | None = Field(
        None, description="each spring's deformation d = q_j - q_i (q_j to the ground) per point: with "
        "spring_forces, its force-deformation loop; null for a job without springs")
    hysteretic_work: list[list[float | None]] | None = Field(
        None, description="each spring's hysteretic (dissipated) work W_h per point (a job with springs and work), "
        "so that H(t) - H(0) + W(t) + sum W_h(t) - W_f(t) is the energy budget's residual; else null")
    momentum: list[list[float | None]] = Field(description="momentum maps per point; [] rows if the model has none")
    work: list[float | None] | None = Field(None, description=(
        "the damping work W(t) per point, so that H(t) - H(0) + W(t) is the energy balance residual (zero for the "
        "exact flow, O(h^2) for the order-2 methods); null for jobs stored before it was kept"))
    load_work: list[float | None] | None = Field(None, description="the load's work W_f(t) per point (a job with a "
                                                 "load or ground motion), so that H(t) - H(0) + W(t) - W_f(t) is the "
                                                 "energy budget's residual; null for a job without a load")


class FileInfo(BaseModel):
    """An uploaded file: a matrix (Matrix Market: a structure's M or K, {"file": id}) or a record (PEER .AT2, text
    columns t, value, .npy: a load's or ground motion's {"file": {"id": id}}, or an initial state's q or p)."""

    id: str
    name: str = Field(description="the file name the client sent")
    bytes: int
    kind: Literal["matrix", "record"] = Field("matrix", description="matrix or record")
    format: Literal["mtx", "at2", "npy", "columns"] = Field("mtx", description="how it was read: Matrix Market, "
                                                            "PEER .AT2, NumPy .npy, or text columns")
    shape: list[int] | None = Field(description="a matrix's [rows, cols] (null for a record)")
    nnz: int | None = Field(description="a matrix's stored entries (a symmetric file's mirrored entries counted)")
    samples: int | None = Field(None, description="a record's number of values")
    t_start: float | None = Field(None, description="a record's first time (null: one column of values, whose "
                                                    "sample interval a job gives as \"dt\")")
    t_end: float | None = Field(None, description="a record's last time")
    dt: float | None = Field(None, description="a record's sample interval, when its times are uniform")
    created_at: datetime


class FileList(BaseModel):
    files: list[FileInfo]


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
    symmetric: bool = Field(False, description="a symmetric order-2 step, which a composition raises to higher order")


class CompositionInfo(BaseModel):
    name: str
    order: int = Field(description="the order of the composed method (a symmetric order-2 base raised)")
    stages: int = Field(description="base steps per composed step (a near-integrable table: its kicks)")
    gammas: list[float] = Field(description="the fractions of h of the base steps (a palindrome summing to 1); "
                                             "for a near-integrable table, its kicks'")
    reference: str
    kind: Literal["composition", "near_integrable"] = Field(
        "composition", description="near_integrable: a table of drifts (ends) and kicks (gammas), SABA/SBAB")
    ends: list[float] = Field(default_factory=list, description="a near-integrable table's drift fractions of h")
    eps_order: int = Field(2, description="a near-integrable table's error O(eps h^eps_order + eps^2 h^2); else order")


class Health(BaseModel):
    status: Literal["ok"]
    version: str
    workers: int


class SweepCreated(JobCreated):
    members: int


class SweepView(_TaskView):
    members: int
    members_done: int = Field(description="members whose chunk has finished")
    outcomes: dict[str, int] | None = Field(description="members per status (completed, non_finite, cancelled, "
                                                        "...), once finished")
    result: str | None = Field(description="URL of the NetCDF result, once stored")
    result_bytes: int | None
    spec: Annotated[dict[str, Any], _Stored(SweepSpec)]


class SweepListItem(_ListItem):
    members: int


class SweepList(BaseModel):
    sweeps: list[SweepListItem]
