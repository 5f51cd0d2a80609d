#!/usr/bin/env python3
"""The cost of a load: ns per step with a series load beside the same run without one.

Issue 26's target: a step with a series load (a record sampled at dt, located by one
division) costs at most 1.15x the unforced step, for the elastic pendulum's 3s (a step of a
few dozen nanoseconds, where the load's lookup shows most) and for a 10^4-DOF linear
structure (3s and the implicit midpoint). A harmonic load (one sine per kick) is shown too.
Runs are interleaved (unforced, series, harmonic, unforced, ...) and the median of several
repeats is printed, so a busy machine shifts all three alike.

    .venv/bin/python benchmarks/bench_loads.py           # about a minute
    .venv/bin/python benchmarks/bench_loads.py --quick   # a few seconds

Prints the figures beside the target and exits 0 whatever they are (a benchmark, not a test).
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
import scipy.sparse as sp

import raydamp
from raydamp.models import ElasticPendulum


def timed(run) -> float:
    start = time.perf_counter()
    sol = run()
    elapsed = time.perf_counter() - start
    assert sol.success, sol.message
    return elapsed


def case(name, model, q0, p0, method, h, steps, loads, repeats):
    times = {label: [] for label in loads}
    for _ in range(repeats):
        for label, load in loads.items():
            times[label].append(timed(lambda load=load: raydamp.integrate(
                model, q0, p0, method=method, h=h, n_steps=steps, save_every=steps, load=load)))
    base = statistics.median(times["none"])
    row = [f"{name:<34}", f"{method:<9}", f"{1e9 * base / steps:9.1f}"]
    for label in list(loads)[1:]:
        t = statistics.median(times[label])
        row.append(f"{1e9 * t / steps:9.1f} ({t / base:4.2f}x)")
    print("  ".join(row))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    repeats = 3 if args.quick else 7
    scale = 0.1 if args.quick else 1.0
    rng = np.random.default_rng(1)
    t_rec = np.arange(4001) * 0.01  # a 40 s record at dt = 0.01
    record = rng.standard_normal(t_rec.size)

    print("ns per step (median of", repeats, "interleaved repeats); target: series <= 1.15x unforced")
    print(f"{'model':<34}  {'method':<9}  {'unforced':>9}  {'series':>16}  {'harmonic':>16}")
    pendulum = ElasticPendulum(eps=0.05)
    d3 = np.array([0.3, 0.0, -0.2])
    loads = {"none": None, "series": raydamp.Load.series(t_rec, record, d3),
             "harmonic": raydamp.Load.harmonic(d3, 2.0)}
    case("elastic pendulum", pendulum, [0.3, 0.1, -1.1], [0.0, 0.2, 0.1], "3s", 0.01, int(2e6 * scale), loads,
         repeats)

    n = 10_000
    main_diag = np.full(n, 2.0)
    main_diag[-1] = 1.0
    K = sp.diags([main_diag, -np.ones(n - 1), -np.ones(n - 1)], [0, 1, -1], format="csr") * 1e2
    structure = raydamp.LinearStructure(sp.identity(n, format="csr"), K, alpha=0.02)
    d = np.zeros(n)
    d[-100:] = 1.0
    loads = {"none": None, "series": raydamp.Load.series(t_rec, record, d), "harmonic": raydamp.Load.harmonic(d, 2.0)}
    q0 = rng.standard_normal(n) * 1e-3
    for method, h in (("3s", 0.005), ("midpoint", 0.01)):
        case(f"linear structure, {n} DOF, alpha M", structure, q0, np.zeros(n), method, h, int(4000 * scale), loads,
             repeats)


if __name__ == "__main__":
    main()
