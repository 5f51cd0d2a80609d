"""Time-dependent loads and ground motion: the numbers of issue 26's "done means".

References are exact and independent of raydamp's step loop: the steady state of a harmonic
load from (K - w^2 M + i w C)^{-1}, and the exact response to a piecewise-linear load,
raydamp.analysis.piecewise_linear_response (the Nigam-Jennings solution: one matrix exponential of
the system augmented with the load's segment; checked against closed forms in test_analysis.py).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse as sp

import raydamp
from raydamp.analysis import piecewise_linear_response
from raydamp.models import ElasticPendulum


def structure(m: float, k: float, c: float) -> raydamp.LinearStructure:
    return raydamp.LinearStructure(np.array([[m]]), np.array([[k]]), alpha=c / m)


def fitted_amplitude(t: np.ndarray, q: np.ndarray, omega: float) -> np.ndarray:
    """|X| of q = Im(X e^{i w t}) by least squares over the rows (one column per coordinate)."""
    basis = np.column_stack([np.sin(omega * t), np.cos(omega * t)])
    coef, *_ = np.linalg.lstsq(basis, q, rcond=None)
    return np.hypot(coef[0], coef[1])


# --- harmonic loads: the steady state -------------------------------------------------------------

@pytest.mark.parametrize("method", ["3s", "2s", "midpoint", "gauss4"])
def test_harmonic_steady_state_of_a_damped_oscillator(method):
    m, k, c, F0, omega = 2.0, 3.0, 0.25, 0.7, 1.4
    model = structure(m, k, c)
    load = raydamp.Load.harmonic([F0], omega)
    h = 1e-3 if method != "gauss4" else 2e-2
    sol = raydamp.integrate(model, [0.0], [0.0], method=method, h=h, t_end=400.0, load=load)
    assert sol.success
    tail = sol.t > 400.0 - 8 * np.pi / omega
    amplitude = fitted_amplitude(sol.t[tail], sol.q[tail, 0], omega)
    exact = F0 / np.hypot(k - m * omega ** 2, c * omega)
    assert abs(amplitude - exact) / exact < 1e-6


def test_harmonic_steady_state_of_a_rayleigh_damped_chain():
    """3 DOF, C = alpha M + beta K: each DOF's amplitude is |(K - w^2 M + i w C)^{-1} F0|."""
    M = np.diag([1.0, 1.5, 0.8])
    K = np.array([[3.0, -1.0, 0.0], [-1.0, 2.5, -1.5], [0.0, -1.5, 1.5]])
    alpha, beta = 0.05, 0.02
    model = raydamp.LinearStructure(M, K, alpha=alpha, beta=beta)
    F0, omega = np.array([0.0, 0.0, 1.0]), 1.1
    X = np.linalg.solve(K - omega ** 2 * M + 1j * omega * (alpha * M + beta * K), F0)
    for method, h in (("3s", 1e-3), ("rks", 1e-3), ("gauss4", 2e-2)):
        sol = raydamp.integrate(model, np.zeros(3), np.zeros(3), method=method, h=h, t_end=600.0,
                                load=raydamp.Load.harmonic(F0, omega), save_every=10)
        tail = sol.t > 600.0 - 8 * np.pi / omega
        amplitude = fitted_amplitude(sol.t[tail], sol.q[tail], omega)
        np.testing.assert_allclose(amplitude, np.abs(X), rtol=1e-6, err_msg=method)


# --- a piecewise-linear record on SDOF systems: exact reference, order 2 ------------------------

def synthetic_record(seconds: float = 10.0, dt: float = 0.01, seed: int = 7) -> tuple[np.ndarray, np.ndarray]:
    """A ground acceleration like an accelerogram: filtered noise under an envelope (m/s^2)."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(round(seconds / dt)) + 1) * dt
    noise = rng.standard_normal(t.size)
    smooth = np.convolve(noise, np.ones(5) / 5, mode="same")
    envelope = np.minimum(1.0, t / 1.0) * np.exp(-np.maximum(0.0, t - 4.0) / 2.0)
    return t, 3.0 * smooth * envelope


def sdof_error(period: float, zeta: float, h_factor: int, method: str = "3s") -> float:
    t_rec, a_g = synthetic_record()
    omega = 2 * np.pi / period
    m, k, c = 1.0, omega ** 2, 2 * zeta * omega
    model = structure(m, k, c)
    dt = t_rec[1] - t_rec[0]
    motion = raydamp.GroundMotion((t_rec, a_g), [1.0])
    sol = raydamp.integrate(model, [0.0], [0.0], method=method, h=dt / h_factor, t_end=float(t_rec[-1]),
                            save_every=h_factor, load=motion)
    assert sol.success
    np.testing.assert_allclose(sol.t, t_rec, atol=1e-9)
    exact = piecewise_linear_response(m, c, k, [-m], t_rec, a_g)[0][:, 0]
    return float(np.max(np.abs(sol.q[:, 0] - exact)) / np.max(np.abs(exact)))


@pytest.mark.parametrize("zeta", [0.02, 0.05])
@pytest.mark.parametrize("period,limit", [(0.2, 2e-3), (0.5, 1e-3), (1.0, 1e-3), (2.0, 1e-3), (5.0, 1e-3)])
def test_record_response_within_the_issue_bounds(period, limit, zeta):
    """dt = 0.01 s, h = dt/10: max |u - u_ref| / max |u_ref| <= 1e-3 (T 0.5-5 s), 2e-3 at T = 0.2 s."""
    assert sdof_error(period, zeta, 10) <= limit


@pytest.mark.parametrize("period", [0.05, 0.2, 1.0, 5.0])
def test_record_response_converges_at_order_2(period):
    errors = [sdof_error(period, 0.02, f) for f in (10, 20, 40)]
    slopes = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(slopes - 2.0) < 0.15), (errors, slopes)


# --- orders with a time-dependent load --------------------------------------------------------

def pendulum_error(method: str, h: float, **options) -> float:
    model = ElasticPendulum(eps=0.05)
    load = raydamp.Load.harmonic([0.3, -0.2, 0.1], 2.3, phase=0.4)
    q0, p0 = np.array([0.3, 0.1, -1.1]), np.array([0.0, 0.2, 0.1])
    t_end = 2.0
    sol = raydamp.integrate(model, q0, p0, method=method, h=h, t_end=t_end, load=load, **options)
    ref = raydamp.integrate(model, q0, p0, method="3s", composition="kahan_li8", h=t_end / 400, t_end=t_end,
                            load=load)
    return float(np.linalg.norm(np.concatenate([sol.q[-1] - ref.q[-1], sol.p[-1] - ref.p[-1]])))


@pytest.mark.parametrize("method,options,order,hs", [
    ("3s", {}, 2, (0.02, 0.01)),
    ("2s", {}, 2, (0.02, 0.01)),
    ("rks", {"tableau": "heun"}, 2, (0.02, 0.01)),
    ("rks", {"tableau": "midpoint"}, 2, (0.02, 0.01)),
    ("3s", {"composition": "yoshida4"}, 4, (0.1, 0.05)),
    ("3s", {"composition": "kahan_li6"}, 6, (0.2, 0.1)),
    ("3s", {"composition": "kahan_li8"}, 8, (0.4, 0.2)),
])
def test_orders_kept_with_a_harmonic_force(method, options, order, hs):
    e1, e2 = (pendulum_error(method, h, **options) for h in hs)
    assert abs(np.log2(e1 / e2) - order) < 0.15, (e1, e2)


def test_load_changes_the_solution_and_zero_load_does_not():
    model = ElasticPendulum(eps=0.05)
    q0, p0 = [0.3, 0.1, -1.1], [0.0, 0.2, 0.1]
    free = raydamp.integrate(model, q0, p0, h=0.01, t_end=1.0)
    zero = raydamp.integrate(model, q0, p0, h=0.01, t_end=1.0, load=raydamp.Load.harmonic([0, 0, 0], 1.0))
    forced = raydamp.integrate(model, q0, p0, h=0.01, t_end=1.0, load=raydamp.Load.harmonic([0.5, 0, 0], 1.0))
    np.testing.assert_array_equal(zero.q, free.q)
    assert np.max(np.abs(forced.q - free.q)) > 1e-3


# --- the energy budget ------------------------------------------------------------------------

def big_chain_structure(n: int = 10_000) -> raydamp.LinearStructure:
    main = np.full(n, 2.0)
    main[-1] = 1.0
    K = sp.diags([main, -np.ones(n - 1), -np.ones(n - 1)], [0, 1, -1], format="csr") * 1e2
    M = sp.identity(n, format="csr")
    return raydamp.LinearStructure(M, K, alpha=0.02, beta=1e-4)


def test_energy_budget_is_second_order_under_a_record_on_a_1e4_dof_structure():
    model = big_chain_structure()
    n = model.dim
    t_rec, a = synthetic_record(seconds=2.0, dt=0.01)
    direction = np.zeros(n)
    direction[-50:] = 1.0
    load = raydamp.Load.series(t_rec, a, direction)
    peaks = []
    for h in (0.01, 0.005, 0.0025):  # h omega_max = 0.2 .. 0.05 (at 0.4 not yet asymptotic)
        sol = raydamp.integrate(model, np.zeros(n), np.zeros(n), method="3s", h=h, t_end=2.0, work=True, load=load,
                                save_dofs=[n - 1])
        assert sol.success
        assert np.max(np.abs(sol.load_work)) > 1e-2  # the load does work
        peaks.append(np.max(np.abs(sol.energy_balance)))
    slopes = np.log2(np.array(peaks[:-1]) / np.array(peaks[1:]))
    assert np.all(np.abs(slopes - 2.0) < 0.1), (peaks, slopes)


@pytest.mark.parametrize("method", ["midpoint", "gauss4"])
def test_implicit_energy_budget_holds_to_rounding_with_random_loads(method):
    model = big_chain_structure()
    n = model.dim
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 1.0, 41)
    load = raydamp.Load.series(t, rng.standard_normal((t.size, n)))  # a vector per time
    load = load + raydamp.Load.harmonic(rng.standard_normal(n), 7.0)
    sol = raydamp.integrate(model, rng.standard_normal(n) * 1e-2, np.zeros(n), method=method, h=0.01, t_end=1.0,
                            work=True, load=load)
    scale = np.max(np.abs(sol.load_work)) + np.max(np.abs(sol.energy))
    assert np.max(np.abs(sol.energy_balance)) < 1e-11 * scale


# --- ground motion on a 10-storey shear frame ------------------------------------------------

def shear_frame(storeys: int = 10):
    m, k = 1.0e5, 2.0e8  # kg, N/m per storey
    M = np.eye(storeys) * m
    K = np.zeros((storeys, storeys))
    for i in range(storeys):
        K[i, i] += k
        if i + 1 < storeys:
            K[i, i] += k
            K[i, i + 1] = K[i + 1, i] = -k
    w = np.sqrt(np.sort(scipy.linalg.eigh(K, M, eigvals_only=True)))
    alpha, beta = raydamp.rayleigh_coefficients(w[0], w[2], 0.05, 0.05)
    return M, K, alpha, beta


def test_ground_motion_on_a_ten_storey_frame_matches_the_exact_response():
    M, K, alpha, beta = shear_frame()
    model = raydamp.LinearStructure(M, K, alpha=alpha, beta=beta)
    t_rec, a_g = synthetic_record(seconds=5.0, dt=0.01)
    r = np.ones(10)
    motion = raydamp.GroundMotion((t_rec, a_g), r)
    sol = raydamp.integrate(model, np.zeros(10), np.zeros(10), method="gauss4", h=0.0025, t_end=5.0, save_every=4,
                            load=motion)
    exact = piecewise_linear_response(M, alpha * M + beta * K, K, -M @ r, t_rec, a_g)[0]
    roof = exact[:, -1]
    assert np.max(np.abs(sol.q[:, -1] - roof)) / np.max(np.abs(roof)) < 1e-6
    # absolute acceleration = relative + a_g: at rest before the record starts moving it equals a_g(0) = 0,
    # and it is what M^{-1}(-K u - C v) gives (the ground's own acceleration cancels).
    acc = sol.absolute_acceleration()
    v = np.linalg.solve(M, sol.p.T).T
    np.testing.assert_allclose(acc, -np.linalg.solve(M, (K @ sol.q.T + (alpha * M + beta * K) @ v.T)).T,
                               rtol=1e-9, atol=1e-9 * np.max(np.abs(acc)))


def test_a_loaded_file_and_an_ensemble_member_keep_their_load(tmp_path):
    # Their load was None: load_values() gave zeros and absolute_acceleration() said "this run had no ground
    # motion" (a numbers audit). It is rebuilt from the provenance, as the model is.
    M, K, alpha, beta = shear_frame()
    model = raydamp.LinearStructure(M, K, alpha=alpha, beta=beta)
    t_rec, a_g = synthetic_record(seconds=2.0, dt=0.01)
    motion = raydamp.GroundMotion((t_rec, a_g), np.ones(10), factor=9.81)
    sol = raydamp.integrate(model, np.zeros(10), np.zeros(10), method="gauss4", h=0.01, t_end=2.0, save_every=5,
                            load=motion)
    forces, absolute = sol.load_values(), sol.absolute_acceleration()
    assert np.max(np.abs(forces)) > 1.0
    for suffix in ("nc", "npz"):
        sol.save(tmp_path / f"run.{suffix}")
        loaded = raydamp.load(tmp_path / f"run.{suffix}")
        np.testing.assert_allclose(loaded.load_values(), forces, rtol=1e-14, atol=0)
        np.testing.assert_allclose(loaded.absolute_acceleration(), absolute, rtol=1e-12,
                                   atol=1e-12 * np.max(np.abs(absolute)))
    # Members with their own load amplitude: each member's load is its own.
    harmonic = raydamp.Load.harmonic(np.ones(10), 3.0)
    ens = raydamp.integrate_ensemble(model, np.zeros(10), np.zeros(10), method="3s", h=0.01, t_end=1.0,
                                     load=harmonic, parameters={"load.amplitude": [1.0, 2.5]})
    for i, amplitude in enumerate((1.0, 2.5)):
        alone = raydamp.integrate(model, np.zeros(10), np.zeros(10), method="3s", h=0.01, t_end=1.0,
                                  load=harmonic.with_parameters(amplitude=amplitude))
        np.testing.assert_array_equal(ens.member(i).load_values(), alone.load_values())
    # A load that cannot be rebuilt (a record uploaded to the service, named by its id) is an error saying so.
    import dataclasses

    spec = {**sol.provenance, "load": {"file": {"id": "5f0c", "direction": [1.0] * 10}}}
    uploaded = dataclasses.replace(sol, load=None, origin=spec)
    assert uploaded.load is None  # rebuilt when asked for, not when the Solution is made
    for what in ("load_values", "absolute_acceleration"):
        with pytest.raises(ValueError, match=f"^{what}: the run's load could not be rebuilt from its provenance"):
            getattr(uploaded, what)()


def test_energy_error_of_a_loaded_forced_run_uses_its_load(tmp_path):
    # A loaded file's load was None: energy_error compared it against an unforced reference (0.648 where the
    # live run's error is 0.00275; an API audit). Now the same as the live run's.
    from raydamp.analysis import energy_error

    model = ElasticPendulum(eps=0.1)
    load = raydamp.Load.harmonic([0.5, 0.0, 0.0], 2.0)
    sol = raydamp.integrate(model, [0.0, 1.0, -0.5], [0.2, 0.0, 0.0], method="rk4", h=0.01, t_end=2.0, load=load)
    sol.save(tmp_path / "forced.nc")
    live = np.max(np.abs(energy_error(model, sol)))
    assert live < 1e-6
    assert np.max(np.abs(energy_error(model, raydamp.load(tmp_path / "forced.nc")))) == pytest.approx(live, rel=1e-6)
