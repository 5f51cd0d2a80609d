#!/usr/bin/env python3
"""The cost of events (issue 41): a run with events against the plain run that steps whole steps.

A run with events steps whole steps (no merged sub-flows between saved rows) and, after every step,
reads the step's end and evaluates each event function. The baseline is the same run without events
stepping whole steps too: ``events=[]`` (nothing watched, whole steps); the merged plain run is shown
beside it. The target: events cost at most 1.2x the plain whole-step run. Both systems by 3s.

Cases:
  damped pendulum      eps = 0.1, h = 0.01, 3s, 10^6 steps from q = 2: one event g = q[0]; ten levels
                       q[0] - 0.1 k; five levels of q and five of p (p[0] + 0.1 k: p's rate is the force,
                       one more sine a step)
  10-storey frame      the README's LinearStructure shear frame (benchmarks/ground_motion_frame.py: storey
                       masses 1e5 kg, stiffness 2e8 N/m, lumped M, 5% Rayleigh damping in modes 1 and 3),
                       free vibration from a linear shape (roof at 0.1 m), h = 0.005, 3s, 2 10^5 steps:
                       one roof drift event q[9] - 0.01 and ten storey drifts q[k] - q[k-1] - 0.005

Beside them: the watcher's floor, one event g = t - 1e9 that never crosses (each step end read: q, p and
M^-1 p copied, g and dg/dt from their coefficients, a sign scan), and on the pendulum the same event as one
compiled call (g = q[0] + 1e-300 sin(q[0]) is not affine, so it runs through the compiled function).
benchmarks/bench_event_watcher.cpp times the pendulum's cases from C++, beside a bare loop of the same step
with ten inlined sign checks (the least any watcher could cost).

Runs are interleaved and the median over rounds printed, so a busy machine shifts all cases alike.

    .venv/bin/python benchmarks/bench_events.py           # about half a minute
    .venv/bin/python benchmarks/bench_events.py --quick   # a few seconds

Exit 0 whatever the figures (a benchmark, not a test).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

import numpy as np

import raydamp

TARGET = 1.2


def pendulum_case(steps: int):
    model = raydamp.models.DampedPendulum(eps=0.1)
    q0, p0 = [2.0], [0.0]
    one = [raydamp.Event("q[0]", name="vertical")]
    ten = [raydamp.Event(f"q[0] - {0.1 * k}", name=f"level{k}") for k in range(10)]
    mixed = ([raydamp.Event(f"q[0] - {0.1 * k}", name=f"q{k}") for k in range(5)]
             + [raydamp.Event(f"p[0] + {0.1 * k}", name=f"p{k}") for k in range(5)])
    clock = [raydamp.Event("t - 1e9", name="never")]
    compiled = [raydamp.Event("q[0] + 1e-300*sin(q[0])", name="vertical")]

    def run(events=None):
        return raydamp.integrate(model, q0, p0, method="3s", h=0.01, n_steps=steps, save_every=steps,
                                 events=events)
    return {"plain (merged)": lambda: run(), "plain, whole steps": lambda: run([]),
            "floor: 1 event g = t - 1e9": lambda: run(clock), "1 event": lambda: run(one),
            "1 event, compiled call": lambda: run(compiled), "10 events on q": lambda: run(ten),
            "10 events: 5 on q, 5 on p": lambda: run(mixed)}


def frame_case(steps: int):
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from ground_motion_frame import frame

    M, K, alpha, beta, _ = frame()
    model = raydamp.LinearStructure(M, K, alpha=alpha, beta=beta)
    q0 = np.linspace(0.01, 0.1, 10)
    p0 = np.zeros(10)
    one = [raydamp.Event("q[9] - 0.01", name="roof")]
    ten = [raydamp.Event("q[0] - 0.005", name="drift0")] + [
        raydamp.Event(f"q[{k}] - q[{k - 1}] - 0.005", name=f"drift{k}") for k in range(1, 10)]
    clock = [raydamp.Event("t - 1e9", name="never")]

    def run(events=None):
        return raydamp.integrate(model, q0, p0, method="3s", h=0.005, n_steps=steps, save_every=steps,
                                 events=events)
    return {"plain (merged)": lambda: run(), "plain, whole steps": lambda: run([]),
            "floor: 1 event g = t - 1e9": lambda: run(clock), "1 event": lambda: run(one),
            "10 storey drifts": lambda: run(ten)}


def measure(cases: dict, rounds: int) -> dict[str, float]:
    times: dict[str, list[float]] = {name: [] for name in cases}
    counts = {name: run().events for name, run in cases.items()}  # warm: compile, fault the pages
    counts = {name: 0 if table is None else len(table.t) for name, table in counts.items()}
    for _ in range(rounds):
        for name, run in cases.items():
            start = time.perf_counter()
            sol = run()
            times[name].append(time.perf_counter() - start)
            assert sol.status == "completed", sol.message
    return {name: (statistics.median(t), counts[name]) for name, t in times.items()}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    scale, rounds = (0.1, 3) if args.quick else (1.0, 7)
    for title, cases, steps, baseline in (
            ("damped pendulum, 3s, h = 0.01", pendulum_case, int(1e6 * scale), "plain, whole steps"),
            ("10-storey frame, 3s, h = 0.005", frame_case, int(2e5 * scale), "plain, whole steps")):
        medians = measure(cases(steps), rounds)
        print(f"{title}: {steps} steps, median of {rounds}")
        print(f"  {'case':34s} {'ms':>9s} {'ns/step':>9s} {'x ' + baseline[:18]:>22s} {'events':>8s}")
        for name, (seconds, count) in medians.items():
            ratio = seconds / medians[baseline][0]
            mark = "" if name in (baseline, "plain (merged)") else ("  ok" if ratio <= TARGET else f"  > {TARGET}")
            print(f"  {name:34s} {1e3 * seconds:9.2f} {1e9 * seconds / steps:9.1f} {ratio:22.2f} {count:8d}{mark}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
