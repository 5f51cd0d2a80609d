"""Events with a Python callable g (issue 41, documented as slower): found after the run on its dense output
with the core's root finder, so they equal the compiled expression's crossings to rounding."""

import numpy as np
import pytest

import raydamp
from raydamp.models import DampedPendulum


def oscillator():
    return raydamp.System(["x"], "k/2*x^2", parameters={"k": 4.0}, damping={"scalar": 0.1}, eps=1.0)


RUN = dict(method="3s", composition="yoshida4", h=0.01, t_end=20.0, save_every=500)


def test_a_callable_g_finds_the_compiled_expressions_crossings():
    compiled = raydamp.integrate(oscillator(), [1.0], [0.0], **RUN,
                                 events=[raydamp.Event("x - 0.2", name="level"), raydamp.Event("p_x", direction=1)])
    python = raydamp.integrate(oscillator(), [1.0], [0.0], **RUN,
                               events=[raydamp.Event(lambda t, q, p: q[:, 0] - 0.2, name="level"),
                                       raydamp.Event("p_x", direction=1)])
    assert len(python.events) == len(compiled.events) > 10
    np.testing.assert_array_equal(python.events.event, compiled.events.event)  # merged in time order
    np.testing.assert_array_equal(python.events.direction, compiled.events.direction)
    np.testing.assert_allclose(python.events.t, compiled.events.t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(python.events.q, compiled.events.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(python.events.p, compiled.events.p, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(python.q, compiled.q)  # the stepped trajectory: the same whole steps
    assert python.dense is None  # kept for g only, not asked for
    assert python.provenance["events"][0]["g"].startswith("<Python callable")


def test_a_callable_g_in_time_and_momentum_with_dense_output_kept():
    sol = raydamp.integrate(DampedPendulum(eps=0.0), [1.0], [0.0], method="sv", h=0.01, t_end=7.0, dense=True,
                            events=[raydamp.Event(lambda t, q, p: np.sin(t) - 0.5, direction=-1, name="clock"),
                                    raydamp.Event(lambda t, q, p: p[:, 0], name="turn")])
    clock = sol.events["clock"]
    np.testing.assert_allclose(clock.t, [5 * np.pi / 6], rtol=0, atol=1e-12)  # sin t falls through 1/2 once
    assert sol.dense is not None and len(sol.events["turn"]) == 2
    np.testing.assert_allclose(sol.events["turn"].p[:, 0], 0.0, atol=1e-12)


@pytest.mark.parametrize("event, match", [
    (dict(g=lambda t, q, p: q[:, 0], terminal=True), r"terminal: a Python callable g .* cannot end the run"),
    (dict(g=lambda t, q, p: q[:, 0], refine="henon"), r"refine: Hénon's step needs g compiled"),
])
def test_what_a_callable_g_cannot_do_is_refused(event, match):
    with pytest.raises(ValueError, match=match):
        raydamp.Event(**event)


def test_a_callable_g_of_the_wrong_shape_or_in_an_ensemble_names_events_i_g():
    with pytest.raises(ValueError, match=r"events\[1\]\.g: a callable g\(t, q, p\) .* return K values"):
        raydamp.integrate(DampedPendulum(), [1.0], [0.0], h=0.1, t_end=1.0,
                          events=[raydamp.Event("q[0]"), raydamp.Event(lambda t, q, p: q)])
    with pytest.raises(ValueError, match=r"events\[0\]\.g: an ensemble takes no Python callable g"):
        raydamp.integrate_ensemble(DampedPendulum(), np.ones((2, 1)), np.zeros((2, 1)), h=0.1, t_end=1.0,
                                   events=[raydamp.Event(lambda t, q, p: q[:, 0])])
