"""From a JobSpec to a raydamp call: the domain checks and the translation of raydamp's errors.

raydamp owns the rules (which methods take which tableau, that sv refuses eps > 0, each
model's parameters and dimension); the service asks it rather than restating them, and
only renames raydamp's argument names to the JSON fields the client sent.
"""

from __future__ import annotations

import functools
import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import raydamp
from raydamp.models import make_model

from .config import Settings
from .schemas import ChainInput, CooForm, DiagonalForm, JobSpec, LinearStructureInput, ModeState, RestState

__all__ = ["SpecError", "RaydampCall", "build_call", "check_spec", "planned_steps"]

# raydamp.integrate's argument -> the JSON field carrying it.
_FIELD_OF_ARGUMENT: dict[str, tuple[str, ...]] = {
    "h": ("step_size",),
    "q0": ("initial_state", "q"),
    "p0": ("initial_state", "p"),
    "method": ("method",),
    "tableau": ("tableau",),
    "composition": ("composition",),
    "save_every": ("save_every",),
    "save_dofs": ("save_dofs",),
    "n_steps": ("n_steps",),
    "t_end": ("t_end",),
}


class SpecError(ValueError):
    """A spec that cannot run; loc is the JSON path of the offending field (without "body")."""

    def __init__(self, loc: tuple[str | int, ...], message: str):
        super().__init__(message)
        self.loc = loc
        self.message = message


@dataclass(frozen=True)
class RaydampCall:
    model: raydamp.models.Model
    q0: list[float]
    p0: list[float]
    options: dict[str, Any]

    def run(self, **extra: Any) -> raydamp.Solution:
        return raydamp.integrate(self.model, self.q0, self.p0, **{**self.options, **extra})


def _translate(error: ValueError, fields: dict[str, tuple[str, ...]]) -> SpecError:
    """Name the field: raydamp's messages start with the argument they are about ("h must be > 0")."""
    message = str(error)
    for name in sorted(fields, key=len, reverse=True):
        rest = message[len(name):]
        if message.startswith(name) and not (rest[:1].isalnum() or rest[:1] == "_"):
            loc = fields[name]
            # Say it in the client's words: "step_size must be > 0", not "h must be > 0".
            return SpecError(loc, ".".join(loc) + rest)
    return SpecError((), message)


@functools.lru_cache(maxsize=32)
def _compiled_system(text: str) -> raydamp.System:
    # Keyed by the canonical JSON: a system checked at submission is not compiled again by the
    # worker, and a sweep over initial states compiles its system once.
    return raydamp.System.from_dict(json.loads(text))


def _system(spec: JobSpec) -> raydamp.System:
    """The user's system; raydamp's own validation names the path inside "system"."""
    try:
        return _compiled_system(json.dumps(spec.system.model_dump(exclude_unset=True), sort_keys=True))
    except raydamp.SpecError as error:
        raise _system_error(error) from None


def _system_error(error: raydamp.SpecError) -> SpecError:
    return SpecError(("system", *error.path), f"system.{error}")


def _system_path_error(error: ValueError, schema: type) -> SpecError:
    """raydamp's message starts with the path inside "system": "dampers.bonds[3]: ...", "K.coo.rows[2]: ..."
    or "n must be ..."."""
    message = str(error)
    path = message.split(" ", 1)[0].rstrip(":").replace("]", "").replace("[", ".").split(".")
    loc = tuple(int(part) if part.isdigit() else part for part in path if part)
    if not loc or loc[0] not in schema.model_fields:
        loc = ()
    return SpecError(("system", *loc), f"system.{message}")


def _chain(system: ChainInput) -> raydamp.Chain:
    """raydamp builds and checks the chain; its messages name the key inside "system"."""
    try:
        return raydamp.Chain.from_dict(system.model_dump(exclude_none=True))
    except ValueError as error:
        raise _system_path_error(error, ChainInput) from None


FileResolver = Callable[[str], Any]


def _no_files(file_id: str) -> Any:
    # Never a path on the server: without the store, a {"file": ...} reference resolves to nothing.
    raise ValueError(f"no uploaded file with id {file_id!r}")


def _linear_structure(system: LinearStructureInput, files: FileResolver | None) -> raydamp.LinearStructure:
    """raydamp builds and checks the structure (indices, shapes, symmetry and definiteness); uploaded
    files come from the store through files(id)."""
    try:
        return raydamp.LinearStructure.from_dict(system.model_dump(exclude_none=True), files=files or _no_files)
    except ValueError as error:
        raise _system_path_error(error, LinearStructureInput) from None


def _check_structure_size(system: LinearStructureInput, settings: Settings) -> None:
    """The operator's bounds, before raydamp allocates anything: entries per matrix, and n (a COO shape
    of [10^9, 10^9] with three entries would still cost 8 GB of column pointers)."""
    for key in ("M", "K"):
        form = getattr(system, key)
        if isinstance(form, CooForm):
            for name in ("rows", "cols", "values"):
                count = len(getattr(form.coo, name))
                if count > settings.max_structure_nnz:
                    raise SpecError(("system", key, "coo", name), f"system.{key}.coo.{name}: {count} entries; this "
                                    f"service accepts at most max_structure_nnz = {settings.max_structure_nnz} per "
                                    "matrix (upload larger ones as Matrix Market files: POST /v1/files)")
            if form.coo.shape[0] > settings.max_structure_dim:
                raise SpecError(("system", key, "coo", "shape"), f"system.{key}.coo.shape: n = {form.coo.shape[0]}; "
                                "this service runs structures of at most max_structure_dim = "
                                f"{settings.max_structure_dim} coordinates")
        elif isinstance(form, DiagonalForm) and len(form.diagonal) > settings.max_structure_dim:
            raise SpecError(("system", key, "diagonal"), f"system.{key}.diagonal: {len(form.diagonal)} entries; "
                            "this service runs structures of at most max_structure_dim = "
                            f"{settings.max_structure_dim} coordinates")


def _initial_state(spec: JobSpec, model) -> tuple[Any, Any]:
    state = spec.initial_state
    if isinstance(state, RestState):
        return np.zeros(model.dim), np.zeros(model.dim)
    if isinstance(state, ModeState):
        if not isinstance(model, raydamp.Chain):
            raise SpecError(("initial_state",), "initial_state: {mode, amplitude} starts a chain; give q and p")
        try:
            return model.normal_mode(state.mode, state.amplitude)
        except ValueError as error:
            raise SpecError(("initial_state", "mode"), f"initial_state.{error}") from None
    return list(state.q), list(state.p)


def _model(spec: JobSpec, files: FileResolver | None = None) -> raydamp.models.Model:
    if (spec.model is None) == (spec.system is None):
        raise SpecError(("model",) if spec.model is None else ("system",),
                        "give exactly one of model (a name from GET /v1/models, with parameters) and system "
                        "(a user-defined system)")
    if spec.system is not None:
        if spec.parameters:
            raise SpecError(("parameters",), "parameters: a system carries its parameters inside system.parameters")
        if isinstance(spec.system, ChainInput):
            return _chain(spec.system)
        if isinstance(spec.system, LinearStructureInput):
            return _linear_structure(spec.system, files)
        return _system(spec)
    try:
        return make_model(spec.model, spec.parameters)
    except ValueError as error:
        fields = {"model": ("model",)}
        for name in spec.parameters:  # make_model says "eps must be ..." or "parameters.eps: ..."
            fields[name] = fields[f"parameters.{name}"] = ("parameters", name)
        raise _translate(error, fields) from None


def build_call(spec: JobSpec, files: FileResolver | None = None) -> RaydampCall:
    """The model and arguments for raydamp.integrate; raises SpecError for a bad model, system or parameter.
    files(id) opens an uploaded file (files.file_resolver); without it a {"file": id} matrix is refused."""
    model = _model(spec, files)
    options: dict[str, Any] = {"method": spec.method, "h": spec.step_size, "save_every": spec.save_every,
                               "work": spec.work}
    if spec.tableau is not None:
        options["tableau"] = spec.tableau if isinstance(spec.tableau, str) else spec.tableau.model_dump(
            exclude_none=True)
    if spec.composition is not None:
        options["composition"] = spec.composition
    if spec.n_steps is not None:
        options["n_steps"] = spec.n_steps
    if spec.t_end is not None:
        options["t_end"] = spec.t_end
    if spec.save_dofs is not None:
        options["save_dofs"] = list(spec.save_dofs)
    q0, p0 = _initial_state(spec, model)
    return RaydampCall(model, q0, p0, options)


def planned_steps(spec: JobSpec) -> int:
    """Steps the run will take, counted by raydamp itself (raises SpecError for a bad t_end)."""
    if spec.n_steps is not None:
        return spec.n_steps
    try:
        return raydamp.steps_for(spec.t_end, spec.step_size)[0]
    except ValueError as error:
        raise _translate(error, _FIELD_OF_ARGUMENT) from None


def check_spec(spec: JobSpec, settings: Settings, files: FileResolver | None = None) -> RaydampCall:
    """Every check a spec must pass before it is queued; raises SpecError naming the field."""
    if (spec.t_end is None) == (spec.n_steps is None):
        both = spec.t_end is not None
        raise SpecError(("n_steps",) if both else ("t_end",),
                        "give exactly one of t_end and n_steps" + (", not both" if both else ""))
    for name in ("q", "p"):
        values = getattr(spec.initial_state, name, ())
        if len(values) > settings.max_dim:
            raise SpecError(("initial_state", name), f"initial_state.{name} has {len(values)} components; "
                            f"this service accepts at most max_dim = {settings.max_dim}")
    for name, value in spec.parameters.items():
        if isinstance(value, list) and len(value) > settings.max_dim:
            raise SpecError(("parameters", name), f"parameters.{name} has {len(value)} components; "
                            f"this service accepts at most max_dim = {settings.max_dim}")

    steps = planned_steps(spec)
    if steps > settings.max_steps:
        field = "n_steps" if spec.n_steps is not None else "t_end"
        raise SpecError((field,), f"{field}: the run would take {steps} steps; this service runs at most "
                        f"max_steps = {settings.max_steps} (raise step_size or shorten the run)")
    if not math.isfinite(spec.step_size * steps):
        raise SpecError(("step_size",), f"step_size: {steps} steps of {spec.step_size} end beyond the largest "
                        "float, so the times would not be finite; lower step_size or the number of steps")
    saved_points = steps // spec.save_every + 2
    if saved_points > settings.max_saved_points:
        raise SpecError(("save_every",), f"save_every: {saved_points} saved points (n_steps // save_every + 2) "
                        f"exceed max_saved_points = {settings.max_saved_points}; raise save_every")

    if isinstance(spec.system, LinearStructureInput):
        _check_structure_size(spec.system, settings)
    call = build_call(spec, files)
    # The largest stored array is q or p: saved_points x dim float64.
    saved = call.model.dim if spec.save_dofs is None else len(spec.save_dofs)
    largest = saved_points * max(saved, len(call.model.momentum_names)) * 8
    if largest > settings.max_trajectory_bytes:
        raise SpecError(("save_every",), f"save_every: the trajectory would take {largest / 2**20:.0f} MiB per "
                        f"array (limit {settings.max_trajectory_bytes / 2**20:.0f} MiB); raise save_every")
    # One step validates method, tableau, their fit with the model, step_size and the initial state
    # the way the real run will, in microseconds.
    try:
        call.run(n_steps=1, t_end=None)
    except raydamp.SpecError as error:  # a system's function is not finite at q0
        raise _system_error(error) from None
    except ValueError as error:
        raise _translate(error, _FIELD_OF_ARGUMENT) from None
    return call
