"""integrate_ensemble of Kepler test particles (issue 46): members that share mu, mass and eps run as
the particles of one model (cpp/include/raydamp/ensemble/lanes_kepler.hpp) and are split back. Each
member's rows, status and message equal its single run bit for bit; its max_momentum_drift is the
largest of its batch's single-run values; a member that blows up, a cancel and progress behave as
they do for members run one by one."""

import threading

import numpy as np
import pytest

import raydamp
from raydamp import _core

MU = 1.0


def orbits(members, dim=2, particles=1, seed=46):
    """Pericentre starts, radii 0.5-2 and e 0-0.9, each particle's orbit turned about z by its own angle
    (and tilted about x in 3-D), so that no two members are alike."""
    rng = np.random.default_rng(seed)
    count = members * particles
    rp, e = rng.uniform(0.5, 2.0, count), rng.uniform(0.0, 0.9, count)
    turn, tilt = rng.uniform(0.0, 2 * np.pi, count), rng.uniform(-1.0, 1.0, count)
    v = np.sqrt(MU * (1.0 + e) / rp)
    q = np.stack([rp * np.cos(turn), rp * np.sin(turn), np.zeros(count)], axis=1)
    p = np.stack([-v * np.sin(turn), v * np.cos(turn), np.zeros(count)], axis=1)
    if dim == 3:
        for x in (q, p):
            x[:, 1], x[:, 2] = x[:, 1] * np.cos(tilt), x[:, 1] * np.sin(tilt)
    return q[:, :dim].reshape(members, -1), p[:, :dim].reshape(members, -1)


ROW_ARRAYS = ("t", "q", "p", "energy", "momentum")


def assert_same_run(member: raydamp.Solution, single: raydamp.Solution, what) -> None:
    """Bit for bit: every saved array and the run's outcome."""
    for name in ROW_ARRAYS:
        assert np.array_equal(getattr(member, name), getattr(single, name), equal_nan=True), (what, name)
    assert ((member.status, member.steps, member.failed_step, member.message)
            == (single.status, single.steps, single.failed_step, single.message)), what


@pytest.mark.parametrize(("method", "composition", "eps", "dim", "particles"), [
    ("3s", None, 1e-3, 2, 1),
    ("2s", None, 1e-3, 2, 1),
    ("2s", "suzuki4", 2e-2, 2, 1),
    ("sv", None, 0.0, 2, 1),
    ("3s", "yoshida4", 1e-2, 3, 2),
])
def test_members_equal_their_single_runs_bit_for_bit(method, composition, eps, dim, particles):
    # 300 members on 2 threads: batches of 20 (batch_lanes: 8 per thread, whole blocks of four), so
    # several batches per thread; 137 steps saved every 20, so the off-grid final row appears too.
    members = 300 if particles == 1 else 60
    k = raydamp.Kepler(MU, eps=eps, dim=dim, particles=particles)
    q0, p0 = orbits(members, dim, particles)
    counts = []
    ens = raydamp.integrate_ensemble(k, q0, p0, method=method, composition=composition, h=0.05, n_steps=137,
                                     save_every=20, threads=2, progress=lambda done, total: counts.append(done))
    assert ens.success and ens.momentum.shape[2] == (1 if dim == 2 else 3)
    done = sorted(set(counts))
    assert counts == done and done[-1] == members
    singles = [raydamp.integrate(k, q0[i], p0[i], method=method, composition=composition, h=0.05, n_steps=137,
                                 save_every=20) for i in range(members)]
    for i, single in enumerate(singles):
        assert_same_run(ens.member(i), single, i)
    # max_momentum_drift: the largest of the member's batch, each member's L against its own law at every
    # step; so never below the member's own, and always one of the members' own values.
    own = np.array([s.max_momentum_drift for s in singles])
    assert np.all(ens.max_momentum_drift >= own)
    assert set(ens.max_momentum_drift) <= set(own)
    if eps > 0:  # the drift is rounding: L decays as e^{-eps t} under the exact flows
        assert np.all(ens.max_momentum_drift <= 1e-13)


def test_members_with_other_parameters_are_cut_out_of_the_batch():
    # The core's door with two models: members 0-49 and 53-99 share mu, mass and eps, 50-52 have another
    # eps (run one by one: fewer than four), and member 20's model is equal but another object.
    k, other, twin = (raydamp.Kepler(MU, eps=e) for e in (1e-3, 2e-3, 1e-3))
    members = 100
    index = np.zeros(members, dtype=np.int64)
    index[50:53] = 1
    index[20] = 2
    q0, p0 = orbits(members)
    cores = [k._core_model, other._core_model, twin._core_model]
    out = _core.Planets.integrate_ensemble(cores, index, [], np.zeros((members, 0)), "2s", "", "", q0, p0, 0.1,
                                           200, 0.1, 50, 1, None, None)
    models = (k, other, twin)
    for i in range(members):
        single = raydamp.integrate(models[index[i]], q0[i], p0[i], method="2s", h=0.1, n_steps=200, save_every=50)
        for name in ("q", "p", "energy", "momentum"):
            assert np.array_equal(out[name][i], getattr(single, name)), (i, name)
        assert out["status"][i] == "completed" and out["steps"][i] == 200
    # the three of the other eps are single runs: their own drift, not a batch's
    for i in (50, 51, 52):
        single = raydamp.integrate(other, q0[i], p0[i], method="2s", h=0.1, n_steps=200, save_every=50)
        assert out["max_momentum_drift"][i] == single.max_momentum_drift


def test_a_member_that_blows_up_keeps_its_rows_and_says_why():
    # Member 7 starts 1e100 times too fast: its state stops being finite at step 3, and so does its
    # batch's, which is then run member by member (the others complete; member 7 keeps its two steps).
    k = raydamp.Kepler(MU, eps=1e-3)
    members = 40
    q0, p0 = orbits(members)
    p0[7] = [0.0, 1e100]
    ens = raydamp.integrate_ensemble(k, q0, p0, method="3s", h=0.05, n_steps=600, save_every=100, threads=1)
    single = raydamp.integrate(k, q0[7], p0[7], method="3s", h=0.05, n_steps=600, save_every=100)
    assert single.status == "non_finite" and single.steps == 2 and "step 3" in single.message
    assert ens.status[7] == single.status and ens.message[7] == single.message and ens.steps[7] == 2
    for i in range(members):
        ref = single if i == 7 else raydamp.integrate(k, q0[i], p0[i], method="3s", h=0.05, n_steps=600,
                                                       save_every=100)
        assert_same_run(ens.member(i), ref, i)
        if i != 7:  # run alone (member 7's batch) or in a batch: its own drift, or its batch's largest
            assert ens.status[i] == "completed" and ens.max_momentum_drift[i] >= ref.max_momentum_drift


def test_cancel_in_a_batch_keeps_each_members_rows():
    # 25,600 steps: the loop's blocks are then its progress points, every 256 steps, so a single run
    # cancelled from its own progress callback at step s stops where a batch cancelled there does.
    k = raydamp.Kepler(MU, eps=1e-3)
    members, steps = 800, 25_600
    q0, p0 = orbits(members)
    token = raydamp.CancelToken()
    timer = threading.Timer(0.05, token.cancel)
    timer.start()
    ens = raydamp.integrate_ensemble(k, q0, p0, method="2s", h=0.01, n_steps=steps, save_every=2560, threads=1,
                                     cancel=token)
    timer.join()
    cancelled = [i for i in range(members) if ens.status[i] == "cancelled"]
    assert cancelled, "the cancel came after the run: make it longer"
    partly = [i for i in cancelled if ens.steps[i] > 0]
    for i in cancelled:
        assert ens.message[i] == f"cancelled after {ens.steps[i]} of {steps} steps"
        assert ens.t_final[i] == pytest.approx(0.01 * ens.steps[i], rel=1e-12)
        if ens.steps[i] == 0:
            assert ens.rows[i] == 1 and np.array_equal(ens.q_final[i], q0[i])
    # a member of the batch the cancel cut: its single run cancelled at the same step, bit for bit
    for i in partly[:3] + partly[-1:]:
        stop = raydamp.CancelToken()
        at = int(ens.steps[i])
        def cancel_at(done, total, at=at, stop=stop):
            if done >= at:
                stop.cancel()

        single = raydamp.integrate(k, q0[i], p0[i], method="2s", h=0.01, n_steps=steps, save_every=2560,
                                   cancel=stop, progress=cancel_at)
        assert single.steps == at
        assert_same_run(ens.member(i), single, i)
    for i in [i for i in range(members) if ens.status[i] == "completed"][:3]:
        assert_same_run(ens.member(i), raydamp.integrate(k, q0[i], p0[i], method="2s", h=0.01, n_steps=steps,
                                                         save_every=2560), i)


def test_refused_method_and_interacting_planets_still_run_one_by_one():
    # Planets interact: every member is its own model's run (no batch), as before.
    planets = raydamp.Planets(masses=[1e-3, 1e-3], eps=[1e-3, 0.0])
    q0 = np.tile([1.0, 0.0, 2.0, 0.0], (6, 1)) * np.linspace(1.0, 1.2, 6)[:, None]
    p0 = np.tile([0.0, 1e-3, 0.0, 0.7e-3], (6, 1))
    ens = raydamp.integrate_ensemble(planets, q0, p0, method="2s", h=0.05, n_steps=80, save_every=20, threads=2)
    for i in range(6):
        single = raydamp.integrate(planets, q0[i], p0[i], method="2s", h=0.05, n_steps=80, save_every=20)
        assert_same_run(ens.member(i), single, i)
        assert ens.max_momentum_drift[i] == single.max_momentum_drift
