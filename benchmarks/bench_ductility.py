#!/usr/bin/env python3
"""A constant-ductility spectrum (mu = 2, 4, 8; 5% damping; elastic-perfectly-plastic) of the 20 s record of
ground_motion_frame.py at n periods from 0.05 to 5 s: raydamp.ductility_spectrum's time (wall and CPU) and
its rounds, and the exact achieved ductility at a few of its answers (the event-driven solution of
tests/ductility_reference.py, when the tests folder is beside this one).

    .venv/bin/python benchmarks/bench_ductility.py [--periods 20]

It prints and exits 0 whatever the figures are: a benchmark, not a test.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

import raydamp

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ground_motion_frame import record  # noqa: E402


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--periods", type=int, default=20)
    args = parser.parse_args()
    t, a_g = record()
    periods = np.geomspace(0.05, 5.0, args.periods)
    targets = [2.0, 4.0, 8.0]
    wall, cpu = time.perf_counter(), time.process_time()
    ds = raydamp.ductility_spectrum((t, a_g), periods, targets)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    print(f"{args.periods} periods x {len(targets)} ductilities, {t[-1] - t[0]:.0f} s record at dt = {t[1] - t[0]}: "
          f"{wall:.2f} s wall, {cpu:.2f} s CPU")
    print(f"{'T (s)':>7s} " + " ".join(f"{'fy/f0 mu=' + str(int(m)):>12s}" for m in targets))
    for i in range(0, args.periods, max(1, args.periods // 8)):
        print(f"{periods[i]:7.3f} " + " ".join(f"{float(ds.fy_ratio[j, i]):12.5f}" for j in range(len(targets))))
    tests = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests")
    if os.path.isdir(tests):
        sys.path.insert(0, tests)
        from ductility_reference import peak_ductility

        worst = 0.0
        for i in range(0, args.periods, max(1, args.periods // 4)):
            for j, mu in enumerate(targets):
                exact = peak_ductility(t, a_g, periods[i], 0.05, float(ds.Ay[j, i]))
                worst = max(worst, abs(exact / mu - 1.0))
        print(f"exact ductility at the fy found, worst relative difference from the target: {worst:.1e}")


if __name__ == "__main__":
    main()
