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

It prints figures and exits 0 whatever they are (a benchmark, not a test).

    .venv/bin/python benchmarks/bench_structure.py            # a few minutes on 2 cores
    .venv/bin/python benchmarks/bench_structure.py --quick    # n = 10^4 only, fewer points
    .venv/bin/python benchmarks/bench_structure.py --sections 3   # the ensemble alone (a minute)
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
        omega_max = np.sqrt(lumped.spectral_bound / 1.05)
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


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="n = 10^4 only and fewer work-precision points")
    parser.add_argument("--png", default=None, help="also plot the work-precision tables to this PNG")
    parser.add_argument("--sections", default="1,2,3", help="which of the sections 1, 2, 3 to run (default all)")
    args = parser.parse_args(argv)
    sections = set(args.sections.split(","))
    sizes = [(100, 50)] if args.quick else [(100, 50), (316, 158)]
    if "1" in sections:
        time_per_step(sizes, steps=20 if args.quick else 50)
    if "2" in sections:
        work_precision(28, 14, t_end=10.0, factors=[1, 2, 4] if args.quick else [1, 2, 4, 8, 16], png=args.png)
    if "3" in sections:
        implicit_ensemble(100, 50, members=100, steps=10 if args.quick else 20, rounds=2 if args.quick else 3)
    return 0


if __name__ == "__main__":
    sys.exit(main())
