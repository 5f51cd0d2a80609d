"""The catalogue of methods and Butcher tableaux, read from the compiled core."""

from __future__ import annotations

from typing import NamedTuple

from . import _core

__all__ = ["MethodInfo", "TableauInfo", "methods", "tableaux"]


class MethodInfo(NamedTuple):
    """One usable (method, tableau) pair; tableau is None for pure splittings."""

    name: str
    tableau: str | None
    order: int
    explicit: bool
    default: bool
    damped: bool
    description: str


class TableauInfo(NamedTuple):
    name: str
    stages: int
    order: int
    kind: str
    a: list[list[float]]
    b: list[float]
    c: list[float]


def methods() -> list[MethodInfo]:
    """Every method with its (global) order and whether it is explicit.

    Methods taking a Runge-Kutta tableau ('rks', 'rksb') are listed once per
    tableau they accept; ``default`` marks the one used when ``tableau=None``;
    ``damped`` is False for 'sv', which refuses models with eps > 0.
    Orders are computed from the tableau's order conditions, not typed in.
    """
    return [MethodInfo(**{k: row[k] for k in MethodInfo._fields}) for row in _core.methods()]


def tableaux() -> list[TableauInfo]:
    """The Butcher tableaux raydamp ships, with their computed orders."""
    return [TableauInfo(**row) for row in _core.tableaux()]
