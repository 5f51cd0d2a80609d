"""The base every JSON form of raydamp is built on: strict, closed inputs, finite numbers and lists
bounded by their length before their items are read. Loads use it here, jobs and systems above.

Inputs are strict and closed: extra="forbid" names a misspelt field rather than ignoring it, and
strict mode refuses "0.2" as a number and true as 1. Bounds sit in the types so that an oversized
list fails at parsing, before any work.
"""

from __future__ import annotations

import functools
import re
from itertools import islice
from typing import Annotated, Any

import numpy as np
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, model_validator
from pydantic_core import PydanticKnownError

__all__ = ["Input", "FiniteFloat", "Vector", "bounded", "at_most", "numbers", "indices", "MAX_ITEM_ERRORS",
           "MAX_VECTOR", "FILE_ID", "FileId"]

# JSON parsing accepts NaN and Infinity (and 1e999 overflows to inf); no run may start from them.
FiniteFloat = Annotated[float, Field(allow_inf_nan=False)]
# The longest vector any job may carry (a service's max_dim is at most this, and usually lower). In the
# schema, so that a list of 200,000 bad items is one error found at once, not 200,000 found one by one.
MAX_VECTOR = 10_000
MAX_ITEM_ERRORS = 20  # a list with more bad items gets one error naming the first of them
_SMALL = 1000  # lists this short are checked by pydantic alone (1000 errors cost about a millisecond)


def _too_long(value: list, max_length: int) -> PydanticKnownError:
    # pydantic's own error (type too_long, its words), raised before the items are looked at
    return PydanticKnownError("too_long", {"field_type": "List", "max_length": max_length,
                                           "actual_length": len(value)})


def at_most(max_length: int) -> BeforeValidator:
    """A list's length checked before its items. Pydantic validates a list's items as it counts them, so
    500,000 bad items cost 500,000 error objects before the list is found too long (issue 44, N2)."""

    def check(value: Any) -> Any:
        if isinstance(value, list) and len(value) > max_length:
            raise _too_long(value, max_length)
        return value

    return BeforeValidator(check)


def bounded(item: Any, max_length: int, *, min_length: int = 0, items: BeforeValidator | None = None) -> Any:
    """list[item] of at most max_length items, its length checked first (at_most, or the items' own check,
    numbers or indices, which checks it too); maxItems in the JSON Schema."""
    first = items if items is not None else at_most(max_length)
    length = Field(max_length=max_length, **({"min_length": min_length} if min_length else {}))
    return Annotated[list[item], length, first]


def _few_bad(what: str, allowed: tuple[type, ...], good: Any, max_length: int) -> BeforeValidator:
    """Validation whose cost is bounded by the list's length, not by its number of bad items.

    Pydantic checks a list item by item in compiled code, which is fast when they are good; each bad
    item costs an error object, so 666k bad indices took 10 s and 1.7 GB (issue 27, F2). This check runs
    first at NumPy speed: a list too long is one too_long error, a list with more than MAX_ITEM_ERRORS bad
    items one error naming the first of them; otherwise pydantic reports each bad item at its own path."""

    def check(value: Any) -> Any:
        if not isinstance(value, list):
            return value  # pydantic's own error
        if len(value) > max_length:
            raise _too_long(value, max_length)
        if len(value) <= _SMALL:
            return value  # at most _SMALL errors, pydantic's own, each at its item's path
        types = {type(item) for item in value}
        if types <= set(allowed):
            bad = np.flatnonzero(~good(np.asarray(value, dtype=float)))
        else:
            bad = np.array(list(islice((i for i, item in enumerate(value)
                                        if type(item) not in allowed or not good(np.array([float(item)]))[0]),
                                       MAX_ITEM_ERRORS + 1)))
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


Vector = bounded(FiniteFloat, MAX_VECTOR, items=numbers(MAX_VECTOR))


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
