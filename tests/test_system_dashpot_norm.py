"""One dashpot whose rate a = grad g^T M^{-1} grad g is constant (a spring's length,
a coordinate difference): detected symbolically at construction, its phi1 and phi2
taken once per sub-step length, and its flows run through the compiled projection
P(q, u) = grad g (grad g . M^{-1} u). The constant path must be the general path's
numbers, and a dashpot with a varying a must keep the general path."""

from __future__ import annotations

import math

import numpy as np
import pytest
import symengine as se
from paper import ELASTIC_P0, ELASTIC_Q0
from scipy.linalg import expm
from systems import elastic_pendulum

import raydamp
from raydamp.models import ElasticPendulum
from raydamp.systems.system.compile import _projection, evaluate
from raydamp.systems.system.system import System, _build_core

SPRING = "k/2*(sqrt((x1-x2)^2 + (y1-y2)^2) - 1)^2"
LENGTH = "sqrt((x1-x2)^2 + (y1-y2)^2)"
SPRING_Q0, SPRING_P0 = [0.0, 0.0, 1.3, 0.4], [0.2, -0.5, -0.1, 0.7]


def _spring(mass, damper=LENGTH, c=1.5, eps=0.1):
    return raydamp.System(["x1", "y1", "x2", "y2"], SPRING, parameters={"k": 2.0}, mass=mass, eps=eps,
                          damping={"dampers": [{"on": damper, "c": c}]})


def _general_path(system: System, keep_projection: bool = False) -> System:
    """The same System (the same compiled functions) with the fused 3s body withheld,
    and unless keep_projection the constant norm and the projection too: then the
    dashpot's gradient and phi1 at every q."""
    other = object.__new__(System)
    for key in ("_spec", "momentum_names", "label", "_compiled", "_python"):
        object.__setattr__(other, key, getattr(system, key))
    spec, compiled = system._spec, system._compiled
    if keep_projection:
        addresses, norm = compiled.addresses[:12] + (0, 0), compiled.damper_norm
    else:
        addresses, norm = compiled.addresses[:10] + (0, 0, 0, 0), None
    object.__setattr__(other, "_core_model", _build_core(spec, addresses, [d.c for d in spec.dampers],
                                                         len(spec.momenta), compiled, norm))
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


@pytest.mark.parametrize("mass", [1.0, 2.0, [1.3, 1.3, 2.7, 2.7],
                                  [[1.0, 0.2, 0.0, 0.0], [0.2, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0],
                                   [0.0, 0.0, 0.0, 1.0]]], ids=["unit", "scalar", "diagonal", "dense"])
@pytest.mark.parametrize("damper", [LENGTH, "x1 - x2"])
def test_projection_is_grad_g_times_its_rate(damper, mass):
    # P(q, u) = grad g (grad g . M^{-1} u) at random points, from the compiled gradient.
    s = _spring(mass, damper=damper)
    compiled = s._compiled
    if compiled.damper_norm is None:  # the dense mass couples x1 and y1: a varies along LENGTH
        assert compiled.damper_projection is None and compiled.addresses[10:] == (0, 0, 0, 0)
        return
    inverse = np.linalg.inv(np.asarray(s._spec.mass))
    rng = np.random.default_rng(7)
    for _ in range(5):
        q, u = rng.normal(size=4), rng.normal(size=4)
        grad = evaluate(compiled.damper_gradients, q)
        expected = grad * (grad @ inverse @ u)
        got = evaluate(compiled.damper_projection, np.concatenate([q, u]))
        np.testing.assert_allclose(got, expected, rtol=1e-13, atol=1e-15)


@pytest.mark.parametrize("mass", [1.0, 2.0, [1.3, 1.3, 2.7, 2.7]], ids=["unit", "scalar", "diagonal"])
def test_fused_3s_body_is_its_sub_flows(mass):
    # damp (p - k P(q, p)), drift t0, kick t1, drift t2, from the separate functions.
    s = _spring(mass)
    compiled = s._compiled
    inverse = np.linalg.inv(np.asarray(s._spec.mass))
    rng = np.random.default_rng(3)
    for _ in range(5):
        q, p = rng.normal(size=4), rng.normal(size=4)
        k, t0, t1, t2 = 0.03, 0.05, 0.1, 0.05
        u = p - k * evaluate(compiled.damper_projection, np.concatenate([q, p]))
        q1 = q + t0 * inverse @ u
        p1 = u - t1 * evaluate(compiled.gradient, q1)
        q2 = q1 + t2 * inverse @ p1
        got = evaluate(compiled.damp_then_3s_body, np.concatenate([q, p, [k, t0, t1, t2]]))
        np.testing.assert_allclose(got, np.concatenate([q2, p1]), rtol=1e-14, atol=1e-15)


@pytest.mark.parametrize("system,q0,p0", [
    (lambda: elastic_pendulum(0.1), ELASTIC_Q0, ELASTIC_P0),
    (lambda: _spring([1.3, 1.3, 2.7, 2.7]), SPRING_Q0, SPRING_P0),
], ids=["elastic", "spring-diagonal-mass"])
def test_fused_3s_runs_equal_the_sub_flows(system, q0, p0):
    # Merged 3s (nothing saved for 50 steps) with and without the fused body; J3's drift too.
    fused = system()
    plain = _general_path(fused, keep_projection=True)
    kw = dict(method="3s", h=0.05, n_steps=4000, save_every=50)
    a, b = raydamp.integrate(fused, q0, p0, **kw), raydamp.integrate(plain, q0, p0, **kw)
    scale = max(1.0, float(np.abs(b.p).max()), float(np.abs(b.q).max()))
    assert np.abs(a.q - b.q).max() <= 1e-12 * scale
    assert np.abs(a.p - b.p).max() <= 1e-12 * scale


def test_projection_of_a_distance_dashpot_has_no_square_root():
    # (q.v) q / |q|^2: the sqrt and division of q / |q| stay off the step's serial chain.
    q = [se.Symbol(f"_q{i}") for i in range(3)]
    u = [se.Symbol(f"_p{i}") for i in range(3)]
    g = se.sqrt(q[0] ** 2 + q[1] ** 2 + q[2] ** 2)
    projection = _projection(g, [se.diff(g, qi) for qi in q], q, u, np.eye(3) / 2.0)
    for expr in projection:
        nodes, stack = [], [expr]
        while stack:
            nodes.append(stack.pop())
            stack.extend(nodes[-1].args)
        powers = [a for a in nodes if isinstance(a, se.Pow)]
        assert powers and all(isinstance(a.args[1], se.Integer) for a in powers), expr


@pytest.mark.parametrize("damper,mass", [
    ("(x1^2 + y1^2)/2", 1.0),                    # |grad g| = |q1|
    ("atan2(y1 - y2, x1 - x2)", 1.0),            # an angle: |grad g| = 1/r
    ("x1^2", [1.0, 2.0, 1.0, 2.0]),
    (LENGTH, [[1.0, 0.2, 0.0, 0.0], [0.2, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]]),
])
def test_varying_norm_keeps_the_general_path(damper, mass):
    compiled = _spring(mass, damper=damper)._compiled
    assert compiled.damper_norm is None and compiled.damper_projection is None


def test_several_dashpots_keep_the_general_path():
    s = raydamp.System(["x", "y"], "(x^2+y^2)/2", eps=0.1,
                       damping={"dampers": [{"on": "x - y", "c": 1.0}, {"on": "x + y", "c": 1.0}]})
    assert s._compiled.damper_norm is None and s._compiled.damper_projection is None


@pytest.mark.parametrize("method", ["3s", "2s", "rks", "rksb", "heun"])
@pytest.mark.parametrize("system,q0,p0", [
    (lambda: elastic_pendulum(0.1), ELASTIC_Q0, ELASTIC_P0),
    (lambda: _spring(1.0), SPRING_Q0, SPRING_P0),
    (lambda: _spring([1.3, 1.3, 2.7, 2.7]), SPRING_Q0, SPRING_P0),
], ids=["elastic", "spring", "spring-diagonal-mass"])
def test_constant_norm_path_equals_general_path(method, system, q0, p0):
    constant = system()
    general = _general_path(constant)
    assert constant._compiled.damper_norm is not None and constant._compiled.damper_projection is not None
    kw = dict(method=method, h=0.1, n_steps=2000, save_every=50)
    a = raydamp.integrate(constant, q0, p0, **kw)
    b = raydamp.integrate(general, q0, p0, **kw)
    # Rounding apart: the projection and the fused 3s body round differently from the
    # gradient form (the single flows agree to 1e-15, below), and 2000 steps of the
    # spring, drifting to |q| = 10, grow that to 1e-12.
    scale = max(1.0, float(np.abs(b.p).max()), float(np.abs(b.q).max()))
    assert np.abs(a.q - b.q).max() <= 2e-12 * scale
    assert np.abs(a.p - b.p).max() <= 2e-12 * scale


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
    from raydamp.systems.system import dashpot_norm

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
