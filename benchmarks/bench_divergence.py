#!/usr/bin/env python3
"""What the divergence test (integrate's ``divergence``) costs: ns per step of the same long runs with the
test on (the default) and off (``divergence=0``), side by side, from the same build.

The test runs once every 256 steps (an energy evaluation), so it should cost well under 2% of a step even
on the cheapest models. Prints the best of several rounds per case and the ratio; exits 0 whatever the
figures (a benchmark, not a test).

    .venv/bin/python benchmarks/bench_divergence.py [--steps N] [--rounds R]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
from scipy import sparse

import raydamp
from raydamp.models import DampedPendulum, ElasticPendulum


def frame(n: int) -> raydamp.LinearStructure:
    main = np.full(n, 2.0)
    main[-1] = 1.0
    K = sparse.diags([-np.ones(n - 1), main, -np.ones(n - 1)], [-1, 0, 1]).tocsc()
    return raydamp.LinearStructure(sparse.identity(n, format="csc"), K, alpha=0.01, beta=0.01)


def cases(steps: int):
    s = frame(10)
    q0 = np.linspace(0.0, 1.0, 10)
    return [
        ("damped pendulum 3s", DampedPendulum(eps=0.01), [0.9 * math.pi], [0.0], {"method": "3s", "h": 1e-3}, steps),
        ("elastic pendulum 2s", ElasticPendulum(eps=0.1), [0.0, 1.55884573, -0.6], [1.34164079, 0.0, 0.0],
         {"method": "2s", "h": 1e-3}, steps),
        ("elastic pendulum rks", ElasticPendulum(eps=0.1), [0.0, 1.55884573, -0.6], [1.34164079, 0.0, 0.0],
         {"method": "rks", "h": 1e-3}, steps),
        ("10-storey frame midpoint", s, q0, 0 * q0, {"method": "midpoint", "h": 0.05}, steps // 10),
    ]


def ns_per_step(model, q0, p0, options, steps, divergence) -> float:
    start = time.perf_counter()
    sol = raydamp.integrate(model, q0, p0, n_steps=steps, save_every=max(1, steps // 10), divergence=divergence,
                            **options)
    elapsed = time.perf_counter() - start
    assert sol.status == "completed", sol.message
    return elapsed / steps * 1e9


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=2_000_000)
    parser.add_argument("--rounds", type=int, default=7)
    args = parser.parse_args()
    print(f"{'case':28s} {'test on ns/step':>16s} {'off ns/step':>12s} {'on/off':>8s}")
    for name, model, q0, p0, options, steps in cases(args.steps):
        on, off = [], []
        for _ in range(args.rounds):  # interleaved, so a drift of the machine's speed hits both
            on.append(ns_per_step(model, q0, p0, options, steps, raydamp.run.integrate.DEFAULT_DIVERGENCE))
            off.append(ns_per_step(model, q0, p0, options, steps, 0.0))
        print(f"{name:28s} {min(on):16.2f} {min(off):12.2f} {min(on) / min(off):8.3f}")


if __name__ == "__main__":
    main()
