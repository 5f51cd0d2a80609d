#!/usr/bin/env python3
"""The step's cost once a damped run has decayed past the smallest normal double (2.2e-308).

Without flushing, the state cycled among subnormals for the rest of the run and every step took a microcode
assist (the damped pendulum's 3s: about 130 ns/step against 5). Each row: ns/step of the damped pendulum at
eps = 0.1, h = 0.1, over steps in the normal range (q0 = 1, 20,000 steps) and over steps
after the decay (q0 = 1e-300: below 1e-308 within 500 steps), median of 5, side by side.

    python benchmarks/bench_subnormals.py
"""

from __future__ import annotations

import statistics
import time

import raydamp
from raydamp.models import DampedPendulum


def ns_per_step(q0: float, steps: int, method: str) -> float:
    model = DampedPendulum(0.1)
    times = []
    for _ in range(5):
        start = time.perf_counter()
        raydamp.integrate(model, [q0], [0.0], method=method, h=0.1, n_steps=steps, save_every=steps)
        times.append(time.perf_counter() - start)
    return statistics.median(times) / steps * 1e9


def main() -> None:
    print(f"{'method':<8}{'normal range':>16}{'decayed':>12}{'ratio':>8}   (ns/step)")
    for method in ("3s", "2s", "rks", "baoab"):
        normal = ns_per_step(1.0, 20_000, method)  # to t = 2,000: amplitude e^{-100}, far from subnormal
        decayed = ns_per_step(1e-300, 1_000_000, method)
        print(f"{method:<8}{normal:>16.1f}{decayed:>12.1f}{decayed / normal:>8.2f}")


if __name__ == "__main__":
    main()
