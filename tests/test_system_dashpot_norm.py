"""One dashpot whose rate a = grad g^T M^{-1} grad g is constant (a spring's length,
a coordinate difference): detected symbolically at construction, its phi1 and phi2
taken once per sub-step length. The constant path must be the general path's
numbers, and a dashpot with a varying a must keep the general path."""

from __future__ import annotations

import math

import numpy as np
import pytest
import symengine as se
from scipy.linalg import expm

import raydamp
from raydamp.models import ElasticPendulum
from raydamp.system.system import System, _build_core

from paper import ELASTIC_P0, ELASTIC_Q0
from systems import elastic_pendulum

SPRING = "k/2*(sqrt((x1-x2)^2 + (y1-y2)^2) - 1)^2"
LENGTH = "sqrt((x1-x2)^2 + (y1-y2)^2)"
SPRING_Q0, SPRING_P0 = [0.0, 0.0, 1.3, 0.4], [0.2, -0.5, -0.1, 0.7]


def _spring(mass, damper=LENGTH, c=1.5, eps=0.1):
    return raydamp.System(["x1", "y1", "x2", "y2"], SPRING, parameters={"k": 2.0}, mass=mass, eps=eps,
                          damping={"dampers": [{"on": damper, "c": c}]})


def _general_path(system: System) -> System:
    """The same System (the same compiled functions) with the constant norm withheld."""
    other = object.__new__(System)
    for key in ("_spec", "momentum_names", "label", "_compiled", "_python"):
        object.__setattr__(other, key, getattr(system, key))
    spec, compiled = system._spec, system._compiled
    object.__setattr__(other, "_core_model", _build_core(spec, compiled.addresses, [d.c for d in spec.dampers],
                                                         len(spec.momenta), compiled, None))
    other._freeze()
    return other


@pytest.mark.parametrize("make,expected", [
    (lambda: elastic_pendulum(0.1), 1.0),
    (lambda: raydamp.System(3, "q2", mass=2.0, eps=0.1, damping={"dampers": [{"on": "sqrt(q0^2+q1^2+q2^2)",
                                                                              "c": 1.0}]}), 0.5),
    (lambda: _spring(1.0), 2.0),
    (lambda: _spring([1.3, 1.3, 2.7, 2.7]), 1 / 1.3 + 1 / 2.7),
    (lambda: _spring(2.0, damper="sqrt((x1-x2)^2 + (y1-y2)^2)/4"), 2 * 0.5 / 16),
    (lambda: _spring(1.0, damper="x1 - x2"), 2.0),
], ids=["elastic", "mass-2", "spring", "spring-diagonal-mass", "scaled-length", "linear"])
def test_constant_norm_is_detected(make, expected):
    assert make()._compiled.damper_norm == pytest.approx(expected, rel=1e-15)


@pytest.mark.parametrize("damper,mass", [
    ("(x1^2 + y1^2)/2", 1.0),                    # |grad g| = |q1|
    ("atan2(y1 - y2, x1 - x2)", 1.0),            # an angle: |grad g| = 1/r
    ("x1^2", [1.0, 2.0, 1.0, 2.0]),
    (LENGTH, [[1.0, 0.2, 0.0, 0.0], [0.2, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]]),
])
def test_varying_norm_keeps_the_general_path(damper, mass):
    assert _spring(mass, damper=damper)._compiled.damper_norm is None


def test_several_dashpots_keep_the_general_path():
    s = raydamp.System(["x", "y"], "(x^2+y^2)/2", eps=0.1,
                       damping={"dampers": [{"on": "x - y", "c": 1.0}, {"on": "x + y", "c": 1.0}]})
    assert s._compiled.damper_norm is None


@pytest.mark.parametrize("method", ["3s", "2s", "rks", "rksb", "heun"])
@pytest.mark.parametrize("system,q0,p0", [
    (lambda: elastic_pendulum(0.1), ELASTIC_Q0, ELASTIC_P0),
    (lambda: _spring(1.0), SPRING_Q0, SPRING_P0),
    (lambda: _spring([1.3, 1.3, 2.7, 2.7]), SPRING_Q0, SPRING_P0),
], ids=["elastic", "spring", "spring-diagonal-mass"])
def test_constant_norm_path_equals_general_path(method, system, q0, p0):
    constant = system()
    general = _general_path(constant)
    assert constant._compiled.damper_norm is not None
    kw = dict(method=method, h=0.1, n_steps=2000, save_every=50)
    a = raydamp.integrate(constant, q0, p0, **kw)
    b = raydamp.integrate(general, q0, p0, **kw)
    scale = max(1.0, float(np.abs(b.p).max()), float(np.abs(b.q).max()))
    assert np.abs(a.q - b.q).max() <= 1e-13 * scale
    assert np.abs(a.p - b.p).max() <= 1e-13 * scale


def test_elastic_constant_norm_matches_builtin_flows():
    # The single flows at several q, against the built-in radial damping.
    s, builtin = elastic_pendulum(0.7), ElasticPendulum(eps=0.7)
    for q in ([0.0, 1.55884573, -0.6], [0.3, -0.2, 2.0], [-1.0, 0.5, 0.1]):
        for flow in ("damp", "kick_damp"):
            for t in (1e-3, 0.05, 0.9):
                _, p_sys = s.flow(flow, q, [1.0, -0.3, 0.4], t)
                _, p_ref = builtin.flow(flow, q, [1.0, -0.3, 0.4], t)
                np.testing.assert_allclose(p_sys, p_ref, rtol=0, atol=1e-15)


@pytest.mark.parametrize("damper,mass", [
    (LENGTH, [1.3, 1.3, 2.7, 2.7]),              # constant a
    (LENGTH, 2.0),                               # constant a, scalar mass
    ("(x1^2 + y1^2)/2", 2.0),                    # varying a, scalar mass
    ("(x1^2 + y1^2)/2", [1.3, 1.3, 2.7, 2.7]),   # varying a, dense kind
])
def test_single_dashpot_flows_match_expm(damper, mass):
    eps, c = 0.4, 1.5
    s = _spring(mass, damper=damper, c=c, eps=eps)
    m = np.diag(np.broadcast_to(np.asarray(mass, dtype=float), (4,)))
    q, p = np.array([0.1, -0.3, 1.2, 0.5]), np.array([1.0, -2.0, 0.5, 0.25])
    x1, y1, x2, y2 = q
    if damper == LENGTH:
        r = math.hypot(x1 - x2, y1 - y2)
        grad = np.array([x1 - x2, y1 - y2, x2 - x1, y2 - y1]) / r
    else:
        grad = np.array([x1, y1, 0.0, 0.0])
    a = eps * c * np.outer(grad, grad) @ np.linalg.inv(m)
    g = s.gradient(q)
    aug = np.zeros((5, 5))
    aug[:4, :4] = -a
    aug[:4, 4] = -g
    for t in (0.01, 0.3, 2.0):
        _, p_damp = s.flow("damp", q, p, t)
        np.testing.assert_allclose(p_damp, expm(-t * a) @ p, rtol=0, atol=1e-14)
        _, p_kd = s.flow("kick_damp", q, p, t)
        expected = (expm(t * aug) @ np.append(p, 1.0))[:4]
        np.testing.assert_allclose(p_kd, expected, rtol=0, atol=1e-14 * max(1.0, np.abs(expected).max()))


def _cable(segments: int) -> str:
    """The total length of a planar cable through segments + 1 points: a realistic dashpot
    whose a(q) is not constant and holds one square root per segment."""
    return " + ".join(f"sqrt((x{i + 1}-x{i})^2 + (y{i + 1}-y{i})^2)" for i in range(segments))


def test_detection_never_expands_a_dashpot_with_many_radicals(monkeypatch):
    # Putting a(q) over one common denominator multiplies out the product of its radicals:
    # measured 109 s for 8 segments, x8 per segment. The numeric check (a varies) and the
    # radical count must keep the symbolic proof from ever starting on such a dashpot.
    from raydamp.system import dashpot_norm

    def refuse(_):
        raise AssertionError("the symbolic proof ran")

    monkeypatch.setattr(dashpot_norm, "_symbolic_constant", refuse)
    coordinates = [f"{axis}{i}" for i in range(11) for axis in "xy"]
    cable = raydamp.System(coordinates, "0", eps=0.1, damping={"dampers": [{"on": _cable(10), "c": 1.0}]})
    assert cable._compiled.damper_norm is None
    # and the radical budget alone would stop it too: a(q) of the cable keeps the products of
    # neighbouring segments' square roots
    symbols = [se.Symbol(name) for name in coordinates]
    g = sum((se.sqrt((symbols[2 * i + 2] - symbols[2 * i]) ** 2 + (symbols[2 * i + 3] - symbols[2 * i + 1]) ** 2)
             for i in range(10)), se.Integer(0))
    form = dashpot_norm._quadratic_form([se.diff(g, s) for s in symbols], np.eye(22))
    assert dashpot_norm._radicals(form) > dashpot_norm._MAX_RADICALS
