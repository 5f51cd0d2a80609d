"""Issue 11, point 4: Proposition 3.1 (invariance under changes of configuration
coordinates) for linear changes s = A q, with raydamp.System in both coordinates."""

from __future__ import annotations

import numpy as np
import pytest

import raydamp
from raydamp.reproduce import experiments
from raydamp.reproduce.settings import Settings


@pytest.fixture(scope="module")
def invariance():
    return experiments.coordinate_invariance(Settings())


@pytest.mark.parametrize("damping", ["matrix", "dampers"])
@pytest.mark.parametrize("method", ["3s", "2s", "rks/heun", "rks/midpoint", "rks/rk4"])
def test_splittings_map_onto_each_other_to_rounding(invariance, damping, method):
    # Measured over 400 steps (states of size ~2): <= 5.0e-13 (3s with a dense constant D,
    # whose exact flow goes through a matrix exponential), <= 1.6e-14 otherwise.
    assert invariance["deviation"][damping, method] < 1e-11


@pytest.mark.parametrize("damping", ["matrix", "dampers"])
@pytest.mark.parametrize("method", ["heun", "rk4", "rksb/heun"])
def test_runge_kutta_methods_map_too_under_linear_changes(invariance, damping, method):
    """Not special to the splittings: a linear change with its cotangent lift is linear in
    (q, p), and Runge-Kutta methods are affine covariant (measured <= 1.8e-14)."""
    assert invariance["deviation"][damping, method] < 1e-12


def test_a_wrong_pull_back_is_seen():
    """The check has teeth: pulling M back but leaving D in q coordinates (D instead of
    A^-T D A^-1) moves the trajectory by far more than rounding."""
    a = experiments.INVARIANCE_A
    a_inv = np.linalg.inv(a)
    system_q, system_s = experiments._invariance_pair("matrix")
    spec = system_s.to_dict()
    spec["damping"] = {"matrix": experiments.INVARIANCE_DAMPING.tolist()}
    wrong = raydamp.System.from_dict(spec)
    q0, p0 = np.array([1.0, -0.5]), np.array([0.2, 0.7])
    in_q = raydamp.integrate(system_q, q0, p0, method="3s", h=0.05, t_end=20.0)
    right = raydamp.integrate(system_s, a @ q0, a_inv.T @ p0, method="3s", h=0.05, t_end=20.0)
    off = raydamp.integrate(wrong, a @ q0, a_inv.T @ p0, method="3s", h=0.05, t_end=20.0)
    assert np.abs(right.q - in_q.q @ a.T).max() < 1e-11
    assert np.abs(off.q - in_q.q @ a.T).max() > 1e-2
