"""raydamp.response_spectrum against a Nigam-Jennings recurrence written here, its step matrices the exponential
of the system augmented with the linear forcing (Van Loan), not the core's closed form; and against eqsig."""

import numpy as np
import pytest

import raydamp

PERIODS = np.geomspace(0.05, 5.0, 100)
TOLERANCE = 1e-8  # relative, per period


def synthetic_record(seconds=30.0, dt=0.01, seed=7):
    """A ground acceleration with a strong-motion envelope: filtered noise rising, holding, decaying (m/s^2)."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(round(seconds / dt)) + 1) * dt
    noise = np.convolve(rng.standard_normal(t.size), np.ones(5) / 5, mode="same")
    envelope = np.minimum(t / 2.0, 1.0) * np.exp(-np.maximum(t - 10.0, 0.0) / 6.0)
    return t, 3.0 * noise * envelope


def stacked_expm(X):
    """exp of each 4 x 4 matrix of the stack X, by Taylor's series on X / 2^s (norm <= 1/4, 18 terms: truncation
    below 1e-25) squared s times. (scipy.linalg.expm took 16 ms per matrix at the long periods' small norms.)"""
    norm = np.abs(X).sum(axis=1).max()
    squarings = max(0, int(np.ceil(np.log2(norm / 0.25)))) if norm > 0 else 0
    Y = X / 2.0 ** squarings
    term = np.broadcast_to(np.eye(4), X.shape).copy()
    E = term.copy()
    for k in range(1, 19):
        term = term @ Y / k
        E += term
    for _ in range(squarings):
        E = E @ E
    return E


def reference_peaks(t, a_g, periods, zeta):
    """max_k |u(t_k)| of u'' + 2 zeta w u' + w^2 u = -a_g, a_g linear between samples, from rest at t_0.

    Over an interval dt the state (u, v, s0, s1), with -a_g = s0 + s1 tau, obeys z' = F z with a constant F, so
    one interval is expm(F dt); the recurrence x_{k+1} = A x_k + b0 a_k + b1 a_{k+1} is read off its first rows."""
    omega = 2 * np.pi / periods
    dts = np.diff(t)
    lengths = np.unique(np.round(dts / dts.max(), 12))
    steps = {}
    for key in lengths:
        dt = dts[np.argmax(np.round(dts / dts.max(), 12) == key)]
        F = np.zeros((omega.size, 4, 4))
        F[:, 0, 1] = F[:, 1, 2] = F[:, 2, 3] = 1.0
        F[:, 1, 0] = -omega ** 2
        F[:, 1, 1] = -2 * zeta * omega
        E = stacked_expm(F * dt)[:, :2]
        A = E[:, :, :2]
        # the forcing -a_g(t_k + tau) = -a_k - (a_{k+1} - a_k) tau / dt: s0 = -a_k, s1 = -(a_{k+1} - a_k) / dt
        b0 = -E[:, :, 2] + E[:, :, 3] / dt
        b1 = -E[:, :, 3] / dt
        steps[key] = tuple(np.ascontiguousarray(c) for c in (A[:, 0, 0], A[:, 0, 1], b0[:, 0], b1[:, 0],
                                                               A[:, 1, 0], A[:, 1, 1], b0[:, 1], b1[:, 1]))
    keys = np.round(dts / dts.max(), 12)
    u, v = np.zeros(omega.size), np.zeros(omega.size)
    peak = np.zeros(omega.size)
    for k in range(t.size - 1):
        uu, uv, u0, u1, vu, vv, v0, v1 = steps[keys[k]]
        u, v = uu * u + uv * v + u0 * a_g[k] + u1 * a_g[k + 1], vu * u + vv * v + v0 * a_g[k] + v1 * a_g[k + 1]
        np.maximum(peak, np.abs(u), out=peak)
    return peak


@pytest.fixture(scope="module")
def record():
    return synthetic_record()


def test_spectrum_equals_the_exact_piecewise_linear_response_at_100_periods(record):
    t, a_g = record
    spectrum = raydamp.response_spectrum((t, a_g), PERIODS, damping=0.05)
    reference = reference_peaks(t, a_g, PERIODS, 0.05)
    np.testing.assert_allclose(spectrum.SD.values, reference, rtol=TOLERANCE, atol=0)
    omega = 2 * np.pi / PERIODS
    np.testing.assert_allclose(spectrum.PSV.values, omega * reference, rtol=TOLERANCE, atol=0)
    np.testing.assert_allclose(spectrum.PSA.values, omega ** 2 * reference, rtol=TOLERANCE, atol=0)
    np.testing.assert_array_equal(spectrum.period.values, PERIODS)
    assert spectrum.attrs["damping"] == 0.05
    assert spectrum.attrs["record"] == f"a (t, a_g) pair of {t.size} samples"
    assert spectrum.attrs["record_samples"] == t.size


@pytest.mark.parametrize("zeta", [0.0, 0.02, 0.3, 0.9])
def test_other_dampings_and_uneven_samples(zeta):
    rng = np.random.default_rng(3)
    t = np.concatenate([[0.0], np.cumsum(rng.uniform(0.004, 0.02, 150))])  # every interval its own length
    a_g = rng.standard_normal(t.size)
    periods = np.array([0.03, 0.1, 1.0, 20.0])
    spectrum = raydamp.response_spectrum((t, a_g), periods, damping=zeta)
    np.testing.assert_allclose(spectrum.SD.values, reference_peaks(t, a_g, periods, zeta), rtol=TOLERANCE, atol=0)


def test_a_load_a_ground_motion_and_a_file_give_the_same_spectrum(record, tmp_path):
    t, a_g = record
    t, a_g = t[:500], a_g[:500]
    periods = PERIODS[::10]
    pair = raydamp.response_spectrum((t, a_g), periods).SD.values
    twice = raydamp.response_spectrum(raydamp.Load.series(t, a_g) * 2.0, periods).SD.values
    np.testing.assert_allclose(twice, 2 * pair, rtol=1e-14)
    ground = raydamp.response_spectrum(raydamp.GroundMotion((t, a_g), [1.0]), periods).SD.values
    np.testing.assert_array_equal(ground, pair)
    path = tmp_path / "record.csv"
    np.savetxt(path, np.column_stack([t, a_g]), delimiter=",", fmt="%.17g")
    from_file = raydamp.response_spectrum(path, periods)
    np.testing.assert_array_equal(from_file.SD.values, pair)
    assert from_file.attrs["record"] == "record.csv"


def test_spectrum_agrees_with_eqsig(record):
    eqsig = pytest.importorskip("eqsig")
    t, a_g = record
    dt = float(t[1] - t[0])
    # eqsig takes omega = 6.2831853 / T (2 pi to 8 digits): given these periods, its oscillators are ours
    sd, _psv, _psa = eqsig.sdof.pseudo_response_spectra(a_g, dt, PERIODS * 6.2831853 / (2 * np.pi), 0.05)
    ours = raydamp.response_spectrum((t, a_g), PERIODS, damping=0.05).SD.values
    np.testing.assert_allclose(ours, sd, rtol=TOLERANCE, atol=0)


@pytest.mark.parametrize(("arguments", "named"), [
    (dict(periods=[0.5, 0.0]), r"periods must be finite and > 0, got periods\[1\] = 0.0"),
    (dict(periods=[-1.0]), r"periods must be finite and > 0"),
    (dict(periods=[]), r"periods: empty"),
    (dict(periods=[[0.5]]), r"periods must be a number or a vector"),
    (dict(periods=[0.5], damping=1.0), r"damping must be in \[0, 1\)"),
    (dict(periods=[0.5], damping=-0.01), r"damping must be in \[0, 1\)"),
    (dict(periods=[0.5], damping="5%"), r"damping must be a real number"),
    (dict(periods=[0.5], record=([], [])), r"record.t: needs at least one time"),
    (dict(periods=[0.5], record=([0.0], [1.0])), r"record: 1 sample\(s\); a record needs at least two samples"),
    (dict(periods=[0.5], record=([0.0, 0.01], [1.0])), r"record.values: 1 values for 2 times"),
    (dict(periods=[0.5], record=[1.0, 2.0, 3.0]), r"record must be a pair \(t, a_g\)"),
    (dict(periods=[0.5], record=raydamp.Load.harmonic(1.0, 2.0)), r"record: expected a history a_g\(t\)"),
])
def test_bad_input_is_refused_naming_the_argument(arguments, named):
    arguments = {"record": ([0.0, 0.01, 0.02], [0.0, 1.0, 0.0]), **arguments}
    with pytest.raises(ValueError, match=named):
        raydamp.response_spectrum(**arguments)
