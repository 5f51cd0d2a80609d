"""Done means 1: each exact sub-flow agrees with DOP853 (rtol 1e-12) on its own ODE to 1e-10."""

from __future__ import annotations

import numpy as np
import pytest
from paper import reference

from raydamp.models import DampedPendulum, ElasticPendulum

STATES = {
    "damped_pendulum": ([2.0], [-0.7]),
    "elastic_pendulum": ([0.3, 1.2, -0.6], [1.1, -0.4, 0.25]),
}


def sub_field(model, name):
    """The vector field whose exact flow the named sub-flow claims to be."""
    zero = np.zeros(model.dim)

    def field(q, p):
        qdot, _ = model.vector_field(q, p)
        grad = model.gradient(q)
        damping = -(model.vector_field(q, p)[1] + grad)  # A p
        if name == "drift":
            return qdot, zero
        if name == "kick":
            return zero, -grad
        if name == "damp":
            return zero, -damping
        return zero, -grad - damping  # kick_damp

    return field


@pytest.mark.parametrize("eps", [0.0, 1e-9, 0.01, 0.5, 3.0])
@pytest.mark.parametrize("flow", ["drift", "kick", "damp", "kick_damp"])
def test_sub_flow_matches_its_ode(model_name, flow, eps):
    model = DampedPendulum(eps=eps) if model_name == "damped_pendulum" else ElasticPendulum(
        eps=eps, m=1.3, k=2.0, l=0.9, g=(0.1, 0.0, -1.0))
    q0, p0 = STATES[model_name]
    t = 0.8
    q, p = model.flow(flow, q0, p0, t)
    q_ref, p_ref = reference(sub_field(model, flow), q0, p0, t, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(q, q_ref, rtol=0, atol=1e-10)
    np.testing.assert_allclose(p, p_ref, rtol=0, atol=1e-10)


def test_kick_damp_reduces_to_kick_as_eps_vanishes():
    q0, p0 = STATES["elastic_pendulum"]
    _, p_kick = ElasticPendulum(eps=0.0).flow("kick", q0, p0, 0.3)
    _, p_tiny = ElasticPendulum(eps=1e-12).flow("kick_damp", q0, p0, 0.3)
    np.testing.assert_allclose(p_tiny, p_kick, rtol=0, atol=1e-12)


def test_radial_damping_leaves_the_tangential_momentum():
    q0, p0 = np.array([0.3, 1.2, -0.6]), np.array([1.1, -0.4, 0.25])
    _, p = ElasticPendulum(eps=2.0).flow("damp", q0, p0, 1.0)
    u = q0 / np.linalg.norm(q0)
    np.testing.assert_allclose(p - (p @ u) * u, p0 - (p0 @ u) * u, atol=1e-15)
    assert p @ u == pytest.approx(np.exp(-2.0) * (p0 @ u), rel=1e-14)


def test_unknown_flow_is_refused():
    with pytest.raises(ValueError, match="flow: unknown sub-flow 'kick_drift'"):
        DampedPendulum().flow("kick_drift", [0.1], [0.0], 0.1)
