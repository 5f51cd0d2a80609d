"""Ensembles of the implicit methods of a LinearStructure ("midpoint", "gauss4"; issue 25): the
factorisations are made once for all members and shared read-only across threads, and each member
equals its single run bit for bit (cpp/tests/test_linear_implicit.cpp counts the factorisations)."""

from __future__ import annotations

import numpy as np
import pytest
from fe_plate import plate
from test_ensemble import same
from test_implicit_structure import damped_plate

import raydamp
from raydamp.models import DampedPendulum

IMPLICIT = ["midpoint", "gauss4"]


@pytest.fixture(scope="module")
def small_plate():
    """A plate of 420 DOF, 2% damping in modes 1 and 3, a constant load, and 7 initial states."""
    pl, s, _, _, _ = damped_plate(20, 10, 3, 5)
    rng = np.random.default_rng(6)
    q0, p0 = 1e-2 * rng.standard_normal((7, pl.n)), 1e-2 * rng.standard_normal((7, pl.n))
    # h omega_max about 20: far past every explicit method's limit
    return s, q0, p0, 20.0 / np.sqrt(s.spectral_bound)


@pytest.mark.parametrize("method", IMPLICIT)
def test_members_equal_single_runs_bit_for_bit_on_any_threads(small_plate, method):
    s, q0, p0, h = small_plate
    # 30 steps and a shorter last one (two factorisations), saved every 7 (an off-grid final row)
    t_end = 30.4 * h
    runs = {threads: raydamp.integrate_ensemble(s, q0, p0, method=method, h=h, t_end=t_end, save_every=7,
                                                threads=threads) for threads in (1, 2)}
    assert runs[2].threads == 2 and runs[2].success
    for i in range(len(q0)):
        ref = raydamp.integrate(s, q0[i], p0[i], method=method, h=h, t_end=t_end, save_every=7)
        assert ref.steps == 31 and ref.t[-1] == t_end
        assert same(runs[1].member(i), ref), i
        assert same(runs[2].member(i), ref), i
    # and the members really differ, and moved
    assert len({float(e) for e in runs[2].energy_final}) == len(q0)
    assert np.linalg.norm(runs[2].q_final[0] - q0[0]) > 0.1 * np.linalg.norm(q0[0])


@pytest.mark.parametrize("method", IMPLICIT)
def test_members_share_a_load(small_plate, method):
    s, q0, p0, h = small_plate
    rng = np.random.default_rng(7)
    load = raydamp.Load.harmonic(1e-3 * rng.standard_normal(s.dim), 0.3 / h)
    amplitude = [1.0, 0.5, 2.0]
    ens = raydamp.integrate_ensemble(s, q0[:3], p0[:3], method=method, h=h, n_steps=25, save_every=5,
                                     load=load, parameters={"load.amplitude": amplitude}, threads=2)
    for i in range(3):
        ref = raydamp.integrate(s, q0[i], p0[i], method=method, h=h, n_steps=25, save_every=5,
                                load=load.with_parameters(amplitude=amplitude[i]))
        assert same(ens.member(i), ref), i
    unloaded = raydamp.integrate(s, q0[0], p0[0], method=method, h=h, n_steps=25, save_every=5)
    assert np.abs(ens.q_final[0] - unloaded.q[-1]).max() > 1e-6


def test_composed_midpoint_members_equal_single_runs_and_refusals_hold():
    pl = plate(12, 6)
    s = raydamp.LinearStructure(pl.M, pl.K, alpha=0.05, beta=0.0)   # beta = 0: the backward step is SPD
    rng = np.random.default_rng(8)
    q0 = 1e-2 * rng.standard_normal((4, pl.n))
    h = 0.05
    ens = raydamp.integrate_ensemble(s, q0, np.zeros(pl.n), method="midpoint", composition="yoshida4", h=h,
                                     t_end=1.02, save_every=4, threads=2)
    assert ens.composition == "yoshida4"
    for i in range(4):
        ref = raydamp.integrate(s, q0[i], np.zeros(pl.n), method="midpoint", composition="yoshida4", h=h,
                                t_end=1.02, save_every=4)
        assert same(ens.member(i), ref), i
    stiff = raydamp.LinearStructure(pl.M, pl.K, alpha=0.0, beta=0.5)
    with pytest.raises(ValueError, match="composition: 'yoshida4'.*not positive definite.*beta"):
        raydamp.integrate_ensemble(stiff, q0, np.zeros(pl.n), method="midpoint", composition="yoshida4", h=h,
                                   n_steps=3)


def test_a_blown_up_member_stops_alone_and_cancelled_members_keep_their_rows(small_plate):
    s, q0, p0, h = small_plate
    # The members share a load, scaled per member: at amplitude 1e306 the response overflows mid-run
    # (K q past the largest double), at 1 it does not.
    load = raydamp.Load.harmonic(np.random.default_rng(1).standard_normal(s.dim), 0.05 / h)
    amplitude = [1.0, 1e306, 1.0]
    ens = raydamp.integrate_ensemble(s, q0[:3], p0[:3], method="midpoint", h=h, n_steps=40, save_every=3,
                                     load=load, parameters={"load.amplitude": amplitude}, threads=2)
    assert ens.status == ("completed", "non_finite", "completed")
    for i in range(3):
        ref = raydamp.integrate(s, q0[i], p0[i], method="midpoint", h=h, n_steps=40, save_every=3,
                                load=load.with_parameters(amplitude=amplitude[i]))
        assert same(ens.member(i), ref), i
    assert 5 < ens.steps[1] < 40 and ens.failed_step[1] == ens.steps[1] + 1
    assert 1 < ens.rows[1] < ens.t.size and np.isnan(ens.q[1, ens.rows[1]:]).all()
    assert np.isfinite(ens.q[1, :ens.rows[1]]).all()
    token = raydamp.CancelToken()
    token.cancel()
    cancelled = raydamp.integrate_ensemble(s, q0, p0, method="gauss4", h=h, n_steps=10**6, save_every=10**6,
                                           cancel=token, threads=2)
    assert cancelled.status == ("cancelled",) * len(q0) and (cancelled.steps == 0).all()
    assert (cancelled.rows == 1).all()
    np.testing.assert_array_equal(cancelled.q[:, 0], q0)


@pytest.mark.parametrize("method", IMPLICIT)
def test_other_kinds_refuse_them_in_an_ensemble_naming_the_method(method):
    with pytest.raises(ValueError, match=f"method: '{method}'.*LinearStructure"):
        raydamp.integrate_ensemble(DampedPendulum(), [[1.0], [0.5]], [0.0], method=method, h=0.1, n_steps=3)


@pytest.mark.parametrize(("method", "composition", "short_last", "count"), [
    ("midpoint", None, False, 1), ("midpoint", None, True, 2), ("gauss4", None, True, 2),
    # yoshida4's sub-steps gamma_1 h, gamma_0 h, gamma_1 h: two lengths, each also of h_last
    ("midpoint", "yoshida4", True, 4)])
def test_one_factorisation_per_sub_step_length_whatever_the_members(method, composition, short_last, count):
    pl = plate(12, 6)
    s = raydamp.LinearStructure(pl.M, pl.K, alpha=0.05, beta=0.0 if composition else 0.002)
    core = s._core_model
    for members in (1, 9):
        q0 = 1e-2 * np.random.default_rng(members).standard_normal((members, pl.n))
        out = type(core).integrate_ensemble([core], np.zeros(members, dtype=np.int64), [], np.zeros((members, 0)),
                                            method, "", composition or "", q0, np.zeros_like(q0), 0.05, 20,
                                            0.02 if short_last else 0.05, 5, 2, None, None)
        assert out["factorisations"] == count, members
        assert list(out["status"]) == ["completed"] * members


def test_vector_sine_is_refused_for_a_structure_naming_it(small_plate):
    # The refusal names the argument (run_ensemble.hpp makes it before the factorisations).
    s, q0, p0, h = small_plate
    with pytest.raises(ValueError, match="vector_sine: only the damped pendulum"):
        raydamp.integrate_ensemble(s, q0, p0, method="midpoint", h=h, n_steps=3, vector_sine=True)
