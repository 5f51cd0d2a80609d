"""Test helpers: the paper's initial conditions, a high-accuracy reference solver, slope fits."""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

from raydamp.models import DampedPendulum, ElasticPendulum

# Paper section 4.3 and 6.2.
PENDULUM_Q0, PENDULUM_P0 = [0.9 * math.pi], [0.0]
ELASTIC_Q0, ELASTIC_P0 = [0.0, 1.55884573, -0.6], [1.34164079, 0.0, 0.0]


def paper_problem(name: str, eps: float):
    """(model, q0, p0) for the paper's damped or elastic pendulum."""
    if name == "damped_pendulum":
        return DampedPendulum(eps=eps), PENDULUM_Q0, PENDULUM_P0
    return ElasticPendulum(eps=eps), ELASTIC_Q0, ELASTIC_P0


def reference(field, q0, p0, t: float, rtol: float = 1e-13, atol: float = 1e-13) -> tuple[np.ndarray, np.ndarray]:
    """DOP853 solution at time t of (q, p)' = field(q, p)."""
    n = len(q0)

    def rhs(_t, z):
        dq, dp = field(z[:n], z[n:])
        return np.concatenate([dq, dp])

    sol = solve_ivp(rhs, (0.0, t), np.concatenate([q0, p0]).astype(float), method="DOP853", rtol=rtol, atol=atol)
    assert sol.success, sol.message
    return sol.y[:n, -1], sol.y[n:, -1]


def fitted_slope(hs, errors) -> float:
    """Least-squares slope of log(error) against log(h)."""
    return float(np.polyfit(np.log(hs), np.log(errors), 1)[0])
