#!/usr/bin/env python3
"""A 10-storey shear frame with and without hysteretic springs: ns per step, side by side (issue 42).

The frame of ground_motion_frame.py (storey masses 1e5 kg, storey stiffness 2e8 N/m, 5% Rayleigh damping
in modes 1 and 3) under its 20 s record at h = dt / 4, once as a LinearStructure (storeys in K) and once as
a raydamp.Structure whose storeys are springs (Bilinear with b = 0.05, ElasticPlastic, BoucWen; the yield
force at 40% of the elastic peak storey force, so the storeys do yield). Same process, interleaved, best
of several rounds; the analysis only (raydamp.integrate), timed in the process's CPU time (the run is one
thread), so that other work on a loaded machine does not count. Target: springs cost <= 1.5x. With
--kinks, also each spring frame with locate_kinks=True (the cost of kink location).

    .venv/bin/python benchmarks/bench_springs.py [--kinks]
"""

from __future__ import annotations

import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ground_motion_frame import MASS, STIFFNESS, STOREYS, frame, record  # noqa: E402

import raydamp  # noqa: E402
from raydamp.materials import Bilinear, BoucWen, ElasticPlastic  # noqa: E402


def springs_frame(material, alpha, beta, locate_kinks=False):
    springs = [raydamp.Spring((0,) if s == 0 else (s - 1, s), material) for s in range(STOREYS)]
    return raydamp.Structure(np.eye(STOREYS) * MASS, springs=springs, alpha=alpha, beta=beta,
                             locate_kinks=locate_kinks)


def best_ns(model, motion, h, t_end, method, rounds=7):
    best = np.inf
    for _ in range(rounds):
        start = time.process_time()
        sol = raydamp.integrate(model, np.zeros(STOREYS), np.zeros(STOREYS), method=method, h=h, t_end=t_end,
                                load=motion, save_every=10**9)
        best = min(best, time.process_time() - start)
    return best / sol.steps * 1e9, sol


def main():
    t, a = record()
    M, K, alpha, beta, _ = frame()
    linear = raydamp.LinearStructure(M, K, alpha=alpha, beta=beta)
    motion = raydamp.GroundMotion((t, a), np.ones(STOREYS))
    h = 0.01 / 4
    elastic = raydamp.integrate(linear, np.zeros(STOREYS), np.zeros(STOREYS), method="3s", h=h, t_end=t[-1],
                                load=motion)
    drift = np.diff(np.column_stack([np.zeros(elastic.q.shape[0]), elastic.q]), axis=1)
    fy = 0.4 * STIFFNESS * np.max(np.abs(drift))
    kinds = {"Bilinear(b=0.05)": Bilinear(STIFFNESS, fy, 0.05), "ElasticPlastic": ElasticPlastic(STIFFNESS, fy),
             "BoucWen": BoucWen(STIFFNESS, fy, 0.05)}
    print(f"10-storey shear frame, {t[-1]:.0f} s record at h = {h} ({int(round(t[-1] / h))} steps); ns per step, "
          "best of 7")
    kinks = "--kinks" in sys.argv
    print(f"{'method':8s} {'material':18s} {'no springs':>11s} {'springs':>9s} {'ratio':>6s} {'peak ductility':>15s}"
          + (f" {'kinks located':>14s} {'ratio':>6s}" if kinks else ""))
    for method in ("3s", "2s", "baoab"):
        for name, material in kinds.items():
            yielding = springs_frame(material, alpha, beta)
            plain_ns, _ = best_ns(linear, motion, h, t[-1], method)
            springs_ns, sol = best_ns(yielding, motion, h, t[-1], method)
            plain_ns = min(plain_ns, best_ns(linear, motion, h, t[-1], method)[0])  # interleaved
            full = raydamp.integrate(yielding, np.zeros(STOREYS), np.zeros(STOREYS), method=method, h=h,
                                     t_end=t[-1], load=motion)
            storey = np.diff(np.column_stack([np.zeros(full.q.shape[0]), full.q]), axis=1)
            ductility = np.max(np.abs(storey)) / (fy / STIFFNESS)
            located = ""
            if kinks:
                located_ns, _ = best_ns(springs_frame(material, alpha, beta, True), motion, h, t[-1], method)
                located = f" {located_ns:14.0f} {located_ns / plain_ns:6.2f}"
            print(f"{method:8s} {name:18s} {plain_ns:11.0f} {springs_ns:9.0f} {springs_ns / plain_ns:6.2f} "
                  f"{ductility:15.2f}{located}")


if __name__ == "__main__":
    main()
