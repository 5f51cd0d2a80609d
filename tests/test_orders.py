"""Done means 2: global order at t = 10 from the fitted slope over h = 0.1 ... 0.0125 (eps = 0.5)."""

from __future__ import annotations

import functools

import numpy as np
import pytest
from paper import fitted_slope, paper_problem, reference

import raydamp
from raydamp.methods.catalogue import linear_structure_methods

HS = [0.1, 0.05, 0.025, 0.0125]
T = 10.0

CASES = [
    ("3s", None, 2), ("baoab", None, 2), ("2s", None, 2), ("rks", "heun", 2), ("rks", "rk4", 2), ("rks", "midpoint", 2),
    ("rks", "euler", 1), ("rksb", "heun", 2), ("rksb", "rk4", 2), ("rksb", "euler", 1),
    ("heun", None, 2), ("rk4", None, 4), ("rk", "euler", 1), ("rk", "heun", 2), ("rk", "rk4", 4),
]


@functools.cache
def reference_at_t(model_name: str, eps: float):
    model, q0, p0 = paper_problem(model_name, eps)
    return reference(model.vector_field, np.array(q0), np.array(p0), T)


def global_errors(model_name: str, eps: float, method: str, tableau):
    model, q0, p0 = paper_problem(model_name, eps)
    q_ref, p_ref = reference_at_t(model_name, eps)
    errors = []
    for h in HS:
        sol = raydamp.integrate(model, q0, p0, method=method, tableau=tableau, h=h, t_end=T, save_every=10**9)
        assert sol.t[-1] == pytest.approx(T, abs=1e-12)
        errors.append(max(np.abs(sol.q[-1] - q_ref).max(), np.abs(sol.p[-1] - p_ref).max()))
    return errors


@pytest.mark.parametrize(("method", "tableau", "order"), CASES)
def test_order_with_damping(model_name, method, tableau, order):
    errors = global_errors(model_name, 0.5, method, tableau)
    assert fitted_slope(HS, errors) == pytest.approx(order, abs=0.1), errors


def test_stormer_verlet_order_undamped(model_name):
    # sv refuses eps > 0 (it would drop the damping), so its order is checked at eps = 0.
    errors = global_errors(model_name, 0.0, "sv", None)
    assert fitted_slope(HS, errors) == pytest.approx(2, abs=0.1), errors


def test_catalogue_orders_match_measured_ones():
    listed = {(m.name, m.tableau): m.order for m in raydamp.methods()}
    tested = set()
    for method, tableau, order in CASES:
        key = (method, tableau if tableau else method if method in ("heun", "rk4") else None)
        assert listed[key] == order
        tested.add(key)
    # Every damped (method, tableau) pair the catalogue offers has an order test here (those that run
    # only a LinearStructure have theirs in test_implicit_structure.py).
    structure_only = linear_structure_methods()
    assert {k for k, m in zip(listed, raydamp.methods()) if m.damped and m.name not in structure_only} == tested
