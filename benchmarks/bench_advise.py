"""What raydamp.advise costs beside the run it recommends (issue 43: advise costs <= 5% of that run, or <= 2 s).

Cases: the 201-DOF cantilever (2% Rayleigh at modes 1 and 3) released from its static tip deflection over two
periods, and a 12 x 12 membrane released from a static deflection, at tolerances 1e-4 and 1e-6. Each row: advise's
wall time (measure=False, and measure=True which also times trial steps) and the processor time of the first (all
threads: on a loaded machine it stands for a quiet machine's wall time, with OPENBLAS_NUM_THREADS=1 so that idle BLAS
threads do not spin), the recommended method, its steps, its predicted time and the measured time of the run it
recommends.

    python benchmarks/bench_advise.py
"""

from __future__ import annotations

import math
import time

import numpy as np
import scipy.sparse as sparse
import scipy.sparse.linalg as sla

import raydamp


def cantilever(elements: int = 67):
    """2-D Euler-Bernoulli cantilever, 3 DOF per node, lumped mass with rotary inertia (as tests/test_advise_start)."""
    length, area, inertia = 1.0 / elements, 0.05, 0.05 ** 3 / 12
    ea, ei, L = area / length, inertia, length
    ke = np.array([[ea, 0, 0, -ea, 0, 0],
                   [0, 12 * ei / L ** 3, 6 * ei / L ** 2, 0, -12 * ei / L ** 3, 6 * ei / L ** 2],
                   [0, 6 * ei / L ** 2, 4 * ei / L, 0, -6 * ei / L ** 2, 2 * ei / L],
                   [-ea, 0, 0, ea, 0, 0],
                   [0, -12 * ei / L ** 3, -6 * ei / L ** 2, 0, 12 * ei / L ** 3, -6 * ei / L ** 2],
                   [0, 6 * ei / L ** 2, 2 * ei / L, 0, -6 * ei / L ** 2, 4 * ei / L]])
    n = 3 * elements
    K, mass = np.zeros((n + 3, n + 3)), np.zeros(n + 3)
    for e in range(elements):
        dofs = slice(3 * e, 3 * e + 6)
        K[dofs, dofs] += ke
        mass[3 * e: 3 * e + 6] += [area * L / 2, area * L / 2, area * L / 2 * L ** 2 / 12] * 2
    return sparse.diags(mass[3:]).tocsc(), sparse.csc_matrix((K[3:, 3:] + K[3:, 3:].T) / 2)


def membrane(side: int = 12):
    T = sparse.diags([-np.ones(side - 1), 2 * np.ones(side), -np.ones(side - 1)], [-1, 0, 1])
    K = (sparse.kron(T, sparse.identity(side)) + sparse.kron(sparse.identity(side), T)).tocsc()
    return sparse.identity(side * side, format="csc"), K


def rayleigh(M, K):
    """alpha, beta giving 2% at modes 1 and 3."""
    w = np.sqrt(np.sort(sla.eigsh(K, k=3, M=M, sigma=0, which="LM", return_eigenvectors=False)))
    w1, w3, zeta = w[0], w[2], 0.02
    return 2 * zeta * w1 * w3 / (w1 + w3), 2 * zeta / (w1 + w3), w1


def main() -> None:
    print(f"{'case':<20}{'tol':>8}{'advise s':>10}{'cpu s':>8}{'+measure s':>12}  {'recommended':<16}{'steps':>9}"
          f"{'predicted s':>13}{'run s':>9}{'advise/run':>12}")
    for name, (M, K), load_dof in (("cantilever static", cantilever(), -2), ("membrane static", membrane(), 66)):
        alpha, beta, w1 = rayleigh(M, K)
        structure = raydamp.LinearStructure(M, K, alpha=alpha, beta=beta)
        e = np.zeros(M.shape[0])
        e[load_dof] = 1.0
        q0 = sla.spsolve(K.tocsc(), e)
        q0 /= np.abs(q0).max()
        t_end = 2 * 2 * math.pi / w1
        for tol in (1e-4, 1e-6):
            start, cpu = time.perf_counter(), time.process_time()
            advice = raydamp.advise(structure, t_end, tol, q0=q0, p0=0 * q0, measure=False)
            plain, cpu = time.perf_counter() - start, time.process_time() - cpu
            start = time.perf_counter()
            advice = raydamp.advise(structure, t_end, tol, q0=q0, p0=0 * q0, measure=True)
            measured = time.perf_counter() - start
            best = advice.recommended
            start = time.perf_counter()
            raydamp.integrate(structure, q0, 0 * q0, **best.options, n_steps=best.steps, save_every=best.steps)
            run = time.perf_counter() - start
            label = best.method + (f"/{best.tableau}" if best.tableau else "")
            print(f"{name:<20}{tol:>8.0e}{plain:>10.2f}{cpu:>8.2f}{measured:>12.2f}  {label:<16}{best.steps:>9d}"
                  f"{best.seconds:>13.3g}{run:>9.3g}{plain / run:>12.2f}")


if __name__ == "__main__":
    main()
