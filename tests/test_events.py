"""Events and dense output (issue 41): crossing times against closed forms and their order in h, a
terminal event's shortened last step, the stepped trajectory unchanged by events, and bad input."""

import math

import numpy as np
import pytest
from scipy.special import ellipk

import raydamp
from raydamp.models import DampedPendulum

# The damped linear oscillator of the issue: m = 1, k = 4, c = 0.1, released from q = 1 at rest.
K, C = 4.0, 0.1
ALPHA = C / 2
OMEGA_D = math.sqrt(K - ALPHA**2)
PHI = math.atan2(ALPHA, OMEGA_D)


def oscillator():
    return raydamp.System(["x"], "k/2*x^2", parameters={"k": K}, damping={"scalar": C}, eps=1.0)


def exact(t):
    """q(t), p(t) of the oscillator: q = e^{-alpha t} (cos w t + alpha/w sin w t)."""
    t = np.asarray(t, dtype=float)
    decay = np.exp(-ALPHA * t)
    q = decay * (np.cos(OMEGA_D * t) + ALPHA / OMEGA_D * np.sin(OMEGA_D * t))
    p = -decay * (K / OMEGA_D) * np.sin(OMEGA_D * t)
    return q, p


def zero_crossings(t_end):
    """Times of q = 0: omega_d t - phi = pi/2 + k pi."""
    times = (np.pi / 2 + np.pi * np.arange(40) + PHI) / OMEGA_D
    return times[times <= t_end]


def crossing_error(h, composition=None, t_end=20.0):
    sol = raydamp.integrate(oscillator(), [1.0], [0.0], method="3s", composition=composition, h=h, t_end=t_end,
                            save_every=1000, events=[raydamp.Event("x", name="zero")])
    expected = zero_crossings(t_end)
    assert len(sol.events) == len(expected)
    assert list(sol.events.direction) == [(-1) ** (i + 1) for i in range(len(expected))]
    return np.max(np.abs(sol.events.t - expected))


def slope(hs, errors):
    return np.polyfit(np.log(hs), np.log(errors), 1)[0]


def test_every_zero_crossing_of_the_damped_oscillator_within_1e_10_at_h_1e_3():
    assert crossing_error(1e-3, "yoshida4") < 1e-10


@pytest.mark.parametrize("composition, order", [("yoshida4", 3.8), (None, 1.9)])
def test_crossing_times_keep_the_method_order(composition, order):
    hs = [0.04, 0.02, 0.01]
    errors = [crossing_error(h, composition) for h in hs]
    assert slope(hs, errors) >= order, errors


def test_dense_output_is_fourth_order_between_step_ends_and_exact_at_them():
    hs = [0.04, 0.02, 0.01]
    times = np.linspace(0.013, 9.97, 301)
    errors = []
    for h in hs:
        sol = raydamp.integrate(oscillator(), [1.0], [0.0], method="3s", composition="yoshida4", h=h, t_end=10.0,
                                save_every=7, dense=True)
        q, p = sol.at(times)
        eq, ep = exact(times)
        errors.append(max(np.max(np.abs(q[:, 0] - eq)), np.max(np.abs(p[:, 0] - ep))))
        # At the saved rows the interpolant is the stepped state itself.
        q_rows, p_rows = sol.at(sol.t)
        np.testing.assert_array_equal(q_rows, sol.q)
        np.testing.assert_array_equal(p_rows, sol.p)
    assert slope(hs, errors) >= 3.8, errors
    assert sol.dense.nbytes == 8 * (round(10.0 / hs[-1]) + 1) * 5


def test_pendulum_quarter_period_by_a_terminal_event():
    theta0 = 1.0
    quarter = ellipk(math.sin(theta0 / 2) ** 2)  # omega_0 = 1
    sol = raydamp.integrate(DampedPendulum(eps=0.0), [theta0], [0.0], method="sv", composition="yoshida4", h=1e-3,
                            t_end=10.0, events=[raydamp.Event("q[0]", direction=-1, terminal=True, name="vertical")])
    assert sol.status == "event"
    assert "vertical" in sol.message
    assert abs(sol.events.t[0] - quarter) < 1e-10
    assert len(sol.events) == 1
    assert sol.t[-1] == sol.events.t[0]  # the last row is at the event: its step was shortened to land there
    assert abs(sol.q[-1, 0]) < 1e-10
    assert sol.steps == math.ceil(quarter / 1e-3)


def test_events_leave_the_stepped_trajectory_bitwise_unchanged():
    pendulum = DampedPendulum(eps=0.1)
    ten = [raydamp.Event(f"q[0] - {0.1 * k}", name=f"level{k}") for k in range(10)]
    for method in ("rk4", "3s"):
        # rk4 steps whole steps anyway; 3s merges its damping flows between rows unless the run reads every
        # step's end: events=[] steps whole steps and watches nothing.
        plain = raydamp.integrate(pendulum, [2.0], [0.0], method=method, h=0.01, t_end=30.0, save_every=3,
                                  events=None if method == "rk4" else [])
        watched = raydamp.integrate(pendulum, [2.0], [0.0], method=method, h=0.01, t_end=30.0, save_every=3,
                                    events=ten)
        np.testing.assert_array_equal(watched.q, plain.q)
        np.testing.assert_array_equal(watched.p, plain.p)
        assert len(watched.events) > 20
        for k in range(10):  # every crossing of a level is at the level
            np.testing.assert_allclose(watched.events[f"level{k}"].q[:, 0], 0.1 * k, atol=1e-6)


def test_a_touch_inside_one_step_is_found():
    # The pendulum swings up from the bottom to its first top at t ~ 1.675, between the step ends 1.65 and 1.70.
    # A level between the highest step end and the top of the interpolant is crossed twice inside one step,
    # with g of one sign at every step end: found by the extremum check.
    pendulum, h = DampedPendulum(eps=0.0), 0.05
    run = dict(method="sv", composition="yoshida4", h=h, t_end=3.0)
    dense = raydamp.integrate(pendulum, [0.0], [2 * math.sin(0.5)], dense=True, **run)
    top = dense.at(np.linspace(1.0, 2.4, 20001))[0][:, 0].max()
    highest_end = dense.dense.q[:, 0].max()
    assert top - highest_end > 1e-5
    level = float((top + highest_end) / 2)
    sol = raydamp.integrate(pendulum, [0.0], [2 * math.sin(0.5)], events=[raydamp.Event(f"q[0] - {level!r}")],
                            **run)
    assert list(sol.events.direction) == [1, -1]
    assert math.floor(sol.events.t[0] / h) == math.floor(sol.events.t[1] / h)  # both inside one step
    np.testing.assert_allclose(sol.events.q[:, 0], level, atol=1e-12)


def test_an_event_in_momenta_and_time_on_a_system():
    sol = raydamp.integrate(oscillator(), [1.0], [0.0], method="3s", composition="yoshida4", h=1e-3, t_end=5.0,
                            events=[raydamp.Event("p_x", direction=1, name="turn"),
                                    raydamp.Event("t - 2.5", terminal=True, name="clock")])
    assert sol.status == "event" and sol.t[-1] == pytest.approx(2.5, abs=1e-14)
    turns = sol.events["turn"]
    # p = 0 rising: the minima of q, at omega_d t = (2k + 1) pi.
    np.testing.assert_allclose(turns.t, np.pi * np.array([1]) / OMEGA_D, atol=1e-10)
    np.testing.assert_allclose(turns.p[:, 0], 0.0, atol=1e-10)


@pytest.mark.parametrize("events, match", [
    ([raydamp.Event("q[0] + y")], r"events\[0\]\.g: unknown name 'y'"),
    ([raydamp.Event("q[5]")], r"events\[0\]\.g: q\[5\] is not a coordinate"),
    ([raydamp.Event("log(q[0])")], r"events\[0\]\.g .* is not finite at the initial state"),
    ([{"g": "q[0]", "direction": 2}], r"events\[0\]\.direction must be -1, 0 or \+1"),
    ([{"g": "q[0]", "when": 2}], r"events\[0\]: unknown key"),
    ("q[0]", r"events must be a list"),
])
def test_bad_events_name_the_argument(events, match):
    with pytest.raises(ValueError, match=match):
        raydamp.integrate(DampedPendulum(), [-1.0], [0.0], h=0.1, t_end=1.0, events=events)


def test_bad_event_direction_and_dense_refusals():
    with pytest.raises(ValueError, match="direction must be -1, 0 or"):
        raydamp.Event("q[0]", direction=3)
    with pytest.raises(ValueError, match="terminal: a Python callable g is found after the run"):
        raydamp.Event(lambda t, q, p: q[:, 0], terminal=True)
    with pytest.raises(ValueError, match="events: a run at a temperature has no dense output"):
        raydamp.integrate(DampedPendulum(), [1.0], [0.0], h=0.1, t_end=1.0, temperature=0.1, seed=1,
                          events=[raydamp.Event("q[0]")])
    sol = raydamp.integrate(DampedPendulum(), [1.0], [0.0], h=0.1, t_end=1.0)
    with pytest.raises(ValueError, match="at: this run kept no dense output"):
        sol.at(0.5)
    dense = raydamp.integrate(DampedPendulum(), [1.0], [0.0], h=0.1, t_end=1.0, dense=True)
    with pytest.raises(ValueError, match="t must lie inside the run"):
        dense.at(1.5)


def test_a_terminal_event_stops_each_ensemble_member_as_its_single_run():
    pendulum = DampedPendulum(eps=0.05)
    q0 = np.linspace(0.3, 2.5, 1000)[:, None]
    p0 = np.zeros_like(q0)
    down = [raydamp.Event("q[0]", direction=-1, terminal=True, name="vertical"), raydamp.Event("p[0] + 0.5")]
    run = dict(method="3s", h=0.01, t_end=10.0, save_every=50)
    ens = raydamp.integrate_ensemble(pendulum, q0, p0, events=down, **run)
    assert set(ens.status) == {"event"}
    assert len(np.unique(ens.t_final)) == 1000  # each member at its own time
    for i in range(1000):
        single = raydamp.integrate(pendulum, q0[i], p0[i], events=down, **run)
        assert single.t[-1] == ens.t_final[i] and single.steps == ens.steps[i]
        assert single.q[-1, 0] == ens.q_final[i, 0] and single.p[-1, 0] == ens.p_final[i, 0]
        member = ens.events.of_member(i)
        np.testing.assert_array_equal(member.t, single.events.t)
        np.testing.assert_array_equal(member.q, single.events.q)
        np.testing.assert_array_equal(member.event, single.events.event)


def test_the_job_json_takes_events_and_the_provenance_runs_again():
    from raydamp.jobs import job_arguments

    job = {"model": "damped_pendulum", "parameters": {"eps": 0.0}, "method": "sv", "composition": "yoshida4",
           "h": 1e-3, "t_end": 10.0, "initial_state": {"q": [1.0], "p": [0.0]}, "work": False,
           "events": [{"g": "q[0]", "direction": -1, "terminal": True, "name": "vertical"}]}
    model, q0, p0, options = job_arguments(job)
    sol = raydamp.integrate(model, q0, p0, **options)
    assert sol.status == "event" and abs(sol.t[-1] - ellipk(math.sin(0.5) ** 2)) < 1e-12
    summary = sol.summary()["events"]
    assert summary["count"] == 1 and summary["name"] == ["vertical"] and summary["direction"] == [-1]
    again = raydamp.integrate(*job_arguments(sol.provenance)[:3], **job_arguments(sol.provenance)[3])
    assert again.t[-1] == sol.t[-1]


@pytest.mark.parametrize("events, path", [
    ([{"g": "q[0] + y"}], r"events\[0\]\.g"),
    ([{"g": "q[0]", "direction": 2}], r"events\.0\.direction|events\[0\]\.direction"),
])
def test_a_bad_event_in_a_job_names_its_path(events, path):
    from raydamp.jobs import job_arguments

    job = {"model": "damped_pendulum", "h": 0.1, "t_end": 1.0, "initial_state": {"q": [1.0], "p": [0.0]},
           "events": events}
    with pytest.raises(ValueError, match=path):
        model, q0, p0, options = job_arguments(job)
        raydamp.integrate(model, q0, p0, **options)
