"""The job: one definition of the JSON that the service takes, ``raydamp run`` reads and every
Solution's provenance holds. A model (by name, with parameters) or a system, a method, a step
size h, a span and an initial state.

The step size is ``h`` here as in Python and the CLI. ``step_size``, its name before 0.2, is still
accepted for one release: an error then names ``step_size``, the key the client wrote.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Annotated, Any, Literal

from pydantic import (
    AfterValidator,
    AliasChoices,
    BaseModel,
    ConfigDict,
    Discriminator,
    Field,
    PrivateAttr,
    Tag,
    WithJsonSchema,
    field_serializer,
    model_validator,
)

from .. import _core
from ..loads.forms import LOAD_TAGS, GroundMotionInput, LoadInput
from ..methods.catalogue import compositions, methods, structure_methods
from ..systems.models import MODELS, make_model
from .envelope_forms import COLLAPSE_TAGS, ENVELOPE_QUANTITIES, CollapseValue, EnvelopeName
from .errors import JobError
from .event_forms import MAX_EVENTS, EventInput
from .forms import (
    FILE_ID,
    MAX_VECTOR,
    STATE_VECTOR_TAGS,
    FiniteFloat,
    InitialState,
    Input,
    ModeState,
    RestState,
    TableauInput,
    Vector,
    VectorFile,
    bounded,
    indices,
)
from .system_forms import FORM_TAGS, MATRIX_TAGS, SYSTEM_TAGS, VALUE_TAGS, AnySystemInput, FileResolver

__all__ = ["ModelSpec", "JobSpec", "StateInput", "UNION_TAGS", "STEP_SIZE_ALIAS", "client_path"]

STEP_SIZE_ALIAS = "step_size"  # accepted for h for one release (0.2), documented in the README


def _one_of(what: str, names: list[str]) -> Any:
    """A name from one of raydamp's catalogues: an enum in the JSON Schema (a client or a fuzzer sees
    every valid value), and an error that lists them in our words."""
    names = list(dict.fromkeys(names))

    def check(value: str) -> str:
        if value not in names:
            raise ValueError(f"unknown {what} {value!r} (known: {', '.join(names)})")
        return value

    return Annotated[str, AfterValidator(check), WithJsonSchema({"type": "string", "enum": names})]


def _method_name() -> Any:
    """A method's name: one of raydamp.methods(), or one of the methods that run a Structure with springs only
    (structure_methods(): newmark). The schema lists the two as two enums, each with its description, so that
    a client sees which names need that kind; running one on another kind is refused by the run's check."""
    general = list(dict.fromkeys(m.name for m in methods()))
    apart = [m for m in structure_methods() if m.name not in general]
    checked = _one_of("method", general + [m.name for m in apart])
    schema = {"anyOf": [{"type": "string", "enum": general, "description": "raydamp.methods() (GET /v1/methods)"},
                        *({"type": "string", "enum": [m.name], "description": f"a raydamp.Structure with springs "
                           f"only (GET /v1/structure_methods): {m.description}"} for m in apart)]}
    return Annotated[checked, WithJsonSchema(schema)]


ModelName = _one_of("model", list(MODELS))
MethodName = _method_name()
TableauName = _one_of("tableau", [m.tableau for m in methods() if m.tableau is not None])
CompositionName = _one_of("composition", [c.name for c in compositions()])
ParameterValue = Annotated[Annotated[FiniteFloat, Tag("number form")] | Annotated[Vector, Tag("vector form")],
                           Discriminator(lambda value: "vector form" if isinstance(value, list) else "number form")]


# Forms a field may take, told apart by their content rather than tried in turn: a bad input then gets
# the errors of the form it meant, not those of every form. Pydantic puts the form's tag into an
# error's loc after the field; client_path drops it, so a loc is the path the client wrote.
def _state_form(value: object) -> str:
    if isinstance(value, dict):
        return "mode form" if "mode" in value else "rest form" if "rest" in value else "q, p form"
    return "mode form" if isinstance(value, ModeState) else "rest form" if isinstance(value, RestState) else "q, p form"


StateInput = Annotated[Annotated[InitialState, Tag("q, p form")] | Annotated[ModeState, Tag("mode form")]
                       | Annotated[RestState, Tag("rest form")], Discriminator(_state_form)]
# A tableau's name or a table, told apart by type: a table's error is the table's, not also a name's.
TableauChoice = Annotated[Annotated[TableauName, Tag("name form")] | Annotated[TableauInput, Tag("table form")],
                          Discriminator(lambda value: "name form" if isinstance(value, str) else "table form")]
UNION_TAGS = {"tableau": frozenset({"name form", "table form"}),
              "initial_state": frozenset({"q, p form", "mode form", "rest form"}), "system": SYSTEM_TAGS,
              "M": MATRIX_TAGS, "K": MATRIX_TAGS, "q": STATE_VECTOR_TAGS, "p": STATE_VECTOR_TAGS,
              "collapse": COLLAPSE_TAGS, **FORM_TAGS}
GRID_TAGS = frozenset({"range", "values"})  # a sweep's axis forms (sweep_spec.py)


def client_path(loc: tuple | list) -> tuple:
    """A pydantic loc as the JSON path the client wrote: without the tags of a field's form (at any depth:
    a system's kind, then a structure's matrix form; a sweep's axis form after the axis's name)."""
    return tuple(part for i, part in enumerate(loc)
                 if not (part in LOAD_TAGS and ("load" in loc[:i] or "ground_motion" in loc[:i]))
                 and not (i >= 1 and isinstance(loc[i - 1], str) and part in UNION_TAGS.get(loc[i - 1], ()))
                 and not (i >= 2 and loc[i - 2] == "grid" and part in GRID_TAGS)
                 and not (i >= 2 and loc[i - 2] == "parameters" and part in VALUE_TAGS)
                 # tableau is a name or a table, tried in turn (an enum of names in the JSON Schema): pydantic
                 # labels each try's errors with the type tried
                 and not (i >= 1 and loc[i - 1] == "tableau" and isinstance(part, str)
                          and part not in TableauInput.model_fields))


def _exactly_one(first: str, second: str, first_type: str, second_type: str) -> dict:
    """JSON Schema for "exactly one of first and second is given (not null)"."""
    return {"oneOf": [{"required": [first], "properties": {first: {"type": first_type}, second: {"type": "null"}}},
                      {"required": [second], "properties": {second: {"type": second_type}, first: {"type": "null"}}}]}


def _flat(schema: dict) -> None:
    """A name or a table, or null, as one anyOf (the forms' oneOf spliced in): a client sees the names' enum."""
    schema["anyOf"] = [form for option in schema.get("anyOf", []) for form in option.get("oneOf", [option])]


def _flat_names(schema: dict) -> None:
    """The method's two enums, or null, as one anyOf: a client's tools see each enum at the top."""
    schema["anyOf"] = [form for option in schema.get("anyOf", []) for form in option.get("anyOf", [option])]


def _job_schema(schema: dict) -> None:
    schema["allOf"] = [_exactly_one("model", "system", "string", "object"),
                       _exactly_one("t_end", "n_steps", "number", "integer")]
    # The former name of h, still accepted (never beside h): a client's tools see it and that it goes
    schema["not"] = {"required": ["h", STEP_SIZE_ALIAS]}
    schema["properties"][STEP_SIZE_ALIAS] = {"type": "number", "exclusiveMinimum": 0, "deprecated": True,
                                             "description": "h under its former name; give h"}


class ModelSpec(Input):
    """The system a job integrates: a built-in model by name with its parameters, or a system (exactly one)."""

    model: ModelName | None = Field(None, description="a built-in model's name (GET /v1/models, raydamp models)")
    system: AnySystemInput | None = Field(
        None, description="a user-defined system, a lattice ({\"kind\": \"chain\", ...}) or a linear structure "
                          "({\"kind\": \"linear_structure\", ...}), in place of model/parameters")
    parameters: dict[str, ParameterValue] = Field(
        default_factory=dict, max_length=64, description="model parameters by name; the rest take their defaults")

    def names(self, dim: int, momenta: int, save_dofs: list[int] | None = None) -> tuple[list[str], list[str]]:
        """(names of the saved coordinates, momentum map names) of the model of dim coordinates and
        momenta momentum maps, without building it: a stored run's files and plots are labelled from its spec."""
        if self.system is not None:
            return self.system.names(dim, momenta, save_dofs)
        cls = MODELS[self.model]
        return [cls.coordinates[i] for i in (save_dofs if save_dofs is not None else range(dim))], \
            list(cls.momentum_names)

    def build_model(self, files: FileResolver | None = None):
        """The model; raises JobError naming the field (a parameter, or the path inside "system")."""
        if (self.model is None) == (self.system is None):
            # loc: the field to remove (a system beside a model) or to add (a model's name)
            raise JobError(("model",) if self.model is None else ("system",),
                           "model: give exactly one of model (a built-in model's name, with parameters) "
                           "and system (a user-defined system)")
        if self.system is not None:
            if self.parameters:
                raise JobError(("parameters",), "parameters: a system carries its parameters inside "
                                                "system.parameters")
            return self.system.build(files)
        try:
            return make_model(self.model, self.parameters)
        except ValueError as error:  # "parameters.k: ... has no parameter" or a model's own "eps must be >= 0"
            message = str(error)
            head = message.replace(":", " ").split(" ", 1)[0]
            if head.startswith("parameters."):
                raise JobError(("parameters", head.split(".", 1)[1]), message) from None
            if head in self.parameters:
                raise JobError(("parameters", head), f"parameters.{message}") from None
            raise JobError(("parameters",), f"parameters: {message}") from None


class JobSpec(ModelSpec):
    """One integration problem: a model (or a system), a method, a step size h and a span.
    Exactly one of model and system; exactly one of t_end, n_steps."""

    # One schema for a job in and out: a stored job is echoed as the client wrote it (_as_written)
    model_config = ConfigDict(json_schema_extra=lambda schema: _job_schema(schema),
                              json_schema_mode_override="validation")

    method: MethodName | None = Field(
        None, description="a name from raydamp.methods() (GET /v1/methods), or for a structure with springs "
                          "\"newmark\" (GET /v1/structure_methods; any other system is refused); null or absent: "
                          "raydamp chooses (3s, except for a linear structure on which 3s is a trap: see "
                          "raydamp.run.choose_method), and the result's provenance names the method and why",
        json_schema_extra=lambda schema: _flat_names(schema))
    tableau: TableauChoice | None = Field(
        None, description="Runge-Kutta tableau for rks, rksb and rk: a name, or your own {A, b, c}",
        json_schema_extra=lambda schema: _flat(schema))
    composition: CompositionName | None = Field(None, description="raises a symmetric method's order: a name from "
                                                                 "raydamp.compositions() (GET /v1/methods lists the "
                                                                 "symmetric methods)")
    h: FiniteFloat = Field(gt=0, validation_alias=AliasChoices(
        "h", STEP_SIZE_ALIAS), description="the step size; h x the number of steps must be finite. The former "
                                           "name step_size is accepted for one release")
    t_end: FiniteFloat | None = Field(None, gt=0, description="the end time; give this or n_steps, not both")
    n_steps: int | None = Field(None, ge=1, description="the number of steps; give this or t_end, not both")
    initial_state: StateInput
    save_every: int = Field(1, ge=1, description="save every this many steps; the final state is always saved")
    work: bool = Field(True, description="record the damping work W(t), so that H(t) - H(0) + W(t) (the energy "
                                         "balance) can be plotted; false skips it and lets 3s merge the damping "
                                         "sub-flows of consecutive steps (a little faster, equal to rounding)")
    save_dofs: bounded(Annotated[int, Field(ge=0)], MAX_VECTOR, min_length=1, items=indices(MAX_VECTOR)) | None = Field(
        None, description="save q and p of these coordinates only (energy, W and momenta "
                                                 "still from the whole state); null saves all")
    load: LoadInput | None = Field(
        None, description="a time-dependent force f(t): {\"harmonic\": {\"amplitude\": [...], \"omega\": w, "
                          "\"phase\": 0}}, {\"series\": {\"t\": [...], \"values\": [...], \"direction\": [...], "
                          "\"hold\": false}}, {\"expression\": {\"expression\": \"F0*sin(w*t)\", \"parameters\": "
                          "{...}, \"direction\": [...]}}, {\"file\": {\"id\": <uploaded .AT2/CSV/.npy>, "
                          "\"direction\": [...], \"factor\": 1}}, or {\"terms\": [several], \"amplitude\": a}")
    ground_motion: GroundMotionInput | None = Field(
        None, description="uniform base excitation (as OpenSees' UniformExcitation): {\"acceleration\": a load form "
                          "without direction (series, file, harmonic with a scalar amplitude, expression), "
                          "\"direction\": r, \"factor\": 1}; the load is -M r a_g(t) and the result is the motion "
                          "relative to the ground")
    temperature: FiniteFloat | None = Field(
        None, ge=0, description="kT of thermal noise: every damping flow of 3s, 2s or baoab becomes its exact "
                                "Ornstein-Uhlenbeck flow (null or 0: none)")
    seed: int | None = Field(None, ge=0, le=2**64 - 1, description="the noise's seed (null: a fresh one, kept in the "
                                                                  "result's provenance)")
    stream: int = Field(0, ge=0, le=2**64 - 1, description="which stream of the seed; a sweep's member k draws stream "
                                                              "stream + k")
    divergence: FiniteFloat = Field(_core.DEFAULT_DIVERGENCE, ge=0, description=(
        "the divergence test's factor G: a run whose energy gains more than G times what its start, its load and "
        "its temperature can give it stops with status \"diverged\", keeping its rows (raydamp.integrate's "
        "divergence documents the rule); 0 turns the test off"))
    events: bounded(EventInput, MAX_EVENTS) | None = Field(
        None, description="events to locate: [{\"g\": \"q[0]\", \"direction\": -1, \"terminal\": false, "
                          "\"name\": \"...\"}]; their crossings are the result's events table (raydamp.Event)")
    dense: bool = Field(False, description="keep t, q, p, M^-1 p and pdot at every step end, for dense output")
    envelope: bounded(EnvelopeName, len(ENVELOPE_QUANTITIES), min_length=1) | None = Field(
        None, description="peaks to take at every step's end (max |x| and its time), not only at saved rows: "
                          "displacement, velocity, acceleration, abs_acceleration (relative + ground), "
                          "residual_displacement per coordinate; drift (a spring's deformation: a shear frame's "
                          "interstorey drift), force, residual_drift per spring (raydamp.run.envelope)")
    collapse: CollapseValue | None = Field(
        None, description="a limit of |drift| for every spring (a number, or one per spring): the run stops at the "
                          "first step's end past it, status \"collapsed\"")
    corrector: Literal[4, 6, 8, 10] | None = Field(
        None, description="a symplectic corrector for planets without drag stepped by sv, 2s or 3s: the error "
                          "linear in the mass ratio eps falls from O(eps h^2) to O(eps h^corrector) "
                          "(raydamp.run.correctors)")
    _h_key: str = PrivateAttr("h")

    @model_validator(mode="wrap")
    @classmethod
    def _remember_h_key(cls, data: Any, handler: Any) -> JobSpec:
        spec = handler(data)
        if isinstance(data, dict) and STEP_SIZE_ALIAS in data:
            spec._h_key = STEP_SIZE_ALIAS
        return spec

    @field_serializer("load", "ground_motion")
    def _as_written(self, value: BaseModel | None) -> dict[str, Any] | None:
        # A stored or echoed job holds its load as the client wrote it, without the defaults
        return None if value is None else value.model_dump(mode="json", exclude_unset=True)

    def _files(self) -> Iterator[tuple[tuple, str, str]]:
        """(JSON path, "id" or "path", the id or path) of every file the job reads: the initial state's uploaded
        vectors, a structure's matrices, the records of its load and its ground motion."""
        for name in ("q", "p"):
            vector = getattr(self.initial_state, name, None)
            if isinstance(vector, VectorFile):
                yield ("initial_state", name, "file"), "id", vector.file
        if self.system is not None:
            yield from self.system.files(("system",))
        for field in ("load", "ground_motion"):
            if getattr(self, field) is not None:
                yield from getattr(self, field).files((field,))

    def sizes(self) -> Iterator[tuple[tuple[str | int, ...], str, int]]:
        """(JSON path, unit, count) of what the job carries inline, for a service's bounds before anything is
        built: "components" of the initial state's and the parameters' vectors, "entries" of a structure's
        COO lists, "coordinates" of a structure given by COO or diagonal."""
        for name in ("q", "p"):
            vector = getattr(self.initial_state, name, None)
            if isinstance(vector, list):  # a {"file": id} is bounded by the model it must fit
                yield ("initial_state", name), "components", len(vector)
        for name, value in self.parameters.items():
            if isinstance(value, list):
                yield ("parameters", name), "components", len(value)
        if self.system is not None:
            yield from self.system.sizes(("system",))

    def uploads(self) -> tuple[str, ...]:
        """The ids of the uploaded files (POST /v1/files) the job reads, each once, in the order named."""
        return tuple(dict.fromkeys(ref for _, source, ref in self._files() if source == "id" and FILE_ID.match(ref)))

    def local_paths(self) -> tuple[tuple[str | int, ...], ...]:
        """The JSON paths of the files of the machine the job runs on, which a service refuses: a load's
        {"file": {"path": ...}}, a structure's {"file": "<path>"} (not an upload's id)."""
        return tuple(at for at, source, _ in self._files() if source == "path")

    def compiles(self) -> bool:
        """Whether checking or running the job compiles machine code (an expression system, a chain of
        expression bonds, an expression in the load or the ground motion)."""
        return bool(self.events) or (self.system is not None and self.system.compiles()) or any(
            getattr(self, field) is not None and getattr(self, field).compiles() for field in ("load", "ground_motion"))

    def compiled_form(self) -> tuple[str, bytes] | None:
        """(key, bytes) of the compiled functions of the job's expression system (built once: the build is
        cached), for another process to load; None for the other kinds."""
        return None if self.system is None else self.system.compiled_form()

    @property
    def h_key(self) -> str:
        """The key the client gave the step size by: "h", or "step_size" (the former name)."""
        return self._h_key
