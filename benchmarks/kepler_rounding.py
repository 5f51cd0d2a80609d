"""Where the error of a long undamped Kepler run comes from (issue 46, e = 0.99 over 10^4 periods).

Three measurements, each against mpmath at 40 digits (tests/test_kepler.py's kepler_reference: classical
elements and Kepler's equation, not universal variables):

1. One drift's own error, |q - q_ref| / |q_ref|, at the same double start and the same h, for starts at,
   before and after the pericentre of e = 0.99 and h from P/64 to 100 P.
2. The error of a run of N steps of sv (eps = 0: each step the exact flow, the state rounded to double
   between steps) against the flow over the exact time N h, for N up to 10^4 periods, with its growth
   exponent: Brouwer's law (a random walk of the energy from the state's rounding) grows like N^{3/2}.
3. The floor of any double-state method: the same N steps done by mpmath's exact flow, the state rounded
   to double after each drift (the one rounding any method whose state is a double must make), at the
   same N. If raydamp's error sits at this floor, the drift is at rounding and what is left is the state's.
   sv rounds the state at every half step: with the start at the pericentre, there once a period, where
   a double state's energy is known only to eps (1 + e) / (1 - e) (2e-14 at e = 0.99): each such rounding
   moves the period by 1.5 times that, and the phase error after N of them is about
   1.5 P eps (1 + e) / (1 - e) N^{3/2} / sqrt(3) in time (Brouwer's law), 1.41 times that in q.

    nice -n 5 .venv/bin/python benchmarks/kepler_rounding.py [--quick]
"""

from __future__ import annotations

import argparse
import math
import pathlib
import sys

import mpmath as mp
import numpy as np

import raydamp

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "tests"))
from test_kepler import kepler_reference  # noqa: E402


def rel(a, b) -> float:
    return float(np.linalg.norm(np.asarray(a) - b) / np.linalg.norm(b))


def one_drift_errors(e: float) -> None:
    k = raydamp.Kepler(1.0)
    q0, p0 = k.pericentre_state(1.0, e)
    period = 2 * math.pi * (1.0 / (1.0 - e)) ** 1.5
    print(f"\n1. one drift, e = {e}, P = {period:.6g}: |q - q_ref| / |q_ref|, |v - v_ref| / |v_ref|")
    starts = {"pericentre": (q0, p0)}
    for name, dt in (("P/64 before pericentre", -period / 64), ("P/64 after", period / 64),
                     ("apocentre", period / 2)):
        starts[name] = kepler_reference(dt, q0, p0)
    for name, (q, v) in starts.items():
        cells = []
        for label, h in (("P/64", period / 64), ("P/16", period / 16), ("P/4", period / 4), ("P", period),
                         ("100P", 100 * period)):
            qd, vd = k.flow("drift", q, v, h)
            rq, rv = kepler_reference(h, q, v)
            cells.append(f"{label} {rel(qd, rq):.1e}/{rel(vd, rv):.1e}")
        print(f"  {name:>24}: " + "  ".join(cells))


def exact_rounded_run(q, v, h: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """sv's sub-flows on Kepler: drift h/2, kick (none), drift h/2 per step (the kick between them keeps
    the two drifts apart), each drift the exact flow, the state rounded to double after each."""
    for _ in range(2 * n):
        q, v = kepler_reference(h / 2, q, v)
    return q, v


def growth(e: float, steps_per_period: int, periods: list[int], floor_up_to: int) -> None:
    k = raydamp.Kepler(1.0)
    q0, p0 = k.pericentre_state(1.0, e)
    period = 2 * math.pi * (1.0 / (1.0 - e)) ** 1.5
    h = period / steps_per_period
    print(f"\n2./3. sv, e = {e}, {steps_per_period} step(s) per period (h = {h:.6g}); errors at pericentre, relative:")
    print(f"  {'periods':>8} {'steps':>7} {'q (t = N h exact)':>18} {'q (t = sol.t)':>14} {'time shift / t':>15} "
          f"{'|dE/E|':>9} {'floor q':>9}")
    last = None
    for n_periods in periods:
        n = n_periods * steps_per_period
        sol = raydamp.integrate(k, q0, p0, method="sv", h=h, n_steps=n, save_every=n)
        with mp.workdps(40):
            exact_t = n * mp.mpf(h)
        rq, rv = kepler_reference(exact_t, q0, p0)
        sq, _ = kepler_reference(sol.t[-1], q0, p0)
        err = rel(sol.q[-1], rq)
        shift = abs(np.dot(sol.q[-1] - rq, rv)) / np.dot(rv, rv) / float(exact_t)
        de = abs(sol.energy[-1] - sol.energy[0]) / abs(sol.energy[0])
        floor = "-"
        if n <= floor_up_to:
            fq, _ = exact_rounded_run(q0, p0, h, n)
            floor = f"{rel(fq, rq):.1e}"
        slope = f"  (N^{math.log(err / last[1]) / math.log(n / last[0]):.2f})" if last else ""
        print(f"  {n_periods:>8} {n:>7} {err:>18.2e} {rel(sol.q[-1], sq):>14.2e} {shift:>15.2e} {de:>9.1e} "
              f"{floor:>9}{slope}")
        last = (n, err)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="fewer periods, no floor past 300 steps")
    args = parser.parse_args()
    one_drift_errors(0.99)
    periods = [10, 100, 1000] if args.quick else [10, 100, 1000, 10_000]
    floor = 300 if args.quick else 1000
    for spp in (1, 4, 16):
        growth(0.99, spp, periods, floor)


if __name__ == "__main__":
    main()
