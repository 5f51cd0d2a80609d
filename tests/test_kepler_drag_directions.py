"""Radial and tangential drag on the exact Kepler split (issue 46): p's part along q_i decays at the radial
rate, the part across it at the tangential one, each exactly at the frozen q. A radial dashpot exerts no
torque (L conserved to rounding); a tangential one decays L as e^{-eps t}; against DOP853 at rtol 1e-13 the
splittings keep their orders; ensembles batch only members with the same direction."""

import numpy as np
import pytest

import raydamp

MU = 1.0


def dop853(eps, drag, q0, p0, times):
    from scipy.integrate import solve_ivp

    def field(_, y):
        q, v = y[:2], y[2:]
        r = q / np.linalg.norm(q)
        along = (v @ r) * r
        force = {"isotropic": v, "radial": along, "tangential": v - along}[drag]
        return np.concatenate([v, -MU * q / np.linalg.norm(q) ** 3 - eps * force])

    out = solve_ivp(field, (0.0, times[-1]), np.concatenate([q0, p0]), method="DOP853", rtol=1e-13, atol=1e-15,
                    t_eval=times)
    return out.y[:2].T


@pytest.mark.parametrize("method", ["3s", "2s", "baoab"])
def test_a_radial_dashpot_keeps_the_angular_momentum_and_takes_energy(method):
    k = raydamp.Kepler(MU, eps=0.05, drag="radial")
    q0, p0 = k.pericentre_state(1.0, 0.5)
    sol = raydamp.integrate(k, q0, p0, method=method, h=0.02, t_end=200.0, save_every=50)
    assert sol.momentum_names == ("L",)
    assert np.max(np.abs(sol.momentum[:, 0] - sol.momentum[0, 0])) <= 1e-13 * abs(sol.momentum[0, 0])
    assert sol.max_momentum_drift <= 1e-13
    # The eccentricity is damped: E falls toward the circular orbit's -mu / (2 r) at that L.
    assert sol.energy[-1] < sol.energy[0] - 0.01
    circular = -MU**2 / (2 * sol.momentum[0, 0] ** 2)
    assert sol.energy[-1] > circular - 1e-9


def test_a_tangential_dashpot_decays_the_angular_momentum_exactly():
    k = raydamp.Kepler(MU, eps=1e-3, drag="tangential")
    sol = raydamp.integrate(k, [1.0, 0.0], [0.0, 1.1], method="3s", h=0.05, t_end=1100.0, save_every=100)
    law = sol.momentum[0, 0] * np.exp(-1e-3 * sol.t)
    assert np.max(np.abs(sol.momentum[:, 0] - law) / np.abs(law)) <= 1e-12


@pytest.mark.parametrize("drag", ["radial", "tangential"])
@pytest.mark.parametrize(("method", "composition", "order"), [("3s", None, 2), ("2s", None, 2), ("baoab", None, 2),
                                                               ("3s", "yoshida4", 4)])
def test_each_direction_keeps_the_splittings_order(drag, method, composition, order):
    k = raydamp.Kepler(MU, eps=0.05, drag=drag)
    q0, p0 = k.pericentre_state(1.0, 0.5)
    hs = [0.1, 0.05, 0.025]
    errors = []
    for h in hs:
        sol = raydamp.integrate(k, q0, p0, method=method, composition=composition, h=h, t_end=10.0,
                                save_every=round(1.0 / h))
        errors.append(np.max(np.linalg.norm(sol.q - dop853(0.05, drag, q0, p0, sol.t), axis=1)))
    slopes = np.diff(np.log(errors)) / np.diff(np.log(hs))
    assert slopes.min() >= order - 0.2, (errors, slopes)


def test_isotropic_is_the_default_and_the_form_round_trips():
    a = raydamp.Kepler(MU, eps=1e-2)
    b = raydamp.Kepler(MU, eps=1e-2, drag="isotropic")
    sa = raydamp.integrate(a, [1.0, 0.0], [0.0, 1.2], method="2s", h=0.05, n_steps=400, save_every=40)
    sb = raydamp.integrate(b, [1.0, 0.0], [0.0, 1.2], method="2s", h=0.05, n_steps=400, save_every=40)
    assert np.array_equal(sa.q, sb.q) and np.array_equal(sa.p, sb.p)
    assert b.to_dict()["drag"] == "isotropic" and raydamp.Kepler.from_dict(b.to_dict()).to_dict() == b.to_dict()
    radial = raydamp.Kepler(MU, eps=1e-2, drag="radial")
    assert raydamp.Kepler.from_dict(radial.to_dict()).drag == "radial"


def test_radial_drag_at_a_temperature_samples_the_boltzmann_law_of_the_momentum():
    # The OU noise of each direction's damping (planets.hpp's add_noise): with the Kepler force switched off in
    # effect (a huge orbit, mu small), p is an OU process whose radial part relaxes at eps and whose stationary
    # law is N(0, kT m) in every direction; the tangential part is not damped and keeps its start.
    k = raydamp.Kepler(1e-12, mass=2.0, eps=1.0, drag="radial")
    sol = raydamp.integrate(k, [1e6, 0.0], [0.0, 0.0], method="baoab", h=0.05, n_steps=200_000, save_every=20,
                            temperature=0.5, seed=11)
    radial, tangential = sol.p[500:, 0], sol.p[500:, 1]
    assert abs(np.var(radial) / (0.5 * 2.0) - 1.0) <= 0.1, np.var(radial)
    assert np.max(np.abs(tangential)) <= 1e-9


def test_planets_with_radial_drag_keep_the_total_angular_momentum():
    system = raydamp.Planets([1e-3, 1e-3], eps=[2e-2, 5e-3], drag="radial")
    q0, p0 = system.jacobi_state([[1.0, 0.0], [0.0, 2.0]], [[0.0, 1.0], [-0.72, 0.02]])
    sol = raydamp.integrate(system, q0, p0, method="2s", h=0.05, t_end=300.0, save_every=100)
    assert sol.momentum_names == ("L",)
    assert np.max(np.abs(sol.momentum[:, 0] - sol.momentum[0, 0])) <= 1e-12 * abs(sol.momentum[0, 0])
    assert sol.energy[-1] < sol.energy[0]
    assert raydamp.Planets.from_dict(system.to_dict()).to_dict() == system.to_dict()


def assert_batched_as_single_runs(model, other, q0, p0, method, split):
    """integrate_ensemble of model's members equals their single runs bit for bit; and through the core's door
    with members [split:] of ``other`` (another drag, the same eps), none of those runs as a particle of the
    first members' batch: each still equals its own single run."""
    from raydamp import _core

    members = len(q0)
    run = {"method": method, "h": 0.05, "n_steps": 200, "save_every": 50}
    ens = raydamp.integrate_ensemble(model, q0, p0, threads=2, **run)
    for i in range(members):
        single = raydamp.integrate(model, q0[i], p0[i], **run)
        assert np.array_equal(ens.member(i).q, single.q) and np.array_equal(ens.member(i).p, single.p), i
    index = np.zeros(members, dtype=np.int64)
    index[split:] = 1
    out = _core.Planets.integrate_ensemble([model._core_model, other._core_model], index, [],
                                           np.zeros((members, 0)), method, "", "", q0, p0, 0.05, 200, 0.05, 50, 1,
                                           None, None)
    for i in range(members):
        single = raydamp.integrate(model if i < split else other, q0[i], p0[i], **run)
        assert np.array_equal(out["q"][i], single.q), i


def test_ensemble_members_equal_single_runs_and_directions_are_not_mixed():
    members = 40
    rng = np.random.default_rng(7)
    rp, e = rng.uniform(0.5, 2.0, members), rng.uniform(0.0, 0.7, members)
    q0 = np.column_stack([rp, np.zeros(members)])
    p0 = np.column_stack([np.zeros(members), np.sqrt(MU * (1.0 + e) / rp)])
    # members 30-39 isotropic: not run as particles of the radial members' batch
    assert_batched_as_single_runs(raydamp.Kepler(MU, eps=1e-2, drag="radial"), raydamp.Kepler(MU, eps=1e-2),
                                  q0, p0, "2s", split=30)


def test_a_bad_direction_is_refused_naming_drag():
    with pytest.raises(ValueError, match="drag: must be one of isotropic, radial, tangential"):
        raydamp.Kepler(MU, eps=1e-3, drag="sideways")
    with pytest.raises(ValueError, match="drag"):
        raydamp.Planets([1e-3], eps=1e-3, drag="up")
    from raydamp.jobs import job_arguments

    job = {"system": {"kind": "kepler", "mu": 1.0, "eps": 1e-3, "drag": "radial"}, "method": "3s", "h": 0.1,
           "t_end": 10.0, "initial_state": {"q": [1.0, 0.0], "p": [0.0, 1.1]}}
    model, q0, p0, options = job_arguments(job)
    assert model.drag == "radial"
    with pytest.raises(ValueError, match="system.drag"):
        job_arguments({**job, "system": {**job["system"], "drag": "sideways"}})
