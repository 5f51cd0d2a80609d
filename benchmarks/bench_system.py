#!/usr/bin/env python3
"""A user's System beside the built-in model it re-states: ns/step and build cost.

The elastic pendulum of the paper's section 6.2 is written as a raydamp.System
(expressions parsed by raydamp, differentiated and compiled by SymEngine's LLVM JIT,
one dashpot on |q|) and run with 3s, 2s and rks beside the hand-written built-in
ElasticPendulum struct, in the same process, interleaved, best of several repeats.
Target: System <= 1.5x the built-in per step (3s). Then the cost of building the
System (parse + derive + compile), target < 50 ms, split into its stages.

It prints figures beside their targets and exits 0 whatever they are (a benchmark,
not a test); it exits 1 only if the two final states disagree beyond 1e-10.

    .venv/bin/python benchmarks/bench_system.py          # about 15 seconds
    .venv/bin/python benchmarks/bench_system.py --quick
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np

import raydamp
from raydamp.models import ElasticPendulum
from raydamp.systems.expressions import parse
from raydamp.systems.system.compile import compile_system
from raydamp.systems.system.spec import normalise

Q0, P0 = [0.0, 1.55884573, -0.6], [1.34164079, 0.0, 0.0]
SPEC = dict(
    coordinates=["x", "y", "z"],
    potential="k/2*(sqrt(x^2+y^2+z^2) - l)^2 - m*g*z",
    parameters={"k": 1.0, "l": 1.0, "m": 1.0, "g": -1.0},
    mass=1.0,
    damping={"dampers": [{"on": "sqrt(x^2+y^2+z^2)", "c": 1.0}]},
    eps=0.1,
    momenta={"J3": "x*p_y - y*p_x"},
)
RATIO_TARGET = 1.5
BUILD_TARGET_MS = 50.0


def ns_per_step(model, method: str, steps: int, repeats: int) -> tuple[float, np.ndarray]:
    best = float("inf")
    for _ in range(repeats):
        sol = raydamp.integrate(model, Q0, P0, method=method, h=1e-3, n_steps=steps, save_every=steps)
        best = min(best, sol.wall_time / steps * 1e9)
    return best, np.concatenate([sol.q[-1], sol.p[-1]])


def build_times(repeats: int) -> dict[str, float]:
    stages: dict[str, list[float]] = {"parse + validate": [], "derive + compile": [], "whole System(...)": []}
    for _ in range(repeats):
        t0 = time.perf_counter()
        spec = normalise(**SPEC)
        t1 = time.perf_counter()
        compile_system(spec)
        t2 = time.perf_counter()
        raydamp.System(**SPEC)
        t3 = time.perf_counter()
        stages["parse + validate"].append(t1 - t0)
        stages["derive + compile"].append(t2 - t1)
        stages["whole System(...)"].append(t3 - t2)
    return {k: statistics.median(v) * 1e3 for k, v in stages.items()}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    steps, repeats = (200_000, 3) if args.quick else (2_000_000, 5)
    system, builtin = raydamp.System(**SPEC), ElasticPendulum(eps=0.1)
    print(f"raydamp {raydamp.__version__}: elastic pendulum, h = 1e-3, {steps} steps, best of {repeats}")
    print(f"{'method':<8}{'built-in ns/step':>18}{'System ns/step':>16}{'ratio':>8}   target <= {RATIO_TARGET}x")
    worst = 0.0
    for method in ("3s", "2s", "rks"):
        ns_builtin, end_builtin = ns_per_step(builtin, method, steps, repeats)
        ns_system, end_system = ns_per_step(system, method, steps, repeats)
        ratio = ns_system / ns_builtin
        flag = "ok" if ratio <= RATIO_TARGET else "OVER"
        print(f"{method:<8}{ns_builtin:>18.1f}{ns_system:>16.1f}{ratio:>8.2f}   {flag}")
        worst = max(worst, float(np.max(np.abs(end_system - end_builtin)) / max(1.0, np.max(np.abs(end_builtin)))))
    print(f"final states agree to {worst:.1e} (relative)")
    print()
    print(f"building the System (median of {repeats * 4}):   target < {BUILD_TARGET_MS:.0f} ms")
    for stage, ms in build_times(repeats * 4).items():
        print(f"  {stage:<20}{ms:>8.2f} ms")
    t0 = time.perf_counter()
    for _ in range(100):
        parse(SPEC["potential"], field="potential",
              names={n: "coordinate" for n in "xyz"} | dict.fromkeys("klmg", "parameter"))
    print(f"  (parsing the potential alone: {(time.perf_counter() - t0) * 10:.3f} ms)")
    return 1 if worst > 1e-10 else 0


if __name__ == "__main__":
    sys.exit(main())
