"""The small forms a job is made of: numbers, vectors, initial states and a user's tableau, on the
base every JSON form shares (raydamp.loads.inputs: strict, closed, lists bounded before their items)."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import Discriminator, Field, Tag, model_validator

from ..loads.inputs import (
    FILE_ID,
    MAX_ITEM_ERRORS,
    MAX_VECTOR,
    FileId,
    FiniteFloat,
    Input,
    Vector,
    at_most,
    bounded,
    indices,
    numbers,
)

__all__ = ["Input", "FiniteFloat", "Vector", "bounded", "at_most", "numbers", "indices", "MAX_ITEM_ERRORS",
           "InitialState", "ModeState", "RestState", "TableauInput", "MAX_VECTOR", "MAX_CHAIN_SITES", "MAX_EXPRESSION",
           "Expression", "Name", "FileId", "FILE_ID", "MatrixFile", "VectorFile", "STATE_VECTOR_TAGS"]

MAX_CHAIN_SITES = 10**7  # a chain's state is built from its description, not sent
MAX_EXPRESSION = 10_000
Expression = Annotated[str, Field(min_length=1, max_length=MAX_EXPRESSION)]
Name = Annotated[str, Field(min_length=1, max_length=100, pattern=r"^[A-Za-z_][A-Za-z0-9_]*$")]


# A structure's matrix file: an upload's id, or (a run outside a service: raydamp run) a Matrix Market path.
MatrixFile = Annotated[str, Field(min_length=1, max_length=4096, description="an id from POST /v1/files; "
                                  "outside the service (raydamp run), a Matrix Market file's path")]


class VectorFile(Input):
    """A vector too long to send inline: an uploaded file of one column of n numbers (a .npy array of
    shape (n,), or text with one number a line), named by its id (a service's POST /v1/files)."""

    file: FileId


def _vector_form(value: object) -> str:
    return "file form" if isinstance(value, (dict, VectorFile)) else "numbers form"


_Numbers = bounded(FiniteFloat, MAX_VECTOR, min_length=1, items=numbers(MAX_VECTOR))
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
_Coefficients = bounded(FiniteFloat, _MAX_STAGES, min_length=1)


class TableauInput(Input):
    """Your own Butcher tableau: each row of A sums to c; the order is computed from the order
    conditions (up to 4) and a claimed order must hold. rks takes diagonally implicit tableaux,
    rksb and rk explicit ones."""

    A: bounded(_Coefficients, _MAX_STAGES, min_length=1) = Field(description="s rows of s coefficients")
    b: _Coefficients = Field(description="the s weights")
    c: _Coefficients = Field(description="the s nodes")
    order: int | None = Field(None, ge=1, description="the order you claim; checked against the order conditions")


