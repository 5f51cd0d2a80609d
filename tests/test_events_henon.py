"""Hénon's step for a Poincaré section's points (issue 41): ``Event(..., refine="henon")`` lands each
crossing on g = 0 from a stepped state, integrating in g itself, where the default reads it off the step's
interpolant. On the damped forced Duffing oscillator of the README."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import raydamp

FORCE = raydamp.Load.harmonic([0.5], omega=1.2, phase=np.pi / 2)  # 0.5 cos(1.2 t)


def duffing():
    return raydamp.System(["x"], "x^4/4 - x^2/2", damping={"scalar": 0.3}, eps=1.0)


def section(events, h, composition="kahan_li6", t_end=60.0):
    return raydamp.integrate(duffing(), [1.0], [0.0], method="3s", composition=composition, h=h, t_end=t_end,
                             save_every=100_000, load=FORCE, events=events).events


@pytest.mark.parametrize("g, on_section", [
    ("x", lambda q, p: q),                                    # affine: Runge-Kutta keeps it, to rounding
    ("x^2 + p_x^2/4 - 1", lambda q, p: q**2 + p**2 / 4 - 1),  # not affine: polished onto it
])
def test_henon_points_lie_on_the_section(g, on_section):
    refined = section([raydamp.Event(g, refine="henon")], h=0.02)
    plain = section([raydamp.Event(g)], h=0.02)
    assert len(refined) == len(plain) >= 5
    assert np.max(np.abs(on_section(refined.q[:, 0], refined.p[:, 0]))) <= 1e-12
    # Each point is its own crossing's: near the interpolant's (the step is 0.02 long).
    assert np.max(np.abs(refined.t - plain.t)) < 1e-6


def flow(t0, x0, p0):
    """The Duffing flow's crossing of x = 0 nearest (t0, x0, p0), forwards or backwards: (t, p) there, at
    rtol 1e-13."""
    def rhs(t, y):
        return [y[1], -(y[0] ** 3 - y[0]) - 0.3 * y[1] + 0.5 * np.cos(1.2 * t)]

    def crossing(t, y):
        return y[0]

    found = []
    for span in (0.1, -0.1):
        out = solve_ivp(rhs, (t0, t0 + span), [x0, p0], method="DOP853", rtol=1e-13, atol=1e-14, events=crossing)
        found += [(t, y[1]) for t, y in zip(out.t_events[0], out.y_events[0])]
    return min(found, key=lambda c: abs(c[0] - t0))


def test_henon_points_are_the_flows_crossing_and_equal_dense_output_within_its_error():
    # Hénon's step runs from the stepped state at the end of the crossing step nearer the section (for g = x:
    # the smaller |x|); the flow's own crossing from that state is computed here at rtol 1e-13. The landed
    # point is that crossing to about 1e-12, where the interpolant's is off by its fourth-order error in h;
    # and the two differ by about that error.
    h = 0.04
    sol = raydamp.integrate(duffing(), [1.0], [0.0], method="3s", composition="kahan_li6", h=h, t_end=60.0,
                            save_every=100_000, load=FORCE, dense=True,
                            events=[raydamp.Event("x", name="plain"), raydamp.Event("x", name="henon", refine="henon")])
    plain, refined, dense = sol.events["plain"], sol.events["henon"], sol.dense
    assert len(plain) == len(refined) >= 5
    plain_error = refined_error = difference = 0.0
    for t_plain, p_plain, t_henon, p_henon in zip(plain.t, plain.p[:, 0], refined.t, refined.p[:, 0]):
        k = np.searchsorted(dense.t, t_plain) - 1
        start = k if abs(dense.q[k, 0]) <= abs(dense.q[k + 1, 0]) else k + 1
        t_flow, p_flow = flow(dense.t[start], dense.q[start, 0], dense.p[start, 0])
        plain_error = max(plain_error, abs(t_plain - t_flow), abs(p_plain - p_flow))
        refined_error = max(refined_error, abs(t_henon - t_flow), abs(p_henon - p_flow))
        difference = max(difference, abs(t_henon - t_plain), abs(p_henon - p_plain))
    assert refined_error < 1e-11, refined_error
    assert plain_error > 100 * refined_error, (plain_error, refined_error)
    assert difference <= 1.01 * plain_error + 1e-11


def test_refine_is_written_and_read_by_the_job_json():
    from raydamp.jobs import job_arguments

    job = {"system": {"coordinates": ["x"], "potential": "x^4/4 - x^2/2", "damping": {"scalar": 0.3}, "eps": 1.0},
           "method": "3s", "h": 0.02, "t_end": 20.0, "initial_state": {"q": [1.0], "p": [2.0]},
           "events": [{"g": "x", "direction": -1, "refine": "henon", "name": "down"}]}
    model, q0, p0, options = job_arguments(job)
    assert options["events"][0]["refine"] == "henon"
    sol = raydamp.integrate(model, q0, p0, **options)
    assert sol.provenance["events"][0]["refine"] == "henon"
    assert len(sol.events) >= 1 and np.max(np.abs(sol.events.q)) <= 1e-12


@pytest.mark.parametrize("event, match", [
    (dict(g="q[0]", refine="newton"), r"refine must be None or 'henon'"),
    (dict(g="q[0]", refine="henon", terminal=True), r"refine: .*terminal"),
])
def test_a_bad_refine_names_the_argument(event, match):
    with pytest.raises(ValueError, match=match):
        raydamp.Event(**event)
    with pytest.raises(ValueError, match=r"events\[0\]\." + match):
        raydamp.integrate(raydamp.models.DampedPendulum(), [1.0], [0.0], h=0.1, t_end=1.0, events=[event])


def test_a_bad_refine_in_a_job_names_its_path():
    from raydamp.jobs import job_arguments

    job = {"model": "damped_pendulum", "h": 0.1, "t_end": 1.0, "initial_state": {"q": [1.0], "p": [0.0]},
           "events": [{"g": "q[0]", "refine": "newton"}]}
    with pytest.raises(ValueError, match=r"events\.0\.refine|events\[0\]\.refine"):
        job_arguments(job)
