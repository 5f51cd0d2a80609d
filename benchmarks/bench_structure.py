#!/usr/bin/env python3
"""Sparse linear structures (raydamp.LinearStructure): time per step, and work against precision.

1. Time per step of 3s, 2s and rks-midpoint on a 2-D elastic plate (plane stress, linear
   triangles, tests/fe_plate.py) with n = 10^4 and 10^5 degrees of freedom, lumped and
   consistent mass, with the Chebyshev degree the exact damping flows use.
2. Work-precision on a plate small enough for its exact modal solution (n about 1700): the
   largest energy error max_t |H(t) - H_exact(t)| / H(0) against wall time, for 3s, 2s,
   rks-midpoint and a Newmark average-acceleration integrator (written here: NumPy and one
   scipy sparse LU factorisation per run), at mild damping and at stiff damping (beta K
   overdamping the high modes, h rho >> 1), where 3s and 2s lose their order and
   rks-midpoint and Newmark keep it. Fitted orders (slope of the state error at t_end
   against h) are printed beside each table. With --png PATH the tables are also plotted.
3. An ensemble of the implicit midpoint rule: 100 members (random initial states) of the
   n = 10^4 plate (consistent mass), integrate_ensemble on 1 and 2 threads (one factorisation
   shared by every member) beside 100 single raydamp.integrate calls (one each), same process,
   interleaved; the members are checked equal to the single runs bit for bit.

4. Small structures (issue 47): ns per step of a 2-DOF LinearStructure beside the same system written
   as a raydamp.System (3s; target <= 1.5x), and of the 10-storey shear frame of ground_motion_frame.py
   with 3s (target <= 150 ns), each also on the sparse path the structure took before (dense_limit 0:
   sparse products, Chebyshev damping flows), same process, interleaved, best of several rounds.
5. A response spectrum as one ensemble: 100 SDOF oscillators (periods 0.05 to 5 s, 5% damping) under a
   30 s record at h = dt = 0.01 s, integrate_ensemble with per-member K_scale and alpha (target <= 50 ms),
   beside the same members as single integrate calls; members checked equal to their single runs.

It prints figures and exits 0 whatever they are (a benchmark, not a test).

    .venv/bin/python benchmarks/bench_structure.py            # a few minutes on 2 cores
    .venv/bin/python benchmarks/bench_structure.py --quick    # n = 10^4 only, fewer points
    .venv/bin/python benchmarks/bench_structure.py --sections 3   # the ensemble alone (a minute)
    .venv/bin/python benchmarks/bench_structure.py --sections 4,5 # small structures (about ten seconds)
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np
import scipy.linalg
import scipy.sparse.linalg as sla

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests"))
from fe_plate import plate  # noqa: E402

import raydamp  # noqa: E402

METHODS = [("3s", None), ("2s", None), ("rks", "midpoint")]


# -- 1. time per step -------------------------------------------------------------------------------

def time_per_step(sizes: list[tuple[int, int]], steps: int) -> None:
    print("1. Time per step on the clamped plate (zeta = 2% at omega_1 and omega_6; h = 1 / omega_max)")
    print(f"{'n':>8} {'mass':>10} {'nnz(K)':>9} {'build s':>8} {'h rho':>7} {'deg damp':>8} {'deg kick':>8} "
          f"{'3s ms':>8} {'2s ms':>8} {'rks-mid ms':>10}")
    for nx, ny in sizes:
        pl = plate(nx, ny)
        lumped = raydamp.LinearStructure(pl.M_lumped, pl.K)
        omega_max = np.sqrt(lumped.spectral_bound / 1.05)  # noqa: F841 - kept: builds and bounds the lumped plate
        w = sla.eigsh(pl.K, k=6, M=pl.M_lumped, sigma=0.0, which="LM", return_eigenvectors=False)
        omega = np.sqrt(np.sort(w))
        alpha, beta = raydamp.rayleigh_coefficients(omega[0], omega[5], 0.02, 0.02)
        rng = np.random.default_rng(0)
        q0 = 1e-3 * rng.standard_normal(pl.n)
        for kind, M in (("lumped", pl.M_lumped), ("consistent", pl.M)):
            start = time.perf_counter()
            s = raydamp.LinearStructure(M, pl.K, alpha=alpha, beta=beta)
            build = time.perf_counter() - start
            h = 1.0 / np.sqrt(s.spectral_bound)
            cells = []
            for method, tableau in METHODS:
                n_steps = steps if kind == "lumped" else max(3, steps // 5)
                sol = raydamp.integrate(s, q0, np.zeros(pl.n), method=method, tableau=tableau, h=h,
                                        n_steps=n_steps, save_every=10 ** 9)
                cells.append(sol.wall_time / n_steps * 1e3)
            # 3s runs damp over h (merged halves) and h/2; 2s kick+damp over h.
            deg_damp = s.chebyshev_degrees(h)[0]
            deg_kick = s.chebyshev_degrees(h)[1]
            print(f"{pl.n:>8} {kind:>10} {pl.K.nnz:>9} {build:>8.2f} {h * s.damping_rate_bound:>7.2f} "
                  f"{deg_damp:>8} {deg_kick:>8} {cells[0]:>8.2f} {cells[1]:>8.2f} {cells[2]:>10.2f}")
    print("   (3s: one gradient + one Chebyshev flow per step; 2s: two Chebyshev sums; rks-midpoint: one "
          "sparse Cholesky solve of M + (h/2) C per step; a consistent M adds one M solve per Chebyshev degree)")


# -- 2. work against precision ----------------------------------------------------------------------

class Modal:
    """The exact solution of M q'' + C q' + K q = 0 (C = alpha M + beta K) by its full modal decomposition."""

    def __init__(self, M, K, alpha, beta):
        w, self.phi = scipy.linalg.eigh(K.toarray(), M.toarray())
        self.omega = np.sqrt(np.maximum(w, 0.0))
        self.c = alpha + beta * w
        self.M, self.K = M, K

    def modal_coordinates(self, q0, p0):
        a = self.phi.T @ (self.M @ q0)
        b = self.phi.T @ p0          # Phi^T M qdot = Phi^T p
        return a, b

    def at(self, a, b, t):
        """(q, qdot) at time t: over-, critically and under-damped modes by one complex formula."""
        c, w2 = self.c, self.omega ** 2
        disc = np.sqrt((c ** 2 / 4 - w2).astype(complex))
        r1, r2 = -c / 2 + disc, -c / 2 - disc
        same = np.abs(r1 - r2) < 1e-9 * np.maximum(1.0, np.abs(r1))
        d = np.where(same, 1.0, r1 - r2)
        e1, e2 = np.exp(r1 * t), np.exp(r2 * t)
        # eta = A e^{r1 t} + B e^{r2 t} with A + B = a, r1 A + r2 B = b; repeated root: (a + (b - r a) t) e^{r t}
        A = (b - r2 * a) / d
        B = a - A
        eta = np.where(same, (a + (b - r1 * a) * t) * e1, A * e1 + B * e2).real
        deta = np.where(same, ((b - r1 * a) + r1 * (a + (b - r1 * a) * t)) * e1, r1 * A * e1 + r2 * B * e2).real
        return self.phi @ eta, self.phi @ deta

    def energy(self, q, qdot):
        return 0.5 * qdot @ (self.M @ qdot) + 0.5 * q @ (self.K @ q)


def newmark(M, K, alpha, beta, q0, v0, h, n_steps, save_every):
    """Newmark average acceleration (gamma = 1/2, beta_N = 1/4): unconditionally stable, order 2, implicit;
    K_eff = K + (2/h) C + (4/h^2) M factorised once (scipy splu). Returns saved (t, q, v)."""
    C = alpha * M + beta * K
    solve = sla.splu((K + (2.0 / h) * C + (4.0 / h ** 2) * M).tocsc()).solve
    q, v = q0.copy(), v0.copy()
    a = sla.splu(M.tocsc()).solve(-(C @ v) - K @ q)
    ts, qs, vs = [0.0], [q.copy()], [v.copy()]
    for k in range(1, n_steps + 1):
        rhs = M @ ((4.0 / h ** 2) * q + (4.0 / h) * v + a) + C @ ((2.0 / h) * q + v)
        q_new = solve(rhs)
        a_new = (4.0 / h ** 2) * (q_new - q) - (4.0 / h) * v - a
        v = v + 0.5 * h * (a + a_new)
        q, a = q_new, a_new
        if k % save_every == 0 or k == n_steps:
            ts.append(k * h)
            qs.append(q.copy())
            vs.append(v.copy())
    return np.array(ts), np.array(qs), np.array(vs)


def work_precision(nx: int, ny: int, t_end: float, factors: list[int], png: str | None) -> None:
    pl = plate(nx, ny)
    M, K = pl.M, pl.K
    start = time.perf_counter()
    undamped = raydamp.LinearStructure(M, K)
    omega_max = np.sqrt(undamped.spectral_bound / 1.05)
    w_low = np.sort(sla.eigsh(K, k=6, M=M, sigma=0.0, which="LM", return_eigenvectors=False))
    omega1, omega6 = np.sqrt(w_low[0]), np.sqrt(w_low[5])
    settings = {
        "mild": raydamp.rayleigh_coefficients(omega1, omega6, 0.02, 0.02),
        # stiff: stiffness-proportional only, damping ratio beta omega / 2 = 20 at omega_max (h rho = 40 at
        # h = 1/omega_max)
        "stiff": (0.0, 40.0 / omega_max),
    }
    # A released tip load: every mode excited, the low ones most.
    f = np.zeros(pl.n)
    f[pl.tip] = -1e-3
    q0 = sla.spsolve(K.tocsc(), f)
    rng = np.random.default_rng(1)
    q0 = q0 + 1e-2 * np.linalg.norm(q0) / np.sqrt(pl.n) * rng.standard_normal(pl.n)  # and some of every mode
    p0 = np.zeros(pl.n)
    h0 = 1.0 / omega_max
    print(f"\n2. Work-precision: plate n = {pl.n} (consistent M), t_end = {t_end}, released tip load plus noise, "
          f"h = h0 / k with h0 = 1 / omega_max = {h0:.3g}; error = max_t |H - H_exact| / H(0) and "
          f"|q(t_end) - q_exact| / |q(t_end)|; exact modal solution set up in {time.perf_counter() - start:.1f} s")
    results = {}
    for label, (alpha, beta) in settings.items():
        s = raydamp.LinearStructure(M, K, alpha=alpha, beta=beta)
        modal = Modal(M, K, alpha, beta)
        a, b = modal.modal_coordinates(q0, p0)
        H0 = modal.energy(q0, np.zeros(pl.n))
        print(f"\n  {label}: alpha = {alpha:.3g}, beta = {beta:.3g}, rho = alpha + beta omega_max^2 = "
              f"{alpha + beta * omega_max ** 2:.3g}")
        print(f"  {'method':>12} {'k':>4} {'h rho':>8} {'deg':>5} {'seconds':>9} {'energy err':>11} {'state err':>10}")
        for method, tableau in METHODS + [("newmark", None)]:
            name = "rks-midpoint" if tableau else method
            rows = []
            for k in factors:
                h = h0 / k
                n_steps = int(round(t_end / h))
                h = t_end / n_steps
                save_every = max(1, n_steps // 50)
                if method == "newmark":
                    start = time.perf_counter()
                    t, q, v = newmark(M, K, alpha, beta, q0, p0, h, n_steps, save_every)
                    seconds = time.perf_counter() - start
                    deg = "-"
                else:
                    sol = raydamp.integrate(s, q0, p0, method=method, tableau=tableau, h=h, n_steps=n_steps,
                                            save_every=save_every)
                    seconds = sol.wall_time
                    t, q, energy_num = sol.t, sol.q, sol.energy
                    # the flow a step runs most: 3s's merged damp over h, 2s's kick+damp over h
                    deg = {"3s": s.chebyshev_degrees(h)[0], "2s": s.chebyshev_degrees(h)[1]}.get(method, "-")
                if method == "newmark":
                    energy_num = np.array([modal.energy(qq, vv) for qq, vv in zip(q, v)])
                exact = [modal.at(a, b, tt) for tt in t]
                energy_exact = np.array([modal.energy(qq, vv) for qq, vv in exact])
                err_energy = float(np.max(np.abs(energy_num - energy_exact)) / H0)
                q_end = exact[-1][0]
                err_state = float(np.linalg.norm(q[-1] - q_end) / np.linalg.norm(q_end))
                rows.append((k, h, seconds, err_energy, err_state))
                print(f"  {name:>12} {k:>4} {h * (alpha + beta * omega_max ** 2):>8.3g} {deg!s:>5} {seconds:>9.3f} "
                      f"{err_energy:>11.3e} {err_state:>10.3e}")
            hs = np.array([r[1] for r in rows])
            es = np.array([r[4] for r in rows])
            slope = np.polyfit(np.log(hs), np.log(es), 1)[0]
            print(f"  {name:>12} fitted order (state error against h): {slope:.2f}")
            results[(label, name)] = rows
    if png:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(1, 2, figsize=(11, 4.5), constrained_layout=True)
        for ax, label in zip(axes, settings):
            for (lab, name), rows in results.items():
                if lab != label:
                    continue
                ax.loglog([r[2] for r in rows], [r[3] for r in rows], "o-", label=name)
            ax.set_xlabel("wall time (s)")
            ax.set_ylabel("max |H - H_exact| / H(0)")
            ax.set_title(f"plate n = {pl.n}, {label} Rayleigh damping")
            ax.legend()
        fig.savefig(png, dpi=120)
        print(f"\n  work-precision plot written to {png}")


# -- 3. an ensemble of the implicit midpoint rule -----------------------------------------------------

def implicit_ensemble(nx: int, ny: int, members: int, steps: int, rounds: int) -> None:
    pl = plate(nx, ny)
    w = np.sqrt(np.sort(sla.eigsh(pl.K, k=3, M=pl.M, sigma=0.0, which="LM", return_eigenvectors=False)))
    alpha, beta = raydamp.rayleigh_coefficients(w[0], w[2], 0.02, 0.02)
    s = raydamp.LinearStructure(pl.M, pl.K, alpha=alpha, beta=beta)
    rng = np.random.default_rng(3)
    q0, p0 = 1e-3 * rng.standard_normal((members, pl.n)), np.zeros((members, pl.n))
    h = 10.0 / np.sqrt(s.spectral_bound)     # h omega_max about 10
    options = {"method": "midpoint", "h": h, "n_steps": steps, "save_every": steps}

    def ensemble(threads: int):
        return raydamp.integrate_ensemble(s, q0, p0, threads=threads, **options)

    def singles():
        return [raydamp.integrate(s, q0[i], p0[i], **options) for i in range(members)]

    print(f"\n3. Ensemble of midpoint: {members} members of the plate n = {pl.n} (consistent M, 2% damping in modes "
          f"1 and 3), {steps} steps each, h omega_max = 10")
    ens, ones = ensemble(2), singles()
    same = all(np.array_equal(ens.q[i], ones[i].q) and np.array_equal(ens.p[i], ones[i].p) for i in range(members))
    print(f"   every member equal to its single run bit for bit: {same}")
    best = {"ensemble, 1 thread": np.inf, "ensemble, 2 threads": np.inf, f"{members} integrate() calls": np.inf}
    for _ in range(rounds):
        for label, fn in zip(best, (lambda: ensemble(1), lambda: ensemble(2), singles)):
            start = time.perf_counter()
            fn()
            best[label] = min(best[label], time.perf_counter() - start)
    factor = raydamp.integrate(s, q0[0], p0[0], method="midpoint", h=h, n_steps=1).wall_time
    print(f"   (one run of 1 step, its factorisation and one solve: {factor:.3f} s)")
    print(f"   {'':<28}{'seconds':>9}{'us per member-step':>20}")
    for label, seconds in best.items():
        print(f"   {label:<28}{seconds:>9.3f}{1e6 * seconds / (members * steps):>20.1f}")
    single = best[f"{members} integrate() calls"]
    print(f"   single calls / ensemble: {single / best['ensemble, 1 thread']:.2f}x on 1 thread, "
          f"{single / best['ensemble, 2 threads']:.2f}x on 2 threads (best of {rounds})")


# -- 4. small structures ------------------------------------------------------------------------------

SMALL_RATIO_TARGET = 1.5
FRAME_NS_TARGET = 150.0
SPECTRUM_MS_TARGET = 50.0


def _sparse_path(build):
    """build() on the sparse path (dense_limit 0): what every structure ran before issue 47."""
    from raydamp.systems import structure

    saved = structure._DENSE_LIMIT
    structure._DENSE_LIMIT = 0
    try:
        return build()
    finally:
        structure._DENSE_LIMIT = saved


def _ns_per_step(model, q0, steps: int) -> tuple[float, float]:
    """(wall ns, CPU ns) per step: the step loop runs on the calling thread, so its CPU time is what a
    quiet machine's wall time would be, where a loaded one (other builds) stretches the wall time."""
    cpu = time.thread_time()
    sol = raydamp.integrate(model, q0, np.zeros(len(q0)), method="3s", h=1e-3, n_steps=steps, save_every=steps)
    cpu = time.thread_time() - cpu
    assert sol.success, sol.message
    return sol.wall_time / steps * 1e9, cpu / steps * 1e9


def small_structures(steps: int, rounds: int) -> None:
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from ground_motion_frame import frame

    # 2 DOF: two storeys, m = (1, 1.5), k = (40, 25), 5% Rayleigh damping in both modes.
    M2 = np.diag([1.0, 1.5])
    K2 = np.array([[65.0, -25.0], [-25.0, 25.0]])
    w = np.sqrt(np.sort(scipy.linalg.eigh(K2, M2, eigvals_only=True)))
    a2, b2 = raydamp.rayleigh_coefficients(w[0], w[1], 0.05, 0.05)
    C2 = a2 * M2 + b2 * K2
    cases = {
        "2-DOF LinearStructure": lambda: raydamp.LinearStructure(M2, K2, alpha=a2, beta=b2),
        "2-DOF System": lambda: raydamp.System(
            coordinates=["x1", "x2"], potential="65/2*x1^2 - 25*x1*x2 + 25/2*x2^2", mass=[1.0, 1.5],
            damping={"matrix": C2.tolist()}, eps=1.0),
    }
    Mf, Kf, af, bf, _ = frame()
    cases["10-DOF frame"] = lambda: raydamp.LinearStructure(Mf, Kf, alpha=af, beta=bf)
    models = {name: build() for name, build in cases.items()}
    models["2-DOF LinearStructure, sparse path"] = _sparse_path(cases["2-DOF LinearStructure"])
    models["10-DOF frame, sparse path"] = _sparse_path(cases["10-DOF frame"])
    starts = {name: (np.array([0.01, 0.02]) if name.startswith("2-DOF") else 1e-3 * np.linspace(0.1, 1.0, 10))
              for name in models}
    best = {name: np.inf for name in models}
    best_cpu = dict(best)
    for _ in range(rounds):
        for name, model in models.items():
            wall, cpu = _ns_per_step(model, starts[name], steps)
            best[name], best_cpu[name] = min(best[name], wall), min(best_cpu[name], cpu)
    # the same trajectory on either path (and the System: the same equations)
    ends = {name: raydamp.integrate(model, starts[name], np.zeros(len(starts[name])), method="3s", h=1e-3,
                                    n_steps=2000, save_every=2000).q[-1] for name, model in models.items()}
    print(f"\n4. Small structures, 3s at h = 1e-3, {steps} steps per run, best of {rounds} rounds (ns per step)")
    print(f"   {'model':<36}{'wall':>9}{'CPU':>9}")
    for name in models:
        print(f"   {name:<36}{best[name]:>9.1f}{best_cpu[name]:>9.1f}")
    best = best_cpu  # the figures below: CPU time, a quiet machine's wall time
    print("   (ratios and targets below are of the CPU time; load average now " + " ".join(
        f"{x:.1f}" for x in os.getloadavg()) + ")")
    ratio = best["2-DOF LinearStructure"] / best["2-DOF System"]
    print(f"   2-DOF LinearStructure / System: {ratio:.2f}x (target <= {SMALL_RATIO_TARGET}x); sparse path "
          f"{best['2-DOF LinearStructure, sparse path'] / best['2-DOF System']:.2f}x")
    print(f"   10-DOF frame: {best['10-DOF frame']:.0f} ns (target <= {FRAME_NS_TARGET:.0f} ns); sparse path "
          f"{best['10-DOF frame, sparse path']:.0f} ns")
    differences = {
        "2-DOF dense vs sparse path": ends["2-DOF LinearStructure"] - ends["2-DOF LinearStructure, sparse path"],
        "2-DOF LinearStructure vs System": ends["2-DOF LinearStructure"] - ends["2-DOF System"],
        "10-DOF dense vs sparse path": ends["10-DOF frame"] - ends["10-DOF frame, sparse path"],
    }
    for label, d in differences.items():
        print(f"   q after 2000 steps, {label}: max |difference| = {np.max(np.abs(d)):.2g}")


# -- 5. a response spectrum as one ensemble -------------------------------------------------------------

def spectrum(rounds: int, threads: int) -> None:
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from ground_motion_frame import record

    t, a_g = record(seconds=30.0, dt=0.01)
    dt = float(t[1] - t[0])
    periods = np.geomspace(0.05, 5.0, 100)
    omega = 2 * np.pi / periods
    zeta = 0.05
    sdof = raydamp.LinearStructure(np.eye(1), np.eye(1))   # m = 1, k = 1: member i has K_scale omega_i^2
    motion = raydamp.GroundMotion((t, a_g), [1.0])
    parameters = {"K_scale": omega ** 2, "alpha": 2 * zeta * omega}   # C = 2 zeta omega m
    options = {"method": "3s", "h": dt, "t_end": float(t[-1]), "save_every": 1, "load": motion}
    zeros = np.zeros((periods.size, 1))

    def ensemble():
        return raydamp.integrate_ensemble(sdof, zeros, zeros, parameters=parameters, threads=threads, **options)

    def singles():
        out = []
        for w in omega:
            s = raydamp.LinearStructure(np.eye(1), np.eye(1) * w ** 2, alpha=2 * zeta * w)
            out.append(raydamp.integrate(s, [0.0], [0.0], **options))
        return out

    ens, ones = ensemble(), singles()
    worst = max(float(np.max(np.abs(ens.q[i, :, 0] - ones[i].q[:, 0]))) for i in range(periods.size))
    peak = max(float(np.max(np.abs(o.q))) for o in ones)
    def peaks_only():  # the final state alone: what the step loop costs without the saved rows
        return raydamp.integrate_ensemble(sdof, zeros, zeros, parameters=parameters, threads=1,
                                          **{**options, "save_every": 10 ** 9})

    labels = {f"one ensemble call, {threads} threads (wall)": (ensemble, time.perf_counter),
              "one ensemble call, 1 thread (CPU)": (lambda: raydamp.integrate_ensemble(
                  sdof, zeros, zeros, parameters=parameters, threads=1, **options), time.process_time),
              "the same, saving the final state only (CPU)": (peaks_only, time.process_time),
              "100 integrate calls, a LinearStructure each (CPU)": (singles, time.process_time)}
    best = {label: np.inf for label in labels}
    for _ in range(rounds):
        for label, (fn, clock) in labels.items():
            start = clock()
            fn()
            best[label] = min(best[label], clock() - start)
    n_steps = int(round(t[-1] / dt))
    print(f"\n5. Response spectrum: 100 SDOF (T = 0.05 to 5 s, 5% damping) under a {t[-1]:.0f} s record, h = dt = "
          f"{dt}, {n_steps} steps each, 3s, every step saved; best of {rounds}; load average "
          + " ".join(f"{x:.1f}" for x in os.getloadavg()))
    for label, seconds in best.items():
        print(f"   {label:<52}{seconds * 1e3:>9.1f} ms")
    print(f"   target: one call <= {SPECTRUM_MS_TARGET:.0f} ms (CPU time on 1 thread: a quiet machine's wall time); "
          f"members against single runs: max |q difference| = {worst:.2g} (peak |q| {peak:.3g})")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="n = 10^4 only and fewer work-precision points")
    parser.add_argument("--png", default=None, help="also plot the work-precision tables to this PNG")
    parser.add_argument("--sections", default="1,2,3,4,5", help="which of the sections 1 to 5 to run (default all)")
    parser.add_argument("--threads", type=int, default=2, help="threads of section 5's ensemble (default 2)")
    args = parser.parse_args(argv)
    sections = set(args.sections.split(","))
    sizes = [(100, 50)] if args.quick else [(100, 50), (316, 158)]
    if "1" in sections:
        time_per_step(sizes, steps=20 if args.quick else 50)
    if "2" in sections:
        work_precision(28, 14, t_end=10.0, factors=[1, 2, 4] if args.quick else [1, 2, 4, 8, 16], png=args.png)
    if "3" in sections:
        implicit_ensemble(100, 50, members=100, steps=10 if args.quick else 20, rounds=2 if args.quick else 3)
    if "4" in sections:
        small_structures(steps=100_000 if args.quick else 1_000_000, rounds=3 if args.quick else 7)
    if "5" in sections:
        spectrum(rounds=3 if args.quick else 7, threads=args.threads)
    return 0


if __name__ == "__main__":
    sys.exit(main())
