"""Per-step cost of 3s, rks-midpoint, midpoint and gauss4 on linear structures against 3s's Chebyshev degree:
the figures behind raydamp.run.choose_method's DEGREE_LIMIT. Prints; never passes or fails.

    PYTHONPATH=python .venv/bin/python benchmarks/bench_choose_method.py
"""

import sys
import time
from pathlib import Path

import numpy as np

import raydamp

sys.path.insert(0, str(Path(__file__).parent))
from bench_vs_opensees import beam, chain, lowest_frequencies  # noqa: E402


def per_step(s, method, h, tableau=None):
    q0, p0 = np.zeros(s.dim), np.zeros(s.dim)
    q0[-1] = 1.0
    steps = max(20, int(2e6 / s.dim))
    best = np.inf
    for _ in range(2):
        start = time.perf_counter()
        raydamp.integrate(s, q0, p0, method=method, tableau=tableau, h=h, n_steps=steps, save_every=steps)
        best = min(best, time.perf_counter() - start)
    return best / steps


def main():
    for kind, size in [("chain", 200), ("chain", 2000), ("chain", 20000), ("beam", 67), ("beam", 667)]:
        st = chain(size) if kind == "chain" else beam(size)
        w = lowest_frequencies(st)
        alpha, beta = raydamp.rayleigh_coefficients(w[0], w[2], 0.02, 0.02)
        s = raydamp.LinearStructure(st.M, st.K, alpha=alpha, beta=beta)
        omega_max = np.sqrt(s.spectral_bound)
        for h_omega in (0.04, 0.2, 1.0, 1.8):
            h = h_omega / omega_max
            row = [f"{kind} {s.dim} DOF ({s.mass_kind})", f"h omega_max={h_omega}", f"degree={s.chebyshev_degrees(h)}"]
            for method, tableau in (("3s", None), ("rks", "midpoint"), ("midpoint", None), ("gauss4", None)):
                cost = per_step(s, method, h, tableau)
                row.append(f"{method}{'-' + tableau if tableau else ''} {cost * 1e6:.1f} us "
                           f"({cost / st.K.nnz * 1e9:.1f} ns/nnz)")
            print(" | ".join(row), flush=True)


if __name__ == "__main__":
    main()
