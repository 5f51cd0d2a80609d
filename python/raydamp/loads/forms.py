"""A load and a ground motion as JSON: the typed forms that Load.to_dict() writes, a job's "load" and
"ground_motion" hold and /openapi.json describes. Pydantic checks their shape (keys, types, sizes);
each form then builds its Load through the constructors of the class it is given (Load.from_form,
GroundMotion.from_form), which check what depends on the values (times increasing, lengths agreeing,
an expression's names).

    {"harmonic": {"amplitude": [...], "omega": w, "phase": 0}}
    {"series": {"t": [...], "values": [...], "direction": [...], "hold": false}}
    {"expression": {"expression": "F0*sin(w*t)", "parameters": {...}, "direction": [...]}}
    {"file": {"id": <upload> | "path": <file>, "direction": [...], "factor": 1, "dt": null, "hold": false}}
    {"terms": [one of the above, ...], "amplitude": a}
    ground motion: {"acceleration": a load without direction, "direction": r, "factor": 1}

A direction is a number, a vector, or {"ground": r} (a ground motion's -M r, as Load.to_dict writes it).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import replace
from functools import cache
from pathlib import Path
from typing import Annotated, Any

import numpy as np
from pydantic import Discriminator, Field, Tag, TypeAdapter, ValidationError, model_validator

from .._validation import _short, real
from . import terms as T
from .inputs import FiniteFloat, Input, bounded, numbers

__all__ = ["LoadInput", "GroundMotionInput", "LOAD_TAGS", "MAX_SERIES", "MAX_TERMS", "MAX_DIRECTION", "plain_json",
           "load_input", "ground_motion_input", "without_tags"]

# Samples of a series: Load.to_dict writes a record's (a sweep's workers and a result's provenance read it back),
# so past any record's samples limit (raydamp.loads.records); a service's body limit binds long before.
MAX_SERIES = 10**8
MAX_DIRECTION = 10**7  # coordinates of a direction (a structure's, raydamp.jobs.MAX_STRUCTURE_DIM)
MAX_TERMS = 256
_MAX_PARAMETERS = 64
_Name = Annotated[str, Field(min_length=1, max_length=100, pattern=r"^[A-Za-z_][A-Za-z0-9_]*$")]
_Times = bounded(FiniteFloat, MAX_SERIES, min_length=1, items=numbers(MAX_SERIES))
_Row = bounded(FiniteFloat, MAX_DIRECTION, min_length=1, items=numbers(MAX_DIRECTION))
FileResolver = Callable[[str], Any]


class GroundDirection(Input):
    """-M r: the direction of a ground motion's force, r its influence vector (Load.to_dict writes it)."""

    ground: _Row


def _direction_form(value: object) -> str:
    if isinstance(value, (dict, GroundDirection)):
        return "ground direction"
    return "vector direction" if isinstance(value, list) else "number direction"


Direction = Annotated[Annotated[FiniteFloat, Tag("number direction")] | Annotated[_Row, Tag("vector direction")]
                      | Annotated[GroundDirection, Tag("ground direction")], Discriminator(_direction_form)]
_DIRECTION = "a vector over the coordinates (a number for a model of one coordinate)"


def _values_form(value: object) -> str:
    return "vector history" if isinstance(value, list) and value and isinstance(value[0], list) else "scalar history"


History = Annotated[Annotated[_Times, Tag("scalar history")]
                    | Annotated[bounded(_Row, MAX_SERIES, min_length=1), Tag("vector history")],
                    Discriminator(_values_form)]


def _direction(value: Any, where: str) -> Any:
    """A direction in the Load's terms (T.direction's array, or T.Ground)."""
    if isinstance(value, GroundDirection):
        return T.Ground(T.direction(where + ".ground", value.ground))
    return T.direction(where, value)


class HarmonicBody(Input):
    amplitude: Direction = Field(description="the amplitude vector: f(t) = amplitude sin(omega t + phase)")
    omega: FiniteFloat = Field(description="the angular frequency")
    phase: FiniteFloat = 0.0
    scale: FiniteFloat = Field(1.0, description="a factor on the term (Load.to_dict writes it)")
    t_end: FiniteFloat | None = Field(None, description="the term acts for t <= t_end and is 0 after (a pulse); "
                                                        "null: it never ends")

    def load(self, where: str, files: FileResolver | None, Load: type):
        return Load([T.Harmonic(_direction(self.amplitude, f"{where}.amplitude"), real(f"{where}.omega", self.omega),
                                T.phase_value(self.phase), t_end=T.end_time(f"{where}.t_end", self.t_end))])


class SeriesBody(Input):
    t: _Times = Field(description="the sample times, increasing")
    values: History = Field(description="a scalar history (one value a time, times direction) or a vector per time "
                                        "(rows of n values, no direction)")
    direction: Direction | None = Field(None, description=_DIRECTION)
    hold: bool = Field(False, description="outside [t[0], t[-1]]: the end values (true) or zero (false)")
    scale: FiniteFloat = 1.0

    def load(self, where: str, files: FileResolver | None, Load: type):
        load = Load.series(self.t, self.values, None, hold=self.hold)
        return Load([replace(load.terms[0], direction=_direction(self.direction, f"{where}.direction"))])


class ExpressionBody(Input):
    expression: Annotated[str, Field(min_length=1, max_length=10_000)] = Field(
        description="s(t): an expression of t and the parameters, in raydamp's expression language")
    parameters: dict[_Name, FiniteFloat] = Field(default_factory=dict, max_length=_MAX_PARAMETERS)
    direction: Direction | None = Field(None, description=_DIRECTION)
    scale: FiniteFloat = 1.0

    def load(self, where: str, files: FileResolver | None, Load: type):
        load = Load.expression(self.expression, self.parameters, None)
        return Load([replace(load.terms[0], direction=_direction(self.direction, f"{where}.direction"))])


class FileBody(Input):
    # Any name the caller's files(id) knows (Load.from_dict's); a service's are FileId's (JobSpec.uploads)
    id: Annotated[str, Field(min_length=1, max_length=4096)] | None = Field(
        None, description="an uploaded record's id (POST /v1/files): .AT2, CSV or .npy")
    path: Annotated[str, Field(min_length=1, max_length=4096)] | None = Field(
        None, description="outside a service (raydamp run): the record's path; a service reads no paths")
    direction: Direction | None = Field(None, description=_DIRECTION)
    factor: FiniteFloat = Field(1.0, description="a factor on the values (9.81 turns g into m/s^2)")
    dt: FiniteFloat | None = Field(None, description="the sample interval of a record of one column of values")
    hold: bool = False

    @model_validator(mode="after")
    def _one_source(self) -> FileBody:
        if (self.path is None) == (self.id is None):
            raise ValueError("give exactly one of path and id")
        return self

    def load(self, where: str, files: FileResolver | None, Load: type):
        if self.path is not None:
            if files is not None:
                raise ValueError(f"{where}.path: the service reads no paths; upload the file (POST /v1/files) and "
                                 "give its id")
            load = Load.from_file(self.path, None, self.factor, dt=self.dt, hold=self.hold)
        else:
            if files is None:
                raise ValueError(f"{where}.id: uploaded files are the service's (POST /v1/files)")
            try:
                record = files(self.id)  # a path, or the parsed (t, values): t None for one column
            except ValueError as error:
                raise ValueError(f"{where}.id: {error}") from None
            if isinstance(record, tuple):
                t, values = _record_times(record, self.dt, f"{where}.dt", self.id)
                load = Load.series(t, values, hold=self.hold) * real(f"{where}.factor", self.factor)
                load = Load(load._scaled_terms())
            elif isinstance(record, (str, Path)):
                load = Load.from_file(record, None, self.factor, dt=self.dt, hold=self.hold)
            else:
                raise ValueError(f"{where}.id: file {self.id} is a matrix (Matrix Market), not a record; upload a "
                                 ".AT2, CSV or .npy record")
        return Load([replace(load.terms[0], direction=_direction(self.direction, f"{where}.direction"))])


def _record_times(record, dt, name: str, file_id) -> tuple[np.ndarray, np.ndarray]:
    """An uploaded record's (t, values): its own times, or one column of values sampled at dt from t = 0."""
    t, values = record
    if t is None and dt is None:
        raise ValueError(f"{name}: file {file_id} holds one column of values (no times); give dt, their sample "
                         "interval")
    if t is not None and dt is not None:
        raise ValueError(f"{name}: file {file_id} has a time column, so dt must not be given")
    if t is None:
        t = np.arange(len(values)) * real(name, dt, positive=True)
    return t, values


class _Term(Input):
    """A load of one term: its one key names the form, its value is the form's body."""

    def body(self) -> tuple[str, Any]:
        name = next(iter(type(self).model_fields))
        return name, getattr(self, name)

    def build(self, Load: type, files: FileResolver | None = None, name: str = "load"):
        kind, body = self.body()
        where = f"{name}.{kind}"
        try:
            load = body.load(where, files, Load)
        except ValueError as error:
            text = str(error)
            raise ValueError(text if text.startswith(name) else f"{where}.{text}") from None
        scale = getattr(body, "scale", 1.0)  # a file's term has its factor instead
        return load if scale == 1.0 else Load([T.scaled(load.terms[0], scale)])

    def files(self, at: tuple) -> Iterator[tuple[tuple, str, str]]:
        """(JSON path, "id" or "path", the id or path) of the file this term reads."""
        kind, body = self.body()
        if isinstance(body, FileBody):
            source = "id" if body.id is not None else "path"
            yield (*at, kind, source), source, getattr(body, source)

    def compiles(self) -> bool:
        return isinstance(self.body()[1], ExpressionBody)


class HarmonicLoad(_Term):
    harmonic: HarmonicBody


class SeriesLoad(_Term):
    series: SeriesBody


class ExpressionLoad(_Term):
    expression: ExpressionBody


class FileLoad(_Term):
    file: FileBody


_FORMS = {"harmonic": HarmonicLoad, "series": SeriesLoad, "expression": ExpressionLoad, "file": FileLoad}
_FORMS_TEXT = ('a load is {"harmonic": {...}}, {"series": {...}}, {"expression": {...}}, {"file": {...}} or '
               '{"terms": [...], "amplitude": a}')


def _term_form(value: object) -> str | None:
    if isinstance(value, dict):
        return next((f"{key} load" for key in value if key in _FORMS), None)
    return next((f"{key} load" for key, form in _FORMS.items() if isinstance(value, form)), None)


Term = Annotated[Annotated[HarmonicLoad, Tag("harmonic load")] | Annotated[SeriesLoad, Tag("series load")]
                 | Annotated[ExpressionLoad, Tag("expression load")] | Annotated[FileLoad, Tag("file load")],
                 Discriminator(_term_form, custom_error_type="load_form",
                               custom_error_message=_FORMS_TEXT.replace(' or {"terms": [...], "amplitude": a}', ""))]


class TermsLoad(Input):
    """A sum of terms, times amplitude (Load.to_dict's form)."""

    terms: bounded(Term, MAX_TERMS) = Field(description="the terms, each a load of one form")
    amplitude: FiniteFloat = Field(1.0, description="a factor on the whole load (a sweep's load.amplitude)")

    def build(self, Load: type, files: FileResolver | None = None, name: str = "load"):
        terms = [part for i, term in enumerate(self.terms)
                 for part in term.build(Load, files, f"{name}.terms[{i}]").terms]
        return Load(terms, self.amplitude)

    def files(self, at: tuple) -> Iterator[tuple[tuple, str, str]]:
        for i, term in enumerate(self.terms):
            yield from term.files((*at, "terms", i))

    def compiles(self) -> bool:
        return any(term.compiles() for term in self.terms)


def _load_form(value: object) -> str | None:
    if isinstance(value, (dict, TermsLoad)) and (isinstance(value, TermsLoad) or "terms" in value):
        return "terms load"
    return _term_form(value)


LoadInput = Annotated[Annotated[HarmonicLoad, Tag("harmonic load")] | Annotated[SeriesLoad, Tag("series load")]
                      | Annotated[ExpressionLoad, Tag("expression load")] | Annotated[FileLoad, Tag("file load")]
                      | Annotated[TermsLoad, Tag("terms load")],
                      Discriminator(_load_form, custom_error_type="load_form", custom_error_message=_FORMS_TEXT)]


class GroundMotionInput(Input):
    """Uniform base excitation (raydamp.GroundMotion): the ground accelerates by a_g(t) along r; the load is
    -M r a_g(t) and the result is the motion relative to the ground."""

    acceleration: LoadInput = Field(description="a_g(t): a load without direction (series, file, harmonic with a "
                                                "scalar amplitude, expression)")
    direction: Annotated[Annotated[FiniteFloat, Tag("number direction")] | Annotated[_Row, Tag("vector direction")],
                         Discriminator(_direction_form)] = Field(description="r, the influence vector")
    factor: FiniteFloat = Field(1.0, description="a factor on a_g (9.81 turns g into m/s^2)")

    def build(self, GroundMotion: type, Load: type, files: FileResolver | None = None, name: str = "ground_motion"):
        acceleration = self.acceleration.build(Load, files, f"{name}.acceleration")
        try:
            return GroundMotion(acceleration, self.direction, factor=self.factor)
        except ValueError as error:
            text = str(error)
            raise ValueError(text if text.startswith(name) else f"{name}.{text}") from None

    def files(self, at: tuple) -> Iterator[tuple[tuple, str, str]]:
        return self.acceleration.files((*at, "acceleration"))

    def compiles(self) -> bool:
        return self.acceleration.compiles()


LOAD_TAGS = frozenset({"harmonic load", "series load", "expression load", "file load", "terms load",
                       "number direction", "vector direction", "ground direction", "scalar history",
                       "vector history"})


def without_tags(loc: tuple | list) -> tuple:
    """A loc inside a load as the client wrote it: without the tags of the forms (their names hold a space,
    which no key of a load has)."""
    return tuple(part for part in loc if part not in LOAD_TAGS)


def plain_json(value: Any) -> Any:
    """JSON's types (lists, floats, ints) for what Python callers pass: tuples, NumPy arrays and scalars."""
    if isinstance(value, Mapping):
        return {k: plain_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain_json(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


@cache
def _adapter(kind: str) -> TypeAdapter:
    return TypeAdapter(LoadInput if kind == "load" else GroundMotionInput)


def _parsed(kind: str, plain: Any, name: str) -> Any:
    """The typed form of a load's JSON; a ValueError starting with the path of the first bad field."""
    try:
        return _adapter(kind).validate_python(plain_json(plain))
    except ValidationError as error:
        raise ValueError(_first_error(error, name)) from None


def _first_error(error: ValidationError, name: str) -> str:
    # The deepest error (of a union's tries, the one about the value's own form); of a misspelt key's two
    # errors, the unknown key's.
    item = max(error.errors(), key=lambda e: (len(without_tags(e["loc"])), e["type"] == "extra_forbidden"))
    path = name
    for part in without_tags(item["loc"]):
        path += f"[{part}]" if isinstance(part, int) else f".{part}"
    if item["type"] in ("float_type", "float_parsing"):
        return f"{path} must be a real number, got {_short(item['input'])}"
    if item["type"] == "finite_number":
        return f"{path} must be finite, got {item['input']!r}"
    message = {"missing": "missing", "extra_forbidden": "unknown key"}.get(item["type"], item["msg"])
    return f"{path}: {message.removeprefix('Value error, ')}"


def load_input(plain: Any, name: str = "load") -> Any:
    """The typed form (LoadInput) of a load's JSON; a ValueError names the path."""
    return _parsed("load", plain, name)


def ground_motion_input(plain: Any, name: str = "ground_motion") -> GroundMotionInput:
    """The typed form of a ground motion's JSON; a ValueError names the path."""
    return _parsed("ground_motion", plain, name)
