"""The fused 3s body of a System with one constant-norm dashpot is derived from the 3s
table the compiled core exports (``_core.splitting``), not written again by hand: it
equals the hand-written body it replaced, and a different table gives a different body.
(That a run with the fused body equals the run through its sub-flows one by one is
test_system_dashpot_norm.py, test_fused_3s_runs_equal_the_sub_flows.)"""

from __future__ import annotations

import numpy as np
import pytest
import symengine as se
from paper import ELASTIC_P0, ELASTIC_Q0
from systems import elastic_pendulum

import raydamp
from raydamp import _core
from raydamp.systems.system import compile as compile_module
from raydamp.systems.system.compile import _projection, _times_inverse, evaluate, fused_body, number

SPRING = "k/2*(sqrt((x1-x2)^2 + (y1-y2)^2) - 1)^2"
LENGTH = "sqrt((x1-x2)^2 + (y1-y2)^2)"
# 3s with its inner sub-flows in the other order: damp, kick, drift, kick, damp.
KICK_DRIFT_KICK = [("damp", 0.5), ("kick", 0.5), ("drift", 1.0), ("kick", 0.5), ("damp", 0.5)]


def _spring(mass) -> raydamp.System:
    return raydamp.System(["x1", "y1", "x2", "y2"], SPRING, parameters={"k": 2.0}, mass=mass, eps=0.1,
                          damping={"dampers": [{"on": LENGTH, "c": 1.5}]})


SYSTEMS = {
    "elastic": lambda: elastic_pendulum(0.1),
    "spring-scalar-mass": lambda: _spring(2.0),
    "spring-diagonal-mass": lambda: _spring([1.3, 1.3, 2.7, 2.7]),
}


def _expressions(system: raydamp.System):
    """What compile_system builds the fused body from: the projection, grad V, the
    symbols and M^{-1}."""
    spec = system._spec
    q = [se.Symbol(f"_q{i}") for i in range(spec.n)]
    p = [se.Symbol(f"_p{i}") for i in range(spec.n)]
    symbols = {name: number(value) for name, value in spec.parameters.items()}
    symbols.update(zip(spec.coordinates, q))
    gradient = [se.diff(spec.potential.to_symengine(symbols), qi) for qi in q]
    g = spec.dampers[0].on.to_symengine(symbols)
    inverse = np.linalg.inv(spec.mass)
    projection = _projection(g, [se.diff(g, qi) for qi in q], q, p, inverse)
    return projection, gradient, q, p, inverse


def _hand_written(projection, gradient, q, p, inverse):
    """The body as compile.py wrote it by hand before it was derived from the table."""
    k, t0, t1, t2 = (se.Symbol(name) for name in ("_k", "_t0", "_t1", "_t2"))
    damped = [pi - k * e for pi, e in zip(p, projection)]
    q1 = [qi + t0 * vi for qi, vi in zip(q, _times_inverse(inverse, damped))]
    at_q1 = dict(zip(q, q1))
    p1 = [pi - t1 * g.subs(at_q1) for pi, g in zip(damped, gradient)]
    q2 = [qi + t2 * vi for qi, vi in zip(q1, _times_inverse(inverse, p1))]
    return [k, t0, t1, t2], q2 + p1


def _random_inputs(n: int, count: int, seed: int) -> list[np.ndarray]:
    # (q, p, k, t0, t1, t2): q, p of order one, k and the durations of a step's scale.
    rng = np.random.default_rng(seed)
    return [np.concatenate([rng.normal(size=2 * n), rng.uniform(0.0, 0.2, size=4)]) for _ in range(count)]


def _lambdify(inputs, outputs):
    return se.Lambdify(inputs, outputs, backend="llvm", cse=True, real=True)


def test_core_exports_the_3s_table():
    assert _core.splitting("3s") == [("damp", 0.5), ("drift", 0.5), ("kick", 1.0), ("drift", 0.5), ("damp", 0.5)]
    assert _core.splitting("sv") == [("drift", 0.5), ("kick", 1.0), ("drift", 0.5)]
    with pytest.raises(ValueError, match="method: unknown method 'nope'"):
        _core.splitting("nope")


@pytest.mark.parametrize("make", SYSTEMS.values(), ids=SYSTEMS.keys())
def test_derived_body_equals_the_hand_written_one(make):
    system = make()
    projection, gradient, q, p, inverse = _expressions(system)
    scalars, derived = fused_body(_core.splitting("3s"), projection, gradient, q, p, inverse)
    old_scalars, old = _hand_written(projection, gradient, q, p, inverse)
    # The same inputs in the same positions (compiled_system.hpp passes k, t0, t1, t2
    # by position) and, built by the same substitutions, the same expressions.
    assert scalars == old_scalars
    assert all(a == b for a, b in zip(derived, old))
    # And the compiled body the step loop calls gives the hand-written numbers.
    reference = _lambdify(q + p + old_scalars, old)
    compiled = system._compiled.damp_then_3s_body
    for x in _random_inputs(len(q), 20, seed=11):
        expected = evaluate(reference, x)
        np.testing.assert_allclose(evaluate(compiled, x), expected, rtol=1e-14, atol=1e-14 * np.abs(expected).max())


def test_a_different_table_gives_a_different_body():
    projection, gradient, q, p, inverse = _expressions(_spring([1.3, 1.3, 2.7, 2.7]))
    scalars, three_s = fused_body(_core.splitting("3s"), projection, gradient, q, p, inverse)
    other_scalars, other = fused_body(KICK_DRIFT_KICK, projection, gradient, q, p, inverse)
    assert other_scalars == scalars  # the same signature ...
    a, b = _lambdify(q + p + scalars, three_s), _lambdify(q + p + other_scalars, other)
    for x in _random_inputs(len(q), 5, seed=5):
        assert np.abs(evaluate(a, x) - evaluate(b, x)).max() > 1e-6  # ... and other numbers
    # sv's table: the join is a drift and the body one kick, so two durations.
    sv_scalars, sv = fused_body(_core.splitting("sv"), projection, gradient, q, p, inverse)
    assert [str(s) for s in sv_scalars] == ["_t", "_t0"]
    x = _random_inputs(len(q), 1, seed=2)[0][:-2]
    t, t0 = x[-2:]
    qx, px = x[:4], x[4:8]
    q1 = qx + t * np.linalg.solve(np.diag([1.3, 1.3, 2.7, 2.7]), px)
    p1 = px - t0 * evaluate(_lambdify(q, gradient), q1)
    np.testing.assert_allclose(evaluate(_lambdify(q + p + sv_scalars, sv), x), np.concatenate([q1, p1]),
                               rtol=1e-14, atol=1e-15)


def test_compile_system_reads_the_table(monkeypatch):
    # The same System compiled while the core's 3s table reads kick, drift, kick inside:
    # its fused body, and so its merged run, change; the sub-flow path does not.
    before = _spring([1.3, 1.3, 2.7, 2.7])
    table = _core.splitting
    monkeypatch.setattr(compile_module._core, "splitting",
                        lambda method: KICK_DRIFT_KICK if method == "3s" else table(method))
    after = _spring([1.3, 1.3, 2.7, 2.7])
    monkeypatch.undo()
    for x in _random_inputs(4, 5, seed=8):
        got, expected = evaluate(after._compiled.damp_then_3s_body, x), evaluate(before._compiled.damp_then_3s_body, x)
        assert np.abs(got - expected).max() > 1e-6
    kw = dict(method="3s", h=0.05, n_steps=400, save_every=400)
    q0, p0 = [0.0, 0.0, 1.3, 0.4], [0.2, -0.5, -0.1, 0.7]
    a, b = raydamp.integrate(before, q0, p0, **kw), raydamp.integrate(after, q0, p0, **kw)
    assert np.abs(a.q[-1] - b.q[-1]).max() > 1e-6
    kw["save_every"] = 1  # every step saved: nothing merges, the fused body is not called
    a, b = raydamp.integrate(before, q0, p0, **kw), raydamp.integrate(after, q0, p0, **kw)
    np.testing.assert_array_equal(a.q, b.q)


@pytest.mark.parametrize("table,message", [
    ([("damp", 0.5), ("drift", 0.5), ("kick", 1.0), ("drift", 0.25), ("damp", 0.75)], "not a symmetric table"),
    ([("drift", 1.0)], "not a symmetric table"),
    (_core.splitting("2s"), r"no symbolic form for the sub-flow\(s\) \['kick_damp'\]"),
])
def test_a_table_without_a_fused_form_is_refused(table, message):
    projection, gradient, q, p, inverse = _expressions(elastic_pendulum(0.1))
    with pytest.raises(ValueError, match=message):
        fused_body(table, projection, gradient, q, p, inverse)


def test_the_elastic_pendulum_runs_as_before():
    # A merged 3s run whose fused body comes from the table, against the built-in
    # struct's hand-written flows (to rounding over 2000 steps).
    system = elastic_pendulum(0.1)
    kw = dict(method="3s", h=0.05, n_steps=2000, save_every=100)
    a = raydamp.integrate(system, ELASTIC_Q0, ELASTIC_P0, **kw)
    b = raydamp.integrate(raydamp.models.ElasticPendulum(eps=0.1), ELASTIC_Q0, ELASTIC_P0, **kw)
    np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.p, b.p, rtol=0, atol=1e-12)
