"""rayleigh_coefficients against the textbook two-frequency formulas, and a System damped with them
whose modes decay at the asked ratios."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import eigh

import raydamp


def test_equal_ratios_match_the_closed_form():
    # zeta = 0.05 at omega = 2 and 20: alpha = 2 zeta w1 w2 / (w1 + w2) = 0.2/22*40, beta = 2 zeta / (w1 + w2).
    alpha, beta = raydamp.rayleigh_coefficients(2.0, 20.0, 0.05, 0.05)
    assert alpha == pytest.approx(0.1 * 40.0 / 22.0, rel=1e-15)
    assert beta == pytest.approx(0.1 / 22.0, rel=1e-15)


def test_hand_computed_values_and_the_ratios_they_give():
    # omega1 = 1, omega2 = 3, zeta1 = 0.02, zeta2 = 0.05 by hand: denominator 9 - 1 = 8,
    # alpha = 2*1*3*(0.02*3 - 0.05*1)/8 = 6*0.01/8 = 0.0075, beta = 2*(0.05*3 - 0.02*1)/8 = 0.26/8 = 0.0325.
    alpha, beta = raydamp.rayleigh_coefficients(1.0, 3.0, 0.02, 0.05)
    assert alpha == pytest.approx(0.0075, rel=1e-14) and beta == pytest.approx(0.0325, rel=1e-14)
    assert raydamp.modal_damping_ratio(1.0, alpha, beta) == pytest.approx(0.02, rel=1e-14)
    assert raydamp.modal_damping_ratio(3.0, alpha, beta) == pytest.approx(0.05, rel=1e-14)
    # Pure stiffness- and pure mass-proportional damping come out exactly.
    assert raydamp.rayleigh_coefficients(1.0, 4.0, 0.01, 0.04)[0] == 0.0
    assert raydamp.rayleigh_coefficients(1.0, 4.0, 0.04, 0.01)[1] == 0.0


@pytest.mark.parametrize(("args", "message"), [
    ((1.0, 1.0, 0.05, 0.05), r"^omega2 must differ"), ((0.0, 2.0, 0.05, 0.05), r"^omega1 must be > 0"),
    ((1.0, 2.0, -0.1, 0.05), r"^zeta1 must be >= 0"), ((1.0, 10.0, 0.05, 0.001), r"^zeta2: damping ratios"),
    ((1.0, 10.0, 0.001, 0.5), r"^zeta2: damping ratios")])
def test_bad_arguments_are_named(args, message):
    with pytest.raises(ValueError, match=message):
        raydamp.rayleigh_coefficients(*args)


def test_a_rayleigh_damped_system_decays_each_mode_at_its_ratio():
    # Two masses, M = diag(1, 2), K = [[2, -1], [-1, 1]]: modes omega_i from K v = omega^2 M v. A mode
    # started alone decays as exp(-zeta_i omega_i t) in amplitude (C = alpha M + beta K keeps modes apart).
    m, k = np.diag([1.0, 2.0]), np.array([[2.0, -1.0], [-1.0, 1.0]])
    omega2, modes = eigh(k, m)
    omega = np.sqrt(omega2)
    alpha, beta = raydamp.rayleigh_coefficients(omega[0], omega[1], 0.02, 0.03)
    system = raydamp.System(["a", "b"], "(2*a^2 - 2*a*b + b^2)/2", mass=[1.0, 2.0],
                            damping={"matrix": (alpha * m + beta * k).tolist()}, eps=1.0)
    for i, zeta in enumerate((0.02, 0.03)):
        t_end = 40.0
        sol = raydamp.integrate(system, modes[:, i], [0.0, 0.0], method="rks", tableau="midpoint", h=0.002,
                                t_end=t_end)
        # The mode's energy decays as exp(-2 zeta omega t) on average over a period.
        period = 2 * np.pi / omega[i]
        late = sol.t >= t_end - period
        early = sol.t <= period
        ratio = sol.energy[late].mean() / sol.energy[early].mean()
        measured = -np.log(ratio) / (2 * omega[i] * (t_end - period))
        assert measured == pytest.approx(zeta, rel=0.02)
