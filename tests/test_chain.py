"""raydamp.Chain: lattices with damped bonds or sites (issue 7, Lattices).

- the normal-mode transforms are orthonormal: mode energies sum to the harmonic energy;
- FPUT at eps = 0 (N = 32, 10^6 steps of sv): bounded energy error with no drift, and the
  recurrence: mode 1 gives most of its energy away and takes it back;
- dashpots on every 10th bond: 3s, 2s, rks order 2 (and yoshida4 order 4) against DOP853,
  H - H0 + W = O(h^2);
- a periodic chain with damped bonds (adjacent ones too) conserves sum p to rounding;
- save_dofs keeps chosen columns, the same numbers as a full run;
- the expression bond equals the built-in family it spells out; bad input names its path;
- friction on every site (one coefficient, or one per site; issue 25 point 4: per-site factors,
  a fused 3s pass, a one-pass kick+damp) equals a NumPy 3s / 2s of the same steps, its damping
  work is the trapezoid of sum a_i p_i^2 / m, and on a periodic chain with one coefficient sum p
  decays as e^{-eps c t / m} to rounding.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import raydamp
from raydamp import Chain, chain_mode_energies
from raydamp.jobs import job_arguments

FAMILIES = {
    "harmonic": {"k": 1.3},
    "fput": {"alpha": 0.25, "beta": 1.0},
    "toda": {"a": 1.0, "b": 0.7},
    "morse": {"depth": 1.2, "a": 0.8},
    "lennard_jones": {"depth": 0.5, "spacing": 1.0},
}


def _state(n: int, seed: int = 1, scale: float = 0.1):
    rng = np.random.default_rng(seed)
    return scale * rng.standard_normal(n), scale * rng.standard_normal(n)


@pytest.mark.parametrize("boundary", ["fixed", "periodic", "free"])
def test_mode_energies_sum_to_the_harmonic_energy(boundary):
    chain = Chain(9, bond="harmonic", parameters={"k": 1.7}, mass=2.0, boundary=boundary)
    q, p = _state(9, scale=1.0)
    energies = chain.mode_energies(q, p)
    assert energies.sum() == pytest.approx(chain.energy(q, p), rel=1e-13)
    assert np.all(energies >= 0)
    # Each normal mode carries its energy alone, in its own slot of mode_energies.
    for mode in ({"fixed": 3, "periodic": 2, "free": 4}[boundary],):
        q1, p1 = chain.normal_mode(mode, amplitude=0.7)
        e = chain.mode_energies(q1, p1)
        slot = mode - 1 if boundary == "fixed" else mode
        assert e[slot] == pytest.approx(chain.energy(q1, p1), rel=1e-13)
        assert np.delete(e, slot).max() <= 1e-13 * e[slot]


def test_fput_energy_bounded_and_recurrence():
    """The classic FPUT-alpha experiment: N = 32 mobile sites, alpha = 0.25, all the energy in
    mode 1. sv (= 3s at eps = 0), h = 0.05, 10^6 steps (t = 5e4, about 750 periods of mode 1)."""
    chain = Chain(32, bond="fput", parameters={"alpha": 0.25}, boundary="fixed", eps=0.0)
    q0, p0 = chain.normal_mode(1, amplitude=1.0)
    sol = raydamp.integrate(chain, q0, p0, method="sv", h=0.05, n_steps=10**6, save_every=200)
    assert sol.success and sol.t.size == 5001
    h0 = sol.energy[0]
    error = np.abs(sol.energy - h0) / h0
    half = sol.t.size // 2
    # Bounded: O(h^2) oscillation, and no drift (the second half no worse than the first).
    assert error.max() < 2e-4
    assert error[half:].max() < 1.2 * error[:half].max()
    e1 = chain_mode_energies(sol)[:, 0] / chain.mode_energies(q0, p0)[0]
    # Recurrence: mode 1 loses most of its energy to modes 2, 3, ... and gets it back.
    first_low = np.argmax(e1 < 0.5)
    assert first_low > 0
    assert e1[first_low:].max() > 0.95, e1[first_low:].max()
    assert e1.min() < 0.4


def _reference(chain, q0, p0, t_end):
    n = chain.dim

    def field(_t, y):
        qd, pd = chain.vector_field(y[:n], y[n:])
        return np.concatenate([qd, pd])

    ref = solve_ivp(field, (0.0, t_end), np.concatenate([q0, p0]), method="DOP853", rtol=1e-13, atol=1e-13)
    return ref.y[:n, -1], ref.y[n:, -1]


def _slope(hs, errors):
    return np.polyfit(np.log(hs), np.log(errors), 1)[0]


DAMPED = dict(n=40, bond="fput", parameters={"alpha": 0.25, "beta": 1.0}, boundary="fixed",
              dampers={"bonds": list(range(9, 41, 10)), "c": 0.1})


@pytest.mark.parametrize("method, tableau, composition, order, hs", [
    ("3s", None, None, 2, (0.2, 0.1, 0.05, 0.025)),
    ("2s", None, None, 2, (0.2, 0.1, 0.05, 0.025)),
    ("rks", "midpoint", None, 2, (0.2, 0.1, 0.05, 0.025)),
    ("3s", None, "yoshida4", 4, (0.2, 0.1, 0.05)),
])
def test_damped_fput_order_and_energy_balance(method, tableau, composition, order, hs):
    chain = Chain(**DAMPED)
    q0, p0 = chain.normal_mode(1, amplitude=0.8)
    p0 = p0 + 0.2 * np.sin(np.arange(chain.dim))  # so the dashpots work from the start
    t_end = 8.0
    q_ref, p_ref = _reference(chain, q0, p0, t_end)
    errors, balance = [], []
    for h in hs:
        sol = raydamp.integrate(chain, q0, p0, method=method, tableau=tableau, composition=composition, h=h,
                                t_end=t_end, save_every=1, work=True)
        errors.append(max(np.abs(sol.q[-1] - q_ref).max(), np.abs(sol.p[-1] - p_ref).max()))
        balance.append(np.abs(sol.energy_balance).max())
    assert sol.work[-1] > 1e-3  # the dashpots took energy
    assert abs(_slope(hs, errors) - order) < 0.1, errors
    if composition is None:
        assert abs(_slope(hs, balance) - 2) < 0.15, balance


def test_damped_chain_equals_sv_at_eps_zero():
    chain = Chain(**{**DAMPED, "eps": 0.0})
    q0, p0 = _state(chain.dim)
    runs = {m: raydamp.integrate(chain, q0, p0, method=m, h=0.05, n_steps=400, save_every=400)
            for m in ("sv", "3s", "2s", "rks")}
    for m in ("2s", "rks"):  # the same arithmetic: equal to the last bit
        assert np.array_equal(runs[m].q, runs["sv"].q) and np.array_equal(runs[m].p, runs["sv"].p), m
    # sv merges the drift h/2 that ends a step with the one that starts the next; 3s cannot (its
    # damping flows sit between them), so it equals sv to rounding (measured 1e-15 after 400 steps).
    assert np.abs(runs["3s"].q - runs["sv"].q).max() < 1e-13 and np.abs(runs["3s"].p - runs["sv"].p).max() < 1e-13


@pytest.mark.parametrize("method", ["3s", "2s", "rks"])
def test_periodic_chain_conserves_momentum_with_damped_bonds(method):
    # Bonds 0, 1, 63 are adjacent across the seam (one block of 4 sites); 20 and 40 alone.
    chain = Chain(64, bond="toda", parameters={"a": 1.0, "b": 1.0}, boundary="periodic",
                  dampers={"bonds": [0, 1, 63, 20, 40], "c": 0.5})
    assert chain.momentum_names == ("P",) and chain.damping_blocks == 3
    q0, p0 = _state(64, seed=3, scale=0.5)
    p0 += 0.3  # net momentum
    sol = raydamp.integrate(chain, q0, p0, method=method, h=0.05, n_steps=20000, save_every=1000)
    assert sol.success
    assert sol.momentum[0, 0] == pytest.approx(p0.sum(), rel=1e-15)
    assert sol.max_momentum_drift < 1e-12
    assert sol.energy[-1] < sol.energy[0] - 1e-3  # damped all the same
    # On-site friction breaks translation invariance: no momentum map then.
    assert Chain(8, boundary="periodic", dampers={"sites": [2], "c": 0.1}).momentum_names == ()


def test_save_dofs_keeps_chosen_columns():
    chain = Chain(200, bond="fput", parameters={"beta": 1.0}, dampers={"sites": [5, 6, 100], "c": 0.2})
    q0, p0 = _state(200, seed=5, scale=0.3)
    full = raydamp.integrate(chain, q0, p0, method="2s", h=0.05, n_steps=1000, save_every=100, work=True)
    dofs = [150, 3, 77]
    part = raydamp.integrate(chain, q0, p0, method="2s", h=0.05, n_steps=1000, save_every=100, work=True,
                             save_dofs=dofs)
    assert part.q.shape == (11, 3) and part.p.shape == (11, 3)
    assert np.array_equal(part.q, full.q[:, dofs]) and np.array_equal(part.p, full.p[:, dofs])
    assert np.array_equal(part.energy, full.energy) and np.array_equal(part.work, full.work)
    assert list(part.dofs) == dofs and part.coordinates == ("q150", "q3", "q77")
    assert part.provenance["save_dofs"] == dofs
    with pytest.raises(ValueError, match=r"save_dofs\[1\]: 200 is not a coordinate"):
        raydamp.integrate(chain, q0, p0, method="2s", h=0.05, n_steps=10, save_dofs=[0, 200])
    with pytest.raises(ValueError, match="save_dofs: an index appears twice"):
        raydamp.integrate(chain, q0, p0, method="2s", h=0.05, n_steps=10, save_dofs=[4, 4])
    with pytest.raises(ValueError, match="mode energies need every site"):
        chain_mode_energies(part)


def test_expression_bond_equals_fput():
    fput = Chain(16, bond="fput", parameters={"alpha": 0.3, "beta": 0.8}, dampers={"bonds": [4, 5], "c": 0.2})
    text = "r^2/2 + a*r^3/3 + b*r^4/4"
    expr = Chain(16, bond="expression", parameters={"potential": text, "a": 0.3, "b": 0.8},
                 dampers={"bonds": [4, 5], "c": 0.2})
    assert expr.harmonic_stiffness == pytest.approx(1.0)
    q0, p0 = _state(16, seed=2, scale=0.4)
    a = raydamp.integrate(fput, q0, p0, method="3s", h=0.05, n_steps=2000, save_every=500)
    b = raydamp.integrate(expr, q0, p0, method="3s", h=0.05, n_steps=2000, save_every=500)
    # The same V(r), evaluated as compiled from the expression (another rounding) or by the built-in.
    assert np.abs(a.q - b.q).max() < 1e-9 and np.abs(a.energy - b.energy).max() < 1e-9


@pytest.mark.parametrize("bond", sorted(FAMILIES))
def test_every_family_runs_with_small_energy_error(bond):
    chain = Chain(24, bond=bond, parameters=FAMILIES[bond], boundary="free", eps=0.0)
    q0, p0 = _state(24, seed=4, scale=0.05)
    # h omega_max <= 0.03 for every family (Lennard-Jones is the stiffest: V''(0) = 36 here; its energy
    # error is 0.6% at h = 0.005 and falls as h^2: 0.14% here).
    sol = raydamp.integrate(chain, q0, p0, method="sv", h=0.0025, n_steps=10_000, save_every=1000)
    assert sol.success
    assert np.abs(sol.energy - sol.energy[0]).max() < 5e-3 * sol.energy[0]
    assert sol.max_momentum_drift < 1e-13  # free chain: sum p conserved


def test_json_round_trip_and_mode_start():
    chain = Chain(50, bond="morse", parameters={"depth": 2.0}, boundary="periodic",
                  dampers={"bonds": [3, 30], "c": [0.1, 0.2]}, eps=0.5)
    spec = chain.to_dict()
    assert spec["kind"] == "chain"
    again = Chain.from_dict(spec)
    assert again.to_dict() == spec
    model, q0, p0, options = job_arguments({"system": spec, "method": "3s", "step_size": 0.1, "n_steps": 10,
                                            "initial_state": {"mode": 2, "amplitude": 0.1}, "save_dofs": [0, 7]})
    assert isinstance(model, Chain) and options["save_dofs"] == [0, 7]
    assert np.allclose(q0, 0.1 * np.cos(2 * math.pi * 2 * np.arange(50) / 50))
    sol = raydamp.integrate(model, q0, p0, **options)
    assert sol.q.shape == (11, 2)


def test_an_undamped_chain_runs_again_from_its_provenance_and_sweeps():
    # Chain.to_dict() writes an undamped chain's dampers as {}, which the job schema refused ("system.dampers.c:
    # missing"): its provenance could not rebuild it, nor could check_sweep or sweep take it (an API audit).
    chain = Chain(8, bond="fput", parameters={"alpha": 0.25})
    q0, p0 = chain.normal_mode(1)
    sol = raydamp.integrate(chain, q0, p0, h=0.1, n_steps=20)
    assert sol.provenance["system"]["dampers"] == {}
    model, q, p, options = job_arguments(sol.provenance)
    np.testing.assert_array_equal(raydamp.integrate(model, q, p, **options).q, sol.q)
    plan = raydamp.check_sweep({"model": chain, "q0": q0, "p0": p0, "h": 0.1, "n_steps": 20}, {"h": [0.1, 0.05]})
    assert plan.members == 2
    # With dampers, c is still required.
    with pytest.raises(ValueError, match="system.dampers.c: missing"):
        job_arguments({**sol.provenance, "system": {**sol.provenance["system"], "dampers": {"bonds": [2]}}})


@pytest.mark.parametrize("kwargs, message", [
    ({"n": 10, "dampers": {"bonds": [11], "c": 0.1}},
     r"dampers.bonds\[0\]: bond 11 is not in this fixed chain \(0..10\)"),
    ({"n": 10, "boundary": "free", "dampers": {"bonds": [0], "c": 0.1}}, r"dampers.bonds\[0\]: bond 0"),
    ({"n": 10, "dampers": {"sites": [1]}}, "dampers.c: missing"),
    ({"n": 10, "dampers": {"bonds": [1, 2], "c": [0.1]}}, "dampers.c: 1 coefficients for 2 dampers"),
    ({"n": 10, "dampers": {"bonds": [1], "c": -1}}, "dampers.c must be >= 0"),
    ({"n": 1}, "n must be >= 2"),
    ({"n": 10, "bond": "spring"}, "bond: unknown bond family"),
    ({"n": 10, "boundary": "open"}, "boundary: unknown boundary"),
    ({"n": 10, "bond": "toda", "parameters": {"b": 0}}, r"parameters.b must be > 0"),
    ({"n": 10, "bond": "fput", "parameters": {"gamma": 1}}, "parameters.gamma: the fput bond has no parameter"),
    ({"n": 10, "bond": "expression", "parameters": {"potential": "r^2 + s"}}, "parameters.potential"),
    ({"n": 400, "dampers": {"bonds": list(range(300)), "c": 0.1}}, "coupled by damped bonds"),
    ({"n": 10, "on_site": {"kind": "quartic"}}, "on_site.kind: unknown on-site potential 'quartic'"),
    ({"n": 10, "on_site": {"kind": "harmonic", "k": -1}}, "on_site.k must be >= 0"),
    ({"n": 10, "on_site": {"kind": "sine", "k": 1}}, "on_site.k: the sine on-site potential has no parameter"),
    ({"n": 10, "on_site": "sine"}, "on_site: expected"),
])
def test_bad_input_names_its_path(kwargs, message):
    with pytest.raises(ValueError, match=message):
        Chain(**kwargs)


# -- on-site potentials (Klein-Gordon, phi^4, Frenkel-Kontorova) ---------------------------------------

def test_klein_gordon_normal_mode_is_exact_with_the_shifted_frequency():
    # Harmonic bonds and harmonic pinning: the linear chain's mode 3 stays a mode, oscillating at
    # omega_3^2 = (k lambda_3 + k_site) / m; 3s at h = 0.005 is second order: 4.4e-6 over 2 periods.
    chain = Chain(24, bond="harmonic", parameters={"k": 1.3}, mass=0.7, on_site={"kind": "harmonic", "k": 0.5},
                  eps=0.0)
    q0, p0 = chain.normal_mode(3, amplitude=0.4)
    omega = chain.frequencies()[2]
    t_end = 4 * math.pi / omega
    sol = raydamp.integrate(chain, q0, p0, method="3s", h=0.005, t_end=t_end, save_every=100)
    expected = np.cos(omega * sol.t)[:, None] * q0[None, :]
    assert np.abs(sol.q - expected).max() <= 1e-5
    # the mode energies hold the whole energy, on-site part included, in mode 3 alone
    energies = chain_mode_energies(sol)
    np.testing.assert_allclose(energies.sum(axis=1), sol.energy, rtol=1e-12)
    assert np.abs(np.delete(energies, 2, axis=1)).max() <= 1e-10 * energies[0, 2]
    assert chain.momentum_names == () and Chain(8, boundary="periodic").momentum_names == ("P",)


def test_phi4_double_well_and_sine_chains_keep_energy_and_balance():
    # eps = 0: energy error O(h^2) and bounded; damped (dashpots on bonds): H - H0 + W = O(h^2).
    for on_site in ({"kind": "phi4", "k2": -0.5, "k4": 1.0}, {"kind": "sine", "g": 0.8}):
        chain = Chain(32, bond="fput", parameters={"alpha": 0.25}, on_site=on_site, eps=0.0)
        q0 = 0.6 * np.sin(np.linspace(0, 3 * math.pi, 32)) + (0.7 if on_site["kind"] == "phi4" else 0.0)
        p0 = 0.3 * np.cos(np.arange(32.0))
        errors = []
        for h in (0.04, 0.02):
            sol = raydamp.integrate(chain, q0, p0, method="3s", h=h, t_end=200.0, save_every=10)
            errors.append(np.abs(sol.energy - sol.energy[0]).max())
        assert 3.5 < errors[0] / errors[1] < 4.5, (on_site, errors)
        assert errors[1] < 1e-3 * abs(sol.energy[0])
        damped = Chain(**{**chain.parameters, "eps": 1.0, "dampers": {"bonds": [4, 12, 20], "c": 0.3}})
        balance = []
        for h in (0.04, 0.02):
            sol = raydamp.integrate(damped, q0, p0, method="3s", h=h, t_end=40.0, save_every=5, work=True)
            balance.append(np.abs(sol.energy_balance).max())
        assert sol.work[-1] > 0.05 * sol.energy[0]  # the dashpots took energy
        assert 3.5 < balance[0] / balance[1] < 4.5, (on_site, balance)


def test_on_site_json_round_trip():
    chain = Chain(16, bond="toda", on_site={"kind": "phi4", "k2": -1.0}, eps=0.0)
    spec = chain.to_dict()
    assert spec["on_site"] == {"kind": "phi4", "k2": -1.0, "k4": 1.0}  # k4 took its default
    again = Chain.from_dict(spec)
    q = np.linspace(-1, 1, 16)
    assert again.energy(q, q) == chain.energy(q, q)
    # U = k2 q^2/2 + k4 q^4/4 on every site, beside the bonds' energy
    plain = Chain(16, bond="toda", eps=0.0)
    assert chain.energy(q, q) - plain.energy(q, q) == pytest.approx(np.sum(-0.5 * q**2 + 0.25 * q**4), rel=1e-13)
    assert "on_site" not in plain.to_dict()


def _fput_gradient(q, alpha, beta):
    """dV/dq of an FPUT chain with fixed ends (walls at q_{-1} = q_n = 0)."""
    r = np.diff(np.concatenate([[0.0], q, [0.0]]))
    f = r * (1.0 + r * (alpha + r * beta))
    return f[:-1] - f[1:]


def _phi1(x):
    return np.expm1(x) / x


@pytest.mark.parametrize("coefficients", ["one", "each"])
def test_friction_on_every_site_equals_numpy_3s_and_2s(coefficients):
    n, mass, eps, h, steps = 700, 1.3, 0.8, 0.05, 300  # 700 sites: several tiles of the fused 3s pass
    rng = np.random.default_rng(7)
    c = 0.4 if coefficients == "one" else rng.uniform(0.1, 0.6, n)
    chain = Chain(n, bond="fput", parameters={"alpha": 0.25, "beta": 1.0}, mass=mass, eps=eps,
                  dampers={"sites": list(range(n)), "c": c if coefficients == "one" else list(c)})
    assert chain.damping_blocks == n
    a = eps * np.broadcast_to(c, n) / mass  # A = eps D M^{-1}: a rate per site
    q0, p0 = _state(n, seed=11, scale=0.3)
    grad = lambda q: _fput_gradient(q, 0.25, 1.0)  # noqa: E731
    # 3s: damp h/2, drift h/2, kick h, drift h/2, damp h/2 (merged between saves: the fused pass).
    q, p = q0.copy(), p0.copy()
    rows3 = []
    for k in range(steps):
        p *= np.exp(-0.5 * h * a)
        q += 0.5 * h * p / mass
        p -= h * grad(q)
        q += 0.5 * h * p / mass
        p *= np.exp(-0.5 * h * a)
        if (k + 1) % 100 == 0:
            rows3.append((q.copy(), p.copy()))
    # 2s: drift h/2, the exact kick+damp e^{-ha} p - h phi1(-ha) grad V, drift h/2.
    q, p = q0.copy(), p0.copy()
    rows2 = []
    for k in range(steps):
        q += 0.5 * h * p / mass
        p = np.exp(-h * a) * p - h * _phi1(-h * a) * grad(q)
        q += 0.5 * h * p / mass
        if (k + 1) % 100 == 0:
            rows2.append((q.copy(), p.copy()))
    for method, rows in (("3s", rows3), ("2s", rows2)):
        sol = raydamp.integrate(chain, q0, p0, method=method, h=h, n_steps=steps, save_every=100)
        assert sol.success
        for row, (q_ref, p_ref) in enumerate(rows, start=1):
            assert np.abs(sol.q[row] - q_ref).max() < 1e-12, (method, row)
            assert np.abs(sol.p[row] - p_ref).max() < 1e-12, (method, row)
    # The damping work by the trapezoidal rule on the dissipated power sum a_i p_i^2 / m at each step.
    sol = raydamp.integrate(chain, q0, p0, method="3s", h=h, n_steps=200, save_every=1, work=True)
    power = (a * sol.p**2).sum(axis=1) / mass
    work = np.concatenate([[0.0], np.cumsum(0.5 * h * (power[1:] + power[:-1]))])
    assert np.abs(sol.work - work).max() < 1e-12 * work[-1]
    assert abs(sol.energy_balance).max() < 0.01 * sol.energy[0]  # H - H0 + W = O(h^2): 0.2% here


@pytest.mark.parametrize("method", ["3s", "2s"])
def test_uniform_friction_takes_total_momentum_down_exactly(method):
    # A periodic chain's bond forces sum to zero, so with A = a I: d(sum p)/dt = -a sum p.
    n, mass, eps, c = 600, 1.5, 0.7, 0.3
    chain = Chain(n, bond="toda", boundary="periodic", mass=mass, eps=eps,
                  dampers={"sites": list(range(n)), "c": c})
    q0, p0 = _state(n, seed=4, scale=0.4)
    p0 += 0.5
    sol = raydamp.integrate(chain, q0, p0, method=method, h=0.05, n_steps=3000, save_every=500)
    assert sol.success
    expected = p0.sum() * np.exp(-eps * c / mass * sol.t)
    assert np.abs(sol.p.sum(axis=1) - expected).max() < 1e-12 * np.abs(p0).sum()


@pytest.mark.parametrize("method", ["3s", "2s"])
def test_friction_on_every_site_under_a_load_equals_numpy(method):
    # A load takes the general flows (its force enters the kick, and 2s's phi1): the same steps
    # as NumPy, the load seen at the time the drifts have reached (t + h/2 in each step).
    n, mass, eps, h, steps, omega = 130, 1.2, 0.6, 0.05, 200, 1.3
    c = np.linspace(0.1, 0.5, n)
    amplitude = np.sin(0.1 * np.arange(n))
    chain = Chain(n, bond="fput", parameters={"alpha": 0.25, "beta": 1.0}, mass=mass, eps=eps,
                  dampers={"sites": list(range(n)), "c": list(c)})
    a = eps * c / mass
    q0, p0 = _state(n, seed=9, scale=0.2)
    q, p = q0.copy(), p0.copy()
    for k in range(steps):
        force = lambda q=q, k=k: _fput_gradient(q, 0.25, 1.0) - amplitude * np.sin(omega * (k + 0.5) * h)  # noqa: E731
        if method == "3s":
            p *= np.exp(-0.5 * h * a)
            q += 0.5 * h * p / mass
            p -= h * force()
            q += 0.5 * h * p / mass
            p *= np.exp(-0.5 * h * a)
        else:
            q += 0.5 * h * p / mass
            p = np.exp(-h * a) * p - h * _phi1(-h * a) * force()
            q += 0.5 * h * p / mass
    sol = raydamp.integrate(chain, q0, p0, method=method, h=h, n_steps=steps, save_every=50,
                            load=raydamp.Load.harmonic(amplitude, omega))
    assert sol.success
    assert np.abs(sol.q[-1] - q).max() < 1e-12 and np.abs(sol.p[-1] - p).max() < 1e-12


def test_a_chain_without_dampers_is_undamped_whatever_its_eps():
    # Chain(8) (eps 1 by default, nothing damped) refused sv with "eps = 1 > 0": the README passes eps=0.0 to get
    # round it (a Chain audit). It runs, and equals 3s on the same chain (the same steps when nothing is damped).
    chain = Chain(8, bond="fput", parameters={"alpha": 0.25})
    q0, p0 = chain.normal_mode(1)
    sv = raydamp.integrate(chain, q0, p0, method="sv", h=0.05, n_steps=200)
    three = raydamp.integrate(Chain(8, bond="fput", parameters={"alpha": 0.25}, eps=0.0), q0, p0, method="3s",
                              h=0.05, n_steps=200)
    assert sv.success and np.abs(sv.q - three.q).max() < 1e-13
    assert chain.eps == 1.0 and chain.to_dict()["eps"] == 1.0  # what was given is what the provenance says
    damped = Chain(8, bond="fput", parameters={"alpha": 0.25}, dampers={"bonds": [3], "c": 0.1})
    with pytest.raises(ValueError, match="method"):
        raydamp.integrate(damped, q0, p0, method="sv", h=0.05, n_steps=10)
