#!/usr/bin/env python3
"""DOF-steps per second of raydamp.Chain (FPUT) for N = 10^3 .. 10^6, beside a hand-written
leapfrog chain loop and a STREAM-like triad measured in the same run.

For each N it runs raydamp.integrate(Chain(N, "fput", alpha=0.25, beta=1), method="sv") for
about 5*10^8 DOF-steps (saving one site, so saving costs nothing) and the same steps of the
hand-written loop in handwritten_chain.cpp (same compiler and flags as _core), and prints
both with their ratio (target: raydamp >= 50% of the hand loop, and >= 5e8 DOF-steps/s at
N = 10^6). One leapfrog step reads and writes q and p once each way: 48 bytes per DOF-step
when the state does not fit in cache, so the triad's bandwidth / 48 bounds the rate there.
It also times 3s with dashpots on every 10th bond (eps > 0), whose damping touches only
the damped sites, and checks that raydamp's sv and the hand loop end in the same state.

    .venv/bin/python benchmarks/bench_large.py            # about a minute
    .venv/bin/python benchmarks/bench_large.py --quick    # about ten seconds

Exit 0 whatever the figures (a benchmark, not a test); 1 if the final states disagree;
2 if the hand-written program cannot be built.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import raydamp

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_steps  # noqa: E402  (its build helpers: the same build directory and compiler)

PROGRAM = bench_steps.BUILD / "benchmarks" / "handwritten_chain"
ALPHA, BETA, H = 0.25, 1.0, 0.05
BYTES_PER_DOF_STEP = 48  # kick: read q, read+write p; drift: read p, read+write q
TARGET_RATE = 5e8
TARGET_RATIO = 0.5


def build() -> None:
    bench_steps.build(reconfigure=False)  # configures build/bench and builds its program
    bench_steps.run_quietly([bench_steps.find_tool("cmake") or "cmake", "--build", str(bench_steps.BUILD),
                             "--target", "handwritten_chain"])
    if not PROGRAM.exists():
        raise OSError(f"{PROGRAM} was not produced")


def hand(*args) -> dict:
    done = subprocess.run([str(PROGRAM), *map(str, args)], capture_output=True, text=True, check=True)
    return json.loads(done.stdout)


def raydamp_run(n: int, steps: int, rounds: int, method: str = "sv", dampers=None, eps: float = 0.0):
    chain = raydamp.Chain(n, bond="fput", parameters={"alpha": ALPHA, "beta": BETA}, boundary="fixed",
                          dampers=dampers, eps=eps)
    q0, p0 = chain.normal_mode(1, amplitude=1.0)
    best, sol = math.inf, None
    for _ in range(rounds):
        sol = raydamp.integrate(chain, q0, p0, method=method, h=H, n_steps=steps, save_every=steps,
                                save_dofs=[n // 2])
        best = min(best, sol.wall_time)
    return best, sol, chain


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="2*10^7 DOF-steps per size, one round")
    args = parser.parse_args()
    work = 2 * 10**7 if args.quick else 5 * 10**8
    rounds = 1 if args.quick else 3
    try:
        build()
    except (OSError, subprocess.CalledProcessError) as error:
        print(f"bench_large: cannot build the hand-written loop: {error}", file=sys.stderr)
        return 2

    triad_n = 10**7
    triad = hand("triad", triad_n, 5 if args.quick else 20)
    bandwidth = 24 * triad_n / triad["seconds"]
    print(f"raydamp {raydamp.__version__}; load average {os.getloadavg()[0]:.1f} (2 cores shared: figures vary)")
    print(f"STREAM-like triad a = b + s c over 3 x {triad_n:.0e} doubles: {bandwidth / 1e9:.2f} GB/s "
          f"-> at most {bandwidth / BYTES_PER_DOF_STEP:.2e} DOF-steps/s for a state out of cache "
          f"({BYTES_PER_DOF_STEP} B per DOF-step)")
    print()
    print(f"FPUT chain (alpha = {ALPHA}, beta = {BETA}, fixed ends), sv (leapfrog), h = {H}; DOF-steps per second")
    print(f"{'N':>9} {'steps':>7} {'raydamp sv':>12} {'hand loop':>12} {'ratio':>6}   "
          f"{'3s, every 10th bond damped':>27}")
    agree = True
    for n in (10**3, 10**4, 10**5, 10**6):
        steps = max(10, work // n)
        seconds, sol, chain = raydamp_run(n, steps, rounds)
        ref = hand("chain", n, steps, H, ALPHA, BETA)
        rate, hand_rate = n * steps / seconds, n * steps / ref["seconds"]
        damped, _, _ = raydamp_run(n, steps, rounds, method="3s", eps=1.0,
                                   dampers={"bonds": list(range(9, n + 1, 10)), "c": 0.1})
        print(f"{n:>9.0e} {steps:>7} {rate:>12.3e} {hand_rate:>12.3e} {rate / hand_rate:>6.2f}   "
              f"{n * steps / damped:>27.3e}")
        # The same state: raydamp saved site n//2 at the end, the hand loop printed it.
        difference = max(abs(sol.q[-1, 0] - ref["q_mid"]), abs(sol.p[-1, 0] - ref["p_mid"]))
        if difference > 1e-10:
            print(f"  final states disagree at N = {n}: |difference| = {difference:.3g}")
            agree = False
        if n == 10**6:
            final = (rate, hand_rate)
    rate, hand_rate = final
    print()
    print(f"N = 10^6: raydamp {rate:.3e} DOF-steps/s (target >= {TARGET_RATE:.0e}: "
          f"{'met' if rate >= TARGET_RATE else 'NOT met'}), {rate / hand_rate:.0%} of the hand loop (target >= "
          f"{TARGET_RATIO:.0%}: {'met' if rate >= TARGET_RATIO * hand_rate else 'NOT met'}), "
          f"{rate * BYTES_PER_DOF_STEP / 1e9:.2f} GB/s of state traffic beside the triad's {bandwidth / 1e9:.2f}")
    print(f"final states {'agree' if agree else 'DISAGREE'} with the hand loop to 1e-10")
    return 0 if agree else 1


if __name__ == "__main__":
    raise SystemExit(main())
