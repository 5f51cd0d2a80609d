"""Request and response bodies. Inputs are strict and closed; outputs describe what we return."""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Literal

import raydamp
from pydantic import BaseModel, ConfigDict, Discriminator, Field, Tag
from raydamp.models import describe_models

__all__ = [
    "FiniteFloat", "InitialState", "JobSpec", "SystemInput", "TableauInput",
    "ChainInput", "LinearStructureInput", "FileInfo", "FileList",
    "JobStatus", "JobCreated", "JobSummary", "JobView", "JobListItem", "JobList", "Trajectory",
    "ParameterInfo", "ModelInfo", "MethodInfo", "Health",
]

# The names a job may use, from raydamp's own catalogue: enums in /openapi.json, so that a client
# (or a fuzzer) sees every valid value.
ModelName = Literal[tuple(model["name"] for model in describe_models())]  # type: ignore[valid-type]
MethodName = Literal[tuple(dict.fromkeys(method.name for method in raydamp.methods()))]  # type: ignore[valid-type]
TableauName = Literal[tuple(dict.fromkeys(  # type: ignore[valid-type]
    method.tableau for method in raydamp.methods() if method.tableau is not None))]
CompositionName = Literal[tuple(c.name for c in raydamp.compositions())]  # type: ignore[valid-type]

# JSON parsing accepts NaN and Infinity (and 1e999 overflows to inf); no run may start from them.
FiniteFloat = Annotated[float, Field(allow_inf_nan=False)]
# The longest vector any job may carry (Settings.max_dim is at most this, and usually lower). In the
# schema, so that a list of 200,000 bad items is one error found at once, not 200,000 found one by one.
MAX_VECTOR = 10_000
MAX_CHAIN_SITES = 10**7  # a chain's state is built by raydamp from its description, not sent
Vector = Annotated[list[FiniteFloat], Field(max_length=MAX_VECTOR)]
ParameterValue = FiniteFloat | Vector
JobStatus = Literal["queued", "running", "completed", "failed", "cancelled"]


# ---- input ------------------------------------------------------------------------------------

class _Input(BaseModel):
    # extra="forbid": a misspelt field is named in the 422 rather than silently ignored.
    # strict: "0.2" is not a number and true is not 1.
    model_config = ConfigDict(extra="forbid", strict=True)


class InitialState(_Input):
    q: list[FiniteFloat] = Field(min_length=1, max_length=MAX_VECTOR,
                                 description="initial positions, length = the model's dim")
    p: list[FiniteFloat] = Field(min_length=1, max_length=MAX_VECTOR,
                                 description="initial momenta, length = the model's dim")


# Bounds of a system: raydamp's own limits (raydamp.systems.system.spec and raydamp.systems.expressions), stated in
# the schema so that an oversized list fails at parsing, before any work.
_MAX_COORDINATES = 256
_MAX_EXPRESSION = 10_000
_MAX_DENSE = 32
Expression = Annotated[str, Field(min_length=1, max_length=_MAX_EXPRESSION)]
Name = Annotated[str, Field(min_length=1, max_length=100, pattern=r"^[A-Za-z_][A-Za-z0-9_]*$")]


_MAX_STAGES = 16  # raydamp.methods.user_tableau.MAX_STAGES
_Coefficients = Annotated[list[FiniteFloat], Field(min_length=1, max_length=_MAX_STAGES)]


class TableauInput(_Input):
    """Your own Butcher tableau: each row of A sums to c; the order is computed from the order
    conditions (up to 4) and a claimed order must hold. rks takes diagonally implicit tableaux,
    rksb and rk explicit ones."""

    A: list[_Coefficients] = Field(min_length=1, max_length=_MAX_STAGES, description="s rows of s coefficients")
    b: _Coefficients = Field(description="the s weights")
    c: _Coefficients = Field(description="the s nodes")
    order: int | None = Field(None, ge=1, description="the order you claim; checked against the order conditions")


class ScalarDamping(_Input):
    scalar: FiniteFloat = Field(ge=0, description="D = c M: every momentum decays at rate eps c")


class DiagonalDamping(_Input):
    diagonal: list[FiniteFloat] = Field(min_length=1, max_length=_MAX_DENSE, description="a constant diagonal D")


class MatrixDamping(_Input):
    matrix: list[Annotated[list[FiniteFloat], Field(max_length=_MAX_DENSE)]] = Field(
        min_length=1, max_length=_MAX_DENSE, description="a constant symmetric positive semi-definite D (rows)")


class Damper(_Input):
    on: Expression = Field(description="g(q): the dashpot resists its rate of change")
    c: FiniteFloat = Field(1.0, ge=0, description="the dashpot's coefficient")


class DamperDamping(_Input):
    dampers: list[Damper] = Field(min_length=1, max_length=32,
                                  description="D(q) = sum_i c_i grad g_i grad g_i^T")


class SystemInput(_Input):
    """A user-defined system: raydamp.System.to_dict()'s form. H = 1/2 p^T M^{-1} p + V(q) with
    damping -eps D(q) M^{-1} p; M constant SPD, D(q) symmetric PSD."""

    coordinates: Annotated[list[Name], Field(min_length=1, max_length=_MAX_COORDINATES)] | Annotated[
            int, Field(ge=1, le=_MAX_COORDINATES)] = Field(
        description="coordinate names, or their number n (names q0..q{n-1})")
    potential: Expression = Field(description="V(q): numbers, names, + - * / ^, parentheses, pi, and "
                                              "sin cos tan asin acos atan atan2 sinh cosh tanh asinh acosh "
                                              "atanh exp log sqrt cbrt")
    parameters: dict[Name, FiniteFloat] = Field(default_factory=dict, max_length=256)
    mass: FiniteFloat | Annotated[list[FiniteFloat], Field(max_length=_MAX_COORDINATES)] | Annotated[
            list[Annotated[list[FiniteFloat], Field(max_length=_MAX_COORDINATES)]],
            Field(max_length=_MAX_COORDINATES)] = Field(
        1.0, description="a number m (M = m I), a diagonal (n numbers) or an n x n SPD matrix")
    damping: ScalarDamping | DiagonalDamping | MatrixDamping | DamperDamping | None = Field(
        None, description="null (undamped) or exactly one form")
    eps: FiniteFloat = Field(0.0, ge=0, description="damping strength")
    momenta: dict[Name, Expression] = Field(default_factory=dict, max_length=16,
                                            description="quantities tracked at every step; momenta are p_<coordinate>")
    name: str | None = Field(None, max_length=200)


class ChainDampers(_Input):
    bonds: list[Annotated[int, Field(ge=0)]] = Field(default_factory=list, max_length=MAX_VECTOR,
                                                     description="damped bonds (bond b joins sites b-1 and b)")
    sites: list[Annotated[int, Field(ge=0)]] = Field(default_factory=list, max_length=MAX_VECTOR,
                                                     description="sites with on-site friction")
    c: FiniteFloat | Annotated[list[FiniteFloat], Field(max_length=2 * MAX_VECTOR)] = Field(
        description="the dashpot coefficient, or one per damper (bonds, then sites)")


class ChainOnSiteInput(_Input):
    """An on-site potential U(q_i) on every site: harmonic (k), phi4 (k2, k4) or sine (g); the
    parameters not given take raydamp's defaults (raydamp.systems.chain documents them)."""

    kind: Literal["harmonic", "phi4", "sine"]
    k: FiniteFloat | None = Field(None, ge=0, description="harmonic: U = k q^2/2")
    k2: FiniteFloat | None = Field(None, description="phi4: U = k2 q^2/2 + k4 q^4/4 (k2 < 0: a double well)")
    k4: FiniteFloat | None = Field(None, ge=0)
    g: FiniteFloat | None = Field(None, ge=0, description="sine: U = g (1 - cos q)")


class ChainInput(_Input):
    """A lattice: raydamp.Chain.to_dict()'s form. n sites of mass m, neighbours joined by bonds of one
    family, dashpots on chosen bonds or friction on chosen sites (raydamp.systems.chain documents it)."""

    kind: Literal["chain"]
    n: int = Field(ge=2, le=MAX_CHAIN_SITES, description="number of sites")
    bond: Literal["harmonic", "fput", "toda", "morse", "lennard_jones", "expression"] = "fput"
    parameters: dict[Name, FiniteFloat | Expression] = Field(
        default_factory=dict, max_length=64,
        description="the family's parameters (fput: k, alpha, beta; ...); an expression bond gives "
                    "potential: V(r) as text, and its named parameters")
    mass: FiniteFloat = Field(1.0, gt=0)
    boundary: Literal["fixed", "periodic", "free"] = "fixed"
    dampers: ChainDampers | None = None
    eps: FiniteFloat = Field(1.0, ge=0, description="damping strength (D is scaled by it)")
    on_site: ChainOnSiteInput | None = Field(None, description="an on-site potential on every site (Klein-Gordon, "
                                                               "Frenkel-Kontorova); none by default")


# ---- linear structures: raydamp.LinearStructure.to_dict()'s form, and uploaded files ----------------

MAX_COO_ENTRIES = 1_000_000  # raydamp.systems.structure.MAX_PLAIN_ENTRIES; Settings.max_structure_nnz is at most this
MAX_STRUCTURE_DIM = 10**7  # Settings.max_structure_dim is at most this
FileId = Annotated[str, Field(pattern=r"^[0-9a-f]{32}$", description="an id from POST /v1/files")]


class CooMatrix(_Input):
    shape: list[Annotated[int, Field(ge=1, le=MAX_STRUCTURE_DIM)]] = Field(min_length=2, max_length=2,
                                                                           description="[n, n]")
    rows: list[Annotated[int, Field(ge=0)]] = Field(max_length=MAX_COO_ENTRIES, description="row of each entry")
    cols: list[Annotated[int, Field(ge=0)]] = Field(max_length=MAX_COO_ENTRIES, description="column of each entry")
    values: list[FiniteFloat] = Field(max_length=MAX_COO_ENTRIES, description="the entries (repeated "
                                                                              "positions add up)")


class CooForm(_Input):
    coo: CooMatrix


class DiagonalForm(_Input):
    diagonal: list[FiniteFloat] = Field(min_length=1, max_length=MAX_STRUCTURE_DIM,
                                        description="a diagonal matrix (lumped mass)")


class FileForm(_Input):
    file: FileId


# The tags are not key names: "K" followed by "coo" in a loc is then always the client's key (our own
# checks' locs carry no tags), and "K" followed by "coo form" is pydantic's tag, dropped from a 422.
def _matrix_form(value: object) -> str | None:
    if isinstance(value, dict):
        for key in ("coo", "file", "diagonal"):
            if key in value:
                return f"{key} form"
        return None  # none of the forms: one error saying which there are
    for form, name in ((CooForm, "coo"), (FileForm, "file"), (DiagonalForm, "diagonal")):
        if isinstance(value, form):
            return f"{name} form"
    return None


MatrixInput = Annotated[Annotated[CooForm, Tag("coo form")] | Annotated[DiagonalForm, Tag("diagonal form")]
                        | Annotated[FileForm, Tag("file form")],
                        Discriminator(_matrix_form, custom_error_type="matrix_form",
                                      custom_error_message='a matrix is {"coo": {"shape", "rows", "cols", "values"}}, '
                                                           '{"diagonal": [...]} or {"file": "<id from POST '
                                                           '/v1/files>"}')]


class LinearStructureInput(_Input):
    """A linear structure M q'' + (alpha M + beta K) q' + K q = f: raydamp.LinearStructure.to_dict()'s
    form, with a matrix also given as {"file": id} of an uploaded Matrix Market file. M symmetric
    positive definite (a diagonal M is a lumped mass), K symmetric positive semi-definite."""

    kind: Literal["linear_structure"]
    M: MatrixInput = Field(description='{"coo": {shape, rows, cols, values}}, {"diagonal": [...]} or {"file": id}')
    K: MatrixInput = Field(description="the stiffness matrix, in the same forms as M")
    alpha: FiniteFloat = Field(0.0, ge=0, description="Rayleigh damping C = alpha M + beta K")
    beta: FiniteFloat = Field(0.0, ge=0)
    f: Annotated[list[FiniteFloat], Field(max_length=MAX_STRUCTURE_DIM)] | None = Field(
        None, description="constant load (length n); null for none")


class ModeState(_Input):
    """A chain started at rest with all its energy in one normal mode (raydamp.Chain.normal_mode):
    a job for a million sites need not carry two million numbers."""

    mode: int = Field(ge=0, description="the mode number (fixed ends: 1..n)")
    amplitude: FiniteFloat = 1.0


class RestState(_Input):
    """Start at rest at q = 0, p = 0: a structure's response to its load f, without sending 2 n zeros
    (so a structure may be larger than max_dim, up to max_structure_dim)."""

    rest: Literal[True]


# Forms a field may take, told apart by their content rather than tried in turn: a bad input then gets
# the errors of the form it meant, not those of every form. Pydantic puts the form's tag into an
# error's loc after the field; the 422 handler drops it (UNION_TAGS), so a loc is the path the client wrote.
def _state_form(value: object) -> str:
    if isinstance(value, dict):
        return "mode" if "mode" in value else "rest" if "rest" in value else "state"
    return "mode" if isinstance(value, ModeState) else "rest" if isinstance(value, RestState) else "state"


def _system_form(value: object) -> str:
    kind = value.get("kind") if isinstance(value, dict) else getattr(value, "kind", None)
    return kind if kind in ("chain", "linear_structure") else "expressions"


_MATRIX_TAGS = frozenset({"coo form", "diagonal form", "file form"})
UNION_TAGS = {"initial_state": frozenset({"state", "mode", "rest"}),
              "system": frozenset({"expressions", "chain", "linear_structure"}), "M": _MATRIX_TAGS, "K": _MATRIX_TAGS}
StateInput = Annotated[Annotated[InitialState, Tag("state")] | Annotated[ModeState, Tag("mode")]
                       | Annotated[RestState, Tag("rest")], Discriminator(_state_form)]
AnySystemInput = Annotated[Annotated[SystemInput, Tag("expressions")] | Annotated[ChainInput, Tag("chain")]
                           | Annotated[LinearStructureInput, Tag("linear_structure")], Discriminator(_system_form)]


def _exactly_one(first: str, second: str, first_type: str, second_type: str) -> dict:
    """JSON Schema for "exactly one of first and second is given (not null)"."""
    return {"oneOf": [{"required": [first], "properties": {first: {"type": first_type}, second: {"type": "null"}}},
                      {"required": [second], "properties": {second: {"type": second_type}, first: {"type": "null"}}}]}


class JobSpec(_Input):
    """One integration problem: a model (or a system), a method, a step size and a span.
    Exactly one of model and system; exactly one of t_end, n_steps."""

    model_config = ConfigDict(json_schema_extra={"allOf": [_exactly_one("model", "system", "string", "object"),
                                                           _exactly_one("t_end", "n_steps", "number", "integer")]})

    model: ModelName | None = Field(None, description="a name from GET /v1/models")
    system: AnySystemInput | None = Field(
        None, description="a user-defined system, a lattice ({\"kind\": \"chain\", ...}) or a linear structure "
                          "({\"kind\": \"linear_structure\", ...}), in place of model/parameters")
    parameters: dict[str, ParameterValue] = Field(
        default_factory=dict, max_length=64, description="model parameters by name; the rest take their defaults")
    method: MethodName = Field(description="a name from GET /v1/methods")
    tableau: TableauName | TableauInput | None = Field(
        None, description="Runge-Kutta tableau for rks, rksb and rk: a name, or your own {A, b, c}")
    composition: CompositionName | None = Field(None, description="raises a symmetric method's order: a name from "
                                                                 "raydamp.compositions() (GET /v1/methods lists the "
                                                                 "symmetric methods)")
    step_size: FiniteFloat = Field(gt=0, description="step_size x the number of steps must be finite")
    t_end: FiniteFloat | None = Field(None, gt=0, description="the end time; give this or n_steps, not both")
    n_steps: int | None = Field(None, ge=1, description="the number of steps; give this or t_end, not both")
    initial_state: StateInput
    save_every: int = Field(1, ge=1, description="save every this many steps; the final state is always saved")
    work: bool = Field(True, description="record the damping work W(t), so that H(t) - H(0) + W(t) (the energy "
                                         "balance) can be plotted; false skips it and lets 3s merge the damping "
                                         "sub-flows of consecutive steps (a little faster, equal to rounding)")
    save_dofs: list[Annotated[int, Field(ge=0)]] | None = Field(
        None, max_length=MAX_VECTOR, description="save q and p of these coordinates only (energy, W and momenta "
                                                 "still from the whole state); null saves all")


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
    composition: str | None = None
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
    work: list[float | None] | None = Field(None, description="the damping work W(t) per point, so that "
                                            "H(t) - H(0) + W(t) is the energy balance residual (zero for the exact "
                                            "flow, O(h^2) for the order-2 methods); null for jobs stored before "
                                            "it was kept")


class FileInfo(BaseModel):
    """An uploaded Matrix Market file, for {"file": id} in place of a structure's M or K."""

    id: str
    name: str = Field(description="the file name the client sent")
    bytes: int
    shape: list[int] = Field(description="[rows, cols] of the matrix")
    nnz: int = Field(description="stored entries (a symmetric file's mirrored entries counted)")
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
    stages: int = Field(description="base steps per composed step")
    gammas: list[float] = Field(description="the fractions of h of the base steps (a palindrome summing to 1)")
    reference: str


class Health(BaseModel):
    status: Literal["ok"]
    version: str
    workers: int
