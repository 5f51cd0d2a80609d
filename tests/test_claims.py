"""Issue 3: the paper's claims asserted with numbers, from the same experiment
functions that write the report (full time spans where they are cheap)."""

from __future__ import annotations

import numpy as np
import pytest

import raydamp
from raydamp.models import DampedPendulum
from raydamp.reproduce import experiments
from raydamp.reproduce.settings import PENDULUM_P0, PENDULUM_Q0, Settings

FULL = Settings()


@pytest.fixture(scope="module")
def pendulum_energy():
    return experiments.pendulum_energy(FULL)


def test_splitting_energy_error_bounded_heun_grows(pendulum_energy):
    growth, trend = pendulum_energy["growth"], pendulum_energy["trend"]
    # Measured: the splittings' max error over [100, 200] is about half that over [0, 100]
    # (0.50); Heun's grows (1.08) with a linear trend of 0.86 max|error| over the span.
    for m in ("3s", "2s", "rks"):
        assert growth[m] < 0.6
        assert abs(trend[m]) < 0.4
    assert growth["heun"] > 1.0
    assert trend["heun"] > 0.7


def test_final_energy_across_step_sizes():
    phase = experiments.pendulum_phase(FULL)
    spread = phase["final_energy_spread"]
    # Measured: 0.021 for 3s, 2s and rks over h = 0.2..0.5; 2.14 for Heun.
    for m in ("3s", "2s", "rks"):
        assert spread[m] < 0.03
    assert spread["heun"] > 1.5
    assert phase["runs"]["heun", 0.2].final_energy > 1.2 * phase["reference_final_energy"]


def test_pairwise_differences(pendulum_energy):
    ratio = pendulum_energy["difference_ratio"]
    # Measured: 2s-rks 5.5e3; pairs with 3s 45 (the paper's '10^2' holds to within a factor 2.2).
    assert ratio["2s-rks"] > 1000
    assert 20 < ratio["3s-2s"] < 100 and 20 < ratio["3s-rks"] < 100
    d = pendulum_energy["differences"]
    assert d["2s-rks"].max() < min(d["3s-2s"].max(), d["3s-rks"].max()) / 50


def test_difference_with_3s_is_order_eps():
    """The explanation of the 3s ratio: the 3s-2s difference is O(eps h^2) while the error
    is O(h^2), so the ratio grows like 1/eps."""
    def ratio(eps):
        model = DampedPendulum(eps)
        a = raydamp.integrate(model, PENDULUM_Q0, PENDULUM_P0, method="3s", h=0.2, t_end=50.0)
        b = raydamp.integrate(model, PENDULUM_Q0, PENDULUM_P0, method="2s", h=0.2, t_end=50.0)
        from raydamp.analysis import energy_error
        return np.abs(energy_error(model, b)).max() / np.abs(a.energy - b.energy).max()

    r1, r2 = ratio(0.01), ratio(0.001)
    assert r2 / r1 == pytest.approx(10, rel=0.25)


def test_momentum_and_orbits():
    mom = experiments.momentum(FULL)
    bound = 1e-12 * max(1.0, abs(mom["j0"]))
    for m in ("3s", "2s", "rks"):
        assert mom["drift"][m] < bound
    assert mom["drift"]["rksb"] > 1e-6 and mom["drift"]["heun"] > 1e-6
    orbits = experiments.elastic_orbits(FULL)
    # Measured over t in [0, 1000]: Heun's mean radius rises in every window, by 0.054;
    # 3s's radius oscillation falls from 0.56 to 4e-9.
    assert orbits["heun_radius_increasing"] and orbits["heun_radius_growth"] > 0.03
    assert orbits["heun_radius_trend"] > 0
    assert orbits["splitting_radius_ptp_last"] < 1e-6 < 0.1 < orbits["splitting_radius_ptp_first"]


def test_modified_energy():
    mod = experiments.modified_energy_study(FULL)
    for name in ("damped_pendulum", "elastic_pendulum"):
        assert mod["Hmod_order"][name] == pytest.approx(4, abs=0.3)
        assert mod["H_order"][name] == pytest.approx(2, abs=0.3)
    assert mod["Hmod_rises"] == 0
    assert mod["H_rises"] > 100  # H itself is not monotone: the claim is about the modified one


def test_relative_equilibrium_offset_is_order_h2():
    eq = experiments.equilibrium(FULL)
    for m, order in eq["offset_order"].items():
        assert order == pytest.approx(2, abs=0.3), m
    assert np.abs(eq["residual_k10"]).max() < 1e-14  # the paper's data with k = 10
    assert np.abs(eq["residual_k1"]).max() > 0.5  # ... and not with the stated k = 1
    assert eq["distance_to_modified"][-1] < eq["distance_to_exact"][-1] / 5


def test_energy_balance():
    bal = experiments.energy_balance(FULL)
    for m in ("3s", "2s", "rks"):
        assert bal["order"][m] == pytest.approx(2, abs=0.3)
    assert abs(bal["trend"]["heun"]) > 1.0 > max(abs(bal["trend"][m]) for m in ("3s", "2s", "rks"))


def test_all_report_claims_but_the_known_discrepancy_hold(tmp_path):
    claims = raydamp.reproduce.run(tmp_path, quick=False, progress=False)
    failed = [c.where for c in claims if not c.passed]
    # Two disagreements with the paper, each explained in the report: the pairs with 3s
    # differ ~45x (not >= 100x) less than the error, and the relative-equilibrium data
    # needs k = 10.
    assert failed == ["Fig. 3 (lower)", "Sec. 6.2 (data)"]
    assert sum(c.where == "Fig. 3 (lower)" and c.passed for c in claims) == 1  # 2s-rks closest: holds
