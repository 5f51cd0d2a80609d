"""The small forms a job is made of: numbers, vectors, initial states and a user's tableau.

Inputs are strict and closed: extra="forbid" names a misspelt field rather than ignoring it, and
strict mode refuses "0.2" as a number and true as 1. Bounds sit in the schema so that an oversized
list fails at parsing, before any work.
"""

from __future__ import annotations

import functools
import re

from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, BeforeValidator, ConfigDict, Discriminator, Field, Tag, model_validator

__all__ = ["Input", "FiniteFloat", "Vector", "numbers", "indices", "MAX_ITEM_ERRORS", "InitialState", "ModeState", "RestState", "TableauInput",
           "MAX_VECTOR", "MAX_CHAIN_SITES", "MAX_EXPRESSION", "Expression", "Name", "FileId", "FILE_ID", "MatrixFile", "VectorFile", "STATE_VECTOR_TAGS"]

# JSON parsing accepts NaN and Infinity (and 1e999 overflows to inf); no run may start from them.
FiniteFloat = Annotated[float, Field(allow_inf_nan=False)]
# The longest vector any job may carry (a service's max_dim is at most this, and usually lower). In the
# schema, so that a list of 200,000 bad items is one error found at once, not 200,000 found one by one.
MAX_VECTOR = 10_000
MAX_CHAIN_SITES = 10**7  # a chain's state is built from its description, not sent
MAX_EXPRESSION = 10_000
MAX_ITEM_ERRORS = 20  # a list with more bad items gets one error naming the first of them
_SMALL = 1000  # lists this short are checked by pydantic alone (1000 errors cost about a millisecond)


def _few_bad(what: str, allowed: tuple[type, ...], good: Any, max_length: int) -> BeforeValidator:
    """Validation whose cost is bounded by the list's length, not by its number of bad items.

    Pydantic checks a list item by item in compiled code, which is fast when they are good; each bad
    item costs an error object, so 666k bad indices took 10 s and 1.7 GB (issue 27, F2). This check runs
    first at NumPy speed: a list with more than MAX_ITEM_ERRORS bad items (or too long) becomes one
    error naming the first of them; otherwise pydantic reports each bad item at its own path."""

    def check(value: Any) -> Any:
        if not isinstance(value, list):
            return value  # pydantic's own error
        if len(value) > max_length or len(value) <= _SMALL:
            # too long: pydantic's one too_long error, found before any item is looked at; short: at most
            # _SMALL errors, pydantic's own, each at its item's path
            return value
        types = {type(item) for item in value}
        if types <= set(allowed):
            bad = np.flatnonzero(~good(np.asarray(value, dtype=float)))
        else:
            bad = np.array([i for i, item in enumerate(value)
                            if type(item) not in allowed or not good(np.array([float(item)]))[0]][:MAX_ITEM_ERRORS + 1])
        if bad.size > MAX_ITEM_ERRORS:
            first = ", ".join(map(str, bad[:MAX_ITEM_ERRORS].tolist()))
            raise ValueError(f"items {first} and more are not {what}")
        return value

    return BeforeValidator(check)


def numbers(max_length: int) -> BeforeValidator:
    """For a list of finite numbers of at most max_length items (ints count as numbers, as in JSON)."""
    return _few_bad("finite numbers", (int, float), np.isfinite, max_length)


def indices(max_length: int) -> BeforeValidator:
    """For a list of integers >= 0 of at most max_length items."""
    return _few_bad("integers >= 0", (int,), lambda a: a >= 0, max_length)


Vector = Annotated[list[FiniteFloat], Field(max_length=MAX_VECTOR), numbers(MAX_VECTOR)]
Expression = Annotated[str, Field(min_length=1, max_length=MAX_EXPRESSION)]
Name = Annotated[str, Field(min_length=1, max_length=100, pattern=r"^[A-Za-z_][A-Za-z0-9_]*$")]


class Input(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)

    @model_validator(mode="before")
    @classmethod
    def _few_unknown_keys(cls, data: Any) -> Any:
        # Each unknown key is an error of its own, built, converted and echoed one by one: a body of 160,000
        # of them held a service's event loop for 2 s. Past MAX_ITEM_ERRORS of them, one error says so.
        if isinstance(data, dict) and len(data) > MAX_ITEM_ERRORS:
            known = _known_keys(cls)
            unknown = [key for key in data if key not in known]
            if len(unknown) > MAX_ITEM_ERRORS:
                shown = ", ".join(repr(str(key)[:40]) for key in unknown[:3])
                raise ValueError(f"{len(unknown)} unknown keys ({shown}, ...)")
        return data


@functools.cache
def _known_keys(model: type[BaseModel]) -> frozenset[str]:
    """The keys a model takes: its fields' names and aliases."""
    keys = set(model.model_fields)
    for field in model.model_fields.values():
        for alias in (field.alias, field.validation_alias):
            choices = getattr(alias, "choices", [alias])
            keys.update(choice for choice in choices if isinstance(choice, str))
    return frozenset(keys)


FILE_ID = re.compile(r"^[0-9a-f]{32}$")
FileId = Annotated[str, Field(pattern=FILE_ID.pattern, description="an id from POST /v1/files")]
# A structure's matrix file: an upload's id, or (a run outside a service: raydamp run) a Matrix Market path.
MatrixFile = Annotated[str, Field(min_length=1, max_length=4096, description="an id from POST /v1/files; "
                                  "outside the service (raydamp run), a Matrix Market file's path")]


class VectorFile(Input):
    """A vector too long to send inline: an uploaded file of one column of n numbers (a .npy array of
    shape (n,), or text with one number a line), named by its id (a service's POST /v1/files)."""

    file: FileId


def _vector_form(value: object) -> str:
    return "file form" if isinstance(value, (dict, VectorFile)) else "numbers form"


_Numbers = Annotated[list[FiniteFloat], Field(min_length=1, max_length=MAX_VECTOR), numbers(MAX_VECTOR)]
# Inline numbers, or {"file": id}; the tags are dropped from a 422's loc (spec.client_path).
StateVector = Annotated[Annotated[_Numbers, Tag("numbers form")] | Annotated[VectorFile, Tag("file form")],
                        Discriminator(_vector_form)]
STATE_VECTOR_TAGS = frozenset({"numbers form", "file form"})


class InitialState(Input):
    q: StateVector = Field(description="initial positions, length = the model's dim: numbers, or {\"file\": id} "
                                       "of an uploaded one-column file (past the inline limit)")
    p: StateVector = Field(description="initial momenta, length = the model's dim: numbers, or {\"file\": id}")


class ModeState(Input):
    """A chain started at rest with all its energy in one normal mode (raydamp.Chain.normal_mode):
    a job for a million sites need not carry two million numbers."""

    mode: int = Field(ge=0, description="the mode number (fixed ends: 1..n)")
    amplitude: FiniteFloat = 1.0


class RestState(Input):
    """Start at rest at q = 0, p = 0: a structure's response to its load f, without sending 2 n zeros
    (so a structure may be larger than a service's max_dim)."""

    rest: Literal[True]

    @model_validator(mode="before")
    @classmethod
    def _exactly(cls, data: Any) -> Any:
        if data != {"rest": True} and not isinstance(data, RestState):
            raise ValueError('a start at rest is exactly {"rest": true}')
        return data


_MAX_STAGES = 16  # raydamp.user_tableau.MAX_STAGES
_Coefficients = Annotated[list[FiniteFloat], Field(min_length=1, max_length=_MAX_STAGES)]


class TableauInput(Input):
    """Your own Butcher tableau: each row of A sums to c; the order is computed from the order
    conditions (up to 4) and a claimed order must hold. rks takes diagonally implicit tableaux,
    rksb and rk explicit ones."""

    A: list[_Coefficients] = Field(min_length=1, max_length=_MAX_STAGES, description="s rows of s coefficients")
    b: _Coefficients = Field(description="the s weights")
    c: _Coefficients = Field(description="the s nodes")
    order: int | None = Field(None, ge=1, description="the order you claim; checked against the order conditions")


