"""User Butcher tableaux (tableau={"A", "b", "c", "order"}) for rks, rksb and the whole-system rk:
the same numbers as ours when the coefficients are ours, the order the conditions give, and every
malformed or unusable tableau refused with the field it is about."""

from __future__ import annotations

import math

import numpy as np
import pytest
from paper import fitted_slope, paper_problem, reference

import raydamp

RK4 = {"A": [[0, 0, 0, 0], [0.5, 0, 0, 0], [0, 0.5, 0, 0], [0, 0, 1, 0]], "b": [1 / 6, 1 / 3, 1 / 3, 1 / 6],
       "c": [0, 0.5, 0.5, 1]}
MIDPOINT = {"A": [[0.5]], "b": [1.0], "c": [0.5]}
# Kutta's third-order method: three stages, not one of ours.
KUTTA3 = {"A": [[0, 0, 0], [0.5, 0, 0], [-1, 2, 0]], "b": [1 / 6, 2 / 3, 1 / 6], "c": [0, 0.5, 1], "order": 3}
# The two-stage SDIRK of order 3 (Crouzeix 1975; Norsett): gamma = (3 + sqrt 3) / 6.
G = (3 + math.sqrt(3)) / 6
SDIRK3 = {"A": [[G, 0], [1 - 2 * G, G]], "b": [0.5, 0.5], "c": [G, 1 - G]}
# The two-stage Gauss method: fully implicit (a_12 != 0).
R3 = math.sqrt(3) / 6
GAUSS2 = {"A": [[0.25, 0.25 - R3], [0.25 + R3, 0.25]], "b": [0.5, 0.5], "c": [0.5 - R3, 0.5 + R3]}

HS = [0.1, 0.05, 0.025, 0.0125]
T = 10.0


def _final(model, q0, p0, **options):
    sol = raydamp.integrate(model, q0, p0, save_every=10**9, **options)
    assert sol.status == "completed", sol.message
    return sol


@pytest.mark.parametrize(("method", "ours", "theirs"), [
    ("rks", "rk4", RK4), ("rksb", "rk4", RK4), ("rk", "rk4", RK4), ("rks", "midpoint", MIDPOINT)])
def test_our_coefficients_given_as_a_dict_give_our_numbers(model_name, method, ours, theirs):
    model, q0, p0 = paper_problem(model_name, 0.3)
    a = _final(model, q0, p0, method=method, tableau=ours, h=0.05, n_steps=2000)
    b = _final(model, q0, p0, method=method, tableau=theirs, h=0.05, n_steps=2000)
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_array_equal(a.p, b.p)
    assert b.tableau.startswith("custom-") and b.provenance["tableau"]["b"] == pytest.approx(theirs["b"])


def test_rk4_method_is_rk_with_rk4():
    model, q0, p0 = paper_problem("elastic_pendulum", 0.1)
    a = _final(model, q0, p0, method="rk4", h=0.05, n_steps=1000)
    b = _final(model, q0, p0, method="rk", h=0.05, n_steps=1000)
    np.testing.assert_array_equal(a.q, b.q)


def _slope(model_name, **options):
    model, q0, p0 = paper_problem(model_name, 0.5)
    q_ref, p_ref = reference(model.vector_field, np.array(q0), np.array(p0), T)
    errors = []
    for h in HS:
        sol = _final(model, q0, p0, h=h, t_end=T, **options)
        errors.append(max(np.abs(sol.q[-1] - q_ref).max(), np.abs(sol.p[-1] - p_ref).max()))
    return fitted_slope(HS, errors), errors


@pytest.mark.parametrize(("method", "tableau", "order"), [
    ("rk", KUTTA3, 3),       # the tableau's own order on the whole system
    ("rks", KUTTA3, 2),      # inside a splitting: the splitting's order 2
    ("rks", SDIRK3, 2),      # a diagonally implicit tableau of ours to no one
    ("rksb", KUTTA3, 2),
])
def test_orders_with_user_tableaux(model_name, method, tableau, order):
    slope, errors = _slope(model_name, method=method, tableau=tableau)
    assert slope == pytest.approx(order, abs=0.1), errors


def test_a_symmetric_user_tableau_can_be_composed():
    """rks over a user's implicit midpoint is symmetric, so yoshida4 raises it to order 4; the
    numbers are those of tableau="midpoint"."""
    model, q0, p0 = paper_problem("damped_pendulum", 0.5)
    ours = _final(model, q0, p0, method="rks", tableau="midpoint", composition="yoshida4", h=0.05, n_steps=400)
    theirs = _final(model, q0, p0, method="rks", tableau=MIDPOINT, composition="yoshida4", h=0.05, n_steps=400)
    np.testing.assert_array_equal(ours.q, theirs.q)
    with pytest.raises(ValueError, match="composition: 'yoshida4' composes a symmetric order-2 step"):
        raydamp.integrate(model, q0, p0, method="rks", tableau=SDIRK3, composition="yoshida4", h=0.05, n_steps=4)


def test_equal_tables_share_a_name_and_different_ones_do_not():
    model, q0, p0 = paper_problem("damped_pendulum", 0.1)
    names = {raydamp.integrate(model, q0, p0, method="rk", tableau=t, h=0.1, n_steps=2).tableau
             for t in (KUTTA3, dict(KUTTA3), {**KUTTA3, "A": np.array(KUTTA3["A"])})}
    assert len(names) == 1
    other = raydamp.integrate(model, q0, p0, method="rk", tableau=RK4, h=0.1, n_steps=2).tableau
    assert other not in names


def test_the_provenance_reruns_a_user_tableau(tmp_path):
    model, q0, p0 = paper_problem("elastic_pendulum", 0.1)
    sol = _final(model, q0, p0, method="rks", tableau=SDIRK3, h=0.05, n_steps=200)
    path = tmp_path / "run.nc"
    sol.save(path)
    from raydamp.jobs import job_arguments
    again_model, q, p, options = job_arguments(raydamp.load(path).provenance)
    np.testing.assert_array_equal(raydamp.integrate(again_model, q, p, **options).q, sol.q)


def _refused(match, method="rks", **tableau_changes):
    model, q0, p0 = paper_problem("damped_pendulum", 0.1)
    tableau = {**KUTTA3, **tableau_changes}
    tableau = {k: v for k, v in tableau.items() if v is not _DROP}
    with pytest.raises(ValueError, match=match):
        raydamp.integrate(model, q0, p0, method=method, tableau=tableau, h=0.1, n_steps=2)


_DROP = object()


@pytest.mark.parametrize(("changes", "match"), [
    ({"A": [[0, 0, 0], [0.5, 0, 0], [-1, 2.5, 0]]}, r"tableau: row 2 of A does not sum to c\[2\]"),
    ({"b": [1 / 6, 2 / 3, 1 / 3]}, r"tableau: weights b do not sum to 1"),
    ({"order": 4}, r"tableau.order: the tableau satisfies the order conditions up to order 3, not 4"),
    ({"order": 6}, r"tableau.order: raydamp checks the order conditions up to order 4"),
    ({"order": 2.0}, r"tableau.order must be an integer"),
    ({"A": [[0, 0, 0], [0.5, 0], [-1, 2, 0]]}, r"tableau.A\[1\] must have 3 entries"),
    ({"A": [[0, 0, 0], [0.5, 0, 0]]}, r"tableau.A must be 3 rows of 3 numbers"),
    ({"A": [[0, 0, 0], [0.5, "0", 0], [-1, 2, 0]]}, r"tableau.A\[1\]\[1\] must be a number"),
    ({"c": [0, 0.5, math.nan]}, r"tableau.c\[2\] must be finite"),
    ({"c": [0, 0.5]}, r"tableau.c must have 3 entries"),
    ({"b": []}, r"tableau.b must have 1 to 16 weights"),
    # A short b beside 3 rows of A and 3 entries of c: it was "tableau.c must have 2 entries" (an API audit).
    ({"b": [0.5, 0.5]}, r"^tableau.b must have 3 weights \(the number of stages"),
    ({"b": True}, r"tableau.b must be a list of numbers"),
    ({"c": _DROP}, r"tableau.c: missing"),
    ({"B": [1]}, r"tableau.B: unknown key"),
])
def test_malformed_tableaux_are_refused_naming_the_field(changes, match):
    _refused(match, **changes)


def test_unusable_tableaux_are_refused_with_the_reason():
    model, q0, p0 = paper_problem("damped_pendulum", 0.1)
    with pytest.raises(ValueError, match=r"fully implicit \(a_ij != 0 above the diagonal\).*one coupled nonlinear"):
        raydamp.integrate(model, q0, p0, method="rks", tableau=GAUSS2, h=0.1, n_steps=2)
    for method in ("rk", "rksb"):
        with pytest.raises(ValueError, match=f"tableau: method '{method}' needs an explicit tableau"):
            raydamp.integrate(model, q0, p0, method=method, tableau=SDIRK3, h=0.1, n_steps=2)
    with pytest.raises(ValueError, match="tableau: method '3s' has no Runge-Kutta stage"):
        raydamp.integrate(model, q0, p0, method="3s", tableau=RK4, h=0.1, n_steps=2)
    with pytest.raises(ValueError, match="tableau must be a tableau name, a dict with A, b, c, or None"):
        raydamp.integrate(model, q0, p0, method="rks", tableau=[[0.5]], h=0.1, n_steps=2)
