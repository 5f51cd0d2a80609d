"""The catalogue of methods and Butcher tableaux, read from the compiled core."""

from __future__ import annotations

from typing import NamedTuple

from .. import _core

__all__ = ["MethodInfo", "TableauInfo", "CompositionInfo", "methods", "tableaux", "compositions",
           "linear_structure_methods", "structure_methods"]


class MethodInfo(NamedTuple):
    """One usable (method, tableau) pair; tableau is None for pure splittings."""

    name: str
    tableau: str | None
    order: int
    explicit: bool
    default: bool
    damped: bool
    description: str
    symmetric: bool = False


class CompositionInfo(NamedTuple):
    """A composition Psi_h = Phi_{gamma_m h} o ... o Phi_{gamma_1 h} of a symmetric step Phi, or a
    near-integrable table (``kind == "near_integrable"``: SABA_n, SBAB_n).

    A table steps a base drift, kick, drift (sv, 2s, or rks with tableau='midpoint') as
    drift(a_0 h) kick(b_1 h) drift(a_1 h) ... kick(b_n h) drift(a_n h): ``ends`` are the a_i,
    ``gammas`` the b_i and ``stages`` their count. Its ``order`` is 2, what it guarantees on any
    system; where the kick carries a small part eps B of H = A + eps B and the drift is A's exact flow
    (raydamp.Kepler, raydamp.Planets: the Kepler drift; the kick the interaction and, with 2s, the drag),
    its error is O(eps h^eps_order + eps^2 h^2).
    """

    name: str
    order: int
    stages: int
    gammas: list[float]
    reference: str
    kind: str = "composition"
    ends: list[float] = []
    eps_order: int = 2


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
    ``damped`` is False for 'sv', which refuses models with eps > 0;
    ``symmetric`` marks the symmetric order-2 steps a composition can raise to
    higher order (see :func:`compositions`): 'gauss4' is symmetric (time-reversible)
    too, but of order 4, which none of the compositions' coefficients are made for.
    Orders are computed from the tableau's order conditions, not typed in.
    'midpoint' and 'gauss4' are implicit steps of a :class:`raydamp.LinearStructure`'s
    whole linear system and run that kind only (:func:`linear_structure_methods`).
    'newmark', Newton's iteration on the springs of a :class:`raydamp.Structure` and that kind's
    only, is listed apart (:func:`structure_methods`).
    """
    return [MethodInfo(**{k: row[k] for k in MethodInfo._fields}) for row in _core.methods()
            if not row["structure_only"]]


def linear_structure_methods() -> frozenset[str]:
    """The methods that run only a :class:`raydamp.LinearStructure` (implicit steps of its whole
    system M q'' + C q' + K q = f; any other kind refuses them with a ValueError naming the method)."""
    return frozenset(row["name"] for row in _core.methods() if row["linear_structure_only"])


def structure_methods() -> list[MethodInfo]:
    """The methods that run only a :class:`raydamp.Structure` with springs: 'newmark', Newmark's average
    acceleration (gamma = 1/2, beta = 1/4) with Newton's iteration on the springs' consistent tangent at
    every step, as OpenSees runs it (``integrate(structure, ..., method="newmark")``, a job's ``"method":
    "newmark"``; GET /v1/structure_methods lists it; any other kind refuses it with a ValueError naming the
    method, a 422 at ``method`` in the service). A step whose iteration does not converge ends the run with
    status "not_converged", its message naming the step, and the rows before it kept."""
    return [MethodInfo(**{k: row[k] for k in MethodInfo._fields}) for row in _core.methods()
            if row["structure_only"]]


def tableaux() -> list[TableauInfo]:
    """The Butcher tableaux raydamp ships, with their computed orders."""
    return [TableauInfo(**row) for row in _core.tableaux()]


def compositions() -> list[CompositionInfo]:
    """The compositions ``integrate(..., composition=...)`` accepts, with their order.

    Each raises a symmetric order-2 method (a row of :func:`methods` with
    ``symmetric=True``) to its order; "none" is the method itself. The
    coefficients are symmetric, sum to 1 and satisfy the odd-power order
    conditions, all checked when the core builds them; every composition of
    order above 2 has a negative coefficient (a backward sub-step).

    The near-integrable tables 'saba2'-'saba4' and 'sbab2'-'sbab4' (Laskar & Robutel 2001; kicks at the
    Gauss-Legendre or Gauss-Lobatto nodes, computed, never typed, and checked to integrate tau^k exactly
    for k < eps_order) have no backward sub-step: with 2s on a Kepler or Planets model their error is
    O(eps h^eps_order + eps^2 h^2), eps the drag and the planets' interaction. They take sv, 2s and rks
    (midpoint); 3s and baoab, whose drift is not their end sub-flow, refuse them, as does a temperature.
    """
    return [CompositionInfo(**row) for row in _core.compositions()]
