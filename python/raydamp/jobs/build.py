"""From a job's JSON to a raydamp call: parsing (pydantic, errors named by JSON path) and building
(the model, the initial state and integrate's keyword arguments).

The library owns the rules (which methods take which tableau, each model's parameters and
dimension); a service adds only its own limits. Names are the same in JSON and Python (h, method,
tableau, ...), so an error from raydamp.integrate names its JSON field by its first word; the
initial state is the one structured field (integrate's q0 and p0 are initial_state.q and .p).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from pydantic import ValidationError

from .. import _core
from .._validation import span
from ..loads import GroundMotion, Load
from ..loads.forms import plain_json
from .errors import JobError, head_path
from .forms import ModeState, RestState, VectorFile
from .spec import JobSpec, ModelSpec, client_path
from .system_forms import FileResolver

__all__ = ["JobCall", "unique_keys", "parse_job", "build_job", "planned_steps", "job_arguments", "model_from_spec",
           "error_at", "validation_error", "PROVENANCE_KEYS"]

# What a Solution's provenance adds to the job (a saved result's provenance runs as a job).
PROVENANCE_KEYS = ("raydamp_version", "job_id", "coordinates", "momentum_names", "method_reason")
_STATE_ARGUMENTS = {"q0": ("initial_state", "q"), "p0": ("initial_state", "p")}


@dataclass(frozen=True)
class JobCall:
    """raydamp.integrate(model, q0, p0, **options): what a job runs."""

    model: Any
    q0: Any
    p0: Any
    options: dict[str, Any] = field(default_factory=dict)


def _path_text(loc: tuple) -> str:
    text = ""
    for part in loc:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text


def validation_error(error: ValidationError) -> JobError:
    """pydantic's first error as a JobError: its loc the path the client wrote, its message in our words."""
    # The deepest error: of a union's tries (tableau: a name or a table), the one about the value's own form.
    item = max(error.errors(), key=lambda e: len(client_path(e["loc"])))
    loc = client_path(item["loc"])
    message = item["msg"].removeprefix("Value error, ")
    if item["type"] == "missing":
        message = "missing"
    elif item["type"] == "extra_forbidden":
        message = "unknown key"
    return JobError(loc, f"{_path_text(loc) or 'job'}: {message}")


def unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """json.loads' object_pairs_hook for a job's JSON (a file for `raydamp run`, a service request body): a key
    named twice in one object is a ValueError. JSON itself keeps the last silently: {"h": 0.1, "h": 10} ran at
    h = 10, where an unknown key is refused."""
    seen: dict[str, Any] = {}
    for key, value in pairs:
        if key in seen:
            raise ValueError(f"the key {key!r} appears twice in one object")
        seen[key] = value
    return seen


def parse_job(data: Any) -> JobSpec:
    """The validated job; raises JobError (a ValueError) naming the JSON path of the first bad field.
    A Solution's provenance parses too: its own keys (raydamp_version, coordinates ...) are set aside."""
    if isinstance(data, Mapping):
        data = {k: v for k, v in data.items() if k not in PROVENANCE_KEYS}
    try:
        return JobSpec.model_validate(plain_json(data))
    except ValidationError as error:
        raise validation_error(error) from None


def _initial_state(spec: JobSpec, model, files: FileResolver | None = None) -> tuple[Any, Any]:
    state = spec.initial_state
    if isinstance(state, RestState):
        return np.zeros(model.dim), np.zeros(model.dim)
    if isinstance(state, ModeState):
        if not hasattr(model, "normal_mode"):
            raise JobError(("initial_state",), "initial_state: {mode, amplitude} starts a chain; give q and p")
        try:
            return model.normal_mode(state.mode, state.amplitude)
        except ValueError as error:
            raise JobError(("initial_state", "mode"), f"initial_state.{error}") from None
    vectors = {}
    for name in ("q", "p"):
        values = getattr(state, name)
        if isinstance(values, VectorFile):
            values = _vector_file(values.file, ("initial_state", name, "file"), files)
        if len(values) != model.dim:
            raise JobError(("initial_state", name), f"initial_state.{name} has length {len(values)}, but the model "
                           f"has {model.dim} coordinates ({_coordinates(model)})")
        vectors[name] = values if isinstance(values, np.ndarray) else list(values)
    return vectors["q"], vectors["p"]


def _coordinates(model, shown: int = 6) -> str:
    names = list(model.coordinates[:shown + 1])
    return ", ".join(names[:shown]) + (", ..." if len(names) > shown else "")


def _vector_file(file_id: str, loc: tuple, files: FileResolver | None) -> np.ndarray:
    """The vector of an uploaded one-column file (files(id) gives its parsed (None, values))."""
    where = ".".join(loc)
    if files is None:
        raise JobError(loc, f"{where}: uploaded files are a service's (POST /v1/files); give the numbers inline")
    try:
        record = files(file_id)
    except ValueError as error:
        raise JobError(loc, f"{where}: {error}") from None
    if not isinstance(record, tuple):
        raise JobError(loc, f"{where}: file {file_id} is a matrix (Matrix Market); a vector is a file of one column "
                            "of numbers (.npy of shape (n,), or text with one number a line)")
    t, values = record
    if t is not None:
        raise JobError(loc, f"{where}: file {file_id} holds two columns (times and values); a vector is one column "
                            "of numbers")
    return np.asarray(values, dtype=float)


def build_job(spec: JobSpec, files: FileResolver | None = None) -> JobCall:
    """The model and arguments of raydamp.integrate; raises JobError for a bad model, system, parameter
    or span. files(id) opens an uploaded matrix file; without it a {"file": id} matrix is refused."""
    planned_steps(spec)  # the span first: a job without one is refused before its model is built
    model = spec.build_model(files)
    options: dict[str, Any] = {"method": spec.method, "h": spec.h, "save_every": spec.save_every, "work": spec.work}
    if spec.tableau is not None:
        options["tableau"] = spec.tableau if isinstance(spec.tableau, str) else spec.tableau.model_dump(
            exclude_none=True)
    for key in ("composition", "n_steps", "t_end"):
        if getattr(spec, key) is not None:
            options[key] = getattr(spec, key)
    if spec.save_dofs is not None:
        options["save_dofs"] = list(spec.save_dofs)
    if spec.divergence != _core.DEFAULT_DIVERGENCE:
        options["divergence"] = spec.divergence
    if spec.events:
        options["events"] = [e.model_dump(exclude_none=True) for e in spec.events]
    if spec.dense:
        options["dense"] = True
    if spec.envelope:
        options["envelope"] = list(spec.envelope)
    if spec.collapse is not None:
        options["collapse"] = spec.collapse
    if spec.corrector is not None:
        options["corrector"] = spec.corrector
    if spec.temperature:
        options.update({"temperature": spec.temperature, "seed": spec.seed, "stream": spec.stream})
    load = job_load(spec, files)
    if load is not None:
        options["load"] = load
    q0, p0 = _initial_state(spec, model, files)
    return JobCall(model, q0, p0, options)


def planned_steps(spec: JobSpec) -> int:
    """The number of steps the job's run takes, counted as raydamp.integrate counts them (one t_end or
    n_steps, with h); a JobError names t_end, n_steps or the step size by the key the client gave."""
    try:
        return span(spec.h, spec.t_end, spec.n_steps)[0]
    except ValueError as error:
        raise error_at(spec, error) from None


def job_load(spec: JobSpec, files: FileResolver | None = None):
    """The job's load (its "load" plus its "ground_motion"), or None; a JobError names the path."""
    try:
        parts = [kind.from_form(form, files, name) for kind, name, form in (
            (Load, "load", spec.load), (GroundMotion, "ground_motion", spec.ground_motion)) if form is not None]
    except ValueError as error:
        raise JobError(head_path(str(error)), str(error)) from None
    return sum(parts) if parts else None


def load_from(load: Any, ground_motion: Any, files: FileResolver | None = None):
    """The load of a job's "load" and "ground_motion" JSON (either may be None), or None; a ValueError names
    the path."""
    parts = []
    if load is not None:
        parts.append(Load.from_dict(load, name="load", files=files))
    if ground_motion is not None:
        parts.append(GroundMotion.from_dict(ground_motion, files=files))
    return sum(parts) if parts else None


def error_at(spec: JobSpec, error: ValueError) -> JobError:
    """A ValueError of raydamp.integrate for this job's call, at the JSON path of the field it is about."""
    from ..systems.system import SpecError

    if isinstance(error, JobError):
        return error
    if isinstance(error, SpecError):  # a system's function is not finite at q0
        return JobError(("system", *error.path), f"system.{error}")
    message = str(error)
    loc = head_path(message) or ("",)
    head, rest = loc[0], message[len(str(loc[0])):]
    if head in _STATE_ARGUMENTS:
        return JobError((*_STATE_ARGUMENTS[head], *loc[1:]), ".".join(_STATE_ARGUMENTS[head]) + rest)
    if head == "h":
        return JobError((spec.h_key,), spec.h_key + rest)
    return JobError(loc if head in JobSpec.model_fields else (), message)


def model_from_spec(spec: Any, files: FileResolver | None = None):
    """The model of {"model": name, "parameters": {...}} or {"system": {...}} (raydamp.systems.kinds.
    describe_model's form); a JobError names the path."""
    if isinstance(spec, Mapping):  # None as "not given", as the job form's null
        spec = {key: value for key, value in spec.items() if value is not None}
    try:
        parsed = ModelSpec.model_validate(plain_json(spec))
    except ValidationError as error:
        raise validation_error(error) from None
    return parsed.build_model(files)


def job_arguments(data: Any, files: FileResolver | None = None) -> tuple[Any, Any, Any, dict[str, Any]]:
    """(model, q0, p0, keyword arguments of raydamp.integrate) for a job's JSON (or a Solution's
    provenance); raises a ValueError whose message starts with the JSON path of the bad field."""
    call = build_job(parse_job(data), files)
    return call.model, call.q0, call.p0, call.options
