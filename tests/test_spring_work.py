"""work=True on a Structure with springs (issue 42): each spring's hysteretic work, the kinetic and stored
energies, and an energy budget H - H0 + W + sum W_h - W_f that closes to O(h^2) for the splittings (order
measured), on Chopra's elastic-perfectly-plastic SDOF and a yielding 3-storey frame."""

import math

import numpy as np
import pytest
from paper import fitted_slope

import raydamp
from raydamp.materials import Bilinear, BoucWen, ElasticPlastic

M, K, FY = 0.2533, 10.0, 7.5
C = 0.1 * math.sqrt(K * M)
PULSE = raydamp.Load.harmonic([10.0], math.pi / 0.6, t_end=0.6)
PERMANENT_SET = 1.483840809739  # the exact solution's (tests/test_structure_springs.py)


def sdof():
    return raydamp.Structure([[M]], springs=[raydamp.Spring((0,), ElasticPlastic(K, FY))], alpha=C / M)


def budget_error(model, load, method, h, t_end):
    sol = raydamp.integrate(model, np.zeros(model.dim), np.zeros(model.dim), method=method, h=h, t_end=t_end,
                            load=load, work=True)
    assert sol.status == "completed"
    return float(np.max(np.abs(sol.energy_balance))), sol


def test_an_epp_springs_hysteretic_work_is_fy_times_its_plastic_deformation():
    # One yield excursion, then elastic vibration about the permanent set: W_h = fy * (u_max - u_y) = fy * set.
    _, sol = budget_error(sdof(), PULSE, "3s", 1e-3, 10.0)
    assert sol.hysteretic_work.shape == (sol.t.size, 1)
    assert sol.hysteretic_work[-1, 0] == pytest.approx(FY * PERMANENT_SET, rel=1e-4)
    assert sol.hysteretic_work[0, 0] == 0.0 and np.all(np.diff(sol.hysteretic_work[:, 0]) >= -1e-12)
    # H splits into T and the stored energy: 1/2 k (u - u_p)^2 at rest after the run has died out
    np.testing.assert_allclose(sol.kinetic_energy + sol.stored_energy, sol.energy, rtol=1e-14)
    assert sol.stored_energy[-1] < 1e-3 * FY * PERMANENT_SET


@pytest.mark.parametrize("method", ["3s", "2s", "baoab", "rks"])
def test_the_budget_closes_at_order_2_on_chopras_sdof(method):
    hs = [0.01 / 9 * 2 ** -k for k in range(4)]
    errors = [budget_error(sdof(), PULSE, method, h, 3.0)[0] for h in hs]
    slope = fitted_slope(hs, errors)
    assert 1.8 < slope < 2.3, (errors, slope)
    assert errors[-1] < 1e-5 * FY * PERMANENT_SET


def test_the_budget_closes_at_order_2_on_a_yielding_frame_of_every_material():
    materials = [Bilinear(400.0, 6.0, 0.05), ElasticPlastic(300.0, 5.0), BoucWen(350.0, 5.0, 0.1)]
    springs = [raydamp.Spring((s - 1, s) if s else (0,), m) for s, m in enumerate(materials)]
    frame = raydamp.Structure(np.diag([1.0, 1.2, 0.8]), springs=springs, alpha=0.2, beta=1e-3)
    # two whole periods: the load ends at a zero of its sine (a jump in f would make W_f's trapezoid order 1)
    load = raydamp.Load.harmonic([20.0, 20.0, 20.0], 5.0, t_end=4 * math.pi / 5.0)
    hs = [0.004 * 2 ** -k for k in range(4)]
    runs = [budget_error(frame, load, "3s", h, 3.0) for h in hs]
    slope = fitted_slope(hs, [e for e, _ in runs])
    assert 1.8 < slope < 2.3, ([e for e, _ in runs], slope)
    work = runs[-1][1].hysteretic_work[-1]
    assert (work > 0.1).all()  # every spring yielded and dissipated
    # per spring, in the Structure's order (the core groups them by kind): the EPP spring's work is fy times
    # its total plastic flow, at least fy times the plastic part of its peak drift
    sol = raydamp.integrate(frame, np.zeros(3), np.zeros(3), method="3s", h=hs[-1], t_end=3.0, load=load,
                            work=True, envelope=["drift"])
    assert sol.hysteretic_work[-1, 1] >= 5.0 * (sol.envelope["drift"].values[1] - 5.0 / 300.0) * (1 - 1e-3)


def test_a_springless_run_has_no_hysteretic_work():
    sol = raydamp.integrate(raydamp.LinearStructure(np.eye(2), np.eye(2)), [1.0, 0.0], [0.0, 0.0], h=0.01,
                            n_steps=10, method="3s", work=True)
    assert sol.hysteretic_work is None
