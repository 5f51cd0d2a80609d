#!/usr/bin/env python3
"""Work-precision diagram: max energy error against wall time on the elastic pendulum, for
Stormer-Verlet (order 2) and its compositions of orders 4, 6 and 8, beside SciPy's DOP853.

The elastic pendulum of paper section 6.2 undamped (eps = 0: sv is the damped splittings'
eps -> 0 limit, and H is then conserved, so max_t |H(t) - H(0)| measures each method's
error), from the paper's initial state over t in [0, T]. Each method runs at a range of step
sizes (DOP853 at a range of tolerances); each point is the best wall time of a few runs,
energies computed at every saved point (every step for the splittings; DOP853's own steps).

Writes a PNG (default work_precision.png) and prints the points; exits 0 (a benchmark).

    .venv/bin/python benchmarks/work_precision.py [--out FILE] [--t-end T]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import raydamp
from raydamp.models import ElasticPendulum

Q0 = np.array([0.0, 1.55884573, -0.6])
P0 = np.array([1.34164079, 0.0, 0.0])
METHODS = (("sv (order 2)", None, [0.05, 0.02, 0.01, 0.005, 0.002, 0.001]),
           ("sv + yoshida4 (order 4)", "yoshida4", [0.2, 0.1, 0.05, 0.025, 0.0125]),
           ("sv + kahan_li6 (order 6)", "kahan_li6", [0.4, 0.2, 0.1, 0.05, 0.025]),
           ("sv + kahan_li8 (order 8)", "kahan_li8", [0.5, 0.3, 0.2, 0.1, 0.05]))
TOLERANCES = [1e-4, 1e-6, 1e-8, 1e-10, 1e-12, 1e-13]


def timed(fn, rounds: int):
    best, out = float("inf"), None
    for _ in range(rounds):
        start = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - start)
    return best, out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default="work_precision.png")
    parser.add_argument("--t-end", type=float, default=100.0)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    model = ElasticPendulum(eps=0.0)
    h0 = model.energy(Q0, P0)
    curves: dict[str, list[tuple[float, float]]] = {}
    for label, composition, steps in METHODS:
        points = []
        for h in steps:
            wall, sol = timed(lambda composition=composition, h=h: raydamp.integrate(model, Q0, P0, method="sv",
                                                                                  composition=composition, h=h,
                                                                                  t_end=args.t_end),
                              args.rounds)
            points.append((wall, float(np.max(np.abs(sol.energy - h0)))))
        curves[label] = points

    from scipy.integrate import solve_ivp

    def field(_t, y):
        qdot, pdot = model.vector_field(y[:3], y[3:])
        return np.concatenate([qdot, pdot])

    points = []
    for tol in TOLERANCES:
        wall, sol = timed(lambda tol=tol: solve_ivp(field, (0.0, args.t_end), np.concatenate([Q0, P0]),
                                                    method="DOP853", rtol=tol, atol=tol), args.rounds)
        energies = [model.energy(y[:3], y[3:]) for y in sol.y.T]
        points.append((wall, float(np.max(np.abs(np.array(energies) - h0)))))
    curves["SciPy DOP853"] = points

    print(f"elastic pendulum, eps = 0, t in [0, {args.t_end:g}]: max |H(t) - H(0)| against wall time (best of "
          f"{args.rounds})")
    for label, pts in curves.items():
        print(f"  {label}")
        for wall, err in pts:
            print(f"    {wall * 1e3:10.3f} ms   {err:10.3e}")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 5))
    for label, pts in curves.items():
        wall, err = np.array(pts).T
        ax.loglog(wall, np.maximum(err, 1e-17), "o-", label=label)
    ax.set_xlabel("wall time [s]")
    ax.set_ylabel("max |H(t) - H(0)|")
    ax.set_title(f"Work-precision, elastic pendulum (eps = 0, T = {args.t_end:g})")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(args.out, dpi=120)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
