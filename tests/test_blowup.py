"""Done means 5: a blown-up run stops at the right step and keeps its finite points."""

from __future__ import annotations

import numpy as np
import pytest
from paper import paper_problem

import raydamp

H_HUGE = 2.5  # Heun's amplification on the elastic pendulum's spring mode at this h is > 1
# These tests are of the finiteness check and its replay: the divergence test (which would stop these runs
# "diverged" at step 256, with energy 1e264, before they overflow) is off. tests/test_divergence.py has it on.
OFF = {"divergence": 0}


def blown_up(save_every=1):
    model, q0, p0 = paper_problem("elastic_pendulum", 0.1)
    return model, q0, p0, raydamp.integrate(model, q0, p0, method="heun", h=H_HUGE, n_steps=100_000,
                                           save_every=save_every, **OFF)


def test_status_and_step_of_the_blow_up():
    model, q0, p0, sol = blown_up()
    assert sol.status == "non_finite"
    k = sol.failed_step
    assert k is not None and 1 < k < 100_000
    assert sol.steps == k - 1
    assert f"step {k}" in sol.message
    # The step is right: k - 1 steps stay finite, the k-th does not.
    before = raydamp.integrate(model, q0, p0, method="heun", h=H_HUGE, n_steps=k - 1, **OFF)
    assert before.status == "completed"
    at = raydamp.integrate(model, q0, p0, method="heun", h=H_HUGE, n_steps=k, **OFF)
    assert at.status == "non_finite" and at.failed_step == k
    # Every saved point is kept, finite, and the same as the clean run's.
    assert sol.t.size == k  # rows for steps 0 .. k-1
    assert np.all(np.isfinite(sol.q)) and np.all(np.isfinite(sol.p))
    np.testing.assert_array_equal(sol.q, before.q)
    np.testing.assert_array_equal(sol.p, before.p)
    assert sol.t[-1] == pytest.approx((k - 1) * H_HUGE)


def test_blow_up_inside_a_block_between_saved_points():
    _, _, _, every = blown_up(save_every=1)
    _, _, _, sparse = blown_up(save_every=7)
    assert sparse.failed_step == every.failed_step
    # Saved rows are every 7th step plus the last finite state.
    np.testing.assert_array_equal(sparse.t[:-1], every.t[: every.failed_step : 7][: sparse.t.size - 1])
    np.testing.assert_array_equal(sparse.q[-1], every.q[-1])


def test_splitting_stays_finite_where_heun_blows_up():
    model, q0, p0 = paper_problem("elastic_pendulum", 0.1)
    sol = raydamp.integrate(model, q0, p0, method="2s", h=0.4, n_steps=100_000, save_every=1000)
    assert sol.status == "completed" and np.all(np.isfinite(sol.energy))
