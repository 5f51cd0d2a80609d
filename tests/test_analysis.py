"""raydamp.analysis: the diagnostics behave as documented on cases with known answers."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from paper import ELASTIC_P0, ELASTIC_Q0, PENDULUM_P0, PENDULUM_Q0

import raydamp
from raydamp.analysis import (
    cartesian_state,
    convergence,
    distance_from,
    energy_error,
    modified_energy,
    modified_relative_equilibrium,
    momentum_drift,
    reduced_coordinates,
    reference_solution,
    relative_equilibrium,
)
from raydamp.analysis.relative_equilibrium import equilibrium_residual
from raydamp.models import DampedPendulum, ElasticPendulum


def test_convergence_reports_errors_and_order():
    model = DampedPendulum(0.5)
    result = convergence(model, "2s", [0.1, 0.05, 0.025], q0=PENDULUM_Q0, p0=PENDULUM_P0, t_end=5.0)
    assert result.errors.shape == (3,) and np.all(np.diff(result.errors) < 0)
    assert result.order == pytest.approx(2, abs=0.1)
    with pytest.raises(ValueError, match="hs must hold at least two"):
        convergence(model, "2s", [0.1], q0=PENDULUM_Q0, p0=PENDULUM_P0)


def test_energy_error_of_rk4_is_tiny_and_heun_is_not():
    model = ElasticPendulum(0.1)
    fine = raydamp.integrate(model, ELASTIC_Q0, ELASTIC_P0, method="rk4", h=0.01, t_end=20.0, save_every=100)
    ref = reference_solution(model, ELASTIC_Q0, ELASTIC_P0, fine.t)
    assert np.abs(energy_error(model, fine, ref)).max() < 1e-8
    coarse = raydamp.integrate(model, ELASTIC_Q0, ELASTIC_P0, method="heun", h=0.2, t_end=20.0)
    assert np.abs(energy_error(model, coarse)).max() > 1e-4
    with pytest.raises(ValueError, match="reference: its times differ"):
        energy_error(model, coarse, ref)


def test_energy_balance_closes_for_the_exact_solution_limit():
    # rk4 integrates the work with its own stages: the balance is O(h^4).
    model = DampedPendulum(0.3)
    sols = [raydamp.integrate(model, PENDULUM_Q0, PENDULUM_P0, method="rk4", h=h, t_end=10.0, work=True)
            for h in (0.1, 0.05)]
    balances = [np.abs(s.energy_balance).max() for s in sols]
    assert np.log2(balances[0] / balances[1]) == pytest.approx(4, abs=0.3)
    assert sols[0].work[-1] == pytest.approx(sols[0].energy[0] - sols[0].energy[-1], rel=1e-4)
    with pytest.raises(ValueError, match="work: this run did not record"):
        _ = raydamp.integrate(model, PENDULUM_Q0, PENDULUM_P0, h=0.1, n_steps=5).energy_balance


def test_modified_energy_is_h_and_model_aware():
    model = DampedPendulum(0.0)
    q, p = np.array([[0.3]]), np.array([[0.4]])
    h = 0.1
    expected = 0.5 * 0.16 + (1 - np.cos(0.3)) + h * h * (np.sin(0.3) ** 2 / 12 - np.cos(0.3) * 0.16 / 24)
    assert modified_energy(model, q, p, h)[0] == pytest.approx(expected, rel=1e-14)
    assert modified_energy(model, q, p, 0.0)[0] == pytest.approx(model.energy([0.3], [0.4]), rel=1e-15)


def test_reduced_coordinates_round_trip_and_momentum_drift():
    q, p = cartesian_state(1.2, -0.5, 0.3, -0.1, 0.7)
    np.testing.assert_allclose(reduced_coordinates(q, p)[0], [1.2, -0.5, 0.3, -0.1, 0.7], atol=1e-15)
    sol = raydamp.integrate(ElasticPendulum(0.1), q, p, method="heun", h=0.1, n_steps=100)
    drift = momentum_drift(sol)
    assert drift.shape == (101, 1) and drift[0, 0] == 0 and drift[-1, 0] > 0


@pytest.mark.parametrize("mu", [0.3, -1.39, 4.0])
def test_relative_equilibrium_solves_the_reduced_equations(mu):
    model = ElasticPendulum(0.1, m=1.3, k=3.0, l=0.8)
    eq = relative_equilibrium(model, mu)
    assert np.abs(equilibrium_residual(model, eq.rho, eq.z, mu)).max() < 1e-12
    # Started there, the exact flow (and rk4 at small h) stays there.
    q, p = cartesian_state(eq.rho, eq.z, 0.0, 0.0, mu)
    sol = raydamp.integrate(model, q, p, method="rk4", h=0.01, t_end=5.0, save_every=50)
    assert distance_from(eq, sol).max() < 1e-8


def test_analysis_names_bad_arguments():
    with pytest.raises(ValueError, match="p: give the momenta"):
        distance_from(relative_equilibrium(ElasticPendulum(), 1.0), np.ones((2, 3)))
    with pytest.raises(ValueError, match="q0 must have length 1"):
        reference_solution(DampedPendulum(), [1.0, 2.0], [0.0], [0.0, 1.0])


def test_relative_equilibrium_refuses_bad_input():
    with pytest.raises(ValueError, match="mu must be finite and nonzero"):
        relative_equilibrium(ElasticPendulum(), 0.0)
    with pytest.raises(ValueError, match="g must point straight down"):
        relative_equilibrium(ElasticPendulum(g=(0.1, 0, -1)), 1.0)


def test_modified_relative_equilibrium_is_a_fixed_point_of_the_step():
    model = ElasticPendulum(0.1, k=10.0)
    mu = -1.3942740046346698
    mod = modified_relative_equilibrium(model, "3s", 0.2, mu)
    q, p = cartesian_state(*mod.reduced, mu)
    sol = raydamp.integrate(model, q, p, method="3s", h=0.2, n_steps=50)
    assert distance_from(mod, sol).max() < 1e-10
    # At eps = 0 the three splittings are Stormer-Verlet and share it.
    undamped = ElasticPendulum(0.0, k=10.0)
    offsets = [modified_relative_equilibrium(undamped, m, 0.2, mu).reduced for m in ("3s", "2s", "rks")]
    np.testing.assert_allclose(offsets[1], offsets[0], atol=1e-12)
    np.testing.assert_allclose(offsets[2], offsets[0], atol=1e-12)


# --- the exact response to a piecewise-linear load --------------------------------------------------

def _ramp_response(m: float, c: float, k: float, t: np.ndarray, derivative: bool = False) -> np.ndarray:
    """u(t) (or u'(t)) of m u'' + c u' + k u = t (t >= 0), from rest, underdamped: the particular
    solution (t - c/k)/k plus the free vibration that starts it at rest (0 for t < 0)."""
    tau = np.maximum(t, 0.0)
    sigma, wd = c / (2 * m), np.sqrt(k / m - (c / (2 * m)) ** 2)
    A = c / k ** 2
    B = (sigma * A - 1 / k) / wd
    decay, cos, sin = np.exp(-sigma * tau), np.cos(wd * tau), np.sin(wd * tau)
    if derivative:
        value = 1 / k + decay * ((wd * B - sigma * A) * cos - (sigma * B + wd * A) * sin)
    else:
        value = (tau - c / k) / k + decay * (A * cos + B * sin)
    return np.where(t > 0, value, 0.0)


def _piecewise_linear_closed_form(m, c, k, knots, values, t, derivative: bool = False):
    """A piecewise-linear a(t) from a(0) = 0 is a sum of ramps starting at the knots, each with the change
    of slope there: the response is the same sum of ramp responses (superposition)."""
    slopes = np.diff(values) / np.diff(knots)
    changes = np.diff(np.concatenate([[0.0], slopes, [0.0]]))
    return sum(dk * _ramp_response(m, c, k, t - tk, derivative) for tk, dk in zip(knots, changes))


def test_piecewise_linear_response_of_an_sdof_matches_the_closed_form():
    """Uneven samples, a triangle pulse then a return to zero and free vibration: to 1e-12 of the peak."""
    from raydamp.analysis import piecewise_linear_response

    m, c, k = 2.0, 0.3, 5.0
    knots = np.array([0.0, 0.3, 0.5, 1.2, 2.0, 2.05, 3.0, 7.5, 9.0])
    values = np.array([0.0, 1.0, -0.5, 0.2, 0.0, 0.4, 0.0, 0.0, 0.0])
    q, p = piecewise_linear_response(m, c, k, [1.7], knots, values)
    exact = 1.7 * _piecewise_linear_closed_form(m, c, k, knots, values, knots)
    peak = np.max(np.abs(exact))
    assert np.max(np.abs(q[:, 0] - exact)) <= 1e-12 * peak and peak > 0.05
    velocity = 1.7 * _piecewise_linear_closed_form(m, c, k, knots, values, knots, derivative=True)
    assert np.max(np.abs(p[:, 0] - m * velocity)) <= 1e-12 * np.max(np.abs(m * velocity))  # p = m u'


def test_piecewise_linear_response_of_a_rayleigh_damped_system_is_its_modes():
    """Two coordinates, C = alpha M + beta K: the modes decouple (Phi^T M Phi = I), each mode an SDOF
    under (Phi^T d) a(t) with damping alpha + beta w^2, whose closed form gives q = Phi eta; and a start
    from (q0, p0) adds the free vibration, expm(t A) of the state."""
    from raydamp.analysis import piecewise_linear_response

    M = np.array([[2.0, 0.3], [0.3, 1.0]])
    K = np.array([[6.0, -2.0], [-2.0, 3.0]])
    alpha, beta = 0.1, 0.02
    C = alpha * M + beta * K
    d = np.array([0.5, -1.0])
    knots = np.linspace(0.0, 6.0, 61)
    values = np.sin(1.3 * knots) * np.exp(-0.2 * knots) * (knots < 4.0)
    values[0] = 0.0
    q, _ = piecewise_linear_response(M, C, K, d, knots, values)
    w2, Phi = scipy.linalg.eigh(K, M)
    eta = np.column_stack([(Phi[:, j] @ d) * _piecewise_linear_closed_form(1.0, alpha + beta * w2[j], w2[j], knots,
                                                                          values, knots) for j in range(2)])
    exact = eta @ Phi.T
    assert np.max(np.abs(q - exact)) <= 1e-12 * np.max(np.abs(exact))
    q0, p0 = np.array([0.2, -0.1]), np.array([0.0, 0.4])
    started, momenta = piecewise_linear_response(M, C, K, d, knots, values, q0=q0, p0=p0)
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    free = np.array([scipy.linalg.expm(tk * A) @ np.concatenate([q0, np.linalg.solve(M, p0)]) for tk in knots])
    np.testing.assert_allclose(started, exact + free[:, :2], atol=1e-12)
    np.testing.assert_allclose(momenta[0], p0, atol=1e-15)


@pytest.mark.parametrize(("arguments", "message"), [
    (dict(M=np.eye(2), C=np.eye(3)), r"C must be an 2 x 2 matrix"),
    (dict(direction=[1.0]), r"direction must be 2 finite numbers"),
    (dict(t=[0.0, 1.0, 1.0], values=[0.0, 1.0, 2.0]), r"t must increase: t\[2\]"),
    (dict(values=[0.0, 1.0]), r"values must be 3 finite numbers"),
    (dict(M=np.zeros((2, 2))), r"M must be invertible"),
])
def test_piecewise_linear_response_names_a_bad_argument(arguments, message):
    from raydamp.analysis import piecewise_linear_response

    given = dict(M=np.eye(2), C=np.zeros((2, 2)), K=np.eye(2), direction=[1.0, 0.0], t=[0.0, 0.5, 1.0],
                 values=[0.0, 1.0, 0.0]) | arguments
    with pytest.raises(ValueError, match=message):
        piecewise_linear_response(**given)


@pytest.mark.parametrize("mu", [1e-14, -3e-13])
def test_relative_equilibrium_at_a_tiny_momentum(mu):
    """rho grows like sqrt(|mu|): below about mu = 1e-12 the root lay under the bracket's fixed 1e-6, and
    SciPy's 'f(a) and f(b) must have different signs' came out."""
    model = ElasticPendulum()
    eq = relative_equilibrium(model, mu)
    assert 0 < eq.rho < 1e-6
    # (the vertical balance's residual is rounding of z's 2.0 amplified by the stiff rho^4 dependence: 8e-11,
    # as at mu = 1e-9, which was solved before)
    assert np.abs(equilibrium_residual(model, eq.rho, eq.z, mu)).max() < 1e-9


def test_energy_error_of_a_forced_run_is_against_a_forced_reference():
    """The reference ignored the run's load: rk4's 'error' at h = 0.001 was 2.16, the load's effect."""
    model = DampedPendulum(eps=0.1)
    load = raydamp.Load.harmonic([1.0], 1.0)
    sol = raydamp.integrate(model, [1.0], [0.0], method="rk4", h=0.001, t_end=10, load=load, save_every=1000)
    assert np.abs(energy_error(model, sol)).max() < 1e-10
    ground = raydamp.GroundMotion(raydamp.Load.harmonic(0.5, 2.0), [1.0])
    sol = raydamp.integrate(model, [1.0], [0.0], method="rk4", h=0.001, t_end=5, load=ground, save_every=1000)
    assert np.abs(energy_error(model, sol)).max() < 1e-10


def test_analysis_refuses_what_it_cannot_read():
    """Each was another exception than a ValueError naming the argument (an audit)."""
    model, eq = ElasticPendulum(eps=0.1), relative_equilibrium(ElasticPendulum(eps=0.1), -2.0)
    with pytest.raises(ValueError, match=r"^mu must be a real number"):
        relative_equilibrium(model, "1")  # a TypeError
    q, p = cartesian_state(*eq)
    permuted = raydamp.integrate(model, q, p, method="rk4", h=0.01, t_end=0.1, save_dofs=[2, 0, 1])
    with pytest.raises(ValueError, match=r"^solution: distance_from needs x, y and z saved in order"):
        distance_from(eq, permuted)  # 2.25 where the full run gives 4e-11
    pendulum = DampedPendulum()
    with pytest.raises(ValueError, match=r"^t_end must be > 0"):
        convergence(pendulum, "3s", [0.1, 0.05], q0=[1.0], p0=[0.0], t_end=0)  # an AttributeError
    for t_eval in (5.0, [0.0, -1.0], [[0.0, 1.0]], [0.0, np.nan]):
        with pytest.raises(ValueError, match=r"^t_eval must be a 1-D array"):
            reference_solution(pendulum, [1.0], [0.0], t_eval)  # an IndexError, or NumPy's own message
    with pytest.raises(ValueError, match=r"^t must be a time or a 1-D array of times"):
        raydamp.Load.harmonic([1.0], 1.0).values(pendulum, [[0.0, 1.0]])  # the binding's TypeError


@pytest.mark.parametrize("tolerances, name", [({"rtol": float("nan")}, "rtol"), ({"atol": float("nan")}, "atol"),
                                              ({"rtol": float("inf")}, "rtol"), ({"rtol": 0.0, "atol": 0.0}, "rtol"),
                                              ({"rtol": "x"}, "rtol"), ({"atol": -1.0}, "atol")])
def test_reference_solution_checks_its_tolerances(tolerances, name):
    # SciPy took them unchecked: NaN, inf or rtol = atol = 0 ran for minutes (over 120 s for one time unit of a
    # pendulum); "x" was a UFuncTypeError and a negative atol SciPy's message naming the other (API audit).
    with pytest.raises(ValueError, match=rf"^{name} must be"):
        reference_solution(DampedPendulum(), [1.0], [0.0], [0.0, 1.0], **tolerances)
