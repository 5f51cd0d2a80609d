"""The extended-precision modal reference's self-checks on the benchmark's beam at 201 and 2,001 DOF: the same
computation in mpmath at 32 digits, and the dense double eigh solution, against it. A script of its own so that
modal_reference.py needs nothing from bench_vs_opensees.py (which imports it)."""

from __future__ import annotations

import numpy as np
import scipy.sparse.linalg as sla
from modal_reference import modal_reference


def main() -> None:
    import os
    import sys

    import scipy.linalg

    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from bench_vs_opensees import beam, lowest_frequencies

    import raydamp

    for elements in (67, 667):
        s = beam(elements)
        w = lowest_frequencies(s)
        alpha, beta = raydamp.rayleigh_coefficients(w[0], w[2], 0.02, 0.02)
        q0 = sla.spsolve(s.K.tocsc(), np.eye(s.n)[s.tip])
        T = 2 * (2 * np.pi / w[0])
        times = T * np.arange(1, 11) / 10
        norm = np.linalg.norm(q0)
        ref = modal_reference(s.M, s.K, alpha, beta, q0, times)
        print(f"beam n = {s.n}: {ref.describe()}")
        high = modal_reference(s.M, s.K, alpha, beta, q0, times, precision="mp", digits=32, start=ref.vectors)
        print(f"    the same in {high.describe()}")
        print(f"    longdouble against mpmath: {np.max(np.linalg.norm(ref.states - high.states, axis=1)) / norm:.1e}")
        w2, phi = scipy.linalg.eigh(s.K.toarray(), s.M.toarray())
        from bench_vs_opensees import ModalSolution

        dense = ModalSolution(lambda w2=w2, phi=phi: iter([(w2, phi)]), s.M, alpha, beta).at(q0, times)
        print(f"    dense eigh (double) against it: {np.max(np.linalg.norm(dense - ref.states, axis=1)) / norm:.1e}")


if __name__ == "__main__":
    main()
