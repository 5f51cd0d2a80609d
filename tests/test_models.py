"""The models: formulas, derivatives, parameter checks, and the catalogue."""

from __future__ import annotations

import inspect

import numpy as np
import pytest

from raydamp.models import DampedPendulum, ElasticPendulum, describe_models, make_model


def finite_difference_gradient(f, q, step=1e-6):
    q = np.asarray(q, dtype=float)
    grad = np.zeros_like(q)
    for i in range(q.size):
        e = np.zeros_like(q)
        e[i] = step
        grad[i] = (f(q + e) - f(q - e)) / (2 * step)
    return grad


@pytest.mark.parametrize(("model", "q"), [
    (DampedPendulum(0.3), [2.1]),
    (ElasticPendulum(0.1, m=1.5, k=2.0, l=0.8, g=(0.2, -0.1, -9.81)), [0.3, 1.2, -0.6]),
])
def test_gradient_matches_potential(model, q):
    # Central differences at step 1e-6 are good to ~1e-9 here.
    np.testing.assert_allclose(model.gradient(q), finite_difference_gradient(model.potential, q), rtol=0, atol=1e-8)
    v = np.linspace(0.3, -0.5, len(q))
    hv = np.asarray(model._core_model.hessian_product(np.asarray(q, float), v)).ravel()
    fd = (model.gradient(np.asarray(q) + 1e-6 * v) - model.gradient(np.asarray(q) - 1e-6 * v)) / 2e-6
    np.testing.assert_allclose(hv, fd, rtol=0, atol=1e-7)


def test_elastic_formulas():
    model = ElasticPendulum(eps=0.2, m=2.0, k=3.0, l=0.5, g=(0.0, 0.0, -1.0))
    q, p = np.array([0.3, 1.2, -0.6]), np.array([1.1, -0.4, 0.25])
    r = np.linalg.norm(q)
    assert model.potential(q) == pytest.approx(1.5 * (0.5 - r) ** 2 - 2.0 * (-1.0) * (-0.6), rel=1e-14)
    assert model.energy(q, p) == pytest.approx(p @ p / 4.0 + model.potential(q), rel=1e-14)
    qdot, pdot = model.vector_field(q, p)
    np.testing.assert_allclose(qdot, p / 2.0, rtol=1e-15)
    expected = -3.0 * (1 - 0.5 / r) * q + 2.0 * np.array([0, 0, -1.0]) - 0.2 * q * (q @ p) / (2.0 * r * r)
    np.testing.assert_allclose(pdot, expected, rtol=1e-14)
    assert model.momenta(q, p)[0] == pytest.approx(q[0] * p[1] - q[1] * p[0], rel=1e-15)


@pytest.mark.parametrize(("factory", "message"), [
    (lambda: DampedPendulum(eps=-0.1), "eps must be >= 0"),
    (lambda: ElasticPendulum(m=0.0), "m must be > 0"),
    (lambda: ElasticPendulum(k=-1.0), "k must be >= 0"),
    (lambda: ElasticPendulum(l=float("nan")), "l must be finite"),
    (lambda: ElasticPendulum(g=(0, 0)), "g must have length 3"),
    (lambda: DampedPendulum(eps="big"), "eps must be a real number"),
])
def test_bad_parameters_are_named(factory, message):
    with pytest.raises(ValueError, match=message):
        factory()


def test_describe_models_reflects_the_signatures():
    described = {m["name"]: m for m in describe_models()}
    assert described["damped_pendulum"]["dim"] == 1 and described["damped_pendulum"]["momenta"] == []
    assert described["elastic_pendulum"]["momenta"] == ["J3"]
    for cls in (DampedPendulum, ElasticPendulum):
        params = inspect.signature(cls).parameters
        for p in described[cls.name]["parameters"]:
            default = params[p["name"]].default
            assert p["default"] == (list(default) if isinstance(default, tuple) else default)


def test_make_model():
    assert make_model("elastic_pendulum", {"eps": 0.01}).parameters["eps"] == 0.01
    with pytest.raises(ValueError, match="model: unknown model 'double_pendulum'"):
        make_model("double_pendulum")
    with pytest.raises(ValueError, match="parameters.mass: elastic_pendulum has no parameter 'mass'"):
        make_model("elastic_pendulum", {"mass": 2.0})
