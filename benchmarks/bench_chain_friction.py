#!/usr/bin/env python3
"""DOF-steps per second of a damped 10^6-site FPUT chain (issue 25, point 4): friction on every
site against the undamped chain, beside a NumPy loop of the same damped step.

Cases, all FPUT (alpha = 0.25, beta = 1, fixed ends), h = 0.05, 3s unless named:
  undamped            eps = 0 (3s is then sv: drift and kick, two passes over the state)
  friction, one c     friction on every site, one coefficient (A = a I: one scalar multiply of p)
  friction, c_i       friction on every site, a coefficient per site (one factor per site)
  friction, 2s        friction on every site, one c, by 2s (the exact kick-damp flow)
  friction, W         friction on every site, one c, 3s with the damping work tracked (whole steps,
                      the dissipated power at every step)
  dashpots, pairs     a dashpot on every other bond: disjoint 2x2 blocks covering every site
                      (a dashpot on every bond of a long chain is one block of 10^6 sites, refused)
  dashpots, 1/10      a dashpot on every 10th bond (bench_large.py's damped case)
  NumPy 3s            the friction-on-every-site 3s step (one c) in NumPy, in place, no temporaries
                      beyond one gradient buffer: the baseline issue 25 measured raydamp against
JAX is timed too when it is importable (it is not a dependency; nothing installs it).

Runs are interleaved (every case once per round) and the median over rounds is printed, so a
busy machine (two shared cores) shifts all cases alike. The target: friction on every site
within 1.3x of the undamped chain's DOF-steps/s (ratio undamped / damped <= 1.3).

    .venv/bin/python benchmarks/bench_chain_friction.py           # about a minute
    .venv/bin/python benchmarks/bench_chain_friction.py --quick   # a few seconds

Exit 0 whatever the figures (a benchmark, not a test); 1 if raydamp and NumPy end in different states.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

import raydamp

N = 10**6
ALPHA, BETA, H, EPS, C = 0.25, 1.0, 0.05, 1.0, 0.1
TARGET = 1.3


def chain(dampers=None, eps=EPS):
    return raydamp.Chain(N, bond="fput", parameters={"alpha": ALPHA, "beta": BETA}, boundary="fixed",
                         dampers=dampers, eps=eps if dampers else 0.0)


def raydamp_case(model, method="3s", work=False):
    q0, p0 = model.normal_mode(1, amplitude=1.0)

    def run(steps):
        sol = raydamp.integrate(model, q0, p0, method=method, h=H, n_steps=steps, save_every=steps,
                                save_dofs=[N // 2], work=work)
        assert sol.success, sol.message
        return sol.wall_time, (sol.q[-1, 0], sol.p[-1, 0])

    return run


def numpy_3s(q0, p0, steps, c=C, mass=1.0):
    """Merged 3s with friction c on every site: damp h/2, [drift h/2, kick h, drift h/2, damp h]*, ..."""
    q, p = q0.copy(), p0.copy()
    g = np.empty(N + 1)   # the force of bond b (b = 0..N, walls at both ends)
    r = np.empty(N + 1)
    decay_half, decay = np.exp(-0.5 * H * EPS * c / mass), np.exp(-H * EPS * c / mass)
    s = 0.5 * H / mass
    p *= decay_half
    for k in range(steps):
        q += s * p
        # bond stretches r_b = q_b - q_{b-1} with q_{-1} = q_N = 0; force V'(r) = r + alpha r^2 + beta r^3
        r[0] = q[0]
        np.subtract(q[1:], q[:-1], out=r[1:N])
        r[N] = -q[-1]
        np.multiply(r, BETA, out=g)
        g += ALPHA
        g *= r
        g += 1.0
        g *= r
        # dV/dq_i = V'(r_i) - V'(r_{i+1}): p <- p - h (g[:-1] - g[1:])
        p -= H * g[:-1]
        p += H * g[1:]
        q += s * p
        p *= decay if k + 1 < steps else decay_half
    return q, p


def jax_3s():
    try:
        import jax
        import jax.numpy as jnp
    except ImportError:
        return None
    jax.config.update("jax_enable_x64", True)
    decay = float(np.exp(-H * EPS * C))
    s = 0.5 * H

    def step(state, _):
        q, p = state
        q = q + s * p
        r = jnp.diff(jnp.concatenate([jnp.zeros(1), q, jnp.zeros(1)]))
        f = r * (1.0 + r * (ALPHA + BETA * r))
        p = p - H * (f[:-1] - f[1:])
        q = q + s * p
        return (q, decay * p), None

    def run(q0, p0, steps):
        body = jax.jit(lambda q, p: jax.lax.scan(step, (q, p), None, length=steps)[0])
        q, p = jnp.asarray(q0), jnp.asarray(p0)
        body(q, p)[0].block_until_ready()  # compile outside the timing
        start = time.perf_counter()
        q, p = body(q, p)
        q.block_until_ready()
        return time.perf_counter() - start

    return run


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="40 steps, two rounds")
    parser.add_argument("--steps", type=int, default=None, help="steps per run (default 200)")
    parser.add_argument("--rounds", type=int, default=None, help="interleaved rounds (default 5)")
    args = parser.parse_args()
    steps = args.steps or (40 if args.quick else 200)
    rounds = args.rounds or (2 if args.quick else 5)

    rng = np.random.default_rng(0)
    every_site = list(range(N))
    per_site_c = [float(x) for x in rng.uniform(0.05, 0.15, N)]
    friction = chain({"sites": every_site, "c": C})
    cases = {
        "undamped": raydamp_case(chain()),
        "friction, one c": raydamp_case(friction),
        "friction, c_i": raydamp_case(chain({"sites": every_site, "c": per_site_c})),
        "friction, 2s": raydamp_case(friction, method="2s"),
        "friction, W": raydamp_case(friction, work=True),
        "dashpots, pairs": raydamp_case(chain({"bonds": list(range(1, N + 1, 2)), "c": C})),
        "dashpots, 1/10": raydamp_case(chain({"bonds": list(range(9, N + 1, 10)), "c": C})),
    }
    q0, p0 = friction.normal_mode(1, amplitude=1.0)
    times: dict[str, list[float]] = {name: [] for name in [*cases, "NumPy 3s"]}
    jax_run = jax_3s()
    if jax_run is not None:
        times["JAX 3s"] = []
    agree = True
    for _ in range(rounds):
        for name, run in cases.items():
            seconds, final = run(steps)
            times[name].append(seconds)
            if name == "friction, one c":
                ours = final
        start = time.perf_counter()
        q, p = numpy_3s(q0, p0, steps)
        times["NumPy 3s"].append(time.perf_counter() - start)
        difference = max(abs(q[N // 2] - ours[0]), abs(p[N // 2] - ours[1]))
        if difference > 1e-10:
            print(f"raydamp and NumPy disagree at site {N // 2}: |difference| = {difference:.3g}")
            agree = False
        if jax_run is not None:
            times["JAX 3s"].append(jax_run(q0, p0, steps))

    print(f"raydamp {raydamp.__version__}; N = {N:.0e}, {steps} steps, median of {rounds} interleaved rounds; "
          f"load average {os.getloadavg()[0]:.1f} (2 cores shared: figures vary)")
    print(f"FPUT chain (alpha = {ALPHA}, beta = {BETA}, fixed ends), h = {H}, eps = {EPS}, c = {C}")
    print(f"{'case':<18} {'DOF-steps/s':>12} {'undamped / case':>16}")
    undamped = N * steps / statistics.median(times["undamped"])
    rates = {}
    for name, t in times.items():
        rates[name] = N * steps / statistics.median(t)
        print(f"{name:<18} {rates[name]:>12.3e} {undamped / rates[name]:>16.2f}")
    if jax_run is None:
        print("JAX: not installed (not timed)")
    ratio = undamped / rates["friction, one c"]
    ratio_ci = undamped / rates["friction, c_i"]
    print()
    print(f"friction on every site: {ratio:.2f}x (one c), {ratio_ci:.2f}x (c_i) the undamped chain's time per step "
          f"(target <= {TARGET}: {'met' if max(ratio, ratio_ci) <= TARGET else 'NOT met'}); "
          f"{rates['friction, one c'] / rates['NumPy 3s']:.1f}x the NumPy loop's rate")
    print(f"final states {'agree' if agree else 'DISAGREE'} with NumPy to 1e-10")
    return 0 if agree else 1


if __name__ == "__main__":
    raise SystemExit(main())
