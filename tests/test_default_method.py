"""integrate's default method (method=None): 3s, except where 3s is a trap on a LinearStructure (issue 25,
point 2); the choice and its reason are in the provenance, and a job without "method" gets the same."""

import numpy as np
import pytest
import scipy.sparse as sparse

import raydamp
from raydamp.jobs import job_arguments
from raydamp.models import DampedPendulum
from raydamp.run.choose_method import DEGREE_LIMIT, choose_method


def shear_building(n):
    main = np.full(n, 2.0)
    main[-1] = 1.0
    return sparse.identity(n, format="csc"), sparse.diags([-np.ones(n - 1), main, -np.ones(n - 1)], [-1, 0, 1]).tocsc()


def two_percent(n, lumped=True):
    """A shear building of n storeys, 2% damping in modes 1 and 3 (beta K dominant)."""
    M, K = shear_building(n)
    w = np.sqrt(np.sort(np.linalg.eigvalsh(K.toarray())))[:3]
    alpha, beta = raydamp.rayleigh_coefficients(w[0], w[2], 0.02, 0.02)
    if not lumped:  # a consistent (tridiagonal, positive definite) mass
        M = (M + sparse.diags([np.full(n - 1, 0.1), np.full(n - 1, 0.1)], [-1, 1])).tocsc()
    return raydamp.LinearStructure(M, K, alpha=alpha, beta=beta)


@pytest.fixture(scope="module")
def chain2000():
    return two_percent(2000)


def start(s):
    q0 = np.linspace(0, 1, s.dim)
    return q0, np.zeros(s.dim)


def test_other_models_keep_3s_and_say_so():
    sol = raydamp.integrate(DampedPendulum(eps=0.1), [1.0], [0.0], h=0.1, n_steps=10)
    assert sol.method == "3s"
    assert sol.provenance["method"] == "3s"
    assert sol.provenance["method_reason"] == "3s: the default for a DampedPendulum"


def test_a_named_method_is_never_changed_and_has_no_reason(chain2000):
    q0, p0 = start(chain2000)
    sol = raydamp.integrate(chain2000, q0, p0, method="3s", h=1.2, n_steps=20)   # h omega_max = 2.4: as asked
    assert sol.method == "3s"
    assert "method_reason" not in sol.provenance


def test_beyond_the_explicit_limit_the_default_is_midpoint(chain2000):
    q0, p0 = start(chain2000)
    sol = raydamp.integrate(chain2000, q0, p0, h=1.2, n_steps=200)
    assert sol.success and sol.method == "midpoint" and sol.tableau is None
    reason = sol.provenance["method_reason"]
    assert reason.startswith("midpoint: h omega_max = 2.4 >= 2")
    same = raydamp.integrate(chain2000, q0, p0, method="midpoint", h=1.2, n_steps=200)
    assert np.array_equal(sol.q, same.q)


def test_a_long_chebyshev_series_makes_the_default_rks_midpoint(chain2000):
    # h omega_max = 1: stable, but 3s's damping flow would be a Chebyshev series of degree 25 (measured per
    # step: 3s 162 us, rks-midpoint 47 us, on this chain)
    assert max(chain2000.chebyshev_degrees(0.5)) == 25 >= DEGREE_LIMIT["lumped"]
    q0, p0 = start(chain2000)
    sol = raydamp.integrate(chain2000, q0, p0, h=0.5, n_steps=100)
    assert (sol.method, sol.tableau, sol.provenance["tableau"]) == ("rks", "midpoint", "midpoint")
    assert "Chebyshev series of degree 25" in sol.provenance["method_reason"]
    same = raydamp.integrate(chain2000, q0, p0, method="rks", tableau="midpoint", h=0.5, n_steps=100)
    assert np.array_equal(sol.q, same.q)


def test_a_short_series_keeps_3s():
    s = two_percent(50)
    degree = max(s.chebyshev_degrees(0.05))
    assert degree < DEGREE_LIMIT["lumped"]
    q0, p0 = start(s)
    sol = raydamp.integrate(s, q0, p0, h=0.05, n_steps=20)
    assert sol.method == "3s"
    assert sol.provenance["method_reason"] == f"3s: h omega_max = {0.05 * np.sqrt(s.spectral_bound):.4g} < 2 and " \
                                              f"its damping flow's Chebyshev degree {degree} < 12"


def test_alpha_damping_alone_keeps_3s():
    M, K = shear_building(2000)
    s = raydamp.LinearStructure(M, K, alpha=0.01)
    q0, p0 = start(s)
    assert raydamp.integrate(s, q0, p0, h=0.5, n_steps=10).method == "3s"


def test_a_consistent_mass_switches_from_degree_4():
    s = two_percent(40, lumped=False)
    assert s.mass_kind == "consistent"
    h = 0.05
    assert max(s.chebyshev_degrees(h)) >= DEGREE_LIMIT["consistent"]
    assert choose_method(s, None, None, None, h).method == "rks"


def test_a_tableau_or_composition_keeps_3s_as_the_base(chain2000):
    choice = choose_method(chain2000, None, None, "yoshida4", 1.2)
    assert (choice.method, choice.tableau) == ("3s", None)
    assert choose_method(chain2000, "2s", None, None, 1.2) == ("2s", None, None)


def test_a_job_without_method_gets_the_same_choice_and_its_provenance_runs_again(chain2000):
    q0, _ = start(chain2000)
    job = {"system": chain2000.to_dict(), "h": 1.2, "n_steps": 50, "initial_state": {"q": q0.tolist(),
                                                                                      "p": [0.0] * 2000}}
    model, q, p, options = job_arguments(job)
    assert options["method"] is None
    sol = raydamp.integrate(model, q, p, **options)
    assert sol.method == "midpoint" and sol.provenance["method_reason"].startswith("midpoint:")
    model, q, p, options = job_arguments(sol.provenance)       # method_reason is set aside as provenance
    assert options["method"] == "midpoint"
    assert np.array_equal(raydamp.integrate(model, q, p, **options).q, sol.q)


def test_at_a_temperature_past_the_explicit_limit_the_default_is_an_error_naming_h(chain2000):
    # Only the explicit splittings take a temperature (exact noise flows): past their stability limit the default
    # ran 3s, which blew up (status non_finite at step 165 in an audit) with no reason recorded.
    q0, p0 = start(chain2000)
    with pytest.raises(ValueError, match=r"^h: h omega_max may reach h sqrt\(spectral_bound\) = 2\.4 >= 2 "
                                         r".*take h < 1, or name the method"):
        raydamp.integrate(chain2000, q0, p0, h=1.2, n_steps=200, temperature=0.1, seed=1)
    sol = raydamp.integrate(chain2000, q0, p0, h=0.5, n_steps=200, temperature=0.1, seed=1)
    assert sol.success and sol.method == "3s"
    assert sol.provenance["method_reason"].startswith("3s: the default at a temperature")


def test_an_ensemble_chooses_as_integrate_does(chain2000):
    # integrate_ensemble's method defaulted to "3s": past the explicit limit its members "completed" at |q| = 1e150.
    q0, p0 = start(chain2000)
    ens = raydamp.integrate_ensemble(chain2000, np.stack([q0, 0.5 * q0]), p0, h=1.2, n_steps=200, threads=1)
    assert ens.method == "midpoint" and all(s == "completed" for s in ens.status)
    assert ens.provenance["method_reason"].startswith("midpoint: h omega_max = 2.4 >= 2")
    alone = raydamp.integrate(chain2000, 0.5 * q0, p0, h=1.2, n_steps=200)
    np.testing.assert_array_equal(ens.q_final[1], alone.q[-1])
    pendulums = raydamp.integrate_ensemble(DampedPendulum(eps=0.1), [[1.0], [2.0]], [0.0], h=0.1, n_steps=10)
    assert pendulums.method == "3s"


def test_a_damping_flow_past_the_series_bound_makes_the_default_rks_midpoint():
    # 60 modes, omega from 1 to 1e7: at h = 1.5e-7 and beta = 0.25, t beta L is about 4e6, past what a Chebyshev
    # series of degree 8192 resolves. The default let that refusal through ("take a smaller h") where rks-midpoint,
    # the choice for a long series, runs at any h rho (found in review).
    omega = np.geomspace(1.0, 1e7, 60)
    s = raydamp.LinearStructure(sparse.identity(60, format="csc"), sparse.diags(omega ** 2).tocsc(), alpha=0.0,
                                beta=0.25)
    with pytest.raises(raydamp.ChebyshevDegreeError, match="needs a Chebyshev degree above 8192"):
        s.chebyshev_degrees(1.5e-7)
    p0 = np.zeros(60)
    p0[0] = 1.0
    sol = raydamp.integrate(s, np.zeros(60), p0, h=1.5e-7, n_steps=10)
    assert sol.success and (sol.method, sol.tableau) == ("rks", "midpoint")
    assert "degree above 8192" in sol.provenance["method_reason"]
    assert abs(sol.p[-1, 0] - np.exp(-0.25 * 1.5e-6)) < 1e-9
    # advise let the same refusal through; such a method's row now says "series" and is not recommended.
    advice = raydamp.advise(s, t_end=1e-5, tolerance=1e-6, measure=False)
    assert advice.row("3s").limited_by == "series" and advice.row("3s").seconds == float("inf")
    assert advice.recommended.label != "3s"
