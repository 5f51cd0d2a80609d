"""Thermal noise of a LinearStructure with Rayleigh damping C = alpha M + beta K (issue 29).

The noise of one damping flow over t is N xi with N N^T = M - E M E^T, E = exp(-t C M^-1); the code's
N is psi(C M^-1) R (C = R R^T, psi(x) = sqrt((1 - e^{-2tx}) / x)), not the symmetric root, so the dense
check compares N N^T (N assembled column by column through the testing hook) with the covariance from
a generalized symmetric eigendecomposition. The statistical checks use exact properties of the linear
case: baoab samples the position covariance kT K^-1 and 3s's saved momenta N(0, kT M) for any stable h."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse as sp

import raydamp


def chain_200(lumped: bool):
    """A supported chain of 200 masses with springs of varying stiffness (K positive definite)."""
    n = 200
    rng = np.random.default_rng(11)
    springs = rng.uniform(0.2, 5.0, n + 1) * 40.0
    K = sp.diags([springs[:-1] + springs[1:], -springs[1:-1], -springs[1:-1]], [0, 1, -1], format="csc")
    if lumped:
        M = sp.diags(rng.uniform(0.5, 2.0, n), format="csc")
    else:
        w = rng.uniform(0.5, 2.0, n + 1) / 6.0  # element masses: consistent 2-node bars
        M = sp.diags([2.0 * (w[:-1] + w[1:]), w[1:-1], w[1:-1]], [0, 1, -1], format="csc")
    return M, K


def covariance(M, C, t):
    """M - E M E^T = M V diag(1 - e^{-2tw}) V^T M, C V = M V diag(w), V^T M V = I."""
    Md = M.toarray()
    w, V = scipy.linalg.eigh(C.toarray(), Md)
    MV = Md @ V
    return (MV * -np.expm1(-2.0 * t * w)) @ MV.T


@pytest.mark.parametrize("lumped", [True, False])
@pytest.mark.parametrize("alpha,beta", [(0.0, 0.02), (0.4, 0.02), (0.0, 3.0)])
@pytest.mark.parametrize("t", [1e-3, 0.05])
def test_noise_factor_matches_the_dense_ou_covariance(lumped, alpha, beta, t):
    """N N^T against the dense M - E M E^T to 1e-10 of its largest entry and each variance to 1e-9 of
    itself (n = 200; alpha = 0 with small t is where the symmetric root's sqrt branch point bites)."""
    M, K = chain_200(lumped)
    s = raydamp.LinearStructure(M, K, alpha=alpha, beta=beta)
    core = s._core_model
    n = K.shape[0]
    N = np.column_stack([core.thermal_noise(t, np.eye(n)[j]) for j in range(n)])
    expected = covariance(M, alpha * M + beta * K, t)
    got = N @ N.T
    assert np.abs(got - expected).max() <= 1e-10 * np.abs(expected).max()
    np.testing.assert_allclose(np.diag(got), np.diag(expected), rtol=1e-9)
    # the noise of a draw is linear in the draw, and the same draw gives the same bits
    xi = np.random.default_rng(3).standard_normal(n)
    once = core.thermal_noise(t, xi)
    np.testing.assert_array_equal(once, core.thermal_noise(t, xi))
    np.testing.assert_allclose(once, N @ xi, rtol=0, atol=1e-12 * np.abs(once).max())


def test_noise_series_degree_stays_small_at_alpha_zero():
    """psi has no branch point on the spectrum: its series degree is at most twice the damping flow's
    (measured: equal for t beta L <~ 1, about 1.7x for t beta L in 10^2 .. 10^4), where Lanczos on the
    symmetric root's (I - e^{-2tS})^{1/2} needs all n = 200 iterations for 1e-10 at t = 0.05 (NumPy, full
    reorthogonalisation: 3e-5 after 150), the series 9 products."""
    M, K = chain_200(True)
    for beta in (0.02, 3.0):
        s = raydamp.LinearStructure(M, K, alpha=0.0, beta=beta)
        for t in (1e-3, 0.05, 1.0, 10.0):
            assert s._core_model.noise_chebyshev_degree(t) <= 2 * max(s.chebyshev_degrees(t)), (beta, t)
    assert s._core_model.noise_chebyshev_degree(1e-3) == 15


def test_a_free_structure_with_beta_k_damping_alone_refuses_a_temperature():
    """C = beta K singular (free ends, rigid-body mode): no noise factor, refused with the reason; alpha > 0
    makes C positive definite and the run goes."""
    n = 50
    K = sp.diags([np.r_[1.0, np.full(n - 2, 2.0), 1.0], -np.ones(n - 1), -np.ones(n - 1)], [0, 1, -1], format="csc")
    M = sp.identity(n, format="csc")
    with pytest.raises(ValueError, match=r"temperature: a LinearStructure with beta K damping and alpha = 0 has "
                                         r"thermal noise only for a positive definite K"):
        raydamp.integrate(raydamp.LinearStructure(M, K, beta=0.1), np.zeros(n), np.zeros(n), method="baoab",
                          h=0.1, n_steps=2, temperature=0.5)
    run = raydamp.integrate(raydamp.LinearStructure(M, K, alpha=0.1, beta=0.1), np.zeros(n), np.zeros(n),
                            method="baoab", h=0.1, n_steps=2, temperature=0.5, seed=1)
    assert np.isfinite(run.p).all() and np.abs(run.p[-1]).max() > 0.0


def grid_10k(masses: bool):
    """A 100 x 100 spring network with fixed edges (4-neighbour springs of stiffness 4), lumped masses:
    random in [0.5, 2], or all 1 (then its modes are the 2-D sine transform's)."""
    side = 100
    line = sp.diags([np.full(side, 2.0), -np.ones(side - 1), -np.ones(side - 1)], [0, 1, -1])
    eye = sp.identity(side)
    K = (sp.kron(line, eye) + sp.kron(eye, line)).tocsc() * 4.0
    m = np.random.default_rng(5).uniform(0.5, 2.0, side * side) if masses else np.ones(side * side)
    return sp.diags(m, format="csc"), K, side


def stationary_draw(side: int, kT: float, members: int, seed: int):
    """q ~ N(0, kT K^-1), p ~ N(0, kT I) for the unit-mass grid: K = V diag(lam) V^T with V the orthonormal
    2-D DST-I (its own inverse), lam_jk = 4 (4 sin^2(j pi / 2(side+1)) + 4 sin^2(k pi / 2(side+1)))."""
    import scipy.fft

    rng = np.random.default_rng(seed)
    s = 4.0 * np.sin(np.arange(1, side + 1) * np.pi / (2 * (side + 1))) ** 2
    lam = 4.0 * (s[:, None] + s[None, :])
    z = rng.standard_normal((members, side, side)) * np.sqrt(kT / lam)
    q = scipy.fft.dstn(z, type=1, norm="ortho", axes=(1, 2)).reshape(members, -1)
    return q, np.sqrt(kT) * rng.standard_normal(q.shape)


@pytest.mark.parametrize("alpha,beta", [(0.3, 0.05), (0.0, 4.0)])
def test_10k_structure_with_beta_k_damping_reaches_equipartition(alpha, beta):
    """10^4 DOF at kT = 0.7: <q^T K q> / n from baoab and <p^T M^-1 p> / n from 3s equal kT within 4
    standard errors (both exact in stationarity for a linear system, any stable h; 8 independent
    members, the standard error from the spread of their means). With alpha > 0 (random masses) the
    members start at rest and burn in for 8 / (2 alpha); with alpha = 0 the slow modes would take ages,
    so the unit-mass grid starts from its stationary distribution (the 2-D sine transform)."""
    M, K, side = grid_10k(masses=alpha > 0)
    n, kT, members = K.shape[0], 0.7, 8
    s = raydamp.LinearStructure(M, K, alpha=alpha, beta=beta)
    h = 1.0 / np.sqrt(s.spectral_bound)  # h omega_max <= 1
    if alpha > 0:
        burn = 8.0 / (2.0 * alpha)
        q0 = p0 = np.zeros((members, n))
    else:
        burn = 0.0
        q0, p0 = stationary_draw(side, kT, members, seed=9)
        assert abs(np.einsum("mi,mi->", q0, (K @ q0.T).T) / (members * n) - kT) < 0.03 * kT
    Minv = 1.0 / M.diagonal()
    for method, what in (("baoab", "configurational"), ("3s", "kinetic")):
        ens = raydamp.integrate_ensemble(s, q0, p0, method=method, h=h, t_end=burn + 12.0,
                                         save_every=max(1, int(1.0 / h)), temperature=kT, seed=21, threads=2)
        keep = ens.t >= burn
        if what == "configurational":
            q = ens.q[:, keep, :]
            per = np.einsum("mri,mri->mr", q, (K @ q.reshape(-1, n).T).T.reshape(q.shape)) / n
        else:
            p = ens.p[:, keep, :]
            per = np.einsum("mri,mri->mr", p, p * Minv) / n
        means = per.mean(axis=1)
        se = means.std(ddof=1) / np.sqrt(members)
        assert abs(means.mean() - kT) <= 4 * se, (what, means, se)
        assert se < 0.01 * kT, (what, se)  # the check has teeth: a 4% error in kT would show


def test_beta_k_noise_is_reproducible_at_any_thread_count():
    """Same seed, same bits: an ensemble on 1 and 2 threads, and member i against its single run
    (stream i); the noise factor's Cholesky factor and series are shared by the threads."""
    M, K = chain_200(False)
    s = raydamp.LinearStructure(M, K, alpha=0.1, beta=0.02)
    n, members = K.shape[0], 4
    q0 = np.tile(np.random.default_rng(1).standard_normal(n) * 0.01, (members, 1))  # one start: only the noise differs
    p0 = np.zeros((members, n))
    run = dict(method="baoab", h=0.02, n_steps=50, save_every=25, temperature=0.3, seed=77)
    one = raydamp.integrate_ensemble(s, q0, p0, threads=1, **run)
    two = raydamp.integrate_ensemble(s, q0, p0, threads=2, **run)
    np.testing.assert_array_equal(one.q, two.q)
    np.testing.assert_array_equal(one.p, two.p)
    single = raydamp.integrate(s, q0[2], p0[2], stream=2, **run)
    np.testing.assert_array_equal(single.q, one.q[2])
    assert np.abs(one.p[1:, -1] - one.p[0, -1]).min() > 0.0  # the members' streams differ
