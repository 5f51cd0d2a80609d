"""Dashpots with holonomic constraints (issue 45): the damping flow of P eps D(q) M^-1 on the constraints'
tangent space, against the same mechanics written in joint angles (solve_ivp DOP853 at rtol 1e-13), where a
dashpot on h(q) is the generalised force -eps c (dh/dt) dh/dtheta."""

from __future__ import annotations

import math

import numpy as np
import pytest
from paper import fitted_slope
from scipy.integrate import solve_ivp

import raydamp

G = 9.81
M1, M2, L1, L2 = 1.0, 0.7, 1.0, 0.8
EPS, C_TIP, C_ELBOW = 0.4, 1.5, 0.8


def double_pendulum_with_dashpots(eps=EPS):
    """Two rods; a dashpot on the tip's horizontal position x2 and one on the elbow's height y1."""
    return raydamp.System(["x1", "y1", "x2", "y2"], "g*(m1*y1 + m2*y2)",
                          parameters={"g": G, "m1": M1, "m2": M2, "a": L1, "b": L2}, mass=[M1, M1, M2, M2],
                          damping={"dampers": [{"on": "x2", "c": C_TIP}, {"on": "y1", "c": C_ELBOW}]}, eps=eps,
                          constraints=["x1^2 + y1^2 - a^2", "(x2 - x1)^2 + (y2 - y1)^2 - b^2"])


def joint_angle_rhs(t, y, eps=EPS):
    """Angles a, b from the downward vertical: M(th) th'' = f(th, th') + Q, Q the dashpots' generalised force."""
    a, b, wa, wb = y
    c, s = math.cos(a - b), math.sin(a - b)
    mass = np.array([[(M1 + M2) * L1**2, M2 * L1 * L2 * c], [M2 * L1 * L2 * c, M2 * L2**2]])
    f = np.array([-M2 * L1 * L2 * s * wb**2 - (M1 + M2) * G * L1 * math.sin(a),
                  M2 * L1 * L2 * s * wa**2 - M2 * G * L2 * math.sin(b)])
    # x2 = L1 sin a + L2 sin b, y1 = -L1 cos a: their gradients in (a, b) and rates
    dx2 = np.array([L1 * math.cos(a), L2 * math.cos(b)])
    dy1 = np.array([L1 * math.sin(a), 0.0])
    q_force = -eps * (C_TIP * (dx2 @ [wa, wb]) * dx2 + C_ELBOW * (dy1 @ [wa, wb]) * dy1)
    acc = np.linalg.solve(mass, f + q_force)
    return [wa, wb, acc[0], acc[1]]


def cartesian(state):
    a, b, wa, wb = state
    x1, y1 = L1 * math.sin(a), -L1 * math.cos(a)
    x2, y2 = x1 + L2 * math.sin(b), y1 - L2 * math.cos(b)
    v1 = np.array([L1 * math.cos(a) * wa, L1 * math.sin(a) * wa])
    v2 = v1 + np.array([L2 * math.cos(b) * wb, L2 * math.sin(b) * wb])
    return np.array([x1, y1, x2, y2]), np.concatenate([M1 * v1, M2 * v2])


STATE0 = [1.2, -0.5, 0.3, 1.1]
T_END = 1.5


def reference(t_end=T_END):
    sol = solve_ivp(joint_angle_rhs, (0, t_end), STATE0, method="DOP853", rtol=1e-13, atol=1e-14)
    return cartesian(sol.y[:, -1])


@pytest.mark.parametrize("method,composition,hs,order", [
    ("3s", None, [0.02, 0.01, 0.005], 2), ("2s", None, [0.02, 0.01, 0.005], 2),
    ("baoab", None, [0.02, 0.01, 0.005], 2), ("3s", "yoshida4", [0.04, 0.02, 0.01], 4),
])
def test_double_pendulum_with_dashpots_matches_the_joint_angle_equations(method, composition, hs, order):
    exact_q, exact_p = reference()
    q0, p0 = cartesian(STATE0)
    system = double_pendulum_with_dashpots()
    errors = []
    for h in hs:
        sol = raydamp.integrate(system, q0, p0, method=method, composition=composition, h=h, t_end=T_END,
                                save_every=100_000)
        assert sol.status == "completed", sol.message
        assert sol.constraint_residual <= 1e-12
        errors.append(float(max(np.max(np.abs(sol.q[-1] - exact_q)), np.max(np.abs(sol.p[-1] - exact_p)))))
    slope = fitted_slope(hs, errors)
    assert order - 0.2 <= slope <= order + 0.4, (errors, slope)


def test_the_dashpots_do_the_work_they_take():
    # Energy balance H - H0 + W = O(h^2), W = eps int v^T D v dt: the dashpots' power on the tangent velocity.
    q0, p0 = cartesian(STATE0)
    balance = []
    hs = [0.02, 0.01, 0.005]
    for h in hs:
        sol = raydamp.integrate(double_pendulum_with_dashpots(), q0, p0, method="3s", h=h, t_end=3.0, save_every=1,
                                work=True)
        balance.append(float(np.max(np.abs(sol.energy_balance))))
    assert 1.8 <= fitted_slope(hs, balance) <= 2.4, balance
    assert sol.work[-1] > 0.1 * abs(sol.energy[0] - sol.energy[-1])  # the dashpots did take energy


def test_the_damping_sub_flow_is_the_exact_flow_of_the_projected_operator():
    # One damp of length t at frozen q against expm of -t P eps D M^-1 (scipy), P the M-orthogonal projector.
    from scipy.linalg import expm

    system = double_pendulum_with_dashpots()
    q, p = cartesian(STATE0)
    t = 0.7
    mass = np.diag([M1, M1, M2, M2])
    Gq = system.constraint_jacobian(q)
    minv = np.linalg.inv(mass)
    P = np.eye(4) - Gq.T @ np.linalg.solve(Gq @ minv @ Gq.T, Gq @ minv)
    tip, elbow = np.array([0, 0, 1.0, 0]), np.array([0, 1.0, 0, 0])
    D = C_TIP * np.outer(tip, tip) + C_ELBOW * np.outer(elbow, elbow)
    exact = expm(-t * P @ (EPS * D) @ minv) @ p
    _, flowed = system._core_model.constrained_flow("damp", q, p, t)
    np.testing.assert_allclose(flowed, exact, rtol=0, atol=1e-14 * np.linalg.norm(p))
    # not the free flow then the projection: that differs here by far more than rounding
    free = P @ expm(-t * EPS * D @ minv) @ p
    assert np.max(np.abs(free - exact)) > 1e-3 * np.linalg.norm(p)


def test_a_pendulum_with_a_dashpot_at_a_temperature_samples_the_constrained_boltzmann_law():
    # A planar pendulum, V = m g y with y up, and one dashpot on x (it damps the tangent velocity by cos^2 of the
    # angle from the vertical, and its noise must have the same projected shape): <y / l> = -I1(a) / I0(a),
    # a = m g l / kT, and the kinetic temperature <|p|^2 / m> = kT (one tangent direction).
    from scipy.special import i0, i1

    kT, a, members = 0.5, 2.0, 200
    system = raydamp.System(["x", "y"], "y", mass=1.0, damping={"dampers": [{"on": "x", "c": 3.0}]}, eps=1.0,
                            constraints=["x^2 + y^2 - 1"])
    ens = raydamp.integrate_ensemble(system, np.tile([1.0, 0.0], (members, 1)), np.zeros((members, 2)),
                                     method="baoab", h=0.1, t_end=230.0, save_every=5, temperature=kT, seed=7,
                                     threads=1)
    assert ens.status == ("completed",) * members
    keep = ens.t > 30
    for values, exact in ((ens.q[:, keep, 1], -i1(a) / i0(a)), ((ens.p[:, keep] ** 2).sum(axis=2), kT)):
        means = values.mean(axis=1)
        se = means.std(ddof=1) / np.sqrt(members)
        assert abs(values.mean() - exact) <= 3 * se, (values.mean(), exact, se)
        assert se <= 0.02 * abs(exact)


def test_rks_with_dashpots_is_first_order_as_documented():
    # rks's Runge-Kutta step of kick+damp uses the free field, then projects: with dashpots the projection does
    # not commute with D M^-1, and the method drops to order 1 (the README and System's docstring say so).
    exact_q, exact_p = reference()
    q0, p0 = cartesian(STATE0)
    hs, errors = [0.02, 0.01, 0.005], []
    for h in hs:
        sol = raydamp.integrate(double_pendulum_with_dashpots(), q0, p0, method="rks", h=h, t_end=T_END,
                                save_every=100_000)
        errors.append(float(max(np.max(np.abs(sol.q[-1] - exact_q)), np.max(np.abs(sol.p[-1] - exact_p)))))
    assert 0.9 <= fitted_slope(hs, errors) <= 1.3, errors  # measured 1.11
