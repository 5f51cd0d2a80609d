"""A user's Butcher tableau, ``tableau={"A": [[...]], "b": [...], "c": [...], "order": k}``.

The core validates it as it validates ours (each row of A sums to c, the weights are consistent)
and computes its order from the order conditions; here the shapes are checked with the path of
the bad entry, a claimed ``order`` is held to what the conditions give, and the core's errors
are named after the field. The core keeps the table under a name derived from its coefficients
("custom-<16 hex digits>"), which is what a run passes on.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from .. import _core
from .._validation import _short, integer

__all__ = ["MAX_STAGES", "MAX_CHECKED_ORDER", "resolve_user_tableau", "plain_tableau"]

MAX_STAGES = 16
MAX_CHECKED_ORDER = 4  # the order conditions the core checks (all rooted trees up to order 4)
_KEYS = ("A", "b", "c", "order")


def _row(path: str, value: Any, length: int | None) -> list[float]:
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, (list, tuple)):
        raise ValueError(f"{path} must be a list of numbers, got {_short(value)}")
    out = []
    for i, entry in enumerate(value):
        if isinstance(entry, (bool, np.bool_)) or not isinstance(entry, (int, float, np.integer, np.floating)):
            raise ValueError(f"{path}[{i}] must be a number, got {_short(entry)}")
        if not np.isfinite(float(entry)):
            raise ValueError(f"{path}[{i}] must be finite, got {float(entry)!r}")
        out.append(float(entry))
    if length is not None and len(out) != length:
        raise ValueError(f"{path} must have {length} entries (the number of stages), got {len(out)}")
    return out


def _stages(tableau: Mapping[str, Any]) -> int:
    """The number of stages: what two of len(A), len(b), len(c) agree on, else len(b). It was len(b) alone: a b
    shorter than A and c was reported as a c too long."""
    lengths = [len(tableau[key]) for key in ("b", "A", "c") if isinstance(tableau[key], (list, tuple, np.ndarray))]
    return max(lengths, key=lengths.count) if lengths else 0


def plain_tableau(tableau: Mapping[str, Any]) -> dict[str, Any]:
    """The tableau as plain lists (for provenance and JSON), checked for shape and finite entries."""
    unknown = [key for key in tableau if key not in _KEYS]
    if unknown:
        raise ValueError(f"tableau.{unknown[0]}: unknown key (a tableau has A, b, c and optionally order)")
    for key in ("A", "b", "c"):
        if key not in tableau:
            raise ValueError(f"tableau.{key}: missing (a tableau has A, b, c and optionally order)")
    b = _row("tableau.b", tableau["b"], None)
    if not 1 <= len(b) <= MAX_STAGES:
        raise ValueError(f"tableau.b must have 1 to {MAX_STAGES} weights, got {len(b)}")
    s = _stages(tableau)
    if len(b) != s:
        raise ValueError(f"tableau.b must have {s} weights (the number of stages: the rows of A and the entries "
                         f"of c), got {len(b)}")
    c = _row("tableau.c", tableau["c"], s)
    rows = tableau["A"]
    if isinstance(rows, np.ndarray):
        rows = rows.tolist()
    if not isinstance(rows, (list, tuple)) or len(rows) != s:
        raise ValueError(f"tableau.A must be {s} rows of {s} numbers (s = the number of stages), got {_short(rows)}")
    a = [_row(f"tableau.A[{i}]", row, s) for i, row in enumerate(rows)]
    plain: dict[str, Any] = {"A": a, "b": b, "c": c}
    if tableau.get("order") is not None:
        plain["order"] = integer("tableau.order", tableau["order"], minimum=1)
    return plain


def resolve_user_tableau(tableau: Mapping[str, Any]) -> tuple[str, dict[str, Any]]:
    """(the core's name for it, its plain form); ValueError naming the field otherwise."""
    plain = plain_tableau(tableau)
    try:
        info = _core.define_tableau(plain["A"], plain["b"], plain["c"])
    except ValueError as error:  # "tableau: row 1 of a does not sum to c[1]"
        message = str(error).replace("of a does", "of A does")
        raise ValueError(message) from None
    claimed = plain.get("order")
    if claimed is not None:
        if claimed > MAX_CHECKED_ORDER:
            raise ValueError(f"tableau.order: raydamp checks the order conditions up to order {MAX_CHECKED_ORDER}, "
                             f"so it cannot confirm order {claimed}; leave order out (the tableau then counts as "
                             f"order {info['order']})")
        if info["order"] < claimed:
            raise ValueError(f"tableau.order: the tableau satisfies the order conditions up to order "
                             f"{info['order']}, not {claimed}")
    return info["name"], plain
