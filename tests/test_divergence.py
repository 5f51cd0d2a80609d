"""Divergence is a status (issue 43, item 4): a run that blows up while its state stays finite stops
"diverged" and keeps its rows; no legitimate run is flagged (forced from rest, thermal, H0 = 0, negative H,
an orbit escaping to infinity, stiff damping stepped exactly)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import sparse

import raydamp
from raydamp.models import DampedPendulum


def frame(n: int = 10, k: float = 4e7, m: float = 1e3) -> raydamp.LinearStructure:
    """A shear frame of n storeys (masses m, storey stiffness k), 2% Rayleigh damping at modes 1 and 3."""
    main = np.full(n, 2.0 * k)
    main[-1] = k
    K = sparse.diags([np.full(n - 1, -k), main, np.full(n - 1, -k)], [-1, 0, 1]).tocsc()
    M = sparse.identity(n, format="csc") * m
    w = np.sqrt(np.sort(np.linalg.eigvalsh(K.toarray() / m)))
    alpha, beta = raydamp.rayleigh_coefficients(w[0], w[2], 0.02, 0.02)
    return raydamp.LinearStructure(M, K, alpha=alpha, beta=beta), w


def kepler(eps: float = 0.0) -> raydamp.System:
    return raydamp.System(["x", "y"], "-1/sqrt(x^2+y^2)", eps=eps)


def test_the_blown_up_frame_ends_diverged_keeping_its_rows():
    s, w = frame()
    h = 6.9 / w[-1]  # h omega_max = 6.9: 3s's drift-kick is unstable in the top mode
    q0 = np.linspace(0.001, 0.01, s.dim)  # a deflected frame released from rest
    unchecked = raydamp.integrate(s, q0, 0 * q0, method="3s", h=h, t_end=3.0, save_every=10, divergence=0)
    assert unchecked.status == "completed" and np.abs(unchecked.q).max() > 1e100  # the premise
    sol = raydamp.integrate(s, q0, 0 * q0, method="3s", h=h, t_end=3.0, save_every=10)
    assert sol.status == "diverged", sol.message
    # 172 steps, fewer than the 256 between checks: the check at the run's end finds it, and every row is kept
    assert sol.failed_step == sol.steps == unchecked.steps == 172
    assert "diverged" in sol.message and "divergence = 0" in sol.message
    # H overflowed to +inf here: the scale the message names is still the start's (T0 + |V0| = 200), not 0
    assert "times 200, the most" in sol.message, sol.message
    np.testing.assert_array_equal(sol.t, unchecked.t)
    np.testing.assert_array_equal(sol.q, unchecked.q)
    assert np.isfinite(sol.q).all() and sol.energy[0] == pytest.approx(200.0, rel=0.01)


def test_a_slower_blow_up_stops_long_before_it_overflows():
    # rk4 at h omega_max = 3.0, past its limit with this damping: without the test it overflows at step 2689
    s, w = frame()
    q0 = np.linspace(0.001, 0.01, s.dim)
    options = {"method": "rk", "tableau": "rk4", "h": 3.0 / w[-1], "n_steps": 200_000, "save_every": 100}
    unchecked = raydamp.integrate(s, q0, 0 * q0, **options, divergence=0)
    assert unchecked.status == "non_finite" and unchecked.failed_step > 2000
    sol = raydamp.integrate(s, q0, 0 * q0, **options)
    # the first check: the first block's end at or past step 256 (blocks end at saved rows here)
    assert sol.status == "diverged" and sol.steps == sol.failed_step == 300, sol.message
    np.testing.assert_array_equal(sol.q, unchecked.q[:4])  # rows 0, 100, 200, 300
    assert 1e10 < np.abs(sol.q).max() < 1e100


def test_forced_and_ground_motion_from_rest_complete():
    s, w = frame()
    h = 0.5 / w[-1]
    zero = np.zeros(s.dim)
    at_resonance = raydamp.Load.harmonic(np.full(s.dim, 1e4), w[0])  # H0 = 0, energy grows for many periods
    sol = raydamp.integrate(s, zero, zero, method="3s", h=h, t_end=30.0, save_every=1000, load=at_resonance)
    assert sol.status == "completed", sol.message
    assert sol.energy[-1] > 0
    t = np.arange(0, 5, 0.01)
    a_g = 3.0 * np.sin(7.0 * t) * np.exp(-0.3 * t)
    ground = raydamp.GroundMotion((t, a_g), np.ones(s.dim))
    sol = raydamp.integrate(s, zero, zero, method="midpoint", h=0.01, t_end=8.0, load=ground)
    assert sol.status == "completed", sol.message
    # a pulse given as an expression, narrow but sampled: from rest, nothing else puts energy in
    pulse = raydamp.Load.expression("A*exp(-((t-1)/0.05)^2)", {"A": 1e5}, direction=np.eye(s.dim)[-1])
    sol = raydamp.integrate(s, zero, zero, method="3s", h=h, t_end=4.0, save_every=1000, load=pulse)
    assert sol.status == "completed", sol.message


def test_thermal_from_rest_completes():
    sol = raydamp.integrate(DampedPendulum(eps=2.0), [0.0], [0.0], method="3s", h=0.05, n_steps=20_000,
                            save_every=1000, temperature=0.5, seed=7)
    assert sol.status == "completed", sol.message
    assert np.abs(sol.p).max() > 0


def test_orbits_zero_and_negative_energy_and_escape_complete():
    s = kepler()
    # H0 = 0: a parabolic escape; H0 < 0: an ellipse of eccentricity 0.9, its close passes fast
    for p0 in ([0.0, np.sqrt(2.0)], [0.0, np.sqrt(0.1)]):
        sol = raydamp.integrate(s, [1.0, 0.0], p0, method="sv", h=1e-3, n_steps=100_000, save_every=10_000)
        assert sol.status == "completed", sol.message
    # H0 > 0: a hyperbolic escape to r ~ 1e5, its energy balanced to rounding
    sol = raydamp.integrate(s, [1.0, 0.0], [0.0, 2.0], method="sv", h=0.05, n_steps=100_000, save_every=10_000)
    assert sol.status == "completed", sol.message
    assert np.hypot(*sol.q[-1]) > 5e3 and sol.energy[-1] == pytest.approx(sol.energy[0], rel=1e-3)


def test_stiff_damping_stepped_exactly_completes():
    # eps h = 50: Heun's damping sub-step would blow up; 3s's damping flow is exact
    sol = raydamp.integrate(DampedPendulum(eps=1000.0), [1.0], [0.0], method="3s", h=0.05, n_steps=5000)
    assert sol.status == "completed", sol.message


def test_the_setting_is_checked():
    for bad in (-1.0, float("inf"), "x"):
        with pytest.raises(ValueError, match="^divergence"):
            raydamp.integrate(DampedPendulum(eps=0.1), [1.0], [0.0], h=0.1, n_steps=10, divergence=bad)


def test_one_list_of_statuses():
    from raydamp.jobs.statuses import MEANINGS, STATUSES
    from raydamp.results.ensemble_solution import STATUSES as in_files

    assert STATUSES == raydamp._core.STATUSES == in_files
    assert STATUSES[:4] == ("completed", "non_finite", "cancelled", "out_of_memory")  # stored as these numbers
    assert set(STATUSES) == set(MEANINGS) >= {"diverged", "event", "not_converged"}


def test_the_save_grid_is_the_core_s():
    from raydamp.run.save_grid import save_grid, save_rows

    for n, every in ((10, 3), (9, 3), (1, 5), (7, 1)):
        sol = raydamp.integrate(DampedPendulum(eps=0.1), [1.0], [0.0], h=0.1, n_steps=n, save_every=every)
        assert sol.t.size == save_rows(n, every)
        np.testing.assert_array_equal(sol.t, save_grid(0.1, n, 0.1, every))
    sol = raydamp.integrate(DampedPendulum(eps=0.1), [1.0], [0.0], h=0.3, t_end=1.0, save_every=2)
    np.testing.assert_array_equal(sol.t, save_grid(0.3, 4, 1.0 - 3 * 0.3, 2))


def test_the_readme_names_every_status_a_run_ends_with():
    # The README said a blow-up ends "non_finite" alone: `diverged` (and `out_of_memory`) were in no line of it.
    import re
    from pathlib import Path

    from raydamp.jobs.statuses import MEANINGS, STATUSES
    from raydamp.run.integrate import DEFAULT_DIVERGENCE

    text = (Path(__file__).resolve().parents[1] / "README.md").read_text(encoding="utf-8")
    for status in STATUSES:
        if not MEANINGS[status].startswith("reserved"):
            assert re.search(rf"[`\"']{status}[`\"']", text), status
    assert re.search(r"`divergence`\s+\(default 10\^6\)", text) and DEFAULT_DIVERGENCE == 1e6
