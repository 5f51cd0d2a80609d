"""Holonomic constraints (issue 45): RATTLE in the splitting methods, against reference solutions of the
same mechanics written in joint angles, the damping laws of a constrained symmetry, and bad inputs."""

from __future__ import annotations

import math

import numpy as np
import pytest
from paper import fitted_slope
from scipy.integrate import solve_ivp

import raydamp

G = 9.81


def pendulum(length=0.8, mass=1.3, eps=0.3, tol=1e-12, damping=None, project_initial=False):
    return raydamp.System(["x", "y"], "m*g*y", parameters={"m": mass, "g": G, "l": length}, mass=mass,
                          damping={"scalar": 1.0} if damping is None else damping, eps=eps,
                          constraints=["x^2 + y^2 - l^2"], constraint_tol=tol, project_initial=project_initial)


def pendulum_start(length=0.8, mass=1.3, theta=1.1, omega=0.4):
    q0 = np.array([length * math.sin(theta), -length * math.cos(theta)])
    p0 = mass * length * omega * np.array([math.cos(theta), math.sin(theta)])
    return q0, p0


def one_angle(length, eps, theta, omega, t_end):
    """theta'' = -(g/l) sin theta - eps theta' (D = M: the damping force -eps m v, tangent to the circle)."""
    sol = solve_ivp(lambda t, y: [y[1], -G / length * math.sin(y[0]) - eps * y[1]], (0, t_end), [theta, omega],
                    method="DOP853", rtol=1e-13, atol=1e-14)
    th = sol.y[0, -1]
    return np.array([length * math.sin(th), -length * math.cos(th)])


def test_residuals_stay_within_the_tolerance_at_every_step():
    length = 0.8
    system = pendulum(length)
    q0, p0 = pendulum_start(length)
    sol = raydamp.integrate(system, q0, p0, method="3s", h=0.01, n_steps=2000, save_every=1)
    assert sol.status == "completed"
    r = np.hypot(sol.q[:, 0], sol.q[:, 1])
    assert np.max(np.abs(r - length)) <= 1e-12 * length
    # p on the tangent space: the radial velocity, relative to the speed
    radial = np.abs(np.sum(sol.q * sol.p, axis=1)) / (r * np.linalg.norm(sol.p, axis=1))
    assert radial.max() <= 1e-13


def test_a_loose_tolerance_is_honoured_and_used():
    length = 0.8
    q0, p0 = pendulum_start(length)
    sol = raydamp.integrate(pendulum(length, tol=1e-5), q0, p0, method="3s", h=0.05, n_steps=400, save_every=1)
    deviation = np.abs(np.hypot(sol.q[:, 0], sol.q[:, 1]) - length) / length
    assert deviation.max() <= 1e-5
    assert deviation.max() > 1e-9  # the solve stopped at the tolerance, not at rounding


@pytest.mark.parametrize(("method", "composition", "order", "hs", "high"), [
    # The "order 4/6/8 where the theory says": RATTLE is a symmetric order-2 step, so the compositions
    # raise it. Measured on this pendulum: kahan_li6 3s slopes 6.02, 5.97, 6.09 (2s the same); kahan_li8 3s
    # 8.78, 8.53, 8.22 over h = 0.2 ... 0.1, falling toward 8 (still above it where the error is above the
    # reference's), so its bound is wider above.
    ("3s", "kahan_li6", 6, [0.2, 0.16, 0.125, 0.1], 0.4), ("2s", "kahan_li6", 6, [0.2, 0.16, 0.125, 0.1], 0.4),
    ("3s", "kahan_li8", 8, [0.2, 0.16, 0.125, 0.1], 1.0)])
def test_planar_pendulum_compositions_reach_orders_6_and_8(method, composition, order, hs, high):
    errors, slope = planar_slope(pendulum(0.8, 1.3, eps=0.3), 0.3, method, composition, hs)
    assert order - 0.2 <= slope <= order + high, (errors, slope)


def planar_slope(system, eps, method, composition, hs):
    """The errors at t = 2 against the one-angle equation (rod 0.8, mass 1.3, from 1.1 rad at 0.4 rad/s) at
    each h, and their fitted slope."""
    length, mass, theta, omega, t_end = 0.8, 1.3, 1.1, 0.4, 2.0
    q0, p0 = pendulum_start(length, mass, theta, omega)
    exact = one_angle(length, eps, theta, omega, t_end)
    errors = []
    for h in hs:
        sol = raydamp.integrate(system, q0, p0, method=method, composition=composition, h=h, t_end=t_end,
                                save_every=10_000)
        assert sol.status == "completed", sol.message
        errors.append(float(np.max(np.abs(sol.q[-1] - exact))))
    return errors, fitted_slope(hs, errors)


@pytest.mark.parametrize("method,composition,order", [("3s", None, 2), ("2s", None, 2), ("baoab", None, 2),
                                                      ("rks", None, 2), ("sv", None, 2), ("3s", "yoshida4", 4),
                                                      ("2s", "yoshida4", 4)])
def test_planar_pendulum_matches_the_one_angle_equation(method, composition, order):
    length, mass = 0.8, 1.3
    eps = 0.0 if method == "sv" else 0.3
    system = pendulum(length, mass, eps=eps)
    if method == "sv":
        system = raydamp.System(["x", "y"], "m*g*y", parameters={"m": mass, "g": G, "l": length}, mass=mass,
                                constraints=["x^2 + y^2 - l^2"])
    hs = [0.04, 0.02, 0.01] if order == 2 else [0.08, 0.04, 0.02]
    errors, slope = planar_slope(system, eps, method, composition, hs)
    assert order - 0.2 <= slope <= order + 0.4, (errors, slope)


def spherical(mass, eps, damping):
    return raydamp.System(["x", "y", "z"], "m*g*z", parameters={"m": mass, "g": G, "l": 1.2}, mass=mass,
                          damping=damping, eps=eps, constraints=["x^2 + y^2 + z^2 - l^2"],
                          momenta={"Lz": "x*p_y - y*p_x"})


def spherical_start(mass):
    length = 1.2
    th, ph = 2.0, 0.3  # from the upward vertical
    q0 = length * np.array([math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph), math.cos(th)])
    # a velocity along the azimuth and some along the meridian: tangent to the sphere
    e_ph = np.array([-math.sin(ph), math.cos(ph), 0.0])
    e_th = np.array([math.cos(th) * math.cos(ph), math.cos(th) * math.sin(ph), -math.sin(th)])
    return q0, mass * (1.7 * e_ph + 0.6 * e_th)


@pytest.mark.parametrize("method", ["3s", "2s", "baoab"])
def test_spherical_pendulum_angular_momentum_decays_as_exp_minus_eps_t(method):
    mass, eps = 2.5, 0.2
    q0, p0 = spherical_start(mass)
    sol = raydamp.integrate(spherical(mass, eps, {"scalar": 1.0}), q0, p0, method=method, h=0.01, n_steps=20_000,
                            save_every=100)
    assert sol.status == "completed"
    lz0 = q0[0] * p0[1] - q0[1] * p0[0]
    law = lz0 * np.exp(-eps * sol.t)
    lz = sol.q[:, 0] * sol.p[:, 1] - sol.q[:, 1] * sol.p[:, 0]
    assert np.max(np.abs(lz - law)) <= 1e-12 * abs(lz0)
    assert sol.max_momentum_drift <= 1e-12 * abs(lz0)  # the same law, checked by the core at every step


@pytest.mark.parametrize(("damping", "rate"), [({"scalar": 1.0}, 1.0), ({"diagonal": [1.0, 1.0, 1.0]}, 1 / 2.5)])
@pytest.mark.parametrize("method", ["3s", "2s"])
def test_the_law_holds_to_1e_12_of_itself_over_a_million_steps(damping, rate, method):
    # Issue 45: L_z(t) = L_z(0) e^{-eps t} (D = M; e^{-eps t / m} for D = I) to 1e-12 relative over 10^6 steps,
    # measured against the law at every saved time. The damping flow adds (e^{-ta} - 1) p to p: e^{-ta}
    # rounded once and applied 10^6 times drifted 1.05e-10 (3s, D = M) and 1.79e-10 (D = I) from the law;
    # now 1.8e-13 and 1.1e-13 (2s: 1.1e-13, 8.9e-14).
    mass, eps = 2.5, 1e-4
    q0, p0 = spherical_start(mass)
    sol = raydamp.integrate(spherical(mass, eps, damping), q0, p0, method=method, h=0.01, n_steps=10**6,
                            save_every=1000)
    assert sol.status == "completed"
    lz0 = q0[0] * p0[1] - q0[1] * p0[0]
    law = lz0 * np.exp(-eps * rate * sol.t)
    lz = sol.q[:, 0] * sol.p[:, 1] - sol.q[:, 1] * sol.p[:, 0]
    assert np.max(np.abs(lz - law) / np.abs(law)) <= 1e-12


def test_spherical_pendulum_with_identity_damping_decays_as_exp_minus_eps_t_over_m():
    mass, eps = 2.5, 0.2
    q0, p0 = spherical_start(mass)
    sol = raydamp.integrate(spherical(mass, eps, {"diagonal": [1.0, 1.0, 1.0]}), q0, p0, method="3s", h=0.01,
                            n_steps=20_000, save_every=100)
    lz0 = q0[0] * p0[1] - q0[1] * p0[0]
    lz = sol.q[:, 0] * sol.p[:, 1] - sol.q[:, 1] * sol.p[:, 0]
    assert np.max(np.abs(lz - lz0 * np.exp(-eps * sol.t / mass))) <= 1e-12 * abs(lz0)


# The double pendulum: two rods, masses m1 at (x1, y1) and m2 at (x2, y2), D = M.
M1, M2, L1, L2, EPS2 = 1.0, 0.7, 1.0, 0.8, 0.15


def double_pendulum(eps=EPS2):
    return raydamp.System(["x1", "y1", "x2", "y2"], "g*(m1*y1 + m2*y2)",
                          parameters={"g": G, "m1": M1, "m2": M2, "a": L1, "b": L2}, mass=[M1, M1, M2, M2],
                          damping={"scalar": 1.0}, eps=eps,
                          constraints=["x1^2 + y1^2 - a^2", "(x2 - x1)^2 + (y2 - y1)^2 - b^2"])


def joint_angles(t_end, state0, eps=EPS2):
    """The same pendulum in joint angles (from the downward vertical), with the Rayleigh function eps T:
    M(th) th'' = f(th, th') - eps M(th) th'."""
    def rhs(t, y):
        a, b, wa, wb = y
        c, s = math.cos(a - b), math.sin(a - b)
        mass = np.array([[(M1 + M2) * L1**2, M2 * L1 * L2 * c], [M2 * L1 * L2 * c, M2 * L2**2]])
        f = np.array([-M2 * L1 * L2 * s * wb**2 - (M1 + M2) * G * L1 * math.sin(a),
                      M2 * L1 * L2 * s * wa**2 - M2 * G * L2 * math.sin(b)])
        acc = np.linalg.solve(mass, f) - eps * np.array([wa, wb])
        return [wa, wb, acc[0], acc[1]]
    return solve_ivp(rhs, (0, t_end), state0, method="DOP853", rtol=1e-13, atol=1e-14).y[:, -1]


def cartesian(state):
    a, b, wa, wb = state
    x1, y1 = L1 * math.sin(a), -L1 * math.cos(a)
    x2, y2 = x1 + L2 * math.sin(b), y1 - L2 * math.cos(b)
    v1 = np.array([L1 * math.cos(a) * wa, L1 * math.sin(a) * wa])
    v2 = v1 + np.array([L2 * math.cos(b) * wb, L2 * math.sin(b) * wb])
    return np.array([x1, y1, x2, y2]), np.concatenate([M1 * v1, M2 * v2])


def test_double_pendulum_matches_the_joint_angle_equations_to_order_two():
    state0 = [1.2, -0.5, 0.3, 1.1]
    t_end = 1.5
    exact_q, _ = cartesian(joint_angles(t_end, state0))
    q0, p0 = cartesian(state0)
    hs = [0.02, 0.01, 0.005]
    errors = []
    for h in hs:
        sol = raydamp.integrate(double_pendulum(), q0, p0, method="3s", h=h, t_end=t_end, save_every=10_000)
        assert sol.status == "completed", sol.message
        errors.append(float(np.max(np.abs(sol.q[-1] - exact_q))))
    assert 1.8 <= fitted_slope(hs, errors) <= 2.4, errors


def test_double_pendulum_energy_balance_is_second_order():
    state0 = [1.2, -0.5, 0.3, 1.1]
    q0, p0 = cartesian(state0)
    hs = [0.02, 0.01, 0.005]
    balance = []
    for h in hs:
        sol = raydamp.integrate(double_pendulum(), q0, p0, method="3s", h=h, t_end=3.0, save_every=1, work=True)
        balance.append(float(np.max(np.abs(sol.energy_balance))))
    assert 1.8 <= fitted_slope(hs, balance) <= 2.4, balance
    assert balance[-1] <= 1e-3 * abs(sol.energy[0])


def test_the_floor_of_a_constrained_step_is_timed_from_a_state_on_the_constraints():
    # benchmarks/bench_constraints.py's floor: a time, finite and positive, from a state on the constraints;
    # a state of the wrong size is refused by name (no time is asserted)
    length = 0.8
    q0, p0 = pendulum_start(length)
    model = pendulum(length)._core_model
    ns = model.least_constraint_work_ns(q0, p0, 0.01, 1000)
    assert math.isfinite(ns) and ns > 0.0
    with pytest.raises(ValueError, match=r"^q, p: expected 2 entries"):
        model.least_constraint_work_ns(q0[:1], p0, 0.01, 10)


def test_json_form_round_trips():
    system = pendulum(tol=1e-9, project_initial=True)
    plain = system.to_dict()
    assert plain["constraints"] == ["x^2 + y^2 - l^2"]
    assert plain["constraint_tol"] == 1e-9 and plain["project_initial"] is True
    again = raydamp.System.from_dict(plain)
    assert again == system and again.constraints == ("x^2 + y^2 - l^2",)
    assert "constraints" not in raydamp.System(["x"], "x^2").to_dict()


# -- bad input -------------------------------------------------------------------------------------

def test_q0_off_the_constraint_is_refused_with_its_residual():
    q0, p0 = pendulum_start()
    with pytest.raises(ValueError, match=r"^q0: does not satisfy constraints\[0\] \('x\^2 \+ y\^2 - l\^2'\): g = "):
        raydamp.integrate(pendulum(), q0 * 1.01, p0, method="3s", h=0.01, n_steps=10)


def test_q0_and_p0_off_the_constraint_are_projected_when_asked():
    length = 0.8
    q0, p0 = pendulum_start(length)
    sol = raydamp.integrate(pendulum(length, project_initial=True), q0 * 1.01, p0 + 0.3 * q0, method="3s", h=0.01,
                            n_steps=10)
    assert abs(math.hypot(*sol.q[0]) - length) <= 1e-12 * length
    assert abs(sol.q[0] @ sol.p[0]) <= 1e-13 * length * np.linalg.norm(sol.p[0])


def test_p0_off_the_tangent_space_is_refused():
    q0, p0 = pendulum_start()
    with pytest.raises(ValueError, match=r"^p0: is not tangent to constraints\[0\]"):
        raydamp.integrate(pendulum(), q0, p0 + 0.1 * q0, method="3s", h=0.01, n_steps=10)


def test_dependent_constraints_at_q0_are_refused():
    # A sphere and the plane x = 1 touch at (1, 0, 0), where their gradients (2, 0, 0) and (1, 0, 0) are parallel.
    system = raydamp.System(["x", "y", "z"], "z", constraints=["x^2 + y^2 + z^2 - 1", "x - 1"])
    with pytest.raises(ValueError, match=r"^q0: the constraints' gradients are dependent"):
        raydamp.integrate(system, [1.0, 0.0, 0.0], [0.0, 0.0, 0.0], method="3s", h=0.01, n_steps=10)


@pytest.mark.parametrize("constraints,path,message", [
    (["x^2 + w^2 - 1"], r"constraints\[0\]", "unknown name"),
    ("x^2 + y^2 - 1", "constraints", "must be a list"),
    (["x^2 + y^2 - 1", "x - y"], "constraints", "leave no motion"),
    (["l^2"], r"constraints\[0\]", "uses no coordinate"),
])
def test_bad_constraints_name_their_path(constraints, path, message):
    with pytest.raises(ValueError, match=rf"^{path}: .*{message}"):
        raydamp.System(["x", "y"], "y", parameters={"l": 1.0}, constraints=constraints)


def test_bad_options_name_their_argument():
    with pytest.raises(ValueError, match=r"^constraint_tol: must be > 0"):
        raydamp.System(["x", "y"], "y", constraints=["x^2 + y^2 - 1"], constraint_tol=0.0)
    with pytest.raises(ValueError, match=r"^project_initial: must be true or false"):
        raydamp.System(["x", "y"], "y", constraints=["x^2 + y^2 - 1"], project_initial="yes")


@pytest.mark.parametrize("method", ["rksb", "rk4", "heun"])
def test_methods_that_drift_inside_a_runge_kutta_stage_are_refused(method):
    q0, p0 = pendulum_start()
    with pytest.raises(ValueError, match=rf"^method: '{method}' steps the kinetic energy as a free drift"):
        raydamp.integrate(pendulum(), q0, p0, method=method, h=0.01, n_steps=10)


def test_a_failed_constraint_solve_stops_the_run_naming_the_constraint_and_keeping_its_rows():
    # A drift of 3 rad-lengths per step: SHAKE's Newton from that far cannot reach the circle.
    length = 0.8
    q0, p0 = pendulum_start(length, omega=40.0)
    sol = raydamp.integrate(pendulum(length), q0, p0, method="3s", h=0.2, n_steps=50, save_every=1)
    assert sol.status == "constraint_failed", sol.message
    assert sol.message.startswith("constraints[0] did not converge at step")
    assert sol.steps == sol.failed_step - 1 == sol.t.size - 1
    assert np.isfinite(sol.q).all()


def test_the_summary_reports_the_residuals():
    q0, p0 = pendulum_start()
    sol = raydamp.integrate(pendulum(), q0, p0, method="3s", h=0.01, n_steps=500)
    summary = sol.summary()
    assert 0 <= summary["constraint_residual"] <= 1e-12
    assert 0 <= summary["constraint_velocity_residual"] <= 1e-13
    free = raydamp.integrate(raydamp.System(["x"], "x^2/2"), [1.0], [0.0], method="sv", h=0.1, n_steps=10)
    assert free.summary()["constraint_residual"] is None


def test_a_job_json_runs_a_constrained_system_and_names_a_bad_initial_state():
    from raydamp.jobs.build import job_arguments

    q0, p0 = pendulum_start()
    job = {"system": pendulum().to_dict(), "method": "baoab", "h": 0.01, "n_steps": 200,
           "initial_state": {"q": q0.tolist(), "p": p0.tolist()}}
    model, q, p, options = job_arguments(job)
    sol = raydamp.integrate(model, q, p, **options)
    direct = raydamp.integrate(pendulum(), q0, p0, method="baoab", h=0.01, n_steps=200)
    np.testing.assert_array_equal(sol.q, direct.q)
    job["initial_state"]["q"] = (1.01 * q0).tolist()
    model, q, p, options = job_arguments(job)
    with pytest.raises(ValueError, match=r"^q0: does not satisfy constraints\[0\]"):
        raydamp.integrate(model, q, p, **options)
    job["system"]["constraints"] = ["x^2 + y^2 - L^2"]
    with pytest.raises(ValueError, match=r"^system\.constraints\[0\]: .*unknown name"):
        job_arguments(job)


@pytest.mark.parametrize("temperature", [None, 0.3])
def test_ensemble_members_equal_single_runs_bit_for_bit(temperature):
    from test_ensemble import same

    system = double_pendulum()
    starts = [cartesian([1.2 - 0.1 * i, -0.5 + 0.2 * i, 0.3 * i, 1.1 - 0.3 * i]) for i in range(5)]
    q0, p0 = np.array([s[0] for s in starts]), np.array([s[1] for s in starts])
    options = dict(method="baoab", h=0.01, n_steps=300, save_every=50)
    if temperature is not None:
        options.update(temperature=temperature, seed=4)
    ens = raydamp.integrate_ensemble(system, q0, p0, threads=2, **options)
    assert ens.status == ("completed",) * 5
    for i in range(5):
        single = raydamp.integrate(system, q0[i], p0[i], **options, **({"stream": i} if temperature else {}))
        assert same(ens.member(i), single), i
        assert single.constraint_residual <= 1e-12
    assert len({float(e) for e in ens.energy_final}) == 5
    # a member off the constraints is refused by its index
    q0[3, 0] += 0.01
    with pytest.raises(ValueError, match=r"^q0\[3\]: does not satisfy constraints\[0\]"):
        raydamp.integrate_ensemble(system, q0, p0, **options)


def test_spherical_pendulum_at_a_temperature_samples_the_constrained_boltzmann_law():
    # V = m g z, z up: <cos theta> = 1/a - coth a, a = m g l / kT (the sphere's surface measure; with M = m I
    # the constraint adds no Fixman term).
    kT, a = 0.5, 2.0
    system = raydamp.System(["x", "y", "z"], "z", mass=1.0, damping={"scalar": 1.0}, eps=1.0,
                            constraints=["x^2 + y^2 + z^2 - 1"])
    sol = raydamp.integrate(system, [1.0, 0.0, 0.0], [0.0, 0.0, 0.0], method="baoab", h=0.05, t_end=20_000,
                            save_every=20, temperature=kT, seed=11)
    assert sol.status == "completed"
    cos = sol.q[sol.t > 20, 2]  # one saved point per time unit, about the damping time 1/eps: nearly independent
    exact = 1 / a - 1 / math.tanh(a)
    blocks = cos[: cos.size // 50 * 50].reshape(50, -1).mean(axis=1)  # 50 batch means: their spread is the SE
    standard_error = blocks.std(ddof=1) / math.sqrt(blocks.size)
    assert abs(cos.mean() - exact) <= 3 * standard_error, (cos.mean(), exact, standard_error)
    assert standard_error < 0.01


def test_the_compiled_form_carries_the_constraints():
    from raydamp.systems.system import compiled_elsewhere, load_compiled
    from raydamp.systems.system.compile import CompiledSystemFunctions, _cache

    system = double_pendulum()
    key, data = system.compiled_form()
    loaded = CompiledSystemFunctions.from_bytes(data)
    assert loaded.constraint_pattern == system._compiled.constraint_pattern == ((0, 0, 1, 1, 1, 1), (0, 1, 0, 1, 2, 3))
    x = np.array([0.3, -0.9, 0.8, -1.4])
    for name in ("constraint_values", "constraint_jacobian"):
        mine, theirs = (np.asarray(getattr(c, name)(x)) for c in (system._compiled, loaded))
        assert mine.tobytes() == theirs.tobytes(), name
    # Built in a process that must not compile: from the loaded functions, the same run.
    _cache.pop(key)
    load_compiled(key, data)
    with compiled_elsewhere():
        again = double_pendulum()
    q0, p0 = cartesian([1.2, -0.5, 0.3, 1.1])
    runs = [raydamp.integrate(s, q0, p0, method="2s", h=0.01, n_steps=100) for s in (system, again)]
    np.testing.assert_array_equal(runs[0].q, runs[1].q)


def one_angle_path(length, eps, theta, omega, times):
    """(theta, theta') at `times` from the one-angle equation (solve_ivp DOP853 at rtol 1e-13)."""
    sol = solve_ivp(lambda t, y: [y[1], -G / length * math.sin(y[0]) - eps * y[1]], (0, times[-1]), [theta, omega],
                    method="DOP853", rtol=1e-13, atol=1e-14, t_eval=times)
    return sol.y[0], sol.y[1]


@pytest.mark.parametrize("method", ["3s", "2s", "baoab"])
def test_multipliers_give_the_rods_tension_to_order_two(method):
    # The rod g = x^2 + y^2 - l^2 pulls with the force -G^T lambda = -2 lambda (x, y): its tension is 2 l lambda,
    # which for the damped pendulum (D = M: the damping force is tangent) is m (v^2 / l + g cos theta), theta from
    # the downward vertical.
    length, mass, eps, theta, omega, t_end = 0.8, 1.3, 0.3, 1.1, 0.4, 2.0
    q0, p0 = pendulum_start(length, mass, theta, omega)
    errors, hs = [], [0.04, 0.02, 0.01]
    for h in hs:
        sol = raydamp.integrate(pendulum(length, mass, eps), q0, p0, method=method, h=h, t_end=t_end,
                                save_every=round(0.2 / h))
        assert sol.status == "completed", sol.message
        assert sol.multipliers.shape == (sol.t.size, 1)
        th, w = one_angle_path(length, eps, theta, omega, sol.t)
        exact = mass * ((length * w) ** 2 / length + G * np.cos(th))
        errors.append(float(np.max(np.abs(2 * length * sol.multipliers[:, 0] - exact))))
    slope = fitted_slope(hs, errors)
    assert 1.8 <= slope <= 2.4, (errors, slope)
    assert errors[-1] <= 2e-3 * mass * G, errors  # measured 2.8e-4 (3s, 2s) to 4.2e-4 (baoab) m g at h = 0.01


def test_multipliers_are_saved_and_read_back(tmp_path):
    q0, p0 = pendulum_start()
    sol = raydamp.integrate(pendulum(), q0, p0, method="3s", h=0.01, n_steps=50, save_every=10)
    assert sol.multipliers.shape == (6, 1) and np.all(sol.multipliers > 0)
    ds = sol.to_xarray()
    assert ds["multipliers"].dims == ("time", "constraint")
    for suffix in (".nc", ".npz"):
        sol.save(tmp_path / f"run{suffix}")
        back = raydamp.load(tmp_path / f"run{suffix}")
        np.testing.assert_array_equal(back.multipliers, sol.multipliers)
    free = raydamp.integrate(raydamp.System(["x"], "x^2/2"), [1.0], [0.0], method="sv", h=0.1, n_steps=10)
    assert free.multipliers is None


def chain_system(links, order=None, length=0.1, mass=0.05, eps=0.5):
    names = [f"{c}{i}" for i in range(1, links + 1) for c in "xy"]
    rods = ["x1^2 + y1^2 - l^2"] + [f"(x{i} - x{i - 1})^2 + (y{i} - y{i - 1})^2 - l^2" for i in range(2, links + 1)]
    if order is not None:
        rods = [rods[i] for i in order]
    return raydamp.System(names, " + ".join(f"g*y{i}" for i in range(1, links + 1)), parameters={"g": G, "l": length},
                          mass=mass, damping={"scalar": 1.0}, eps=eps, constraints=rods)


def chain_start(links, length=0.1, angle=math.pi / 6):
    q0 = np.array([v for i in range(1, links + 1)
                   for v in (length * i * math.sin(angle), -length * i * math.cos(angle))])
    return q0, np.zeros(2 * links)


def test_the_constraints_order_does_not_change_the_solution():
    # Listed out of order, the chain's rods are put back in a band (reverse Cuthill-McKee) for the solve.
    links = 8
    q0, p0 = chain_start(links)
    shuffled = [5, 0, 7, 2, 4, 1, 6, 3]
    runs = [raydamp.integrate(chain_system(links, order), q0, p0, method="3s", h=1e-3, n_steps=500)
            for order in (None, shuffled)]
    for sol in runs:
        assert sol.status == "completed", sol.message
        assert sol.constraint_residual <= 1e-12
    np.testing.assert_allclose(runs[1].q, runs[0].q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(runs[1].multipliers, runs[0].multipliers[:, shuffled], rtol=1e-9)


def test_a_chain_at_a_long_step_converges_with_newtons_matrix():
    # 8 rods swinging down at h = 0.01: SHAKE's chord (the matrix frozen at the drift's start) gains less than 16x
    # an iteration in most drifts here (131 of 200), and the solve takes Newton's matrix G(q) M^-1 G(q0)^T
    # instead, whose pivots may be negative (it is not symmetric).
    links = 8
    q0, p0 = chain_start(links)
    sol = raydamp.integrate(chain_system(links), q0, p0, method="3s", h=0.01, t_end=1.0, save_every=10)
    assert sol.status == "completed", sol.message
    assert sol.constraint_residual <= 1e-12
    assert sol.constraint_velocity_residual <= 1e-12
    # the rods keep their length at every saved row
    xy = sol.q.reshape(sol.t.size, links, 2)
    rods = np.linalg.norm(np.diff(np.concatenate([np.zeros((sol.t.size, 1, 2)), xy], axis=1), axis=1), axis=2)
    assert np.max(np.abs(rods - 0.1)) <= 2e-12 * 0.1
