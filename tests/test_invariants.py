"""Done means 3 and 4: undamped equivalence with sv, and the momentum map J3."""

from __future__ import annotations

import numpy as np
import pytest
from paper import paper_problem

import raydamp

SPLITTINGS = [("3s", None), ("2s", None), ("rks", "heun"), ("rks", "rk4"), ("rks", "midpoint"), ("rks", "euler")]


@pytest.mark.parametrize(("method", "tableau"), SPLITTINGS)
def test_undamped_splittings_are_stormer_verlet(model_name, method, tableau):
    model, q0, p0 = paper_problem(model_name, 0.0)
    sv = raydamp.integrate(model, q0, p0, method="sv", h=0.1, n_steps=2000)
    other = raydamp.integrate(model, q0, p0, method=method, tableau=tableau, h=0.1, n_steps=2000)
    assert np.abs(other.q - sv.q).max() <= 1e-13
    assert np.abs(other.p - sv.p).max() <= 1e-13


def test_rksb_undamped_is_the_kick_drift_kick_verlet():
    # rksb reduces to the A-form (kick-drift-kick) of Stormer-Verlet, conjugate to sv.
    model, q0, p0 = paper_problem("elastic_pendulum", 0.0)
    q, p = np.array(q0), np.array(p0)
    for _ in range(500):
        q, p = model.flow("kick", q, p, 0.05)
        q, p = model.flow("drift", q, p, 0.1)
        q, p = model.flow("kick", q, p, 0.05)
    sol = raydamp.integrate(model, q0, p0, method="rksb", h=0.1, n_steps=500)
    np.testing.assert_allclose(sol.q[-1], q, rtol=0, atol=1e-13)
    np.testing.assert_allclose(sol.p[-1], p, rtol=0, atol=1e-13)


@pytest.mark.parametrize(("method", "tableau"), SPLITTINGS)
def test_splittings_conserve_j3(method, tableau):
    model, q0, p0 = paper_problem("elastic_pendulum", 0.1)
    sol = raydamp.integrate(model, q0, p0, method=method, tableau=tableau, h=0.1, n_steps=100_000,
                            save_every=100)
    j0 = sol.momentum[0, 0]
    bound = 1e-12 * max(1.0, abs(j0))
    assert sol.max_momentum_drift < bound  # over every step, tracked in the loop
    assert np.abs(sol.momentum[:, 0] - j0).max() < bound
    assert sol.summary()["momentum_drift"] < bound


@pytest.mark.parametrize("method", ["rksb", "heun"])
def test_rksb_and_heun_do_not_conserve_j3(method):
    model, q0, p0 = paper_problem("elastic_pendulum", 0.1)
    sol = raydamp.integrate(model, q0, p0, method=method, h=0.1, n_steps=100_000, save_every=100)
    # Measured: rksb drifts by ~6e-6, heun by O(1); both at least 1e6 times the splittings' bound.
    assert sol.max_momentum_drift > 1e-6


def test_rotation_equivariance_of_3s():
    """Rotating the initial state about z rotates the 3s trajectory (paper Proposition 5.x)."""
    model, q0, p0 = paper_problem("elastic_pendulum", 0.1)
    angle = 0.7
    c, s = np.cos(angle), np.sin(angle)
    rot = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    a = raydamp.integrate(model, q0, p0, h=0.1, n_steps=500)
    b = raydamp.integrate(model, rot @ q0, rot @ p0, h=0.1, n_steps=500)
    np.testing.assert_allclose(b.q, a.q @ rot.T, rtol=0, atol=1e-11)
    np.testing.assert_allclose(b.p, a.p @ rot.T, rtol=0, atol=1e-11)


# ---- Issue 28, point 3: the momentum drift is measured from the law the exact flow follows.

def kepler_with_drag() -> raydamp.System:
    """A Kepler orbit under isotropic drag D = M ({"scalar": 1}): A = eps I, so the angular momentum
    decays exactly as L(0) e^{-eps t} (the Hamiltonian part conserves L; the damping scales p)."""
    return raydamp.System(["x", "y"], "-1/sqrt(x^2 + y^2)", damping={"scalar": 1.0}, eps=0.001,
                          momenta={"L": "x*p_y - y*p_x"})


@pytest.mark.parametrize(("method", "tableau"), [("3s", None), ("2s", None), ("rks", "heun")])
def test_momentum_drift_is_measured_from_the_decay_law(method, tableau):
    # Once |L - L(0)| = 0.2175 here, which read as an error; 3s, 2s and rks follow the law to
    # rounding (measured 1.1e-13, 1.0e-13; rks with heun 3.3e-12: its stability function against
    # e^{-eps h}, |z^3/6| = 1.7e-16 a step over 20,000 steps).
    sol = raydamp.integrate(kepler_with_drag(), [1.0, 0.0], [0.0, 1.2], method=method, tableau=tableau, h=0.01,
                            n_steps=20_000, save_every=1000)
    assert sol.success
    assert sol.max_momentum_drift <= 1e-11
    assert sol.summary()["momentum_drift"] == sol.max_momentum_drift
    # The saved L follows the law too, and the law is no constant: L fell by 18%.
    law = 1.2 * np.exp(-0.001 * sol.t)
    assert np.abs(sol.momentum[:, 0] - law).max() <= 1e-11
    assert abs(sol.momentum[-1, 0] - 1.2) > 0.2
    from raydamp.analysis import momentum_drift
    assert momentum_drift(sol, decay_rate=0.001).max() <= 1e-11


def test_momentum_drift_of_heun_under_drag_stays_large():
    sol = raydamp.integrate(kepler_with_drag(), [1.0, 0.0], [0.0, 1.2], method="heun", h=0.01, n_steps=20_000,
                            save_every=1000)
    assert sol.max_momentum_drift > 1e-6  # measured 2.25e-5: Heun does not keep the momentum map


# ---- Issue 28, point 6: at eps = 0, 3s is sv bit for bit (run as sv's table: its damping flows are
# identities, and its merged steps would otherwise split each of sv's drifts h in two: measured 5.6e-12
# apart after 5000 steps on the damped pendulum, 2.3e-11 composed with yoshida4).

def _undamped_cases():
    import systems

    yield "damped_pendulum", *paper_problem("damped_pendulum", 0.0)
    yield "elastic_pendulum", *paper_problem("elastic_pendulum", 0.0)
    yield "two_dof", systems.two_dof().replace(eps=0.0), [1.0, -0.5], [0.0, 0.3]  # a constant damping matrix
    yield "kepler", systems.kepler(0.0), [1.0, 0.0], [0.0, 1.2]  # a dashpot
    yield ("chain", raydamp.Chain(16, bond="fput", parameters={"beta": 1.0}, boundary="periodic",
                                  dampers={"bonds": [0, 5], "c": 0.5}, eps=0.0),
           0.3 * np.sin(np.arange(16.0)), 0.2 * np.cos(np.arange(16.0)))


@pytest.mark.parametrize("composition", [None, "yoshida4"])
@pytest.mark.parametrize("work", [False, True])  # merged steps, and whole steps
def test_3s_at_eps_zero_is_sv_bit_for_bit(composition, work):
    for name, model, q0, p0 in _undamped_cases():
        sv = raydamp.integrate(model, q0, p0, method="sv", composition=composition, h=0.1, n_steps=5000,
                               save_every=500, work=work)
        three = raydamp.integrate(model, q0, p0, method="3s", composition=composition, h=0.1, n_steps=5000,
                                  save_every=500, work=work)
        np.testing.assert_array_equal(three.q, sv.q, err_msg=name)
        np.testing.assert_array_equal(three.p, sv.p, err_msg=name)
        np.testing.assert_array_equal(three.energy, sv.energy, err_msg=name)
