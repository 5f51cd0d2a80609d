#!/usr/bin/env python3
"""A constrained step beside the unconstrained step of the same system: ns/step.

Two systems, each run twice in the same process, interleaved, best of several repeats:
- the damped double pendulum in Cartesian coordinates (4 coordinates), with its two rods as constraints,
  and the same system without them (the masses then fall freely: the same potential, mass and damping);
- a damped chain of N links hanging under gravity (2 (N) coordinates, N rods, the first from the origin),
  with and without the rods.
Target (issue 45): constrained <= 2x unconstrained at the default tolerance (1e-12). The figures are printed
beside it; the script exits 0 whatever they are (a benchmark, not a test). The free systems are a free fall
(V's gradient is a constant): their step is a few vector operations, so the ratio is the constraint solve's
whole cost over almost nothing.

The ratio is the issue's: the constrained step over the step of the same system without its constraints
(same potential, mass, damping), not over a stiff-spring stand-in. What dominates it (perf record of the
double pendulum's 3s, 3e6 steps, shares of the time inside the step loop): factored_at 21% (G and the band
factor of G M^-1 G^T at each new q, with its cache test and copy of q), project 20% (three projections a
step: after each kick and the drift) plus the M^-1, G and band-solve passes it calls (inverse_mass_times 8%,
times_G 4%, NormalPattern::solve 4%), SHAKE's Newton loop in drift 13%; the compiled constraint, Jacobian and
gradient functions together 3%. So the cost is a dozen small passes over dynamic-size vectors per step, not
the constraints' arithmetic; the free fall it is compared with is a gradient call and two vector updates.
The 100-link chain (perf of the same headers built stand-alone with hand-written constraint functions, 3s,
h = 1e-3): the band solves (latency-bound, a tridiagonal substitution of 100 rows) 21%, G and the factor at
each new q 21%, the drift's own passes 27% (its G^T products and the residual test's divisions most), the
projections 14%. A step takes two drifts (the tables' drifts are not merged: two constrained drifts are not
one), each with its Newton iterations (2.85 from a zero impulse, 2.16 from the last drift's impulse, here),
a check of g, a factor and a projection, and the kick's projection. Measured (medians of 5 runs, load 3 on
2 cores): the floor is 3.0-4.7x the free step of the double pendulum and 13-22x the chain's, so <= 2x
cannot be met by any RATTLE step of these systems; the constrained step is 3.1-3.4 floors on the double
pendulum, 4.6-5.1 on the chain.
The floor: the free step plus the least work any RATTLE step adds to it (constraints/least_work.hpp: g and G
evaluated once at the new q, G M^-1 G^T formed and factored once, one Newton solve with the previous step's
factor and one projection, with their products by G, G^T and M^-1), timed in C++ from a state of the run.
floor/free is the least ratio any constrained step could reach; where it is above the target, the target
cannot be met by any RATTLE implementation. constr/floor: how far the step is above that floor.
The last column: per step, the drifts (3s has two), Newton iterations per drift, refreshes of Newton's
matrix and factorisations of G M^-1 G^T.

    .venv/bin/python benchmarks/bench_constraints.py            # about a minute (the chain's compile)
    .venv/bin/python benchmarks/bench_constraints.py --quick    # a 20-link chain

Old against new in one call: the same script under two installs (OLD: a directory holding the old
raydamp package with its built _core), paired by farm-bench, each run's table kept in a file:

    B=benchmarks/bench_constraints.py
    farm-bench -n 3 --timeout 900 --vs "sh -c 'PYTHONPATH=$OLD exec .venv/bin/python $B --quick >>/tmp/old'" \
        -- sh -c "exec .venv/bin/python $B --quick >>/tmp/new"
"""

from __future__ import annotations

import argparse
import math
import os

import numpy as np

import raydamp

TARGET = 2.0
G = 9.81


def double_pendulum(constrained: bool) -> tuple[raydamp.System, np.ndarray, np.ndarray]:
    system = raydamp.System(["x1", "y1", "x2", "y2"], "g*(m1*y1 + m2*y2)",
                            parameters={"g": G, "m1": 1.0, "m2": 0.7, **({"a": 1.0, "b": 0.8} if constrained else {})},
                            mass=[1.0, 1.0, 0.7, 0.7], damping={"scalar": 1.0}, eps=0.1,
                            constraints=["x1^2 + y1^2 - a^2", "(x2 - x1)^2 + (y2 - y1)^2 - b^2"] if constrained
                            else None)
    a, b = 1.2, -0.5
    x1, y1 = math.sin(a), -math.cos(a)
    q0 = np.array([x1, y1, x1 + 0.8 * math.sin(b), y1 - 0.8 * math.cos(b)])
    v1 = 0.3 * np.array([math.cos(a), math.sin(a)])
    v2 = v1 + 0.8 * 1.1 * np.array([math.cos(b), math.sin(b)])
    return system, q0, np.concatenate([v1, 0.7 * v2])


def chain(links: int, constrained: bool) -> tuple[raydamp.System, np.ndarray, np.ndarray]:
    names = [f"{c}{i}" for i in range(1, links + 1) for c in "xy"]
    rods = ["x1^2 + y1^2 - l^2"] + [f"(x{i} - x{i - 1})^2 + (y{i} - y{i - 1})^2 - l^2" for i in range(2, links + 1)]
    system = raydamp.System(names, " + ".join(f"g*y{i}" for i in range(1, links + 1)),
                            parameters={"g": G, **({"l": 0.1} if constrained else {})}, mass=0.05,
                            damping={"scalar": 1.0}, eps=0.5, constraints=rods if constrained else None)
    # hanging at 30 degrees from the vertical, at rest: it swings down
    q0 = np.array([v for i in range(1, links + 1) for v in (0.1 * i * 0.5, -0.1 * i * math.sqrt(3) / 2)])
    return system, q0, np.zeros(2 * links)


def ns_per_step(system, q0, p0, method: str, h: float, steps: int, repeats: int) -> float:
    best = math.inf
    for _ in range(repeats):
        sol = raydamp.integrate(system, q0, p0, method=method, h=h, n_steps=steps, save_every=steps)
        assert sol.status == "completed", sol.message
        best = min(best, sol.wall_time / steps * 1e9)
    return best


def solves_per_step(system, q0, p0, method: str, h: float, steps: int) -> tuple[str, np.ndarray, np.ndarray]:
    """What the constraint solve did per step (the core's counters): drifts, Newton iterations, refreshes
    of Newton's matrix, factorisations of G M^-1 G^T; and the state the run ended at."""
    out = system._core_model.integrate(method, "", "", np.asarray(q0, float), np.asarray(p0, float), h, steps, h,
                                       steps, False, None, None)
    drifts, iterations, refreshes, factorisations = out["constraint_solves"]
    return (f"{drifts / steps:.0f} drift, {iterations / max(drifts, 1):.2f} it/drift, "
            f"{refreshes / steps:.2f} refresh, {factorisations / steps:.2f} factor"), out["q"][-1], out["p"][-1]


def least_work_ns(system, q, p, h: float, steps: int, repeats: int) -> float:
    """The least a RATTLE step adds to the free step, ns (constraints/least_work.hpp): g and G once, G M^-1 G^T
    formed and factored once, one Newton solve and one projection, from a state on the constraints."""
    q, p = np.asarray(q, float), np.asarray(p, float)
    return min(system._core_model.least_constraint_work_ns(q, p, h, steps) for _ in range(repeats))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    links = 20 if args.quick else 100
    cases = [("double pendulum", double_pendulum, 1e-3, 200_000), (f"{links}-link chain", lambda c: chain(links, c),
                                                                   1e-3, 2_000)]
    print(f"raydamp {raydamp.__file__}; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    print(f"{'system':<18} {'method':<6} {'free ns/step':>13} {'constrained':>12} {'ratio':>7} {'floor':>8} "
          f"{'floor/free':>11} {'constr/floor':>13}  target <= {TARGET}x   per step")
    for label, build, h, steps in cases:
        free, q0, p0 = build(False)
        constrained, _, _ = build(True)
        for method in ("3s", "2s", "baoab"):
            a = ns_per_step(free, q0, p0, method, h, steps, 5)
            b = ns_per_step(constrained, q0, p0, method, h, steps, 5)
            solves, q, p = solves_per_step(constrained, q0, p0, method, h, steps)
            if hasattr(constrained._core_model, "least_constraint_work_ns"):  # an older install has no floor
                floor = a + least_work_ns(constrained, q, p, h, steps, 5)
                columns = f"{floor:>8.0f} {floor / a:>11.2f} {b / floor:>13.2f}"
            else:
                columns = f"{'-':>8} {'-':>11} {'-':>13}"
            print(f"{label:<18} {method:<6} {a:>13.0f} {b:>12.0f} {b / a:>7.2f} {columns}                 {solves}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
