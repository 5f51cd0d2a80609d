"""raydamp.System against the built-in models, orders, invariants, and the exact
damping flows of each damping form (issue: bring your own system)."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest
from paper import ELASTIC_P0, ELASTIC_Q0, PENDULUM_P0, PENDULUM_Q0, fitted_slope, reference
from scipy.linalg import expm
from systems import CHAIN_MASS, TWO_DOF_K, TWO_DOF_M, chain, damped_pendulum, elastic_pendulum, kepler, two_dof

import raydamp
from raydamp.methods.catalogue import linear_structure_methods
from raydamp.models import DampedPendulum, ElasticPendulum

# (midpoint and gauss4 run only a LinearStructure: tests/test_implicit_structure.py)
ROWS = [(m.name, m.tableau, m.damped) for m in raydamp.methods() if m.name not in linear_structure_methods()]


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


@pytest.mark.parametrize("method,tableau,damped", ROWS, ids=[f"{m}-{t}" for m, t, _ in ROWS])
def test_elastic_pendulum_as_system_matches_builtin(method, tableau, damped):
    eps = 0.1 if damped else 0.0
    # divergence off: explicit Euler blows up here (J3 to 1e42), and the two blown-up runs are compared
    kw = dict(method=method, tableau=tableau, h=0.1, n_steps=10_000, save_every=100, divergence=0)
    ours = raydamp.integrate(elastic_pendulum(eps), ELASTIC_Q0, ELASTIC_P0, **kw)
    builtin = raydamp.integrate(ElasticPendulum(eps=eps), ELASTIC_Q0, ELASTIC_P0, **kw)
    assert ours.status == builtin.status == "completed"
    assert _relative(ours.q, builtin.q) <= 1e-12
    assert _relative(ours.p, builtin.p) <= 1e-12
    assert _relative(ours.energy, builtin.energy) <= 1e-12
    # Relative to the largest |J3| (explicit Euler on the whole system grows it to 1e42 here).
    scale = max(1.0, float(np.abs(builtin.momentum[:, 0]).max()))
    np.testing.assert_allclose(ours.momentum[:, 0], builtin.momentum[:, 0], rtol=0, atol=1e-12 * scale)


@pytest.mark.parametrize("method,tableau,damped", ROWS, ids=[f"{m}-{t}" for m, t, _ in ROWS])
def test_damped_pendulum_as_system_matches_builtin(method, tableau, damped):
    eps = 0.01 if damped else 0.0
    kw = dict(method=method, tableau=tableau, h=0.1, n_steps=10_000, save_every=100)
    ours = raydamp.integrate(damped_pendulum(eps), PENDULUM_Q0, PENDULUM_P0, **kw)
    builtin = raydamp.integrate(DampedPendulum(eps=eps), PENDULUM_Q0, PENDULUM_P0, **kw)
    assert _relative(ours.q, builtin.q) <= 1e-12
    assert _relative(ours.p, builtin.p) <= 1e-12


@pytest.mark.parametrize("method", ["3s", "2s", "rks"])
def test_elastic_system_conserves_j3(method):
    sol = raydamp.integrate(elastic_pendulum(0.1), ELASTIC_Q0, ELASTIC_P0, method=method, h=0.1, n_steps=100_000,
                            save_every=1000)
    assert sol.max_momentum_drift <= 1e-12
    assert sol.momentum.shape == (sol.t.size, 1)


def _order(system, method, q0, p0, t_end, hs, tableau=None):
    exact_q, exact_p = reference(system.vector_field, np.asarray(q0, float), np.asarray(p0, float), t_end)
    errors = []
    for h in hs:
        sol = raydamp.integrate(system, q0, p0, method=method, tableau=tableau, h=h, t_end=t_end,
                                save_every=10**9)
        errors.append(max(np.max(np.abs(sol.q[-1] - exact_q)), np.max(np.abs(sol.p[-1] - exact_p))))
    return fitted_slope(hs, errors), errors


@pytest.mark.parametrize("method", ["3s", "2s", "rks"])
def test_two_dof_rayleigh_order_two(method):
    slope, errors = _order(two_dof(), method, [1.0, -0.5], [0.0, 0.3], 10.0, [0.1, 0.05, 0.025, 0.0125])
    assert abs(slope - 2.0) <= 0.05, (slope, errors)


@pytest.mark.parametrize("method", ["3s", "2s", "rks"])
def test_two_dof_energy_balance_is_order_two(method):
    peaks = []
    hs = [0.1, 0.05, 0.025]
    for h in hs:
        sol = raydamp.integrate(two_dof(), [1.0, -0.5], [0.0, 0.3], method=method, h=h, t_end=20.0, work=True)
        peaks.append(np.max(np.abs(sol.energy_balance)))
    assert abs(fitted_slope(hs, peaks) - 2.0) <= 0.1, peaks


def test_two_dof_matches_linear_algebra():
    # The exact damping flow of the constant D is expm(-t eps D M^{-1}).
    s = two_dof()
    d = 0.01 * TWO_DOF_M + 0.001 * TWO_DOF_K
    p = np.array([0.4, -1.3])
    _, p1 = s.flow("damp", [0.3, 0.2], p, 0.7)
    np.testing.assert_allclose(p1, expm(-0.7 * d @ np.linalg.inv(TWO_DOF_M)) @ p, rtol=1e-14, atol=1e-15)


KEPLER_Q0, KEPLER_P0 = [1.0, 0.0], [0.0, 1.2]  # an eccentric bound orbit


@pytest.mark.parametrize("method", ["3s", "2s", "rks"])
def test_kepler_conserves_angular_momentum(method):
    sol = raydamp.integrate(kepler(0.01), KEPLER_Q0, KEPLER_P0, method=method, h=0.01, n_steps=100_000,
                            save_every=1000)
    assert sol.status == "completed"
    assert sol.max_momentum_drift <= 1e-12
    assert sol.energy[-1] < sol.energy[0] - 1e-3  # it did dissipate


@pytest.mark.parametrize("method", ["3s", "2s", "rks"])
def test_kepler_energy_decays_monotonically(method):
    sol = raydamp.integrate(kepler(0.05), KEPLER_Q0, KEPLER_P0, method=method, h=0.001, t_end=30.0, save_every=10)
    rises = np.diff(sol.energy)
    assert rises.max() <= 1e-12, rises.max()


def _chain_matrices(q):
    e1 = np.array([-1.0, 1.0, 0.0])
    e2 = np.array([0.0, -1.0, 1.0])
    return 1.0 * np.outer(e1, e1) + 0.5 * np.outer(e2, e2)


def test_chain_dampers_do_not_commute_and_flow_is_exact():
    eps, t = 0.2, 0.9
    d = _chain_matrices(None)
    assert np.abs(np.outer([-1, 1, 0], [-1, 1, 0]) @ np.outer([0, -1, 1], [0, -1, 1])
                  - np.outer([0, -1, 1], [0, -1, 1]) @ np.outer([-1, 1, 0], [-1, 1, 0])).max() > 0.5
    a = eps * d @ np.linalg.inv(np.diag(CHAIN_MASS))
    q, p = np.array([0.3, -0.2, 0.5]), np.array([1.0, -2.0, 0.7])
    s = chain(eps)
    _, p_damp = s.flow("damp", q, p, t)
    np.testing.assert_allclose(p_damp, expm(-t * a) @ p, rtol=0, atol=1e-13 * np.abs(p).max())
    # kick+damp: p' = -g - A p with g frozen; the augmented matrix [[-A, -g], [0, 0]] gives it exactly.
    g = s.gradient(q)
    aug = np.zeros((4, 4))
    aug[:3, :3] = -a
    aug[:3, 3] = -g
    expected = (expm(t * aug) @ np.append(p, 1.0))[:3]
    _, p_kd = s.flow("kick_damp", q, p, t)
    np.testing.assert_allclose(p_kd, expected, rtol=0, atol=1e-13 * np.abs(expected).max())


def test_nonlinear_dampers_match_expm_at_frozen_q():
    # Two dashpots whose directions depend on q, with a full mass matrix.
    mass = np.array([[2.0, 0.3], [0.3, 1.0]])
    s = raydamp.System(["x", "y"], "(x^2 + y^2)/2 + x^3/3", mass=mass.tolist(), eps=0.3,
                       damping={"dampers": [{"on": "sqrt(x^2+y^2)", "c": 2.0}, {"on": "x*y", "c": 0.7}]})
    q, p, t = np.array([0.8, -0.4]), np.array([0.5, 1.1]), 1.3
    g1 = q / np.linalg.norm(q)
    g2 = np.array([q[1], q[0]])
    d = 2.0 * np.outer(g1, g1) + 0.7 * np.outer(g2, g2)
    a = 0.3 * d @ np.linalg.inv(mass)
    _, p1 = s.flow("damp", q, p, t)
    np.testing.assert_allclose(p1, expm(-t * a) @ p, rtol=0, atol=1e-13)


@pytest.mark.parametrize("method", ["3s", "2s", "rks"])
def test_chain_methods_order_two(method):
    slope, errors = _order(chain(), method, [0.5, -0.2, 0.3], [0.0, 0.4, -0.1], 8.0, [0.1, 0.05, 0.025, 0.0125])
    assert abs(slope - 2.0) <= 0.05, (slope, errors)


def test_mass_kinds_give_the_same_trajectory():
    base = dict(coordinates=["x", "y"], potential="(x^2 + 3*y^2)/2 + x*y^3", eps=0.1,
                damping={"dampers": [{"on": "x + y^2", "c": 1.0}]})
    kw = dict(method="3s", h=0.05, n_steps=2000, save_every=100)
    runs = [raydamp.integrate(raydamp.System(**base, mass=mass), [0.4, 0.1], [0.0, -0.2], **kw)
            for mass in (2.0, [2.0, 2.0], [[2.0, 0.0], [0.0, 2.0]])]
    for other in runs[1:]:
        assert _relative(other.q, runs[0].q) <= 1e-13
        assert _relative(other.p, runs[0].p) <= 1e-13


def test_diagonal_and_matrix_damping_agree():
    base = dict(coordinates=["x", "y"], potential="(x^2 + y^2)/2", mass=[1.0, 3.0], eps=0.2)
    a = raydamp.System(**base, damping={"diagonal": [1.0, 0.5]})
    b = raydamp.System(**base, damping={"matrix": [[1.0, 0.0], [0.0, 0.5]]})
    kw = dict(method="2s", h=0.1, n_steps=500)
    assert _relative(raydamp.integrate(a, [1, 1], [0, 0], **kw).q, raydamp.integrate(b, [1, 1], [0, 0], **kw).q) < 1e-14


def test_scalar_damping_decays_every_momentum_at_eps_c():
    s = raydamp.System(["x", "y"], "0", mass=[[2.0, 0.5], [0.5, 1.0]], damping={"scalar": 3.0}, eps=0.1)
    _, p1 = s.flow("damp", [0, 0], [1.0, -2.0], 2.0)
    np.testing.assert_allclose(p1, math.exp(-0.6) * np.array([1.0, -2.0]), rtol=1e-15)


@pytest.mark.parametrize("mass", [[[1.0, 2.0], [2.0, 1.0]], [1.0, -1.0], 0.0, [[1.0, 0.5], [0.4, 1.0]]])
def test_bad_mass_is_refused_naming_mass(mass):
    with pytest.raises(ValueError, match=r"^mass: "):
        raydamp.System(["x", "y"], "x^2", mass=mass)


@pytest.mark.parametrize("damping,path", [
    ({"matrix": [[1.0, 2.0], [2.0, 1.0]]}, "damping.matrix"),
    ({"diagonal": [1.0, -0.1]}, "damping.diagonal"),
    ({"scalar": -1.0}, "damping.scalar"),
    ({"dampers": [{"on": "x", "c": -1.0}]}, r"damping.dampers\[0\].c"),
    ({"viscous": 1.0}, "damping"),
])
def test_bad_damping_is_refused_naming_the_path(damping, path):
    with pytest.raises(ValueError, match=rf"^{path}: "):
        raydamp.System(["x", "y"], "x^2", damping=damping, eps=0.1)


def test_eps_without_damping_is_refused_naming_eps():
    # It ran undamped, silently (energy kept to O(h^2) where the user asked for eps = 0.5; an API audit), as an
    # ensemble's parameters.eps on such a system was already refused. eps = 0 stays the undamped default.
    for build in (lambda eps: raydamp.System(1, "q0^2/2", eps=eps),
                  lambda eps: raydamp.System.from_functions(1, potential=lambda q: 0.5 * q[0] ** 2,
                                                            gradient=lambda q: q, eps=eps)):
        with pytest.raises(ValueError, match=r"^eps: 0.5 given, but this system has no damping for it to scale"):
            build(0.5)
        assert build(0.0).eps == 0.0
    with pytest.raises(ValueError, match=r"^system.eps: 0.5 given, but this system has no damping"):
        raydamp.jobs.build.job_arguments({"system": {"coordinates": 1, "potential": "q0^2/2", "eps": 0.5}, "h": 0.1,
                                          "n_steps": 3, "initial_state": {"q": [1.0], "p": [0.0]}})


def test_configuration_dependent_mass_is_explained():
    with pytest.raises(ValueError, match=r"^mass: .*outside the class.*Cartesian coordinates"):
        raydamp.System(["a", "b"], "-cos(a) - cos(b)", mass=[["2", "cos(a-b)"], ["cos(a-b)", "1"]])


def test_sv_refuses_damped_system_but_runs_undamped():
    with pytest.raises(ValueError, match="method"):
        raydamp.integrate(kepler(0.1), KEPLER_Q0, KEPLER_P0, method="sv", h=0.01, n_steps=10)
    undamped = raydamp.System(["x", "y"], "-1/sqrt(x^2+y^2)")
    sol = raydamp.integrate(undamped, KEPLER_Q0, KEPLER_P0, method="sv", h=0.01, n_steps=100)
    assert sol.status == "completed"


def test_damper_singular_at_q0_is_refused_naming_it():
    s = raydamp.System(["x", "y"], "(x^2+y^2)/2", damping={"dampers": [{"on": "x", "c": 1}, {"on": "1/x", "c": 1}]},
                       eps=0.1)
    with pytest.raises(ValueError, match=r"^damping\.dampers\[1\]\.on: .*not finite at q0"):
        raydamp.integrate(s, [0.0, 1.0], [0.0, 0.0], h=0.1, n_steps=10)


def test_potential_singular_at_q0_is_refused():
    with pytest.raises(ValueError, match=r"^potential: .*not finite at q0"):
        raydamp.integrate(kepler(), [0.0, 0.0], [0.0, 1.0], h=0.1, n_steps=10)


def test_nan_parameter_is_refused():
    with pytest.raises(ValueError, match=r"^parameters\.k: must be finite"):
        raydamp.System(["x"], "k*x^2", parameters={"k": float("nan")})


def test_systems_are_immutable_and_replace_builds_new_ones():
    s = kepler(0.01)
    with pytest.raises(AttributeError, match="immutable"):
        s.eps = 0.5
    assert s.eps == 0.01
    t = s.replace(eps=0.5)
    assert t.eps == 0.5 and s.eps == 0.01
    pendulum = DampedPendulum(0.01)
    with pytest.raises(AttributeError, match="immutable"):
        pendulum.eps = 0.5
    assert pendulum.replace(eps=0.5).eps == 0.5 and pendulum.eps == 0.01


def test_to_dict_round_trip_and_pickle():
    for s in (elastic_pendulum(), two_dof(), chain(), kepler(), damped_pendulum()):
        d = s.to_dict()
        again = raydamp.System.from_dict(d)
        assert again.to_dict() == d
        assert pickle.loads(pickle.dumps(s)).to_dict() == d
    assert raydamp.System(3, "q0^2 + q1^2 + q2^2").to_dict()["coordinates"] == 3


def test_from_dict_names_unknown_and_missing_keys():
    with pytest.raises(ValueError, match=r"^dampingg: unknown key"):
        raydamp.System.from_dict({"coordinates": ["x"], "potential": "x^2", "dampingg": None})
    with pytest.raises(ValueError, match=r"^potential: missing"):
        raydamp.System.from_dict({"coordinates": ["x"]})


def test_system_gradient_matches_builtin():
    q = np.array([0.3, -0.7, 1.1])
    v = np.array([0.2, 0.5, -0.4])
    ours, builtin = elastic_pendulum(), ElasticPendulum()
    np.testing.assert_allclose(ours.gradient(q), builtin.gradient(q), rtol=1e-14)
    np.testing.assert_allclose(ours._core_model.hessian_product(q, v), builtin._core_model.hessian_product(q, v),
                               rtol=1e-13)
    assert ours.potential(q) == pytest.approx(builtin.potential(q), rel=1e-14)


def _elastic_functions(fail_above_y: float | None = None):
    def potential(q):
        return 0.5 * (np.linalg.norm(q) - 1.0) ** 2 + q[2]

    def gradient(q):
        # A function of q alone (the blow-up replay calls it again from the last
        # checkpoint, so a call counter would fail earlier on the replay).
        if fail_above_y is not None and q[1] > fail_above_y:
            raise RuntimeError("the user's gradient gave up")
        r = np.linalg.norm(q)
        return (1.0 - 1.0 / r) * q + np.array([0.0, 0.0, 1.0])

    return raydamp.System.from_functions(
        3, potential=potential, gradient=gradient, eps=0.1,
        damping={"dampers": [{"gradient": lambda q: q / np.linalg.norm(q), "c": 1.0}]},
        momenta={"J3": lambda q, p: q[0] * p[1] - q[1] * p[0]})


@pytest.mark.parametrize("method", ["3s", "2s", "rks", "heun"])
def test_from_functions_matches_expression_system(method):
    kw = dict(method=method, h=0.1, n_steps=1000, save_every=50)
    slow = raydamp.integrate(_elastic_functions(), ELASTIC_Q0, ELASTIC_P0, **kw)
    fast = raydamp.integrate(elastic_pendulum(0.1), ELASTIC_Q0, ELASTIC_P0, **kw)
    assert _relative(slow.q, fast.q) <= 1e-12
    assert _relative(slow.momentum, fast.momentum) <= 1e-12


def test_from_functions_error_stops_the_run_and_keeps_what_it_computed():
    kw = dict(method="3s", h=0.1, n_steps=2000)
    reference = raydamp.integrate(elastic_pendulum(0.1), ELASTIC_Q0, ELASTIC_P0, save_every=1, **kw)
    # A threshold on y first passed late in the run (y's largest value is near step
    # 500): 3s ends step j with a kick at q_j, so the gradient first sees q_j in step j.
    y = reference.q[:, 1]
    threshold = 0.5 * (y[1:400].max() + y.max())
    first = int(np.argmax(y > threshold))
    assert 400 < first < 2000
    sol = raydamp.integrate(_elastic_functions(fail_above_y=threshold), ELASTIC_Q0, ELASTIC_P0, save_every=10, **kw)
    assert sol.status == "non_finite"
    assert sol.failed_step == first
    assert "gradient raised RuntimeError: the user's gradient gave up" in sol.message
    assert np.isfinite(sol.q).all() and sol.t[-1] == pytest.approx(0.1 * (sol.failed_step - 1))


def test_from_functions_checks_q0_and_has_no_plain_form():
    s = raydamp.System.from_functions(1, potential=lambda q: float(1 / q[0]), gradient=lambda q: -1 / q ** 2)
    with np.errstate(divide="ignore"), pytest.raises(ValueError, match=r"^potential: .*q0"):
        raydamp.integrate(s, [0.0], [1.0], h=0.1, n_steps=10)
    with pytest.raises(ValueError, match="to_dict"):
        s.to_dict()
    with pytest.raises(ValueError, match=r"^gradient: must be a callable"):
        raydamp.System.from_functions(1, potential=lambda q: 0.0, gradient="x^2")


@pytest.mark.parametrize(("potential", "words"), [
    ("(4*x)^600", "beyond a double's range"),   # 4^600 x^600: the compiled value was inf * 0 = NaN
    ("(x/3)^700", "beyond a double's range"),   # 3^-700 underflowed to 0: the value was 0
    ("(-2)^x", "not a finite real number"),     # its gradient holds log(-2): a RuntimeError "I"
    ("0^x", "not a finite real number"),        # log(0) = zoo: an AttributeError
])
def test_constants_a_double_cannot_hold_are_refused_naming_the_field(potential, words):
    """An audit: these compiled to NaN or 0 (wrong numbers, silently), or raised SymEngine's own errors."""
    with pytest.raises(ValueError, match=rf"^potential: .*{words}"):
        raydamp.System(["x"], potential)
    with pytest.raises(ValueError, match=rf"^damping\.dampers: .*{words}"):
        raydamp.System(["x", "y"], "x^2 + y^2", damping={"dampers": [{"on": potential, "c": 1.0}]})


def test_a_large_but_representable_power_is_exact():
    system = raydamp.System(["x"], "(4*x)^100 + (x/10)^10")
    assert system.potential(np.array([0.25])) == pytest.approx(1.0 + 0.025**10, rel=1e-14)
    assert system.gradient(np.array([0.25]))[0] == pytest.approx(400.0 + 10 * 0.025**9 / 10, rel=1e-13)


def test_from_functions_refuses_complex_values():
    # The imaginary part was dropped with only a ComplexWarning and the run "completed" (API audit).
    at_q0 = raydamp.System.from_functions(2, potential=lambda q: 0.0, gradient=lambda q: q + 1j)
    with pytest.raises(ValueError, match=r"^gradient: returned complex numbers at q0 = \[1.0, 0.0\]"):
        raydamp.integrate(at_q0, [1.0, 0.0], [0.0, 0.0], h=0.1, n_steps=2)
    later = raydamp.System.from_functions(2, potential=lambda q: 0.0,
                                          gradient=lambda q: q + (1j if q[0] > 1.05 else 0))
    sol = raydamp.integrate(later, [1.0, 0.0], [1.0, 0.0], h=0.1, n_steps=5)
    assert sol.status == "non_finite" and sol.message.endswith("gradient raised ValueError: returned complex "
                                                               "numbers; it must return real ones")
    assert np.isfinite(sol.q).all() and sol.q[-1, 0] <= 1.05 + 0.1


def test_a_parameter_no_expression_uses_is_refused_naming_it():
    # Accepted silently (an ensemble or sweep over it changed nothing), where Load.expression refuses one (API
    # audit). One used only by a dashpot or a momentum map is used.
    with pytest.raises(ValueError, match=r"^parameters.k: is used by none of the potential, the dampers"):
        raydamp.System(["x"], "x^2/2", parameters={"k": 1.0})
    raydamp.System(["x", "y"], "x^2/2 + y^2/2", parameters={"a": 2.0, "w": 3.0},
                   damping={"dampers": [{"on": "a*(x - y)"}]}, eps=0.1, momenta={"J": "w*p_x"})
