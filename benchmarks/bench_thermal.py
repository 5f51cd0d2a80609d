#!/usr/bin/env python3
"""The cost of thermal noise (issue 29): ns per member-step with and without a temperature, same run.

- the damped pendulum ensemble (10^4 members, 3s and baoab): noiseless members run as SIMD lanes
  of one step loop; with noise each member runs its own loop (the lanes' step has no noise yet), and
  each damping flow draws one normal number (Philox-4x32-10 blocks, computed 16 ahead, and a ziggurat;
  benchmarks/bench_normals.cpp times the stream alone);
- a 10^4-DOF LinearStructure with alpha M damping, lumped and consistent M (the noise is a root of M
  times n normals: sqrt of the diagonal, or the sparse Cholesky factor), and with beta K damping
  (psi(C M^-1) R xi: a sparse Cholesky factor of C and a Chebyshev series; ratio measured, no target);
- a 3-DOF System with Rayleigh damping D = a M + b K (a constant matrix: the OU flow's noise is one
  3x3 product) and the elastic pendulum (radial damping: one normal along q).
Target: with noise <= 2x the noiseless step. Interleaved repeats, medians; exits 0 whatever the figures.

    .venv/bin/python benchmarks/bench_thermal.py [--quick]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

import raydamp
from raydamp.models import DampedPendulum, ElasticPendulum


def timed(run) -> float:
    start = time.perf_counter()
    run()
    return time.perf_counter() - start


def row(label, runs: dict, work: int, repeats: int) -> None:
    times = {k: [] for k in runs}
    for _ in range(repeats):
        for k, run in runs.items():
            times[k].append(timed(run))
    cold = statistics.median(times["noiseless"])
    hot = statistics.median(times["kT = 0.5"])
    print(f"{label:<46} {1e9 * cold / work:10.1f} {1e9 * hot / work:10.1f} {hot / cold:8.2f}x")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    repeats = 3 if args.quick else 5
    scale = 0.2 if args.quick else 1.0
    print(f"{'ns per member-step':<46} {'noiseless':>10} {'kT = 0.5':>10} {'ratio':>9}")
    members, steps = 10_000, int(2000 * scale)
    q0 = np.full((members, 1), 0.5)
    p0 = np.zeros((members, 1))
    pendulum = DampedPendulum(eps=0.3)
    for method in ("3s", "baoab"):
        runs = {"noiseless": lambda m=method: raydamp.integrate_ensemble(
                    pendulum, q0, p0, method=m, h=0.05, n_steps=steps, save_every=steps),
                "kT = 0.5": lambda m=method: raydamp.integrate_ensemble(
                    pendulum, q0, p0, method=m, h=0.05, n_steps=steps, save_every=steps, temperature=0.5, seed=1)}
        row(f"damped pendulum ensemble, {members} members, {method}", runs, members * steps, repeats)
    steps = int(2_000_000 * scale)
    M, K = np.diag([1.0, 2.0, 1.5]), np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
    system = raydamp.System(["a", "b", "c"], "(2*a^2 - 2*a*b + 2*b^2 - 2*b*c + c^2)/2", mass=[1.0, 2.0, 1.5],
                            damping={"matrix": (0.05 * M + 0.01 * K).tolist()}, eps=1.0)
    elastic = ElasticPendulum(eps=0.1)
    for label, model, q, p in (("3-DOF System, D = a M + b K, baoab", system, [0.1, 0.2, 0.3], [0.0, 0.0, 0.0]),
                               ("elastic pendulum (radial damping), baoab", elastic, [0.3, 0.1, -1.1], [0.0] * 3)):
        runs = {"noiseless": lambda m=model, q=q, p=p: raydamp.integrate(m, q, p, method="baoab", h=0.01, n_steps=steps,
                                                                        save_every=steps),
                "kT = 0.5": lambda m=model, q=q, p=p: raydamp.integrate(m, q, p, method="baoab", h=0.01, n_steps=steps,
                                                                       save_every=steps, temperature=0.5, seed=1)}
        row(label, runs, steps, repeats)
    import scipy.sparse as sp

    def baoab_runs(structure, n, steps):
        """baoab from rest, noiseless and at kT = 0.5: the pair a row compares."""
        zeros = np.zeros(n)
        return {"noiseless": lambda: raydamp.integrate(structure, zeros, zeros, method="baoab", h=0.01,
                                                       n_steps=steps, save_every=steps),
                "kT = 0.5": lambda: raydamp.integrate(structure, zeros, zeros, method="baoab", h=0.01, n_steps=steps,
                                                      save_every=steps, temperature=0.5, seed=1)}

    n = 10_000
    K = sp.diags([np.full(n, 2.0), -np.ones(n - 1), -np.ones(n - 1)], [0, 1, -1], format="csc") * 100.0
    for kind, M in (("lumped", sp.identity(n, format="csc")),
                    ("consistent", sp.diags([np.full(n, 4.0), np.ones(n - 1), np.ones(n - 1)], [0, 1, -1],
                                            format="csc") / 6.0)):
        structure = raydamp.LinearStructure(M, K, alpha=0.05)
        steps = int(2000 * scale)
        runs = baoab_runs(structure, n, steps)
        row(f"{n}-DOF structure, {kind} M, alpha M damping, baoab (per step)", runs, steps, repeats)
    # beta K damping: the noise is psi(C M^-1) R xi, a Chebyshev series in K M^-1 of about the damping flow's
    # degree after a product with C's sparse Cholesky factor R, so a step does about twice the products.
    M = sp.identity(n, format="csc")
    for alpha, beta in ((0.05, 0.005), (0.0, 0.005)):
        structure = raydamp.LinearStructure(M, K, alpha=alpha, beta=beta)
        steps = int(2000 * scale)
        runs = baoab_runs(structure, n, steps)
        row(f"{n}-DOF structure, lumped M, C = {alpha} M + {beta} K, baoab", runs, steps, repeats)


if __name__ == "__main__":
    main()
