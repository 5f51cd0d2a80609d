"""raydamp.advise (issue 25, point 3): the stability limits match measured blow-up thresholds, and the
recommended method at its suggested step reaches the tolerance, as the error model predicts."""

import json

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse as sparse

import raydamp
from raydamp.cli import main
from raydamp.models import DampedPendulum

N = 40


@pytest.fixture(scope="module")
def building():
    """A shear building of N storeys, 2% damping in modes 1 and 3; its modes (w2, phi) for exact solutions."""
    main_diagonal = np.full(N, 2.0)
    main_diagonal[-1] = 1.0
    K = sparse.diags([-np.ones(N - 1), main_diagonal, -np.ones(N - 1)], [-1, 0, 1]).tocsc()
    M = sparse.identity(N, format="csc")
    w2, phi = scipy.linalg.eigh(K.toarray())
    w = np.sqrt(w2)
    alpha, beta = raydamp.rayleigh_coefficients(w[0], w[2], 0.02, 0.02)
    return raydamp.LinearStructure(M, K, alpha=alpha, beta=beta), w2, phi


@pytest.fixture(scope="module")
def advice(building):
    s, w2, _ = building
    return raydamp.advise(s, 2 * 2 * np.pi / np.sqrt(w2[0]), 1e-4, measure=False)


def exact_first_mode(s, w2, phi, t):
    """q(t) of the first mode released at rest with unit amplitude (mode shape of unit norm)."""
    c, w = s.alpha + s.beta * w2[0], np.sqrt(w2[0])
    zeta = c / (2 * w)
    wd = w * np.sqrt(1 - zeta ** 2)
    return np.outer(np.exp(-zeta * w * t) * (np.cos(wd * t) + zeta * w / wd * np.sin(wd * t)), phi[:, 0])


def test_frequencies(building, advice):
    _, w2, _ = building
    assert advice.omega_max == pytest.approx(np.sqrt(w2[-1]), rel=1e-10)
    assert advice.omega_1 == pytest.approx(np.sqrt(w2[0]), rel=1e-10)
    assert advice.omega == advice.omega_1


def test_stability_limits(advice):
    # Stormer-Verlet in drift and kick: 2 / omega_max; rk4 on the whole system: 2 sqrt 2 / omega_max (the
    # imaginary-axis limit, the damping moves it a little); the implicit methods have none
    for label in ("3s", "rks-midpoint"):
        assert advice.row(label).h_max * advice.omega_max == pytest.approx(2.0, rel=1e-3)
    assert 2 * np.sqrt(2) <= advice.row("rk4").h_max * advice.omega_max <= 3.0      # 2.954 here
    assert np.isinf(advice.row("midpoint").h_max) and np.isinf(advice.row("gauss4").h_max)


@pytest.mark.parametrize("label", ["3s", "2s", "rks-heun", "rks-midpoint", "rk4"])
def test_stability_limits_match_the_measured_blow_up_within_5_percent(building, advice, label):
    s, _, _ = building
    row = advice.row(label)
    q0 = np.random.default_rng(1).standard_normal(N)
    below = raydamp.integrate(s, q0, np.zeros(N), method=row.method, tableau=row.tableau, h=0.95 * row.h_max,
                              n_steps=4000, save_every=4000)
    above = raydamp.integrate(s, q0, np.zeros(N), method=row.method, tableau=row.tableau, h=1.05 * row.h_max,
                              n_steps=4000, save_every=4000)
    assert below.success and np.abs(below.q[-1]).max() <= 10 * np.abs(q0).max()
    assert not above.success or np.abs(above.q[-1]).max() > 1e6 * np.abs(q0).max()


@pytest.mark.parametrize("label", ["recommended", "3s", "midpoint", "gauss4", "rk4"])
def test_the_suggested_step_reaches_the_tolerance(building, advice, label):
    # Motion in the first mode (the error model's omega = omega_1): measured error <= tolerance, and above a
    # third of it (the model's constants are the leading phase-error terms, 2% damping lowers the error)
    s, w2, phi = building
    row = advice.recommended if label == "recommended" else advice.row(label)
    steps = row.steps
    sol = raydamp.integrate(s, phi[:, 0], np.zeros(N), method=row.method, tableau=row.tableau, h=row.h,
                            n_steps=steps, save_every=max(1, steps // 200))
    error = np.max(np.linalg.norm(sol.q - exact_first_mode(s, w2, phi, sol.t), axis=1))
    # whole steps: the predicted error just below the tolerance
    assert 0.9 * advice.tolerance <= row.error <= advice.tolerance or row.limited_by == "stability"
    assert advice.tolerance / 3 <= error <= advice.tolerance if row.limited_by == "tolerance" else error <= row.error


def test_recommended_and_table(advice):
    assert advice.recommended.label == "gauss4"         # by steps (measure=False): order 4, A-stable
    assert advice.recommended.options == {"method": "gauss4", "tableau": None, "h": advice.recommended.h}
    text = str(advice)
    assert "omega_max = " in text and "h_max" in text and "recommended: gauss4" in text
    assert len(text.splitlines()) == 2 + 1 + 8 + 1          # heading, column names, a row per method, advice


def test_measured_costs(building):
    s, w2, _ = building
    advice = raydamp.advise(s, 100.0, 1e-3)
    for row in advice.rows:
        assert row.seconds_per_step > 0 and row.setup_seconds >= 0
        assert row.seconds == pytest.approx(row.setup_seconds + row.steps * row.seconds_per_step)
    assert advice.row("3s").chebyshev_degree == max(s.chebyshev_degrees(advice.row("3s").h))


def test_other_kinds_are_refused_with_the_reason():
    with pytest.raises(ValueError, match="structure: advise needs a raydamp.LinearStructure"):
        raydamp.advise(DampedPendulum(), 10.0, 1e-6)


@pytest.mark.parametrize(("arguments", "message"), [((0.0, 1e-6), "t_end"), ((10.0, 2.0), "tolerance")])
def test_bad_arguments(building, arguments, message):
    with pytest.raises(ValueError, match=message):
        raydamp.advise(building[0], *arguments)


def test_a_run_beyond_what_integrate_runs(building):
    """tolerance=1e-300 recommended a run of a 77-digit step count (integrate runs at most 2^62 steps), and a
    t_end of 1e300 or an omega of 1e300 raised an OverflowError or a ZeroDivisionError. A method needing more
    steps is marked "steps" and never recommended; when every method does, a ValueError says so; and below
    MIN_TOLERANCE rounding sets the error (asked for 1e-20, gauss4 gave 1.4e-14), so it is refused."""
    from raydamp.run.advise import MIN_TOLERANCE
    from raydamp.run.integrate import MAX_STEPS

    advice = raydamp.advise(building[0], 1e12, MIN_TOLERANCE, measure=False)
    over = [row for row in advice.rows if row.limited_by == "steps"]
    assert over and all(row.order == 2 and row.steps > MAX_STEPS for row in over)
    assert advice.recommended.order == 4 and advice.recommended.steps <= MAX_STEPS
    assert "steps" in str(advice)
    for t_end, extra in ((1e300, {}), (10.0, {"omega": 1e300})):
        with pytest.raises(ValueError, match=r"^tolerance: no method reaches 1e-06 by t_end"):
            raydamp.advise(building[0], t_end, 1e-6, measure=False, **extra)
    for tolerance in (1e-20, 5e-324):
        with pytest.raises(ValueError, match=r"^tolerance must be at least 1e-13"):
            raydamp.advise(building[0], 10.0, tolerance, measure=False)


def test_cli(building, tmp_path, capsys):
    s, _, _ = building
    path = tmp_path / "spec.json"
    path.write_text(json.dumps({"system": s.to_dict(), "h": 0.1, "t_end": 50.0,
                                "initial_state": {"q": [0.0] * N, "p": [0.0] * N}}))
    assert main(["advise", str(path), "--tolerance", "1e-5", "--no-measure"]) == 0
    out = capsys.readouterr().out
    assert "to t_end = 50 within 1e-05" in out and "recommended:" in out
    assert main(["advise", str(path), "--tolerance", "1e-5", "--t-end", "-1", "--no-measure"]) == 2
    assert "t_end" in capsys.readouterr().err


def test_cli_weights_the_jobs_start_and_load(building, tmp_path, capsys):
    """A whole job's initial state and load weight the CLI's advice as raydamp.advise's q0, p0 and load do."""
    s, _, _ = building
    q0 = np.linspace(0.0, 1.0, N).tolist()
    path = tmp_path / "spec.json"
    path.write_text(json.dumps({"system": s.to_dict(), "h": 0.1, "t_end": 50.0,
                                "initial_state": {"q": q0, "p": [0.0] * N}}))
    assert main(["advise", str(path), "--tolerance", "1e-5", "--no-measure"]) == 0
    out = capsys.readouterr().out
    expected = raydamp.advise(s, 50.0, 1e-5, q0=np.array(q0), p0=np.zeros(N), measure=False)
    assert expected.weighting != "mode"
    assert str(expected) == out.rstrip("\n")
    load = {"harmonic": {"amplitude": [1.0] + [0.0] * (N - 1), "omega": 2.0}}
    path.write_text(json.dumps({"system": s.to_dict(), "h": 0.1, "t_end": 50.0, "load": load,
                                "initial_state": {"q": [0.0] * N, "p": [0.0] * N}}))
    assert main(["advise", str(path), "--tolerance", "1e-5", "--no-measure"]) == 0
    out = capsys.readouterr().out
    expected = raydamp.advise(s, 50.0, 1e-5, load=raydamp.Load.from_dict(load), measure=False)
    assert expected.weighting != "mode" and str(expected) == out.rstrip("\n")


def test_cli_help_says_what_omega_is(capsys):
    # The help still gave the remedy issue 43 found wrong ("the highest circular frequency the answer must resolve":
    # 16 to 7,400 times the steps needed); --omega is the one weighted mode of a file without a start or load.
    with pytest.raises(SystemExit):
        main(["advise", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "highest" not in text and "the one mode the error model weights" in text and "ignored when it does" in text
