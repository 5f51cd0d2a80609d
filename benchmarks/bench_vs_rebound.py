#!/usr/bin/env python3
"""raydamp against REBOUND (WHFast, IAS15) with REBOUNDx drag on Kepler orbits with linear drag (issue 46).

The problem, the same in both tools: a test particle around a fixed central body,

    x'' = -mu x / |x|^3 - eps x',     mu = 1, eps = 1e-3, t in [0, 1100],

from q0 = (1, 0), p0 = (0, 1.1) (e = 0.21), and a second case at the pericentre of an e = 0.5 orbit
(q0 = (1, 0), p0 = (0, sqrt(1.5))). raydamp: Kepler(mu=1, mass=1, dim=2, particles=1, eps=1e-3), so
p = x' and H is the specific energy. REBOUND: G = 1, a central particle of mass 1 at rest at the origin
and the orbiting particle with mass 0 (a test particle: it pulls nothing, and REBOUNDx's drag, which is
momentum-conserving through the mass ratio m / M, puts no back-reaction on the central body, so the
central body stays at rest at the origin; no move_to_com, which would change nothing here anyway).
WHFast's Kepler drift then has mu = G (M + m) = 1 exactly.

The drag in REBOUNDx: the force "modify_orbits_forces" adds to a particle the acceleration
(v - v_ref) / (2 tau_a) (+ terms in tau_e, tau_inc, left unset), v_ref the velocity of the reference body;
with params["coordinates"] = PARTICLE and the central body marked "primary", that is the central body, at
rest. (The default, Jacobi, gives the same force on test particles, but its back-reaction loop, zero here,
is O(N^2) per step: with the RK4 operator, 21 us per particle per step at 1,000 particles against 2.5 us.)
So tau_a = -1 / (2 eps) gives a = -eps v exactly. The script checks this at start: it calls the force's own
update_accelerations on a few states and compares the acceleration it writes with -eps v (and 0 on the
central body); the raydamp 3s and WHFast + RK4-operator rows, the same Strang splitting, then agree in h
and error, and the ensemble's two tools agree state for state.

Variants (all in one process, case by case):
- WHFast + force: rebx.add_force(modify_orbits_forces): the drag enters WHFast's kick (drift h/2, kick h,
  drift h/2), evaluated with the velocities at the middle of the step before the kick (REBOUND's defaults:
  Jacobi coordinates, no corrector, safe_mode = 1). Its error falls only as h^1 (measured: the script
  prints the order); where the targets need more than 10 / 65536 per step, it prints how far it got and
  the steps and seconds the targets would take at that order, not a timed row.
- WHFast + RK4 operator: the same force, not added as a force but as the parameter "force" of the operator
  "integrate_force" with "integrator" = reboundx.integrators["rk4"], added with rebx.add_operator(op):
  for WHFast that is half a step of RK4 on the drag before each WHFast step and half a step after
  (a Strang splitting of Kepler and drag). A row with "rk2" in place of "rk4" too (cheaper, as accurate
  here: the splitting error dominates).
- IAS15 + force: the adaptive integrator (its epsilon scanned in place of h).
- raydamp: 3s, 2s, and 3s composed with yoshida4, suzuki4 and kahan_li6: exact Kepler drift (universal
  variables) and exact drag; and 2s as the near-integrable tables saba2, saba3 and sbab2 (error
  O(eps h^{2n} + eps^2 h^2): the drag and the interaction are the small part).

Reference: scipy's DOP853 at rtol = 1e-13, atol = 1e-16 on the ODE above, at the 110 save times
t = 10, 20, ..., 1100; the script prints how far IAS15 at epsilon = 1e-15 is from it, as a check. Errors:
the largest over the saves of |E - E_ref| / |E0| and |q - q_ref| / |q_ref|, E = |v|^2 / 2 - mu / |x|
computed the same way for every tool from the saved states. The orbit decays (a falls e^{-2 eps t}, by
9x; the period from 9 to about 0.33), so a fixed step is set by the last orbits and a phase error grows
fast: a relative error d in the drag rate gives a phase error of about 2e7 d eps (e = 0.21). That is why
WHFast + force is first order: its kick damps by (1 - eps h) in place of e^{-eps h}, d = eps h / 2, and
|dq|/|q| is about 10 h, where the operators (RK2, RK4) and raydamp's exact drag are second order.

For each variant the largest step h = 10 / n (n integer, so that every save falls on a step) on a
geometric grid (ratio about 2^(1/4)) with |E - E_ref| / |E0| <= 1e-6 and |q - q_ref| / |q_ref| <= 1e-4
is found by scanning n upward; the run at that h is timed (best of REPEATS runs with perf_counter; the
building of the simulation or system is not timed, the saving of the 110 states is, in both tools). A
step of a composition is all its stages (yoshida4: three 3s steps), so its ns/step is that of the whole.
The machine's load average is printed first: on a shared machine the seconds move by 2x from run to run.

The two-planet table: two planets of mass 1e-3 around the central body (heliocentric starts (1, 0) and
(0, 2)), drag eps = 2e-4 on the inner one as REBOUNDx's modify_orbits_forces applies it in its default
Jacobi coordinates (a = -eps u on the planet, u its velocity relative to the inner bodies' centre of mass, the
reaction on those bodies). raydamp.Planets (Jacobi coordinates, each planet's exact Kepler drift, the
interaction as the kick) with the drag rate that is on the inner planet's Jacobi momentum; REBOUND WHFast
(Jacobi) with the force, and with the RK4 operator. Reference: DOP853 at rtol 1e-13 on the inertial
three-body equations with those forces; the same two criteria, on the barycentric energy and on each planet's
heliocentric position.

The ensemble table: 1,000 decaying orbits (pericentre radii 0.5-2, e 0-0.7) as one raydamp.Kepler with
particles = 1000 beside one REBOUND simulation of 1,000 test particles (WHFast + force, and + RK4
operator), the same h: ns per particle per step, and how far apart the two tools' final states are.

    .venv/bin/pip install rebound reboundx            # optional: without them raydamp's rows alone
    # a reboundx built from source finds librebound only on the library path:
    export LD_LIBRARY_PATH=$(.venv/bin/python -c 'import rebound, os; print(os.path.dirname(rebound.__libpath__))')
    nice -n 5 .venv/bin/python benchmarks/bench_vs_rebound.py
    nice -n 5 .venv/bin/python benchmarks/bench_vs_rebound.py --quick   # first case only, 3 repeats
    nice -n 5 .venv/bin/python benchmarks/bench_vs_rebound.py --ensemble-only
    nice -n 5 .venv/bin/python benchmarks/bench_vs_rebound.py --planets-only
    nice -n 5 .venv/bin/python benchmarks/bench_vs_rebound.py --correctors-only   # two planets, no drag

It prints figures and exits 0 whatever they are.
"""

from __future__ import annotations

import argparse
import ctypes
import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

import raydamp
from raydamp import _core

try:
    import rebound
    import reboundx
except ImportError:  # pragma: no cover - optional
    rebound = reboundx = None

MU = 1.0
EPS = 1e-3
T_END = 1100.0
T_SAVE = 10.0
SAVES = round(T_END / T_SAVE)
E_TOL = 1e-6
Q_TOL = 1e-4
TIMES = T_SAVE * np.arange(1, SAVES + 1)
# steps per save, n: h = T_SAVE / n, a geometric grid of ratio about 2^(1/4)
GRID = [round(2 ** (k / 4)) for k in range(65)]  # to h = 10 / 65536


def specific_energy(x: np.ndarray, v: np.ndarray) -> np.ndarray:
    return 0.5 * np.sum(v * v, axis=-1) - MU / np.linalg.norm(x, axis=-1)


@dataclass
class Reference:
    x: np.ndarray  # (SAVES, 2)
    v: np.ndarray
    energy: np.ndarray
    e0: float


def reference(q0: np.ndarray, p0: np.ndarray) -> Reference:
    def rhs(_t, y):  # in floats: a tenth of the cost of numpy on four numbers
        x, y_, vx, vy = y.tolist()
        k = MU / (x * x + y_ * y_) ** 1.5
        return np.array([vx, vy, -k * x - EPS * vx, -k * y_ - EPS * vy])

    sol = solve_ivp(rhs, (0.0, T_END), np.concatenate([q0, p0]), method="DOP853", rtol=1e-13, atol=1e-16,
                    t_eval=TIMES)
    if not sol.success:
        raise RuntimeError(f"reference: DOP853 failed: {sol.message}")
    x, v = sol.y[:2].T, sol.y[2:].T
    return Reference(x, v, specific_energy(x, v), float(specific_energy(q0, p0)))


def errors(ref: Reference, x: np.ndarray, v: np.ndarray) -> tuple[float, float]:
    if x.shape != ref.x.shape or not (np.all(np.isfinite(x)) and np.all(np.isfinite(v))):
        return math.inf, math.inf
    e = float(np.max(np.abs(specific_energy(x, v) - ref.energy)) / abs(ref.e0))
    q = float(np.max(np.linalg.norm(x - ref.x, axis=1) / np.linalg.norm(ref.x, axis=1)))
    return e, q


@dataclass
class Row:
    tool: str
    h: float | None  # None: adaptive
    steps: int
    e_err: float
    q_err: float
    seconds: float
    note: str = ""

    @property
    def ns_per_step(self) -> float:
        return 1e9 * self.seconds / self.steps


# A variant: given the steps per save n (or, for IAS15, an epsilon), builds its run (not timed) and returns
# a function that runs it (timed) and returns (x, v, steps) at the save times.
Runner = Callable[[float], Callable[[], tuple[np.ndarray, np.ndarray, int]]]


def best_time(build: Callable[[], Callable], repeats: int) -> tuple[float, tuple]:
    best, out = math.inf, None
    for _ in range(repeats):
        run = build()
        t0 = time.perf_counter()
        out = run()
        best = min(best, time.perf_counter() - t0)
    return best, out


def scan(name: str, runner: Runner, ref: Reference, repeats: int, grid=GRID, h_of=lambda n: T_SAVE / n,
         note_of=lambda _n: "", error_of=None) -> Row | None:
    """The first grid point (the largest h) meeting both targets, timed there: every fourth point (h halved)
    until one passes, then the three before it. If none passes, says how far the smallest h got."""
    tried: list[tuple[int, float, float, float, int]] = []  # (index, |dE|, |dq|, seconds of one run, steps)
    error_of = error_of or errors

    def passes(i: int) -> bool:
        run = runner(grid[i])
        t0 = time.perf_counter()
        x, v, steps = run()
        seconds = time.perf_counter() - t0
        e, q = error_of(ref, x, v)
        tried.append((i, e, q, seconds, steps))
        return e <= E_TOL and q <= Q_TOL

    hit = next((i for i in range(0, len(grid), 4) if passes(i)), None)
    if hit is None:
        _, e, q, seconds, steps = tried[-1]
        line = (f"  {name}: no h >= {h_of(grid[tried[-1][0]]):.3g} met the targets"
                f" (there |dE|/|E0| = {e:.2e}, |dq|/|q| = {q:.2e}, {1e9 * seconds / steps:.0f} ns/step)")
        if len(tried) >= 2 and all(math.isfinite(t) for t in (e, q, tried[-2][1], tried[-2][2])):
            _, e1, q1, _, _ = tried[-2]
            order = math.log2(q1 / q)  # the last two points are h and h / 2
            if order > 0.2:
                shrink = max((q / Q_TOL) ** (1 / order), (e / E_TOL) ** (1 / math.log2(e1 / e)) if e1 > e else 1.0)
                line += (f"; the error falls as h^{order:.2f}: the targets need about {shrink:.0f}x smaller h, "
                         f"{shrink * steps:.2e} steps, about {shrink * seconds:.0f} s")
        print(line)
        return None
    hit = next((i for i in range(max(0, hit - 3), hit) if passes(i)), hit)
    seconds, (x, v, steps) = best_time(lambda: runner(grid[hit]), repeats)
    e, q = error_of(ref, x, v)
    return Row(name, h_of(grid[hit]), steps, e, q, seconds, note_of(grid[hit]))


# ---------------------------------------------------------------------------------------------- raydamp
def raydamp_runner(q0, p0, method: str, composition: str | None) -> Runner:
    def build(n: int):
        k = raydamp.Kepler(mu=MU, mass=1.0, dim=2, particles=1, eps=EPS)
        h = T_SAVE / n

        def run():
            sol = raydamp.integrate(k, q0, p0, method=method, composition=composition, h=h, t_end=T_END,
                                    save_every=n)
            t = np.asarray(sol.t)
            rows = np.flatnonzero(t > 0.5 * T_SAVE)
            return np.asarray(sol.q)[rows], np.asarray(sol.p)[rows], SAVES * n

        return run

    return build


# ---------------------------------------------------------------------------------------------- REBOUND
def rebound_sim(q0, p0, integrator: str):
    sim = rebound.Simulation()
    sim.G = 1.0
    sim.integrator = integrator
    sim.add(m=MU, x=0.0, y=0.0, z=0.0, vx=0.0, vy=0.0, vz=0.0)
    sim.add(m=0.0, x=q0[0], y=q0[1], z=0.0, vx=p0[0], vy=p0[1], vz=0.0)
    return sim


def add_drag(rebx, drag, as_operator: str | None) -> None:
    """The drag as a force WHFast sees each step, or as an operator integrating it (RK2, RK4, ...)."""
    if as_operator is None:
        rebx.add_force(drag)
    else:
        op = rebx.load_operator("integrate_force")
        op.params["force"] = drag
        op.params["integrator"] = reboundx.integrators[as_operator]
        rebx.add_operator(op)


def attach_drag(sim, *, as_operator: str | None):
    """REBOUNDx drag a = -eps v on every particle but the central one: modify_orbits_forces with
    tau_a = -1 / (2 eps), as a force, or (as_operator = "rk4", ...) integrated by integrate_force."""
    rebx = reboundx.Extras(sim)
    drag = rebx.load_force("modify_orbits_forces")
    # relative to the central body (the same as the default, Jacobi, for test particles, whose interior
    # centre of mass is the central body; but Jacobi walks every inner particle to apply a back-reaction,
    # zero here: O(N^2) per step with 1,000 test particles)
    drag.params["coordinates"] = reboundx.coordinates["PARTICLE"]
    sim.particles[0].params["primary"] = 1
    add_drag(rebx, drag, as_operator)
    for p in sim.particles[1:]:
        p.params["tau_a"] = -1.0 / (2.0 * EPS)
    return rebx, drag


def check_drag_mapping() -> float:
    """The largest |a - (-eps v)| / (eps |v|) of the force's own update_accelerations on a few states (and
    the central body's |a|, which must be 0)."""
    worst = 0.0
    rng = np.random.default_rng(1)
    for _ in range(5):
        x, v = rng.normal(size=2) + np.array([1.5, 0.0]), rng.normal(size=2)
        sim = rebound_sim(x, v, "whfast")
        rebx, drag = attach_drag(sim, as_operator=None)
        for p in sim.particles:
            p.ax = p.ay = p.az = 0.0
        drag.update_accelerations(ctypes.byref(sim), ctypes.byref(drag), sim._particles, sim.N)
        a = np.array([sim.particles[1].ax, sim.particles[1].ay])
        a0 = np.array([sim.particles[0].ax, sim.particles[0].ay, sim.particles[0].az])
        worst = max(worst, float(np.linalg.norm(a + EPS * v) / (EPS * np.linalg.norm(v))),
                    float(np.linalg.norm(a0)))
        del rebx
    return worst


def whfast_runner(q0, p0, *, as_operator: str | None) -> Runner:
    def build(n: int):
        sim = rebound_sim(q0, p0, "whfast")
        sim.dt = T_SAVE / n
        rebx, _ = attach_drag(sim, as_operator=as_operator)
        x = np.empty((SAVES, 2))
        v = np.empty((SAVES, 2))

        def run():
            _keep = rebx
            particle = sim.particles[1]
            for i in range(SAVES):
                sim.steps(n)
                x[i] = particle.x, particle.y
                v[i] = particle.vx, particle.vy
            return x, v, SAVES * n

        return run

    return build


def ias15_runner(q0, p0) -> Runner:
    def build(epsilon: float):
        sim = rebound_sim(q0, p0, "ias15")
        sim.integrator.epsilon = epsilon
        rebx, _ = attach_drag(sim, as_operator=None)
        x = np.empty((SAVES, 2))
        v = np.empty((SAVES, 2))

        def run():
            _keep = rebx
            particle = sim.particles[1]
            for i, t in enumerate(TIMES):
                sim.integrate(t, exact_finish_time=1)
                x[i] = particle.x, particle.y
                v[i] = particle.vx, particle.vy
            return x, v, int(sim.steps_done)

        return run

    return build


# ---------------------------------------------------------------------------------------------- tables
def print_rows(rows: list[Row]) -> None:
    print(f"  {'tool / variant':<44} {'h':>9} {'steps':>9} {'|dE|/|E0|':>10} {'|dq|/|q|':>10} "
          f"{'seconds':>10} {'ns/step':>9}")
    for r in rows:
        h = "adaptive" if r.h is None else f"{r.h:.4g}"
        print(f"  {r.tool:<44} {h:>9} {r.steps:>9} {r.e_err:>10.2e} {r.q_err:>10.2e} {r.seconds:>10.3e} "
              f"{r.ns_per_step:>9.0f}{'  ' + r.note if r.note else ''}")


def single_orbit(label: str, q0, p0, repeats: int) -> None:
    print(f"\n== {label}: q0 = ({q0[0]:g}, {q0[1]:g}), p0 = ({p0[0]:g}, {p0[1]:.6g}), mu = {MU:g}, eps = {EPS:g}, "
          f"t_end = {T_END:g}, {SAVES} saves")
    t0 = time.perf_counter()
    ref = reference(q0, p0)
    print(f"  reference: DOP853 rtol 1e-13 ({time.perf_counter() - t0:.1f} s); E0 = {ref.e0:.6f}, "
          f"E(t_end) = {ref.energy[-1]:.6f}, |q(t_end)| = {np.linalg.norm(ref.x[-1]):.6f}")
    rows: list[Row] = []
    for method, comp in (("3s", None), ("2s", None), ("3s", "yoshida4"), ("3s", "suzuki4"), ("3s", "kahan_li6"),
                         ("2s", "saba2"), ("2s", "saba3"), ("2s", "sbab2")):
        name = f"raydamp {method}" + (f" + {comp}" if comp else "")
        row = scan(name, raydamp_runner(q0, p0, method, comp), ref, repeats)
        if row:
            rows.append(row)
    ours = min(rows, key=lambda r: r.seconds) if rows else None
    theirs: list[Row] = []
    if rebound is not None:
        for name, runner in (
            ("REBOUND WHFast + REBOUNDx force", whfast_runner(q0, p0, as_operator=None)),
            ("REBOUND WHFast + REBOUNDx RK4 operator", whfast_runner(q0, p0, as_operator="rk4")),
            ("REBOUND WHFast + REBOUNDx RK2 operator", whfast_runner(q0, p0, as_operator="rk2")),
        ):
            row = scan(name, runner, ref, repeats)
            if row:
                theirs.append(row)
        epsilons = [10.0 ** (-k / 4) for k in range(8, 61)]
        row = scan("REBOUND IAS15 + REBOUNDx force", ias15_runner(q0, p0), ref, repeats, grid=epsilons,
                   h_of=lambda _e: None, note_of=lambda e: f"epsilon = {e:.1e}")
        if row:
            theirs.append(row)
        x, v, _ = ias15_runner(q0, p0)(1e-15)()
        e, q = errors(ref, x, v)
        print(f"  check of the reference: IAS15 at epsilon 1e-15 is |dE|/|E0| = {e:.1e}, |dq|/|q| = {q:.1e} from it")
    print_rows(rows + theirs)
    if ours and theirs:
        whfast = [r for r in theirs if r.h is not None]
        shown = set()
        for against, pool in (("the fastest WHFast variant", whfast), ("the fastest REBOUND row", theirs)):
            best = min(pool, key=lambda r: r.seconds) if pool else None
            if best is not None and best.tool not in shown:
                shown.add(best.tool)
                print(f"  speed-up of raydamp's fastest ({ours.tool}, {ours.seconds:.3e} s) against {against} "
                      f"({best.tool.removeprefix('REBOUND ')}, {best.seconds:.3e} s): "
                      f"{best.seconds / ours.seconds:.1f}x")
    print("  cost per step: " + "; ".join(f"{r.tool.removeprefix('REBOUND ')} {r.ns_per_step:.0f} ns"
                                          for r in rows + theirs))


# ---------------------------------------------------------------------------------------------- two planets
# Two Jupiter-mass planets, drag on the inner one (issue 46's "two planets with drag on one"). REBOUNDx's
# modify_orbits_forces in its default Jacobi coordinates gives a planet the force -eps m'_i u (u its velocity
# relative to the inner bodies' centre of mass, here the central body's; m'_i = m_i eta_{i-1} / eta_i its
# reduced mass, eta_i the mass of the central body and planets 0..i) and the inner bodies the reaction, spread
# by mass, so that u decays at eps: raydamp.Planets' drag eps_i on that planet's Jacobi momentum. The script
# checks the force's mapping at start.
# The inner planet's orbit shrinks from a = 1 to about 0.64 (e^{-2 eps t}), away from the outer one's (a = 2):
# drag on the outer one would bring it in through resonances with the inner one, or onto it.
PLANET_MASSES = (1e-3, 1e-3)
PLANET_EPS = 2e-4
PLANET_X = np.array([[1.0, 0.0], [0.0, 2.0]])
PLANET_V = np.array([[0.0, 1.0], [-0.72, 0.02]])


def bodies_energy(x: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The barycentric energy of the central body (mass MU) and the planets from heliocentric x, v
    (..., planets, 2), computed the same way for every tool."""
    m = np.array([MU, *PLANET_MASSES])
    shape = x.shape[:-2] + (1, 2)
    xb = np.concatenate([np.zeros(shape), x], axis=-2)
    vb = np.concatenate([np.zeros(shape), v], axis=-2)
    vb = vb - np.einsum("i,...ij->...j", m, vb)[..., None, :] / m.sum()
    energy = 0.5 * np.einsum("i,...i->...", m, np.sum(vb * vb, axis=-1))
    for a in range(len(m)):
        for b in range(a + 1, len(m)):
            energy = energy - m[a] * m[b] / np.linalg.norm(xb[..., b, :] - xb[..., a, :], axis=-1)
    return energy


def planets_reference(x0: np.ndarray, v0: np.ndarray, eps: float = PLANET_EPS) -> Reference:
    m = np.array([MU, *PLANET_MASSES])
    xb = np.vstack([np.zeros(2), x0])
    vb = np.vstack([np.zeros(2), v0])
    xb, vb = xb - m @ xb / m.sum(), vb - m @ vb / m.sum()

    def rhs(_t, y):
        x, v = y[:6].reshape(3, 2), y[6:].reshape(3, 2)
        a = np.zeros((3, 2))
        for i in range(3):
            for j in range(i + 1, 3):
                r = x[j] - x[i]
                k = 1.0 / (r @ r) ** 1.5
                a[i] += m[j] * k * r
                a[j] -= m[i] * k * r
        force = -eps * m[0] * m[1] / (m[0] + m[1]) * (v[1] - v[0])  # on the inner planet; its reaction
        a[1] += force / m[1]
        a[0] -= force / m[0]
        return np.concatenate([v.reshape(-1), a.reshape(-1)])

    sol = solve_ivp(rhs, (0.0, T_END), np.concatenate([xb.reshape(-1), vb.reshape(-1)]), method="DOP853",
                    rtol=1e-13, atol=1e-16, t_eval=TIMES)
    if not sol.success:
        raise RuntimeError(f"planets reference: DOP853 failed: {sol.message}")
    x = sol.y[:6].T.reshape(-1, 3, 2)
    v = sol.y[6:].T.reshape(-1, 3, 2)
    x, v = x[:, 1:] - x[:, :1], v[:, 1:] - v[:, :1]
    return Reference(x, v, bodies_energy(x, v), float(bodies_energy(x0, v0)))


def planet_errors(ref: Reference, x: np.ndarray, v: np.ndarray) -> tuple[float, float]:
    if x.shape != ref.x.shape or not (np.all(np.isfinite(x)) and np.all(np.isfinite(v))):
        return math.inf, math.inf
    e = float(np.max(np.abs(bodies_energy(x, v) - ref.energy)) / abs(ref.e0))
    q = float(np.max(np.linalg.norm(x - ref.x, axis=-1) / np.linalg.norm(ref.x, axis=-1)))
    return e, q


def raydamp_planets_runner(method: str, composition: str | None, eps: float = PLANET_EPS,
                           corrector: int | None = None) -> Runner:
    system = raydamp.Planets(list(PLANET_MASSES), central_mass=MU, eps=[eps, 0.0])
    q0, p0 = system.jacobi_state(PLANET_X, PLANET_V)

    def build(n: int):
        h = T_SAVE / n

        def run():
            sol = raydamp.integrate(system, q0, p0, method=method, composition=composition, h=h, t_end=T_END,
                                    save_every=n, corrector=corrector)
            rows = np.flatnonzero(np.asarray(sol.t) > 0.5 * T_SAVE)
            x, v = system.heliocentric(np.asarray(sol.q)[rows], np.asarray(sol.p)[rows])
            return x, v, SAVES * n

        return run

    return build


def rebound_planets(integrator: str):
    sim = rebound.Simulation()
    sim.G = 1.0
    sim.integrator = integrator
    sim.add(m=MU)
    for m, x, v in zip(PLANET_MASSES, PLANET_X, PLANET_V, strict=True):
        sim.add(m=m, x=x[0], y=x[1], vx=v[0], vy=v[1])
    sim.move_to_com()
    return sim


def attach_planet_drag(sim, *, as_operator: str | None):
    rebx = reboundx.Extras(sim)
    drag = rebx.load_force("modify_orbits_forces")  # Jacobi coordinates, REBOUNDx's default
    add_drag(rebx, drag, as_operator)
    sim.particles[1].params["tau_a"] = -1.0 / (2.0 * PLANET_EPS)
    return rebx, drag


def check_planet_drag_mapping() -> float:
    """|a - a_expected| / (eps |u|) for the inner planet, the central body's reaction and the outer planet
    (none), from the force's own update_accelerations."""
    sim = rebound_planets("whfast")
    rebx, drag = attach_planet_drag(sim, as_operator=None)
    for p in sim.particles:
        p.ax = p.ay = p.az = 0.0
    drag.update_accelerations(ctypes.byref(sim), ctypes.byref(drag), sim._particles, sim.N)
    m = np.array([p.m for p in sim.particles])
    v = np.array([[p.vx, p.vy] for p in sim.particles])
    a = np.array([[p.ax, p.ay] for p in sim.particles])
    u = v[1] - v[0]
    expected = PLANET_EPS / (m[0] + m[1]) * np.vstack([m[1] * u, -m[0] * u, np.zeros(2)])
    del rebx
    return float(np.max(np.linalg.norm(a - expected, axis=1)) / (PLANET_EPS * np.linalg.norm(u)))


def planets_run(sim, n: int, *, keep=None, synchronize: bool = False):
    """The timed run of a two-planet WHFast simulation: n steps per save, the planets' heliocentric x, v at each
    save (after synchronising, where the integrator is left unsynchronised); keep: what must outlive the build."""
    x = np.empty((SAVES, 2, 2))
    v = np.empty((SAVES, 2, 2))

    def run():
        _keep = keep
        ps = sim.particles
        for i in range(SAVES):
            sim.steps(n)
            if synchronize:
                sim.synchronize()
            star = ps[0]
            for k in (1, 2):
                x[i, k - 1] = ps[k].x - star.x, ps[k].y - star.y
                v[i, k - 1] = ps[k].vx - star.vx, ps[k].vy - star.vy
        return x, v, SAVES * n

    return run


def planets_whfast_runner(*, as_operator: str | None) -> Runner:
    def build(n: int):
        sim = rebound_planets("whfast")
        sim.dt = T_SAVE / n
        rebx, _ = attach_planet_drag(sim, as_operator=as_operator)
        return planets_run(sim, n, keep=rebx)

    return build


def print_speedup(rows: list[Row], theirs: list[Row]) -> None:
    """The table, and raydamp's fastest row against REBOUND's."""
    print_rows(rows + theirs)
    if rows and theirs:
        ours, best = min(rows, key=lambda r: r.seconds), min(theirs, key=lambda r: r.seconds)
        print(f"  speed-up of raydamp's fastest ({ours.tool}, {ours.seconds:.3e} s) against the fastest WHFast "
              f"variant ({best.tool.removeprefix('REBOUND ')}, {best.seconds:.3e} s): "
              f"{best.seconds / ours.seconds:.1f}x")


def two_planets(repeats: int) -> None:
    print(f"\n== two planets (masses {PLANET_MASSES[0]:g}, {PLANET_MASSES[1]:g}; a = 1, 2), drag eps = {PLANET_EPS:g} "
          f"on the inner one, t_end = {T_END:g}, {SAVES} saves")
    t0 = time.perf_counter()
    ref = planets_reference(PLANET_X, PLANET_V)
    print(f"  reference: DOP853 rtol 1e-13 on the inertial equations ({time.perf_counter() - t0:.1f} s); "
          f"E0 = {ref.e0:.8f}, E(t_end) = {ref.energy[-1]:.8f}")
    if rebound is not None:
        print(f"  drag mapping check: modify_orbits_forces (Jacobi) writes the expected accelerations to "
              f"{check_planet_drag_mapping():.1e} relative")
    rows: list[Row] = []
    for method, comp in (("3s", None), ("2s", None), ("3s", "yoshida4"), ("2s", "saba2"), ("2s", "saba3")):
        name = f"raydamp Planets {method}" + (f" + {comp}" if comp else "")
        row = scan(name, raydamp_planets_runner(method, comp), ref, repeats, error_of=planet_errors)
        if row:
            rows.append(row)
    theirs: list[Row] = []
    if rebound is not None:
        for name, runner in (("REBOUND WHFast + REBOUNDx force", planets_whfast_runner(as_operator=None)),
                             ("REBOUND WHFast + REBOUNDx RK4 operator", planets_whfast_runner(as_operator="rk4"))):
            row = scan(name, runner, ref, repeats, error_of=planet_errors)
            if row:
                theirs.append(row)
    print_speedup(rows, theirs)


# ------------------------------------------------------------------------------- two planets without drag
# The symplectic correctors' table: the same two planets with no drag, raydamp's leapfrog with and without its
# corrector (raydamp.run.correctors) and SABA, against WHFast with and without its own (correctors 11 and 17, the
# latter with the lazy implementer's kernel, REBOUND's "whckl"; in the mode REBOUND documents for correctors:
# safe_mode 0, keep_unsynchronized 1, synchronised at each save).
def planets_free_whfast_runner(corrector: int, kernel: str = "default") -> Runner:
    def build(n: int):
        sim = rebound_planets("whfast")
        sim.dt = T_SAVE / n
        sim.integrator.corrector = corrector
        sim.integrator.kernel = kernel
        sim.integrator.safe_mode = 0
        sim.integrator.keep_unsynchronized = 1
        return planets_run(sim, n, synchronize=True)

    return build


def two_free_planets(repeats: int) -> None:
    print(f"\n== two planets without drag (masses {PLANET_MASSES[0]:g}, {PLANET_MASSES[1]:g}; a = 1, 2), "
          f"t_end = {T_END:g}, {SAVES} saves: symplectic correctors")
    ref = planets_reference(PLANET_X, PLANET_V, eps=0.0)
    rows: list[Row] = []
    for method, comp, corrector in (("sv", None, None), ("sv", None, 4), ("sv", None, 6), ("sv", None, 10),
                                    ("2s", "saba2", None)):
        name = f"raydamp Planets {method}" + (f" + {comp}" if comp else "") + (
            f", corrector {corrector}" if corrector else "")
        row = scan(name, raydamp_planets_runner(method, comp, eps=0.0, corrector=corrector), ref, repeats,
                   error_of=planet_errors)
        if row:
            rows.append(row)
    theirs: list[Row] = []
    if rebound is not None:
        for corrector, kernel in ((0, "default"), (11, "default"), (17, "lazy")):
            name = f"REBOUND WHFast, corrector {corrector}" + (f", {kernel} kernel" if kernel != "default" else "")
            row = scan(name, planets_free_whfast_runner(corrector, kernel), ref, repeats, error_of=planet_errors)
            if row:
                theirs.append(row)
    print_speedup(rows, theirs)


# ---------------------------------------------------------------------------------------------- ensemble
# Earlier figures of the same rows, for the side by side: (method, one Kepler with the orbits as particles?) ->
# ns per member per step. Before the drift ran in SIMD lanes (flows/kepler_lanes.hpp; measured 2026-11-29
# 21:48, load 0.9, in the same hour as the lanes' 23.3 / 25.8 / 38.7 / 40.9 ns), and before short drifts were
# formed in double (flows/kepler.hpp, kShortReach; benchmarks/bench_kepler_drift.cpp times the drifts alone).
BEFORE_LANES = {("2s", True): "49.2 ns", ("2s", False): "51.4 ns", ("3s", True): "88.9 ns", ("3s", False): "91.1 ns"}
BEFORE_SHORT_STEPS = {("2s", True): "88 ns", ("2s", False): "101 ns", ("3s", True): "163 ns",
                      ("3s", False): "not recorded"}


def one_by_one(method: str, q0: np.ndarray, p0: np.ndarray, h: float, steps: int) -> dict:
    """integrate_ensemble as it ran before members were batched, each member its own run: through the core's
    door with two models of eps a rounding apart, alternating, so that no two neighbours share a batch."""
    models = [raydamp.Kepler(mu=MU, eps=e) for e in (EPS, EPS * (1 + 2**-50))]
    index = np.arange(len(q0)) % 2
    return _core.Planets.integrate_ensemble([m._core_model for m in models], index, [], np.zeros((len(q0), 0)),
                                            method, "", "", q0, p0, h, steps, h, steps, 1, None, None)


def ensemble(members: int, h: float, t_end: float, repeats: int) -> None:
    print(f"\n== ensemble: {members} decaying orbits (pericentre radii 0.5-2, e 0-0.7), eps = {EPS}, h = {h}")
    rng = np.random.default_rng(46)
    rp = rng.uniform(0.5, 2.0, members)
    e = rng.uniform(0.0, 0.7, members)
    q0 = np.zeros((members, 2))
    p0 = np.zeros((members, 2))
    q0[:, 0] = rp
    p0[:, 1] = np.sqrt(MU * (1.0 + e) / rp)
    q0, p0 = q0.reshape(-1), p0.reshape(-1)
    steps = round(t_end / h)

    # raydamp's two doors: one Kepler with the orbits as its particles, and integrate_ensemble over one-particle
    # members on one thread (which runs them as the particles of one model, in batches, and splits them back).
    # Wall seconds and the process's CPU seconds (on a loaded machine the second moves less).
    single = raydamp.Kepler(mu=MU, mass=1.0, dim=2, particles=1, eps=EPS)
    many = raydamp.Kepler(mu=MU, mass=1.0, dim=2, particles=members, eps=EPS)
    for method in ("3s", "2s"):
        for door, call in (
            (f"one Kepler(particles={members})",
             lambda method=method: raydamp.integrate(many, q0, p0, method=method, h=h, t_end=t_end, save_every=steps)),
            ("integrate_ensemble, threads=1",
             lambda method=method: raydamp.integrate_ensemble(single, q0.reshape(members, 2), p0.reshape(members, 2),
                                                              method=method, h=h, t_end=t_end, save_every=steps,
                                                              threads=1)),
            ("integrate_ensemble, each member its own run",
             lambda method=method: one_by_one(method, q0.reshape(members, 2), p0.reshape(members, 2), h, steps)),
        ):
            best, cpu = math.inf, math.inf
            for _ in range(repeats):
                w0, c0 = time.perf_counter(), time.process_time()
                call()
                best, cpu = min(best, time.perf_counter() - w0), min(cpu, time.process_time() - c0)
            per, per_cpu = 1e9 * best / (members * steps), 1e9 * cpu / (members * steps)
            particles = door.startswith("one")
            earlier = "" if door.endswith("own run") else (
                f"; with the scalar drift {BEFORE_LANES[method, particles]}; with every drift in long "
                f"double {BEFORE_SHORT_STEPS[method, particles]}")
            print(f"  raydamp {method}, {door}: {steps} steps in {best:.3e} s = {per:.1f} ns per member per step "
                  f"(CPU {per_cpu:.1f} ns{earlier})")
    if rebound is None:
        return
    for label, op in (("WHFast + REBOUNDx force", None), ("WHFast + REBOUNDx RK4 operator", "rk4")):
        r_steps = max(1, steps // 10)  # REBOUND is slower: a tenth of the run is enough for its cost

        def build_theirs(op=op, r_steps=r_steps):
            sim = rebound.Simulation()
            sim.G = 1.0
            sim.integrator = "whfast"
            sim.add(m=MU)
            for i in range(members):
                sim.add(m=0.0, x=q0[2 * i], y=q0[2 * i + 1], vx=p0[2 * i], vy=p0[2 * i + 1])
            sim.N_active = 1
            sim.dt = h
            rebx, _ = attach_drag(sim, as_operator=op)

            def run():
                _keep = rebx
                sim.steps(r_steps)
                return sim

            return run

        seconds, sim = best_time(build_theirs, max(1, repeats // 2))
        per = 1e9 * seconds / (members * r_steps)
        print(f"  REBOUND {label}, {members} test particles: {r_steps} steps in {seconds:.3e} s = {per:.1f} ns "
              "per particle per step")
    # the two tools integrate the same thing: raydamp at the REBOUND run's length, state against state
    k = raydamp.Kepler(mu=MU, mass=1.0, dim=2, particles=members, eps=EPS)
    sol = raydamp.integrate(k, q0, p0, method="3s", h=h, t_end=r_steps * h, save_every=r_steps)
    xs = np.array([[p.x, p.y] for p in sim.particles[1:]]).reshape(-1)
    print(f"  after {r_steps} steps, raydamp 3s and REBOUND WHFast + RK4 operator differ by at most "
          f"{np.max(np.abs(np.asarray(sol.q)[-1] - xs)):.1e} in position")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="the first case only, 3 repeats")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--no-ensemble", action="store_true", help="the single orbits only")
    parser.add_argument("--ensemble-only", action="store_true", help="the 1,000-orbit table only")
    parser.add_argument("--no-planets", action="store_true", help="without the two-planet table")
    parser.add_argument("--planets-only", action="store_true", help="the two-planet table only")
    parser.add_argument("--correctors-only", action="store_true",
                        help="the two planets without drag only: symplectic correctors")
    args = parser.parse_args()
    repeats = 3 if args.quick else args.repeats
    print(f"raydamp {raydamp.__version__}; "
          + (f"REBOUND {rebound.__version__}, REBOUNDx {reboundx.__version__}" if rebound else "REBOUND not installed")
          + f"; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    if rebound is not None:
        print(f"drag mapping check: modify_orbits_forces with tau_a = -1/(2 eps) writes a = -eps v to "
              f"{check_drag_mapping():.1e} relative (central body: a = 0)")
    if args.planets_only:
        two_planets(repeats)
        return
    if args.correctors_only:
        two_free_planets(repeats)
        return
    if not args.ensemble_only:
        single_orbit("e = 0.21 (issue 46's case)", np.array([1.0, 0.0]), np.array([0.0, 1.1]), repeats)
    if not (args.quick or args.ensemble_only):
        single_orbit("e = 0.5, at the pericentre", np.array([1.0, 0.0]), np.array([0.0, math.sqrt(1.5)]), repeats)
    if not args.ensemble_only and not args.no_planets:
        two_planets(repeats)
        if not args.quick:
            two_free_planets(repeats)
    if not args.no_ensemble:
        ensemble(1000, 0.01, 20.0, repeats)


if __name__ == "__main__":
    main()
