"""Small LinearStructures (n <= raydamp's dense limit) step by dense products and the exact damping flows of
their modes (issue 47). The dense path must equal the sparse one (sparse products, Chebyshev flows), which
the same structure runs with the limit set to 0: trajectories of a 2-DOF and a 10-DOF structure, lumped and
consistent, with every method that runs structures, with and without a load and a temperature. And an
ensemble's members may differ by alpha, beta and a factor on K (one SDOF per period of a spectrum)."""

from __future__ import annotations

import numpy as np
import pytest

import raydamp
from raydamp.systems import structure

# Both paths compute the same flows, up to rounding (the Chebyshev series leave out < 1e-13 of each function):
# over 200 steps the states agree to this, relative to the largest |q| and |p| of the run.
PATHS_AGREE = 1e-11


def two_dof(consistent: bool = False) -> tuple[np.ndarray, np.ndarray, float, float]:
    M = np.array([[1.0, 0.2], [0.2, 1.5]]) if consistent else np.diag([1.0, 1.5])
    K = np.array([[65.0, -25.0], [-25.0, 25.0]])
    return M, K, 0.3, 2e-3


def frame(consistent: bool = False) -> tuple[np.ndarray, np.ndarray, float, float]:
    n = 10
    K = 2.0 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1)
    K[-1, -1] = 1.0
    K *= 400.0
    M = np.eye(n)
    if consistent:
        M = M + 0.1 * (np.eye(n, k=1) + np.eye(n, k=-1))
    return M, K, 0.2, 1e-3


def both_paths(monkeypatch, build):
    dense = build()
    monkeypatch.setattr(structure, "_DENSE_LIMIT", 0)
    sparse = build()
    monkeypatch.undo()
    assert dense._core_model.dense and not sparse._core_model.dense
    return dense, sparse


def agree(a, b) -> float:
    scale = max(np.max(np.abs(b.q)), np.max(np.abs(b.p)), 1e-300)
    return max(np.max(np.abs(a.q - b.q)), np.max(np.abs(a.p - b.p))) / scale


STRUCTURE_METHODS = [("3s", None), ("2s", None), ("baoab", None), ("rks", "heun"), ("rks", "midpoint"),
                     ("rksb", None), ("rk4", None), ("midpoint", None), ("gauss4", None)]


@pytest.mark.parametrize("shape", [two_dof, frame], ids=["2-DOF", "10-DOF"])
@pytest.mark.parametrize("consistent", [False, True], ids=["lumped", "consistent"])
@pytest.mark.parametrize("loaded", [False, True], ids=["free", "loaded"])
def test_the_dense_path_equals_the_sparse_path(monkeypatch, shape, consistent, loaded):
    M, K, alpha, beta = shape(consistent)
    n = M.shape[0]
    dense, sparse = both_paths(monkeypatch, lambda: raydamp.LinearStructure(M, K, alpha=alpha, beta=beta))
    assert dense.mass_kind == ("consistent" if consistent else "lumped")
    assert dense.spectral_bound == sparse.spectral_bound
    q0 = 0.01 * np.cos(np.arange(n) + 0.5)
    p0 = 0.02 * np.sin(np.arange(n))
    load = raydamp.Load.harmonic(np.linspace(1.0, 2.0, n), 3.0) if loaded else None
    h = 0.5 / np.sqrt(dense.spectral_bound)
    for method, tableau in STRUCTURE_METHODS:
        runs = [raydamp.integrate(s, q0, p0, method=method, tableau=tableau, h=h, n_steps=200, save_every=10,
                                  load=load, work=True) for s in (dense, sparse)]
        assert all(r.success for r in runs), (method, runs[0].message)
        error = agree(*runs)
        assert error <= PATHS_AGREE, (method, tableau, error)
        assert np.max(np.abs(runs[0].energy_balance - runs[1].energy_balance)) <= PATHS_AGREE * np.max(runs[1].energy)
    # Undamped, sv runs too (and 3s equals it, the damping flows being the identity).
    free, free_sparse = both_paths(monkeypatch, lambda: raydamp.LinearStructure(M, K))
    runs = [raydamp.integrate(s, q0, p0, method="sv", h=h, n_steps=200, load=load) for s in (free, free_sparse)]
    assert agree(*runs) <= PATHS_AGREE


@pytest.mark.parametrize("shape", [two_dof, frame], ids=["2-DOF", "10-DOF"])
@pytest.mark.parametrize("beta", [0.0, 2e-3])
def test_the_dense_path_equals_the_sparse_path_at_a_temperature(monkeypatch, shape, beta):
    # The noise is the same draws through the same factor on either path: only the flows differ, by rounding.
    M, K, alpha, _ = shape()
    n = M.shape[0]
    dense, sparse = both_paths(monkeypatch, lambda: raydamp.LinearStructure(M, K, alpha=alpha, beta=beta))
    h = 0.5 / np.sqrt(dense.spectral_bound)
    for method in ("3s", "2s", "baoab"):
        runs = [raydamp.integrate(s, np.zeros(n), np.zeros(n), method=method, h=h, n_steps=200, save_every=10,
                                  temperature=0.5, seed=3) for s in (dense, sparse)]
        assert agree(*runs) <= PATHS_AGREE, method


def test_dense_flows_are_the_exact_modal_flows():
    # exp(-t C M^{-1}) p and the kick+damp flow, against scipy's modes of the 2-DOF consistent structure.
    import scipy.linalg

    M, K, alpha, beta = two_dof(consistent=True)
    s = raydamp.LinearStructure(M, K, alpha=alpha, beta=beta)
    assert s._core_model.dense
    lam, V = scipy.linalg.eigh(K, M)   # V^T M V = I: f(K M^{-1}) = M V f(Lambda) V^T
    rates = alpha + beta * lam
    q, p = np.array([0.3, -0.2]), np.array([1.0, 0.5])
    for t in (1e-4, 0.1, 10.0):
        _, damped = s.flow("damp", q, p, t)
        expected = M @ V @ (np.exp(-t * rates) * (V.T @ p))
        assert np.max(np.abs(damped - expected)) <= 1e-14 * np.max(np.abs(p)), t
        _, kicked = s.flow("kick_damp", q, p, t)
        expected -= M @ V @ (-np.expm1(-t * rates) / rates * (V.T @ (K @ q)))
        assert np.max(np.abs(kicked - expected)) <= 1e-14 * (np.max(np.abs(p)) + t * np.max(np.abs(K @ q))), t


def test_a_spectrum_runs_as_one_ensemble_of_k_scale_and_alpha():
    # One SDOF (m = k = 1) made into 12 periods by K_scale = omega^2 and alpha = 2 zeta omega: each member equals
    # a LinearStructure built with that K and alpha.
    periods = np.geomspace(0.05, 5.0, 12)
    omega = 2 * np.pi / periods
    zeta = 0.05
    t = np.arange(301) * 0.01
    a_g = np.sin(7.0 * t) * np.exp(-0.3 * t)
    motion = raydamp.GroundMotion((t, a_g), [1.0])
    sdof = raydamp.LinearStructure(np.eye(1), np.eye(1))
    assert raydamp.run.ensemble.member_parameters(sdof) == ("alpha", "beta", "K_scale")
    zeros = np.zeros((periods.size, 1))
    ens = raydamp.integrate_ensemble(sdof, zeros, zeros, parameters={"K_scale": omega ** 2, "alpha": 2 * zeta * omega},
                                     method="3s", h=0.01, t_end=3.0, load=motion, threads=2)
    assert ens.members == periods.size and all(s == "completed" for s in ens.status)
    for i, w in enumerate(omega):
        single = raydamp.integrate(raydamp.LinearStructure(np.eye(1), np.eye(1) * w ** 2, alpha=2 * zeta * w),
                                   [0.0], [0.0], method="3s", h=0.01, t_end=3.0, load=motion)
        scale = np.max(np.abs(single.q))
        assert scale > 0
        np.testing.assert_allclose(ens.q[i], single.q, rtol=0, atol=1e-13 * scale)
    # the peaks differ by period: the members really run different structures
    peaks = np.max(np.abs(ens.q[:, :, 0]), axis=1)
    assert peaks.max() / peaks.min() > 10


def test_members_that_differ_by_beta_equal_their_single_runs_on_the_sparse_path_too(monkeypatch):
    M, K, alpha, _ = frame()
    monkeypatch.setattr(structure, "_DENSE_LIMIT", 0)
    s = raydamp.LinearStructure(M, K, alpha=alpha)
    betas = [0.0, 1e-3, 2e-3]
    q0 = 0.01 * np.ones(10)
    ens = raydamp.integrate_ensemble(s, q0, np.zeros(10), parameters={"beta": betas, "K_scale": [1.0, 2.0, 1.0]},
                                     method="3s", h=0.01, n_steps=100, threads=1)
    for i, (beta, k) in enumerate(zip(betas, [1.0, 2.0, 1.0])):
        single = raydamp.integrate(raydamp.LinearStructure(M, k * K, alpha=alpha, beta=beta), q0, np.zeros(10),
                                   method="3s", h=0.01, n_steps=100)
        np.testing.assert_allclose(ens.q[i], single.q, rtol=0, atol=1e-12 * np.max(np.abs(single.q)))


@pytest.mark.parametrize("parameters, message", [
    ({"K_scale": [1.0, 0.0]}, r"^parameters\.K_scale must be > 0, got K_scale\[1\] = 0\.0"),
    ({"alpha": [-0.1, 0.0]}, r"^parameters\.alpha must be >= 0, got alpha\[0\] = -0\.1"),
    ({"eps": [0.1, 0.2]}, r"^parameters\.eps: not a parameter .*\(known: alpha, beta, K_scale"),
])
def test_bad_member_parameters_are_named(parameters, message):
    s = raydamp.LinearStructure(np.eye(1), np.eye(1))
    with pytest.raises(ValueError, match=message):
        raydamp.integrate_ensemble(s, np.zeros((2, 1)), np.zeros((2, 1)), parameters=parameters, h=0.01, n_steps=3)
