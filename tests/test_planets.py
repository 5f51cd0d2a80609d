"""raydamp.Planets: interacting planets in Jacobi coordinates with drag on one, against an independent
reference (the inertial N-body equations with the drag written as forces on every body, DOP853 at
rtol 1e-13), the energy balance E + W = E0, the splitting's order, and the refusals."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import raydamp

CENTRAL = 1.0
MASSES = [1e-2, 5e-3]
EPS = [0.0, 0.005]  # drag on the outer planet only: in 20 time units its orbit shrinks by about a fifth
# Period ratio about 2.8: the planets stay apart while the drag moves the outer one in (a start at 1.6, or
# a stronger drag, brings close encounters within 20 time units, and errors that grow exponentially).
START_X = np.array([[1.0, 0.0], [0.0, 2.0]])
START_V = np.array([[0.0, 1.05], [-0.72, 0.05]])


def inertial_reference(system, x_helio, v_helio, times):
    """The planets' heliocentric positions and velocities at ``times``: every body in the inertial frame,
    pairwise gravity, and the drag as forces: on planet k, -eps_k m'_k (v_k - V_k) with V_k the velocity of
    the centre of mass of the bodies inside it, and its reaction spread over those bodies by mass."""
    G = system.G
    m = np.array([system.central_mass, *system.masses])
    eps = np.broadcast_to(np.asarray(system.eps, dtype=float), (len(system.masses),))
    bodies, d = len(m), system.space_dim
    # barycentric start: x_0 = -sum m_i h_i / M
    x0 = np.vstack([np.zeros(d), x_helio])
    v0 = np.vstack([np.zeros(d), v_helio])
    x0 -= m @ x0 / m.sum()
    v0 -= m @ v0 / m.sum()

    def field(_, y):
        x = y[: bodies * d].reshape(bodies, d)
        v = y[bodies * d:].reshape(bodies, d)
        force = np.zeros((bodies, d))
        for a in range(bodies):
            for b in range(a + 1, bodies):
                r = x[b] - x[a]
                f = G * m[a] * m[b] * r / np.linalg.norm(r) ** 3
                force[a] += f
                force[b] -= f
        for k in range(1, bodies):
            if eps[k - 1] == 0.0:
                continue
            inner = m[:k].sum()
            centre_velocity = m[:k] @ v[:k] / inner
            reduced = m[k] * inner / (inner + m[k])
            drag = -eps[k - 1] * reduced * (v[k] - centre_velocity)
            force[k] += drag
            force[:k] -= np.outer(m[:k] / inner, drag)
        return np.concatenate([v.reshape(-1), (force / m[:, None]).reshape(-1)])

    out = solve_ivp(field, (0.0, times[-1]), np.concatenate([x0.reshape(-1), v0.reshape(-1)]), method="DOP853",
                    rtol=1e-13, atol=1e-15, t_eval=times)
    assert out.success
    x = out.y[: bodies * d].T.reshape(len(times), bodies, d)
    v = out.y[bodies * d:].T.reshape(len(times), bodies, d)
    return x[:, 1:] - x[:, :1], v[:, 1:] - v[:, :1]


@pytest.fixture(scope="module")
def system():
    return raydamp.Planets(MASSES, central_mass=CENTRAL, eps=EPS)


def test_the_jacobi_coordinates_round_trip(system):
    q0, p0 = system.jacobi_state(START_X, START_V)
    x, v = system.heliocentric(q0, p0)
    assert np.allclose(x, START_X, rtol=0, atol=1e-15) and np.allclose(v, START_V, rtol=0, atol=1e-15)


def test_the_energy_is_the_barycentric_energy(system):
    """H(Q, P) in Jacobi coordinates equals the inertial kinetic plus potential energy of every body."""
    q0, p0 = system.jacobi_state(START_X, START_V)
    m = np.array([CENTRAL, *MASSES])
    x = np.vstack([np.zeros(2), START_X])
    v = np.vstack([np.zeros(2), START_V])
    v = v - m @ v / m.sum()
    kinetic = 0.5 * np.sum(m * np.sum(v * v, axis=1))
    potential = -sum(m[a] * m[b] / np.linalg.norm(x[a] - x[b]) for a in range(3) for b in range(a + 1, 3))
    assert system.energy(q0, p0) == pytest.approx(kinetic + potential, rel=1e-14)


@pytest.mark.parametrize(("method", "composition", "order"), [("3s", None, 2), ("2s", None, 2),
                                                               ("3s", "yoshida4", 4)])
def test_two_planets_with_drag_on_one_have_the_order_against_an_inertial_reference(system, method, composition,
                                                                                   order):
    q0, p0 = system.jacobi_state(START_X, START_V)
    t_end = 20.0
    hs = [0.2, 0.1, 0.05]
    errors = []
    reference = None
    for h in hs:
        sol = raydamp.integrate(system, q0, p0, method=method, composition=composition, h=h, t_end=t_end,
                                save_every=round(2.0 / h))
        assert sol.status == "completed"
        if reference is None:
            reference = inertial_reference(system, START_X, START_V, sol.t)
        x, _ = system.heliocentric(sol.q, sol.p)
        errors.append(np.max(np.linalg.norm(x - reference[0], axis=-1)))
    slopes = np.diff(np.log(errors)) / np.diff(np.log(hs))
    assert slopes.min() >= order - 0.2, (errors, slopes)
    # measured at h = 0.05: 8.8e-6 (3s), 4.6e-6 (2s), 2.0e-9 (yoshida4)
    assert errors[-1] <= (2e-5 if order == 2 else 1e-8), errors


def test_the_energy_balance_closes_to_second_order(system):
    """E(t) + W(t) = E0, W the energy the drag took (work=True): the gap falls as h^2."""
    q0, p0 = system.jacobi_state(START_X, START_V)
    gaps = []
    hs = [0.1, 0.05]
    for h in hs:
        sol = raydamp.integrate(system, q0, p0, method="3s", h=h, t_end=20.0, save_every=round(1.0 / h), work=True)
        gaps.append(np.max(np.abs(sol.energy + sol.work - sol.energy[0])) / abs(sol.energy[0]))
        assert sol.work[-1] > 0.04 * abs(sol.energy[0])  # the drag took 4.6% of |E0|
    order = np.log2(gaps[0] / gaps[1])
    assert order >= 1.8, (gaps, order)
    assert gaps[-1] <= 3e-6, gaps  # measured: 9.9e-7 at h = 0.05


def test_one_planet_is_the_kepler_orbit_about_the_total_mass():
    """No interaction for one planet: the Jacobi Kepler drift about G (m_0 + m_1) with the reduced mass."""
    one = raydamp.Planets([0.1], central_mass=2.0, eps=0.01)
    test = raydamp.Kepler(mu=2.1, mass=0.1 * 2.0 / 2.1, eps=0.01)
    q0, p0 = one.jacobi_state([[1.0, 0.2]], [[-0.1, 1.3]])
    a = raydamp.integrate(one, q0, p0, method="3s", h=0.05, n_steps=400, save_every=100)
    b = raydamp.integrate(test, q0, p0, method="3s", h=0.05, n_steps=400, save_every=100)
    assert np.max(np.abs(a.q - b.q)) <= 1e-12 * np.max(np.abs(b.q))
    assert np.max(np.abs(a.momentum - b.momentum)) <= 1e-13 * abs(b.momentum[0, 0])


def test_uniform_drag_decays_the_total_angular_momentum_exactly():
    sys3 = raydamp.Planets([1e-3, 2e-3, 1e-3], dim=3, eps=0.01)
    x = np.array([[1.0, 0.0, 0.01], [0.0, 1.5, -0.02], [-2.2, 0.1, 0.0]])
    v = np.array([[0.0, 1.0, 0.02], [-0.8, 0.0, 0.01], [0.0, -0.67, 0.03]])
    q0, p0 = sys3.jacobi_state(x, v)
    sol = raydamp.integrate(sys3, q0, p0, method="2s", h=0.05, t_end=30.0, save_every=100)
    law = sol.momentum[0] * np.exp(-0.01 * sol.t)[:, None]
    assert sys3.momentum_names == ("Lx", "Ly", "Lz")
    assert np.max(np.abs(sol.momentum - law)) <= 1e-13 * np.linalg.norm(sol.momentum[0])


def test_the_json_form_round_trips(system):
    assert raydamp.Planets.from_dict(system.to_dict()).to_dict() == system.to_dict()
    assert system.to_dict()["eps"] == EPS


@pytest.mark.parametrize(("arguments", "message"), [
    ({"masses": [1e-3, -1e-3]}, r"masses\[1\] must be > 0"), ({"masses": []}, "masses"),
    ({"masses": [1e-3], "central_mass": 0.0}, "central_mass"), ({"masses": [1e-3], "G": -1.0}, "G"),
    ({"masses": [1e-3, 1e-3], "eps": [0.1]}, "eps: expected one drag rate per planet"),
    ({"masses": [1e-3], "eps": [-0.1]}, r"eps\[0\] must be >= 0"), ({"masses": [1e-3], "dim": 4}, "dim")])
def test_bad_parameters_are_refused_naming_them(arguments, message):
    with pytest.raises(ValueError, match=message):
        raydamp.Planets(**arguments)


def test_a_planet_at_the_central_body_or_two_at_one_place_are_refused(system):
    with pytest.raises(ValueError, match="positions: planet 1 is at the central body"):
        system.jacobi_state([[1.0, 0.0], [0.0, 0.0]], START_V)
    q0, p0 = system.jacobi_state(START_X, START_V)
    at_centre = q0.copy()
    at_centre[2:] = -system.masses[0] / (CENTRAL + system.masses[0]) * q0[:2]  # planet 1 at x = 0
    with pytest.raises(ValueError, match="q0: planet 1 is at the central body"):
        raydamp.integrate(system, at_centre, p0, method="3s", h=0.1, n_steps=5)
    with pytest.raises(ValueError, match="positions: planets 0 and 1 are at the same position"):
        system.jacobi_state([[1.0, 0.5], [1.0, 0.5]], START_V)
    with pytest.raises(ValueError, match="q0: planet 1 is at the centre of mass of the bodies inside it"):
        raydamp.integrate(system, np.concatenate([q0[:2], [0.0, 0.0]]), p0, method="3s", h=0.1, n_steps=5)


@pytest.mark.parametrize("method", ["rksb", "rk4", "midpoint"])
def test_methods_that_step_a_free_drift_are_refused(system, method):
    q0, p0 = system.jacobi_state(START_X, START_V)
    with pytest.raises(ValueError, match="method: '" + method + "'"):
        raydamp.integrate(system, q0, p0, method=method, h=0.1, n_steps=10)


def test_ensemble_members_equal_their_single_runs(system):
    rng = np.random.default_rng(7)
    starts = [system.jacobi_state(START_X * (1 + 0.05 * rng.standard_normal()), START_V) for _ in range(4)]
    q0 = np.array([s[0] for s in starts])
    p0 = np.array([s[1] for s in starts])
    ens = raydamp.integrate_ensemble(system, q0, p0, method="2s", h=0.05, n_steps=200, save_every=50, threads=2)
    for i in range(4):
        one = raydamp.integrate(system, q0[i], p0[i], method="2s", h=0.05, n_steps=200, save_every=50)
        assert np.array_equal(ens.member(i).q, one.q) and np.array_equal(ens.member(i).energy, one.energy), i


def test_a_planets_job_runs_and_names_a_bad_field(system):
    """raydamp run and the service read a job through job_arguments: the same model, and a bad field named by
    its JSON path."""
    from raydamp.jobs import job_arguments

    q0, p0 = system.jacobi_state(START_X, START_V)
    job = {"system": system.to_dict(), "method": "2s", "h": 0.1, "n_steps": 200, "save_every": 50,
           "initial_state": {"q": q0.tolist(), "p": p0.tolist()}}
    model, q, p, options = job_arguments(job)
    direct = raydamp.integrate(system, q0, p0, method="2s", h=0.1, n_steps=200, save_every=50, work=True)
    assert np.array_equal(raydamp.integrate(model, q, p, **options).q, direct.q)
    with pytest.raises(ValueError, match=r"system\.masses\[1\]"):
        job_arguments({**job, "system": {**job["system"], "masses": [1e-2, -1.0]}})


@pytest.mark.slow  # two interpreters' start-up, seconds: the job path itself is tested above
def test_raydamp_run_takes_a_planets_job(system, tmp_path):
    import json
    import subprocess
    import sys

    q0, p0 = system.jacobi_state(START_X, START_V)
    job = {"system": system.to_dict(), "method": "2s", "h": 0.1, "n_steps": 200, "save_every": 50,
           "initial_state": {"q": q0.tolist(), "p": p0.tolist()}}
    (tmp_path / "planets.json").write_text(json.dumps(job))
    done = subprocess.run([sys.executable, "-m", "raydamp", "run", "planets.json", "--out", "planets.nc"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    direct = raydamp.integrate(system, q0, p0, method="2s", h=0.1, n_steps=200, save_every=50, work=True)
    np.testing.assert_array_equal(raydamp.load(tmp_path / "planets.nc").q, direct.q)
