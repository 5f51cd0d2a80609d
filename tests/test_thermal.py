"""Thermal noise (issue 29): each damping flow of 3s, 2s and baoab becomes its exact Ornstein-Uhlenbeck
flow. Linear systems are checked against the exact one-step maps written here from the methods'
definitions (affine in z plus Gaussian noise; their stationary covariance from the discrete Lyapunov
equation); statistical checks use fixed seeds and state their tolerance in standard errors."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

import raydamp
from raydamp.analysis import kinetic_temperature
from raydamp.models import DampedPendulum


def quadratic_system(M, K, D, eps: float = 1.0) -> raydamp.System:
    n = K.shape[0]
    names = [f"x{i}" for i in range(n)]
    terms = [f"({float(K[i, j])!r})*{names[i]}*{names[j]}" for i in range(n) for j in range(n) if K[i, j] != 0]
    return raydamp.System(names, "(" + " + ".join(terms) + ")/2", mass=M.tolist(), damping={"matrix": D.tolist()},
                          eps=eps)


def random_linear(seed: int = 5, n: int = 3):
    rng = np.random.default_rng(seed)
    a, b = rng.standard_normal((n, n)), rng.standard_normal((n, n))
    M = a @ a.T + n * np.eye(n)
    K = b @ b.T + 0.5 * np.eye(n)
    D = 0.3 * M + 0.05 * K
    return M, K, D


# -- the documented one-step maps: z -> F z + w, w ~ N(0, Q) ------------------------------------

def _kick(K, n, t):
    F = np.eye(2 * n)
    F[n:, :n] = -t * K
    return F, np.zeros((2 * n, 2 * n))


def _drift(Minv, n, t):
    F = np.eye(2 * n)
    F[:n, n:] = t * Minv
    return F, np.zeros((2 * n, 2 * n))


def _ou(M, A, n, t, kT):
    E = scipy.linalg.expm(-t * A)
    F = np.eye(2 * n)
    F[n:, n:] = E
    Q = np.zeros((2 * n, 2 * n))
    Q[n:, n:] = kT * (M - E @ M @ E.T)
    return F, Q


def _kick_ou(M, K, A, n, t, kT):  # 2s's affine kick-damp: p -> E p - t phi1(-tA) K q + noise
    F, Q = _ou(M, A, n, t, kT)
    B = np.zeros((2 * n, 2 * n))  # expm([[X, I], [0, 0]]) = [[e^X, phi1(X)], [0, I]]: no A^-1 (A may be singular)
    B[:n, :n], B[:n, n:] = -t * A, np.eye(n)
    F[n:, :n] = -t * scipy.linalg.expm(B)[:n, n:] @ K
    return F, Q


def step_map(method: str, M, K, D, h: float, kT: float):
    n = M.shape[0]
    Minv = np.linalg.inv(M)
    A = D @ Minv
    parts = {
        "baoab": [_kick(K, n, h / 2), _drift(Minv, n, h / 2), _ou(M, A, n, h, kT), _drift(Minv, n, h / 2),
                  _kick(K, n, h / 2)],
        "3s": [_ou(M, A, n, h / 2, kT), _drift(Minv, n, h / 2), _kick(K, n, h), _drift(Minv, n, h / 2),
               _ou(M, A, n, h / 2, kT)],
        "2s": [_drift(Minv, n, h / 2), _kick_ou(M, K, A, n, h, kT), _drift(Minv, n, h / 2)],
    }[method]
    F, Q = np.eye(2 * n), np.zeros((2 * n, 2 * n))
    for Fi, Qi in parts:
        F, Q = Fi @ F, Fi @ Q @ Fi.T + Qi
    return F, Q


def stationary(method, M, K, D, h, kT):
    F, Q = step_map(method, M, K, D, h, kT)
    S = scipy.linalg.solve_discrete_lyapunov(F, Q)
    return 0.5 * (S + S.T)


def omega_max(M, K):
    return float(np.sqrt(np.max(scipy.linalg.eigh(K, M, eigvals_only=True))))


def assert_runs_documented_map(system, method, M, K, D, *, kT, h, rtol, atol, rng_seed, seed):
    """The code runs the documented one-step map of (M, K, D): its deterministic part to rounding (temperature
    0, the columns of F), and 10^5 members started from its stationary law keep that law, every covariance
    entry within 4 standard errors."""
    F, _ = step_map(method, M, K, D, h, kT)
    for j in range(6):
        z = np.eye(6)[j]
        one = raydamp.integrate(system, z[:3], z[3:], method=method, h=h, n_steps=1)
        np.testing.assert_allclose(np.concatenate([one.q[-1], one.p[-1]]), F[:, j], rtol=rtol, atol=atol)
    S = stationary(method, M, K, D, h, kT)
    members = 100_000
    z0 = np.random.default_rng(rng_seed).multivariate_normal(np.zeros(6), S, size=members)
    ens = raydamp.integrate_ensemble(system, z0[:, :3], z0[:, 3:], method=method, h=h, n_steps=6, save_every=6,
                                     temperature=kT, seed=seed, threads=2)
    sample = np.cov(np.concatenate([ens.q_final, ens.p_final], axis=1).T)
    se = np.sqrt((np.outer(np.diag(S), np.diag(S)) + S ** 2) / members)
    assert np.all(np.abs(sample - S) <= 4 * se), np.max(np.abs(sample - S) / se)


@pytest.mark.parametrize("h_omega", [0.2, 1.0, 1.9])
def test_baoab_samples_the_exact_position_covariance_of_a_linear_system(h_omega):
    M, K, D = random_linear()
    kT = 0.7
    h = h_omega / omega_max(M, K)
    S = stationary("baoab", M, K, D, h, kT)
    np.testing.assert_allclose(S[:3, :3], kT * np.linalg.inv(K), rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("method", ["baoab", "3s", "2s"])
def test_the_code_runs_the_documented_map(method):
    """Its deterministic part to rounding (temperature 0, columns of F), its stationary covariance in
    an ensemble of 10^5 members started from it: every entry within 4 standard errors."""
    M, K, D = random_linear()
    assert_runs_documented_map(quadratic_system(M, K, D), method, M, K, D, kT=0.7, h=1.0 / omega_max(M, K),
                               rtol=1e-12, atol=1e-13, rng_seed=1, seed=2024)


def dashpot_system(M, K, dampers):
    """The quadratic system of K and M with dashpots on linear functions: constant gradients, so
    D = sum c g g^T is constant and the documented map applies."""
    n = K.shape[0]
    names = [f"x{i}" for i in range(n)]
    terms = [f"({float(K[i, j])!r})*{names[i]}*{names[j]}" for i in range(n) for j in range(n) if K[i, j] != 0]
    damping = {"dampers": [{"on": " + ".join(f"({float(gi)!r})*{names[i]}" for i, gi in enumerate(g) if gi), "c": c}
                           for g, c in dampers]}
    D = sum(c * np.outer(g, g) for g, c in dampers)
    return raydamp.System(names, "(" + " + ".join(terms) + ")/2", mass=M.tolist(), damping=damping, eps=1.0), D


@pytest.mark.parametrize("dashpots", ["one", "two"])
@pytest.mark.parametrize("method", ["baoab", "3s", "2s"])
def test_dashpots_run_their_exact_ou_flow(method, dashpots):
    """Dashpots (one: the rank-one closed form; two: through the modes of S): the deterministic part
    is the documented map to rounding and 10^5 members started from its stationary law keep it,
    every covariance entry within 4 standard errors."""
    M, K, _ = random_linear(seed=8)
    dampers = [(np.array([1.0, -1.0, 0.5]), 2.0)] + ([(np.array([0.0, 0.3, 1.0]), 0.7)] if dashpots == "two" else [])
    system, D = dashpot_system(M, K, dampers)
    assert_runs_documented_map(system, method, M, K, D, kT=0.6, h=0.8 / omega_max(M, K), rtol=1e-11, atol=1e-12,
                               rng_seed=4, seed=77)


def test_a_q_dependent_dashpot_thermalises_an_anharmonic_oscillator():
    """A dashpot whose gradient varies with q (on x + x^3/3: D = c (1 + x^2)^2): 10^4 members from rest
    reach the kinetic temperature <p^2> = kT and the configurational one <x V'(x)> = kT, each within 4
    standard errors plus the method's O(h^2) bias (h = 0.02; about 1e-3 kT here)."""
    system = raydamp.System(["x"], "x^4/4 + x^2/2", eps=1.0, damping={"dampers": [{"on": "x + x^3/3", "c": 0.8}]})
    members, kT = 10_000, 0.4
    ens = raydamp.integrate_ensemble(system, np.zeros((members, 1)), np.zeros((members, 1)), method="baoab",
                                     h=0.02, n_steps=3000, save_every=3000, temperature=kT, seed=3, threads=2)
    x, p = ens.q_final[:, 0], ens.p_final[:, 0]
    for name, values in (("kinetic", p ** 2), ("configurational", x * (x ** 3 + x))):
        assert abs(values.mean() - kT) <= 4 * values.std() / np.sqrt(members) + 2e-3 * kT, (name, values.mean())


@pytest.mark.parametrize("method", ["3s", "baoab"])
def test_kinetic_temperature_of_an_oscillator_matches_the_discrete_value(method):
    m, k, c, kT = 2.0, 3.0, 0.8, 0.4
    M, K, D = np.array([[m]]), np.array([[k]]), np.array([[c * m]])
    system = raydamp.System(["x"], f"{k}*x^2/2", mass=m, damping={"scalar": c}, eps=1.0)
    h = 0.8 / np.sqrt(k / m)
    S = stationary(method, M, K, D, h, kT)
    members = 100_000
    z0 = np.random.default_rng(3).multivariate_normal(np.zeros(2), S, size=members)
    ens = raydamp.integrate_ensemble(system, z0[:, :1], z0[:, 1:], method=method, h=h, n_steps=8, save_every=8,
                                     temperature=kT, seed=11)
    p2m = ens.p_final[:, 0] ** 2 / m
    exact = S[1, 1] / m
    assert abs(p2m.mean() - exact) <= 4 * p2m.std() / np.sqrt(members)
    # The README's figures: 3s samples p at kT exactly (its last sub-flow is the OU flow) and q at
    # kT/k (1 - (h omega)^2 / 4); baoab the mirror image.
    shrunk = 1 - (h * np.sqrt(k / m)) ** 2 / 4
    exact_p, exact_q = (kT, kT / k * shrunk) if method == "3s" else (kT * shrunk, kT / k)
    assert exact == pytest.approx(exact_p, rel=1e-12)
    assert S[0, 0] == pytest.approx(exact_q, rel=1e-12)
    q2 = ens.q_final[:, 0] ** 2
    assert abs(q2.mean() - exact_q) <= 4 * q2.std() / np.sqrt(members)


def test_same_seed_same_run_and_members_equal_their_single_runs():
    model = DampedPendulum(eps=0.3)
    q0 = np.linspace(0.1, 1.0, 6)[:, None]
    p0 = np.zeros((6, 1))
    runs = [raydamp.integrate_ensemble(model, q0, p0, method="baoab", h=0.05, n_steps=400, save_every=50,
                                       temperature=0.5, seed=99, threads=t) for t in (1, 2)]
    np.testing.assert_array_equal(runs[0].q, runs[1].q)
    for i in range(6):
        single = raydamp.integrate(model, q0[i], p0[i], method="baoab", h=0.05, n_steps=400, save_every=50,
                                   temperature=0.5, seed=99, stream=i)
        np.testing.assert_array_equal(runs[0].member(i).q, single.q)
        assert runs[0].member(i).provenance.get("stream", 0) == i
    again = raydamp.integrate(model, q0[2], p0[2], method="baoab", h=0.05, n_steps=400, temperature=0.5, seed=99,
                              stream=2)
    other = raydamp.integrate(model, q0[2], p0[2], method="baoab", h=0.05, n_steps=400, temperature=0.5, seed=100,
                              stream=2)
    assert again.provenance["seed"] == 99 and again.provenance["temperature"] == 0.5
    assert not np.array_equal(again.q, other.q)
    fresh = raydamp.integrate(model, q0[2], p0[2], method="3s", h=0.05, n_steps=10, temperature=0.5)
    repeat = raydamp.integrate(*raydamp.jobs.job_arguments(fresh.provenance)[:3],
                               **raydamp.jobs.job_arguments(fresh.provenance)[3])
    np.testing.assert_array_equal(fresh.q, repeat.q)


@pytest.mark.parametrize("method", ["3s", "2s", "baoab"])
def test_pendulum_lanes_carry_each_members_own_noise(method):
    """A pendulum ensemble at a temperature runs as SIMD lanes; lane k draws member k's stream, so every
    member equals its single run bit for bit, at 1 and 2 threads (300 members: several batches)."""
    model = DampedPendulum(eps=0.2)
    members = 300
    q0 = np.linspace(-1.0, 1.0, members)[:, None]
    p0 = np.linspace(0.5, -0.5, members)[:, None]
    run = dict(method=method, h=0.05, n_steps=200, save_every=50, temperature=0.7, seed=11)
    for threads in (1, 2):
        ens = raydamp.integrate_ensemble(model, q0, p0, first_stream=5, threads=threads, **run)
        for i in (0, 1, 137, 299):
            single = raydamp.integrate(model, q0[i], p0[i], stream=5 + i, **run)
            np.testing.assert_array_equal(ens.member(i).q, single.q)
            np.testing.assert_array_equal(ens.member(i).p, single.p)
    # vector_sine lanes take noise too; a member does not depend on how the ensemble was cut into lanes
    whole = raydamp.integrate_ensemble(model, q0, p0, first_stream=5, vector_sine=True, **run)
    part = raydamp.integrate_ensemble(model, q0[:7], p0[:7], first_stream=5, vector_sine=True, **run)
    np.testing.assert_array_equal(whole.q[:7], part.q)
    single = raydamp.integrate(model, q0[3], p0[3], stream=8, **run)
    np.testing.assert_allclose(whole.member(3).q, single.q, rtol=0, atol=1e-12)  # raydamp's sine vs libm: last bits


def test_member_noises_are_independent():
    """Members 0 and 1 of one seed: their first-step momentum kicks are uncorrelated (10^6 pairs, 4 SE)."""
    model = DampedPendulum(eps=1.0)
    members = 200_000
    draws = []
    for offset in (0, members):
        ens = raydamp.integrate_ensemble(model, np.zeros((members, 1)), np.zeros((members, 1)), method="3s", h=0.1,
                                         n_steps=1, temperature=1.0, seed=5, first_stream=offset)
        draws.append(ens.p_final[:, 0])
    a, b = draws
    r = np.corrcoef(a, b)[0, 1]
    assert abs(r) <= 4 / np.sqrt(members)
    assert abs(np.corrcoef(a[:-1], a[1:])[0, 1]) <= 4 / np.sqrt(members)


def test_bad_input_names_the_argument():
    model = DampedPendulum(eps=0.1)
    run = dict(h=0.1, n_steps=2)
    with pytest.raises(ValueError, match=r"temperature must be >= 0"):
        raydamp.integrate(model, [0.1], [0.0], temperature=-1.0, **run)
    with pytest.raises(ValueError, match=r"seed must be an integer"):
        raydamp.integrate(model, [0.1], [0.0], temperature=1.0, seed=1.5, **run)
    with pytest.raises(ValueError, match=r"first_stream: members draw streams first_stream \+ i for i < 3"):
        raydamp.integrate_ensemble(model, np.full((3, 1), 0.1), np.zeros((3, 1)), temperature=1.0, seed=1,
                                   first_stream=2**64 - 2, **run)  # stream 2^64 - 2 + 2 would wrap to 0
    for bad in (-1, True, 1.5):  # the message said "stream must be ..."
        with pytest.raises(ValueError, match=r"^first_stream must be an integer in \[0, 2\^64\)"):
            raydamp.integrate_ensemble(model, np.full((3, 1), 0.1), np.zeros((3, 1)), temperature=1.0,
                                       first_stream=bad, **run)
    with pytest.raises(ValueError, match=r"temperature: method 'rks' has no exact noise flow"):
        raydamp.integrate(model, [0.1], [0.0], method="rks", temperature=1.0, **run)
    with pytest.raises(ValueError, match=r"^temperature: method 'rk4' has no exact noise flow"):  # it said 'rk'
        raydamp.integrate(model, [0.1], [0.0], method="rk4", temperature=1.0, **run)
    with pytest.raises(ValueError, match=r"temperature: composition 'yoshida4' runs sub-steps backward"):
        raydamp.integrate(model, [0.1], [0.0], composition="yoshida4", temperature=1.0, **run)
    with pytest.raises(ValueError, match=r"temperature: this model has no damping"):
        raydamp.integrate(DampedPendulum(eps=0.0), [0.1], [0.0], temperature=1.0, **run)


def test_double_well_bias_is_second_order_and_smallest_for_baoab():
    """V = (x^2 - 1)^2 at kT = 0.5 with unit friction: <x^2> and <V> against quadrature of the Boltzmann
    density. 3s and 2s: |bias of <x^2>| fitted against h over four step sizes has slope 2 +- 0.3; baoab's bias is
    the smallest at every h where the difference is resolved (4 standard errors). 4,000 members x 350
    time units each (time averages after a burn-in of 50; members are independent, so the standard
    error is that of the members' averages). baoab's own slope needs ~100 times the samples
    (its bias at h = 0.1 is 2.5e-4 against a standard error of 3e-4 here; h = 0.3 blows up rare members):
    benchmarks/bench_thermal.py."""
    import scipy.integrate as si

    kT = 0.5
    V = lambda x: (x ** 2 - 1) ** 2  # noqa: E731
    Z = si.quad(lambda x: np.exp(-V(x) / kT), -4, 4)[0]
    exact = {"x2": si.quad(lambda x: x * x * np.exp(-V(x) / kT), -4, 4)[0] / Z,
             "V": si.quad(lambda x: V(x) * np.exp(-V(x) / kT), -4, 4)[0] / Z}
    system = raydamp.System(["x"], "(x^2-1)^2", damping={"scalar": 1.0}, eps=1.0)
    members, hs = 4000, [0.24, 0.2, 0.17, 0.14]
    start = np.where(np.arange(members) % 2 == 0, -1.0, 1.0)[:, None]
    bias = {}
    for method in ("baoab", "3s", "2s"):
        for h in hs:
            ens = raydamp.integrate_ensemble(system, start, np.zeros((members, 1)), method=method, h=h, t_end=400.0,
                                             save_every=max(1, round(1.0 / h)), temperature=kT, seed=11)
            assert all(s == "completed" for s in ens.status)
            x = ens.q[:, ens.t >= 50.0, 0]
            for name, values in (("x2", x ** 2), ("V", V(x))):
                per_member = values.mean(axis=1)
                bias[method, name, h] = (per_member.mean() - exact[name], per_member.std() / np.sqrt(members))
    for name in ("x2", "V"):
        for method in ("3s", "2s") if name == "x2" else ():  # <V>'s biases are within a few SE of each other
            b = np.array([abs(bias[method, name, h][0]) for h in hs])
            se = np.array([bias[method, name, h][1] for h in hs])
            slope = np.polyfit(np.log(hs), np.log(b), 1, w=b / se)[0]  # weights: 1 / the logs' standard errors
            assert abs(slope - 2.0) <= 0.3, (method, name, b, slope)
        for h in hs:
            (b0, s0), (b1, s1) = bias["baoab", name, h], bias["3s", name, h]
            if abs(abs(b1) - abs(b0)) > 4 * np.hypot(s0, s1):
                assert abs(b0) < abs(b1), (name, h, b0, b1)
        assert abs(bias["baoab", name, 0.24][0]) < min(abs(bias["3s", name, 0.24][0]),
                                                       abs(bias["2s", name, 0.24][0])), \
            {k: v for k, v in bias.items() if k[1] == name}


@pytest.mark.parametrize("lumped", [True, False])
def test_linear_structure_with_alpha_damping_reaches_equipartition(lumped):
    """A 200-DOF structure (lumped or consistent M) with C = alpha M at kT = 0.3, 3s from rest: 3s's saved
    momenta are N(0, kT M) exactly in stationarity (its last sub-flow is the OU flow), so
    <p^T M^-1 p> / n = kT; 64 members x 200 DOF x 20 saved rows, within 4 standard errors."""
    import scipy.sparse as sp

    n, kT = 200, 0.3
    rng = np.random.default_rng(4)
    K = sp.diags([np.full(n, 2.0), -np.ones(n - 1), -np.ones(n - 1)], [0, 1, -1], format="csc") * 50.0
    if lumped:
        M = sp.diags(rng.uniform(0.5, 2.0, n), format="csc")
    else:
        M = sp.diags([np.full(n, 4.0), np.ones(n - 1), np.ones(n - 1)], [0, 1, -1], format="csc") / 6.0
    structure = raydamp.LinearStructure(M, K, alpha=0.5)
    members = 64
    ens = raydamp.integrate_ensemble(structure, np.zeros((members, n)), np.zeros((members, n)), method="3s",
                                     h=0.05, t_end=60.0, save_every=40, temperature=kT, seed=8, threads=2)
    p = ens.p[:, ens.t >= 40.0, :].reshape(-1, n)
    Minv = sp.linalg.splu(M)
    per_row = np.einsum("ij,ij->i", p, Minv.solve(p.T).T) / n
    se = per_row.std() / np.sqrt(per_row.size)
    assert abs(per_row.mean() - kT) <= 4 * se + 1e-12


def test_3s_at_a_temperature_draws_one_path_whatever_is_saved():
    """3s's join of two damping flows would be one OU draw over h where an unmerged step draws two over h/2
    (found in review): at a temperature 3s runs whole steps, so save_every and work do not change the path."""
    model = DampedPendulum(eps=0.3)
    runs = [raydamp.integrate(model, [0.5], [0.0], method="3s", h=0.05, n_steps=600, temperature=0.5, seed=3,
                              save_every=every, work=work) for every, work in ((1, False), (50, False), (600, True))]
    np.testing.assert_array_equal(runs[0].q[::50], runs[1].q)
    np.testing.assert_array_equal(runs[0].q[-1], runs[2].q[-1])



@pytest.mark.parametrize("method", ["baoab", "2s"])
def test_two_dashpots_at_a_temperature_draw_one_path_whatever_is_saved(method):
    # Several dashpots draw their noise through the modes of S(q). It was L V diag(s) xi, V as the eigensolver
    # gave it, defined up to its columns' signs: steps merged (save_every=7) or not (save_every=1), 1e-16 apart in
    # q, drew noise 1.6e-2 apart. Now the root is symmetric in the modes, L V diag(s) V^T xi: measured 5e-15.
    damped = raydamp.System(["x", "y"], "x^2 + y^4/4 + x*y/3",
                            damping={"dampers": [{"on": "x - y", "c": 0.5}, {"on": "x*y", "c": 0.2}]}, eps=1.0)
    runs = [raydamp.integrate(damped, [0.3, -0.2], [0.1, 0.4], method=method, h=0.05, n_steps=400,
                              save_every=every, temperature=0.4, seed=2024, stream=3) for every in (1, 7)]
    np.testing.assert_allclose(runs[1].q[:-1], runs[0].q[::7], rtol=0, atol=1e-12)  # (and the last step's row)
    np.testing.assert_allclose(runs[1].q[-1], runs[0].q[-1], rtol=0, atol=1e-12)
    # A blow-up is found where it happens, whatever is saved: a block of merged steps that blew up is replayed
    # unmerged, and a replay that stayed finite ended the run anyway, "non_finite" at the block's end (step 1401
    # with a finite state saved, where save_every=1 ran on to step 6048).
    well = raydamp.System(["x", "y"], "x^2/2 + y^2/2 - 0.01*x^4",
                          damping={"dampers": [{"on": "x - y", "c": 0.5}, {"on": "x*y", "c": 0.2}]}, eps=1.0)
    ends = [raydamp.integrate(well, [0.0, 0.0], [0.0, 0.0], method=method, h=0.05, n_steps=20_000,
                              save_every=every, temperature=1.5, seed=7, stream=2) for every in (20_000, 1)]
    assert ends[0].status == ends[1].status
    assert ends[0].failed_step == ends[1].failed_step  # (the last states, a blow-up's, may differ in size)


def test_the_temperatures_of_a_member_and_of_a_loaded_run_rebuild_its_model(tmp_path):
    # They needed "the model of the run", which only integrate's own Solution carried: an ensemble's member and
    # a loaded file (both with their provenance) were a ValueError. The members differ in their mass m, which
    # both temperatures read (p^T M^-1 p; grad V and its Laplacian): a member rebuilt with another m would differ.
    from raydamp.analysis import configurational_temperature
    from raydamp.models import ElasticPendulum

    q0, p0 = [0.0, 1.0, -0.5], [0.2, 0.0, 0.0]
    ens = raydamp.integrate_ensemble(ElasticPendulum(eps=0.5), q0, p0, parameters={"m": [1.0, 2.5]},
                                     method="baoab", h=0.02, n_steps=4000, save_every=10, temperature=0.5, seed=11)
    alone = raydamp.integrate(ElasticPendulum(eps=0.5, m=2.5), q0, p0, method="baoab", h=0.02, n_steps=4000,
                              save_every=10, temperature=0.5, seed=11, stream=1)
    member = ens.member(1)
    np.testing.assert_array_equal(member.p, alone.p)
    for temperature in (kinetic_temperature, configurational_temperature):
        assert temperature(member, burn_in=20) == temperature(alone, burn_in=20)
    other = raydamp.integrate(ElasticPendulum(eps=0.5, m=1.0), q0, p0, method="baoab", h=0.02, n_steps=4000,
                              save_every=10, temperature=0.5, seed=11, stream=1)
    assert kinetic_temperature(member, burn_in=20) != kinetic_temperature(other, burn_in=20)
    alone.save(tmp_path / "run.nc")
    loaded = raydamp.load(tmp_path / "run.nc")
    assert kinetic_temperature(loaded, burn_in=20) == kinetic_temperature(alone, burn_in=20)
    # The summaries too: a member's and a loaded run's said None (no model at hand), as if run without noise.
    expected = alone.summary()["kinetic_temperature"]
    assert expected is not None
    assert member.summary()["kinetic_temperature"] == pytest.approx(expected, rel=1e-14)
    assert loaded.summary()["kinetic_temperature"] == pytest.approx(expected, rel=1e-14)
    assert ens.member(0).summary()["kinetic_temperature"] != pytest.approx(expected, rel=1e-3)


def test_a_seed_or_stream_without_a_temperature_is_refused_naming_it():
    # They were dropped silently (the provenance said seed None), where the CLI and the job JSON refuse them.
    model = DampedPendulum(eps=0.5)
    for kwargs, name in (({"seed": 5}, "seed"), ({"stream": 5}, "stream")):
        with pytest.raises(ValueError, match=f"^{name}: given without a temperature"):
            raydamp.integrate(model, [0.5], [0.0], h=0.1, n_steps=10, **kwargs)
    with pytest.raises(ValueError, match="^first_stream: given without a temperature"):
        raydamp.integrate_ensemble(model, [[0.5], [1.0]], [0.0], h=0.1, n_steps=10, first_stream=3)
    # A temperature of 0 may carry them (a sweep over temperatures from 0 passes one seed to every member).
    quiet = raydamp.integrate(model, [0.5], [0.0], h=0.1, n_steps=10, temperature=0.0, seed=5)
    assert quiet.provenance.get("temperature") is None

def test_a_load_history_of_one_column_on_a_one_coordinate_model():
    model = DampedPendulum()
    rows = raydamp.Load.series([0.0, 1.0], [[0.0], [2.0]])
    np.testing.assert_allclose(rows.values(model, [0.25])[0], [0.5])


def test_the_summary_reports_the_kinetic_temperature_of_a_run_at_a_temperature():
    """3s's saved momentum is sampled at kT exactly (its last sub-flow is the OU flow); saved points 20
    time units apart (25 relaxation times of p) are independent, so the summary's mean of p^2/m over
    the 2000 points of the second half lies within 4 standard errors, 4 sqrt(2 / 2000) kT, of kT."""
    m, k, c, kT = 2.0, 3.0, 0.8, 0.4
    system = raydamp.System(["x"], f"{k}*x^2/2", mass=m, damping={"scalar": c}, eps=1.0)
    h = 0.5
    sol = raydamp.integrate(system, [0.0], [0.0], method="3s", h=h, t_end=80_000.0, save_every=40, temperature=kT,
                            seed=17)
    summary = sol.summary()
    assert abs(summary["kinetic_temperature"] - kT) <= 4 * np.sqrt(2 / 2000) * kT
    # the same estimate as raydamp.analysis's over the second half (2001 points: one thinned away)
    half = kinetic_temperature(sol, burn_in=40_000.0)
    assert summary["kinetic_temperature"] == pytest.approx(half, rel=5e-3)
    short = raydamp.integrate(system, [0.0], [0.0], method="3s", h=h, t_end=400.0, save_every=40, temperature=kT,
                              seed=17)
    assert short.summary()["kinetic_temperature"] == pytest.approx(
        kinetic_temperature(short, burn_in=200.0), rel=1e-15)
    assert raydamp.integrate(system, [0.0], [0.0], method="3s", h=h, t_end=400.0).summary()["kinetic_temperature"] \
        is None
    assert raydamp.integrate(system, [0.0], [0.0], method="3s", h=h, t_end=400.0, temperature=kT, seed=1,
                             save_dofs=[0]).summary()["kinetic_temperature"] is None
