"""Drag along fixed axes on the exact Kepler split (issue 46): p_i' = ... - eps A p_i with A a symmetric
positive semi-definite matrix in the inertial frame, whose exact damping flow is e^{-t eps A} (by A's
eigenvectors). A = e_z e_z^T damps the vertical momentum alone: the inclination decays and L_z, about which
that drag has no torque, is kept to rounding. Against DOP853 at rtol 1e-13 the splittings keep their orders;
A = diag(1, 1, 0) on a planar orbit is isotropic drag; ensembles batch only members with the same matrix."""

import numpy as np
import pytest
from test_kepler_drag_directions import assert_batched_as_single_runs

import raydamp

MU = 1.0
VERTICAL = [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
TILTED = [[1.0, 0.2, -0.1], [0.2, 0.5, 0.3], [-0.1, 0.3, 0.8]]  # positive definite, no axis along x, y or z


def inclined(speed=1.1, degrees=30.0):
    i = np.radians(degrees)
    return np.array([1.0, 0.0, 0.0]), np.array([0.0, speed * np.cos(i), speed * np.sin(i)])


def dop853(eps, A, q0, p0, times):
    from scipy.integrate import solve_ivp

    A = np.asarray(A)

    def field(_, y):
        q, v = y[:3], y[3:]
        return np.concatenate([v, -MU * q / np.linalg.norm(q) ** 3 - eps * A @ v])

    out = solve_ivp(field, (0.0, times[-1]), np.concatenate([q0, p0]), method="DOP853", rtol=1e-13, atol=1e-15,
                    t_eval=times)
    return out.y[:3].T, out.y[3:].T


def test_vertical_drag_damps_the_inclination_and_keeps_lz():
    k = raydamp.Kepler(MU, dim=3, eps=2e-2, drag=VERTICAL)
    assert k.momentum_names == ()
    q0, p0 = inclined()
    sol = raydamp.integrate(k, q0, p0, method="3s", h=0.02, t_end=300.0, save_every=100)
    L = np.cross(sol.q, sol.p)
    assert np.max(np.abs(L[:, 2] - L[0, 2])) <= 1e-12 * abs(L[0, 2])
    tan_i = np.hypot(L[:, 0], L[:, 1]) / L[:, 2]
    # tan i = |L_xy| / L_z: L_z is kept, and L_xy decays at eps / 2 averaged over an orbit (the vertical
    # momentum, damped at eps, carries half of it), so tan i / tan i0 follows e^{-eps t / 2}
    assert np.degrees(np.arctan(tan_i[0])) == pytest.approx(30.0, abs=1e-9)
    assert tan_i[-1] / tan_i[0] == pytest.approx(np.exp(-2e-2 * 300.0 / 2), rel=0.05)
    assert np.all(np.diff(tan_i[:: 10]) < 0)
    # Kepler.elements gives the inclination (radians) and the rest as in 2D
    elements = k.elements(sol.q, sol.p)
    assert np.allclose(np.tan(elements["inclination"][:, 0]), tan_i, rtol=1e-12, atol=0)  # (rows, particles)
    assert elements["inclination"][0, 0] == pytest.approx(np.radians(30.0), rel=1e-12)
    assert "inclination" not in raydamp.Kepler(MU).elements([1.0, 0.0], [0.0, 1.0])
    q_ref, _ = dop853(2e-2, VERTICAL, q0, p0, sol.t)
    assert np.max(np.linalg.norm(sol.q - q_ref, axis=1)) <= 2e-3


@pytest.mark.parametrize("A", [VERTICAL, TILTED], ids=["vertical", "tilted"])
@pytest.mark.parametrize(("method", "composition", "order"), [("3s", None, 2), ("2s", None, 2), ("baoab", None, 2),
                                                               ("3s", "yoshida4", 4)])
def test_fixed_axes_keep_the_splittings_order(A, method, composition, order):
    k = raydamp.Kepler(MU, dim=3, eps=0.05, drag=A)
    q0, p0 = inclined(speed=1.2)
    hs = [0.1, 0.05, 0.025]
    errors = []
    for h in hs:
        sol = raydamp.integrate(k, q0, p0, method=method, composition=composition, h=h, t_end=10.0,
                                save_every=round(1.0 / h))
        errors.append(np.max(np.linalg.norm(sol.q - dop853(0.05, A, q0, p0, sol.t)[0], axis=1)))
    slopes = np.diff(np.log(errors)) / np.diff(np.log(hs))
    assert slopes.min() >= order - 0.2, (errors, slopes)


def test_planar_axes_on_a_planar_orbit_are_isotropic_drag():
    flat = raydamp.Kepler(MU, dim=3, eps=1e-2, drag=[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]])
    plane = raydamp.Kepler(MU, dim=2, eps=1e-2)
    a = raydamp.integrate(flat, [1.0, 0.0, 0.0], [0.0, 1.2, 0.0], method="2s", h=0.05, t_end=200.0, save_every=100)
    b = raydamp.integrate(plane, [1.0, 0.0], [0.0, 1.2], method="2s", h=0.05, t_end=200.0, save_every=100)
    assert np.max(np.abs(a.q[:, :2] - b.q)) <= 1e-12 and np.max(np.abs(a.q[:, 2])) == 0.0
    # a multiple of I: the isotropic flow at eps times that multiple
    scaled = raydamp.Kepler(MU, dim=2, eps=1e-2, drag=[[2.0, 0.0], [0.0, 2.0]])
    double = raydamp.Kepler(MU, dim=2, eps=2e-2)
    c = raydamp.integrate(scaled, [1.0, 0.0], [0.0, 1.2], method="3s", h=0.05, t_end=200.0, save_every=100)
    d = raydamp.integrate(double, [1.0, 0.0], [0.0, 1.2], method="3s", h=0.05, t_end=200.0, save_every=100)
    assert np.max(np.abs(c.q - d.q)) <= 1e-12


def test_planets_take_fixed_axes_per_planet_rate():
    system = raydamp.Planets([1e-3, 2e-3], dim=3, eps=[1e-2, 0.0], drag=VERTICAL)
    assert system.momentum_names == ()
    q0, p0 = system.jacobi_state([[1.0, 0.0, 0.05], [0.0, 2.0, 0.0]], [[0.0, 1.0, 0.1], [-0.72, 0.02, 0.0]])
    sol = raydamp.integrate(system, q0, p0, method="2s", h=0.05, t_end=300.0, save_every=100)
    L = np.cross(sol.q.reshape(-1, 2, 3), sol.p.reshape(-1, 2, 3)).sum(axis=1)
    # vertical drag on the inner planet's Jacobi momentum: no torque about z on the system
    assert np.max(np.abs(L[:, 2] - L[0, 2])) <= 1e-12 * abs(L[0, 2])
    assert np.hypot(L[-1, 0], L[-1, 1]) < 0.9 * np.hypot(L[0, 0], L[0, 1])
    assert raydamp.Planets.from_dict(system.to_dict()).to_dict() == system.to_dict()


def test_ensemble_members_equal_single_runs_and_matrices_are_not_mixed():
    members = 24
    rng = np.random.default_rng(46)
    rp, e = rng.uniform(0.5, 2.0, members), rng.uniform(0.0, 0.7, members)
    q0 = np.column_stack([rp, np.zeros(members), 0.1 * rp])
    p0 = np.column_stack([np.zeros(members), np.sqrt(MU * (1.0 + e) / rp), np.full(members, 0.05)])
    # members 16-23 with another matrix: not run as particles of the first members' batch
    assert_batched_as_single_runs(raydamp.Kepler(MU, dim=3, eps=1e-2, drag=TILTED),
                                  raydamp.Kepler(MU, dim=3, eps=1e-2, drag=VERTICAL), q0, p0, "3s", split=16)


def test_the_json_form_round_trips_and_runs_as_a_job():
    from raydamp.jobs import job_arguments

    k = raydamp.Kepler(MU, dim=3, eps=1e-2, drag=np.array(VERTICAL))
    assert k.to_dict()["drag"] == VERTICAL
    assert raydamp.Kepler.from_dict(k.to_dict()).to_dict() == k.to_dict()
    job = {"system": k.to_dict(), "method": "3s", "h": 0.05, "t_end": 10.0,
           "initial_state": {"q": [1.0, 0.0, 0.0], "p": [0.0, 1.0, 0.3]}}
    model, q0, p0, options = job_arguments(job)
    assert model.to_dict() == k.to_dict()


@pytest.mark.parametrize(("drag", "message"), [
    ([[1.0, 0.0], [0.0, 1.0]], r"drag: a matrix must be 3 x 3"),
    ([[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], r"drag: the matrix must be symmetric"),
    ([[1.0, 0.0, 0.0], [0.0, -0.5, 0.0], [0.0, 0.0, 1.0]], r"drag: the matrix must be positive semi-definite"),
    ([[1.0, 0.0, 0.0], [0.0, float("nan"), 0.0], [0.0, 0.0, 1.0]], r"drag: the matrix must be finite"),
    ([["a", 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], r"drag: must be one of .* or a 3 x 3 matrix"),
])
def test_a_bad_matrix_is_refused_naming_drag(drag, message):
    with pytest.raises(ValueError, match=message):
        raydamp.Kepler(MU, dim=3, eps=1e-3, drag=drag)
    with pytest.raises(ValueError, match=message):
        raydamp.Planets([1e-3], dim=3, eps=1e-3, drag=drag)


def test_a_bad_matrix_in_a_job_names_its_path():
    from raydamp.jobs import job_arguments

    job = {"system": {"kind": "kepler", "dim": 3, "eps": 1e-3, "drag": [[1, 0, 0], [0, -1, 0], [0, 0, 1]]},
           "method": "3s", "h": 0.1, "t_end": 10.0, "initial_state": {"q": [1.0, 0.0, 0.0], "p": [0.0, 1.1, 0.0]}}
    with pytest.raises(ValueError, match=r"system\.drag.*positive semi-definite"):
        job_arguments(job)
    with pytest.raises(ValueError, match=r"system\.drag"):
        job_arguments({**job, "system": {**job["system"], "drag": [[1, 0, 0, 0]] * 4}})
