"""Thermal noise of a Chain's damping (issue 29): site friction (a diagonal A) and dashpots on bonds
(blocks of A), M = m I, so each damping flow's noise is sqrt(m) V diag(sqrt(1 - e^{-2t lambda})) V^T xi
(cpp/tests/test_noise.cpp checks that factor against m (I - e^{-2tA})). Here: equipartition of 1000-site
harmonic chains, where 3s's saved momenta are exactly N(0, kT m I) and baoab's positions exactly
N(0, kT K^-1) in stationarity, for any stable h."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.fft

import raydamp

SOME_SITES = sorted(np.random.default_rng(2).choice(1000, 300, replace=False).tolist())


def stationary_draw(n: int, k: float, m: float, kT: float, members: int, seed: int):
    """q ~ N(0, kT K^-1), p ~ N(0, kT m I) for the fixed harmonic chain: K = V diag(lam) V^T with V the
    orthonormal DST-I (its own inverse), lam_j = 4 k sin^2(j pi / 2(n+1))."""
    rng = np.random.default_rng(seed)
    lam = 4.0 * k * np.sin(np.arange(1, n + 1) * np.pi / (2 * (n + 1))) ** 2
    q = scipy.fft.dst(rng.standard_normal((members, n)) * np.sqrt(kT / lam), type=1, norm="ortho", axis=1)
    return q, np.sqrt(kT * m) * rng.standard_normal((members, n))


@pytest.mark.parametrize("dampers", [
    {"sites": list(range(1000)), "c": list(np.linspace(0.2, 1.0, 1000))},   # friction on every site
    {"sites": SOME_SITES, "c": 0.8},                                         # on 300 random sites
    {"bonds": list(range(0, 1001, 2)), "c": 0.6},                            # dashpots on every other bond
], ids=["every-site", "some-sites", "dashpots"])
def test_1000_site_harmonic_chain_stays_at_kT(dampers):
    """kT = 0.4, 8 members from the stationary distribution (dashpots leave the long waves almost
    undamped, so a start at rest would take ages): <p_i^2 / m> from 3s and <q^T K q> / n from baoab equal
    kT within 4 standard errors (from the spread of the members' means). The damped modes forget their
    start within the run (rates ~ c / m), so a noise of the wrong size would cool or heat them: the
    same run at 0.81 kT (noise 0.9 times as large) fails the check."""
    n, k, kT, m, members = 1000, 2.0, 0.4, 1.5, 8
    chain = raydamp.Chain(n, bond="harmonic", parameters={"k": k}, mass=m, boundary="fixed", dampers=dampers,
                          eps=1.0)
    q0, p0 = stationary_draw(n, k, m, kT, members, seed=8)

    def means(method, temperature):
        ens = raydamp.integrate_ensemble(chain, q0, p0, method=method, h=0.1, t_end=60.0, save_every=20,
                                         temperature=temperature, seed=5, threads=2)
        if method == "3s":
            per = (ens.p[:, 1:, :] ** 2 / m).mean(axis=2)
        else:
            q = ens.q[:, 1:, :]
            walls = np.zeros(q.shape[:2] + (1,))
            per = (k * np.diff(np.concatenate([walls, q, walls], axis=2), axis=2) ** 2).sum(axis=2) / n
        return per.mean(axis=1)

    for method in ("3s", "baoab"):
        got = means(method, kT)
        se = got.std(ddof=1) / np.sqrt(members)
        assert abs(got.mean() - kT) <= 4 * se, (method, got, se)
        assert se < 0.02 * kT, (method, se)
    wrong = means("3s", 0.81 * kT)
    assert abs(wrong.mean() - kT) > 4 * wrong.std(ddof=1) / np.sqrt(members)
