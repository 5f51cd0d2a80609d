#!/usr/bin/env python3
"""raydamp.ida on one thread and on two: wall and CPU time per record-run, and the scaling (issue 42: >= 1.8x).

The 10-storey Bilinear frame of ida_frame.py under its synthetic records (--records of them, 10 scales each,
40 s at dt = 0.01), by raydamp's routes there: 3s at dt/8, and the order-4 route, 3s + suzuki4 on the structure
with its kinks located, at dt/2; with --all also 3s + suzuki4 without kink location and 3s located at dt/8. Each
route runs one thread, two threads, twice over, alternated; the best of each is printed. Only the analysis is
timed (the ida call), in wall and in process CPU time: CPU per run rising with two threads means the threads
contend for something they share, wall alone could be another process's doing.

    .venv/bin/python benchmarks/bench_ida_threads.py [--records 4] [--all]
    /old/checkout/.venv/bin/python benchmarks/bench_ida_threads.py   # another build, the same runs

Prints figures and exits 0 whatever they are (a benchmark, not a test).
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np
from ida_frame import DT, SECONDS, rayleigh, record, structure

import raydamp


def analysis(model, motions, scales, k: int, composition: str | None, threads: int) -> tuple[float, float]:
    """(wall seconds, CPU seconds) of one raydamp.ida call."""
    cpu, wall = time.process_time(), time.perf_counter()
    result = raydamp.ida(model, motions, scales, h=DT / k, t_end=SECONDS, collapse_drift=1e9, threads=threads,
                         composition=composition)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    assert (result["status"].values == "completed").all()
    return wall, cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--records", type=int, default=4, help="records, each at 10 scales (default 4)")
    parser.add_argument("--all", action="store_true", help="also the routes between those two")
    args = parser.parse_args()
    alpha, beta, _ = rayleigh()
    plain, located = structure(alpha, beta), structure(alpha, beta, locate_kinks=True)
    routes = {"3s, dt/8": (plain, 8, None), "3s + suzuki4, kinks located, dt/2": (located, 2, "suzuki4")}
    if args.all:
        routes |= {"3s + suzuki4, dt/2": (plain, 2, "suzuki4"), "3s, kinks located, dt/8": (located, 8, None)}
    motions = [raydamp.GroundMotion(record(seed), np.ones(10)) for seed in range(args.records)]
    scales = np.linspace(0.4, 4.0, 10)
    runs = len(motions) * scales.size
    print(f"raydamp {raydamp.__version__} from {os.path.dirname(raydamp.__file__)}; {runs} runs of {SECONDS:g} s; "
          f"load average {os.getloadavg()[0]:.1f}, {os.cpu_count()} CPUs")
    for name, (model, k, composition) in routes.items():
        analysis(model, motions[:1], scales[:1], k, composition, 1)  # first calls, before any timing
        best = {1: (np.inf, np.inf), 2: (np.inf, np.inf)}
        for _ in range(2):
            for threads in (1, 2):
                best[threads] = min(best[threads], analysis(model, motions, scales, k, composition, threads))
        (w1, c1), (w2, c2) = best[1], best[2]
        print(f"{name}: 1 thread {1e3 * w1 / runs:.2f} ms per run ({1e3 * c1 / runs:.2f} CPU); 2 threads "
              f"{1e3 * w2 / runs:.2f} ({1e3 * c2 / runs:.2f} CPU); scaling {w1 / w2:.2f}x (target 1.8x); "
              f"load average {os.getloadavg()[0]:.1f}", flush=True)


if __name__ == "__main__":
    main()
