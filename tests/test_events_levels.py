"""Affine events by level (issue 41): the watcher rules a step out once per form (levels of one q, one p, one drift)
and reads every g only where a level may be near. It must find exactly what reading every g at every step
finds: the same events, bit for bit, as the compiled path (which one event that is not affine forces on all)."""

import math

import numpy as np

import raydamp
from raydamp.models import DampedPendulum

# Not affine (sin), never zero: in a list it makes every g go through the compiled function, which reads every
# g at every step end; its own g is the same for the affine events in it (q[0] - c is c' + 1 q[0] bit for bit).
COMPILED = raydamp.Event("t + 1e9 + 1e-300*sin(q[0])", name="compiled")


def table(sol):
    e = sol.events
    return e.event, e.direction, e.t, e.q, e.p


def assert_same_events(a, b, names):
    ta, tb = table(a), table(b)
    keep = np.isin(tb[0], range(len(names)))
    assert len(ta[2]) > 0
    for x, y in zip(ta, tb):
        np.testing.assert_array_equal(x, y[keep])


def test_levels_of_q_and_p_find_what_every_g_at_every_step_finds():
    pendulum = DampedPendulum(eps=0.05)
    run = dict(method="3s", h=0.02, t_end=40.0, save_every=100)
    dense = raydamp.integrate(pendulum, [2.0], [0.0], dense=True, **run).dense
    # Levels exactly at step-end values (g = 0 at a step's end), two levels one rounding apart, one level
    # twice, one just past the lowest step end of the first swing (the interpolant may dip below it inside
    # a step: a touch between step ends), and levels of p and t.
    exact_q = [float(dense.q[k, 0]) for k in (7, 150, 1001)]
    exact_p = [float(dense.p[k, 0]) for k in (33, 640)]
    bottom = int(np.argmin(dense.q[150:280, 0])) + 150  # the first swing's lowest step end, near t = 4.2
    assert 150 < bottom < 279
    near_bottom = float(dense.q[bottom, 0]) - 1e-9
    levels_q = exact_q + [0.5, math.nextafter(0.5, 1.0), 0.5, 1.0, near_bottom, -1.3]
    levels_p = exact_p + [0.25, -0.7]
    events = ([raydamp.Event(f"q[0] - {c!r}", name=f"q{k}") for k, c in enumerate(levels_q)]
              + [raydamp.Event(f"p[0] - {c!r}", direction=(0, 0, 1, -1)[k], name=f"p{k}")
                 for k, c in enumerate(levels_p)]
              + [raydamp.Event("t - 12.345", name="clock"), raydamp.Event("2*q[0] - 1.0", name="twice")])
    names = [e.name for e in events]
    affine = raydamp.integrate(pendulum, [2.0], [0.0], events=events, **run)
    compiled = raydamp.integrate(pendulum, [2.0], [0.0], events=events + [COMPILED], **run)
    assert_same_events(affine, compiled, names)
    found = set(affine.events.name)
    assert {"q0", "q1", "q2", "p0", "p1", "clock", "twice"} <= found  # the exact step ends among them
    # The duplicated levels and the pair one rounding apart cross together.
    np.testing.assert_array_equal(affine.events["q3"].t, affine.events["q5"].t)
    assert len(affine.events["q4"]) == len(affine.events["q3"])


def test_storey_drifts_find_what_every_g_at_every_step_finds():
    # Forms of two terms (q[k] - q[k-1]), each with a few levels, on a 4-storey shear frame by 3s.
    M = np.eye(4)
    K = 2 * np.eye(4) - np.eye(4, k=1) - np.eye(4, k=-1)
    K[-1, -1] = 1.0
    frame = raydamp.LinearStructure(M, K, alpha=0.02, beta=0.01)
    q0 = np.array([0.25, 0.5, 0.75, 1.0])
    events = [raydamp.Event(f"q[{k}] - q[{k - 1}] - {c}" if k else f"q[0] - {c}", name=f"d{k}_{j}")
              for k in range(4) for j, c in enumerate((0.2, 0.0, -0.15))]
    names = [e.name for e in events]
    run = dict(method="3s", h=0.05, t_end=60.0, save_every=100)
    affine = raydamp.integrate(frame, q0, np.zeros(4), events=events, **run)
    compiled = raydamp.integrate(frame, q0, np.zeros(4), events=events + [COMPILED], **run)
    a, c = table(affine), table(compiled)
    keep = np.isin(c[0], range(len(names)))
    # The compiled g rounds q[k] - q[k-1] - c in another order than c' + q[k] - q[k-1]: the same crossings in
    # the same order, their times equal to a few roundings.
    np.testing.assert_array_equal(a[0], c[0][keep])
    np.testing.assert_array_equal(a[1], c[1][keep])
    np.testing.assert_allclose(a[2], c[2][keep], rtol=0, atol=1e-12)
    assert len(a[2]) > 25
