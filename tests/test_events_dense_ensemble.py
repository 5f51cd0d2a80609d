"""Dense output in ensembles (issue 41): integrate_ensemble(..., dense=True) keeps each member's dense output as
its single run does, bit for bit, and bad input for it names the argument."""

import numpy as np
import pytest

import raydamp
from raydamp.models import DampedPendulum

RUN = dict(method="3s", h=0.01, t_end=4.0, save_every=40)


def pendulum_members(members=40):
    q0 = np.linspace(0.3, 2.5, members)[:, None]
    return q0, np.zeros_like(q0), np.linspace(0.0, 0.2, members)


def test_each_members_dense_output_is_its_single_runs_bit_for_bit():
    # Members stop at their own times (a terminal event at the first fall through q = -0.5, which the
    # smallest swings never reach), so their records differ in length; eps varies per member.
    q0, p0, eps = pendulum_members()
    stop = [raydamp.Event("q[0] + 0.5", direction=-1, terminal=True, name="low")]
    ens = raydamp.integrate_ensemble(DampedPendulum(), q0, p0, parameters={"eps": eps}, events=stop, dense=True,
                                     threads=2, **RUN)
    assert {"event", "completed"} == set(ens.status)
    times = np.linspace(0.0, ens.t[-1], 397)
    q_all, p_all = ens.at(times)
    assert q_all.shape == p_all.shape == (len(eps), len(times), 1)
    for i in range(len(eps)):
        single = raydamp.integrate(DampedPendulum(eps=eps[i]), q0[i], p0[i], events=stop, dense=True, **RUN)
        for key in ("t", "q", "p", "v", "f"):
            np.testing.assert_array_equal(getattr(ens.dense[i], key), getattr(single.dense, key), err_msg=key)
        inside = times <= single.t[-1]
        q, p = single.at(times[inside])
        member = ens.member(i)
        np.testing.assert_array_equal(member.at(times[inside])[0], q)
        np.testing.assert_array_equal(member.at(times[inside])[1], p)
        np.testing.assert_array_equal(q_all[i, inside], q)
        np.testing.assert_array_equal(p_all[i, inside], p)
        assert np.isnan(q_all[i, ~inside]).all() and np.isnan(p_all[i, ~inside]).all()  # past its stop
        assert member.at(0.7)[0][0] == single.at(0.7)[0][0]  # a scalar t as the single run's
    q_one, p_one = ens.at(0.7)
    assert q_one.shape == p_one.shape == (len(eps), 1)
    np.testing.assert_array_equal(q_one, np.stack([ens.member(i).at(0.7)[0] for i in range(len(eps))]))


def test_a_structure_ensembles_dense_output_is_its_single_runs():
    M, K = np.diag([2.0, 1.0]), np.array([[3.0, -1.0], [-1.0, 1.0]])
    s = raydamp.LinearStructure(M, K, alpha=0.05, beta=0.01)
    q0 = np.array([[0.1, 0.2], [0.0, -0.3], [0.2, 0.0]])
    p0 = np.zeros_like(q0)
    ens = raydamp.integrate_ensemble(s, q0, p0, method="gauss4", h=0.05, t_end=3.0, save_every=20, dense=True)
    for i in range(3):
        single = raydamp.integrate(s, q0[i], p0[i], method="gauss4", h=0.05, t_end=3.0, save_every=20, dense=True)
        np.testing.assert_array_equal(ens.dense[i].f, single.dense.f)
        np.testing.assert_array_equal(ens.member(i).at([0.33, 2.9])[1], single.at([0.33, 2.9])[1])


def test_no_dense_output_unless_asked():
    q0, p0, _ = pendulum_members(3)
    ens = raydamp.integrate_ensemble(DampedPendulum(eps=0.1), q0, p0, **RUN)
    assert ens.dense is None and ens.member(0).dense is None
    with pytest.raises(ValueError, match="at: this ensemble kept no dense output"):
        ens.at(1.0)
    with pytest.raises(ValueError, match="at: this run kept no dense output"):
        ens.member(0).at(1.0)


@pytest.mark.parametrize("options, match", [
    (dict(dense="yes"), r"dense must be True or False"),
    (dict(dense=1), r"dense must be True or False"),
    (dict(dense=True, temperature=0.1, seed=1), r"dense: a run at a temperature has no dense output"),
    (dict(dense=True, vector_sine=True), r"dense: .*vector_sine"),
    (dict(dense=True, t_end=None, n_steps=10**6, save_every=10**6), r"dense: 1000 members .* GiB"),
])
def test_bad_dense_in_an_ensemble_names_the_argument(options, match):
    q0 = np.linspace(0.1, 1.0, 1000)[:, None]
    run = {**RUN, **options}
    with pytest.raises(ValueError, match=match):
        raydamp.integrate_ensemble(DampedPendulum(eps=0.1), q0, np.zeros_like(q0), **run)


@pytest.mark.parametrize("t", [-0.1, 4.5, float("nan"), [0.5, 9.0], [[0.5]]])
def test_an_ensembles_at_outside_the_run_names_t(t):
    q0, p0, _ = pendulum_members(2)
    ens = raydamp.integrate_ensemble(DampedPendulum(eps=0.1), q0, p0, dense=True, **RUN)
    with pytest.raises(ValueError, match=r"^t must be a time or a 1-d array of times inside the run"):
        ens.at(t)
