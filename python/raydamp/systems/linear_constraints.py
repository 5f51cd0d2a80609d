"""Linear constraints C q = 0 of a LinearStructure (multi-point constraints, rigid links, a rigid diaphragm),
by elimination: q = T y with T a sparse basis of C's null space, built once.

Each constraint row gets one "slave" coordinate among its non-zeros of at least a tenth of its largest: the
one in the fewest rows, then the largest (a diaphragm's node DOFs, not its centre's rotation); where that
choice leaves C's slave columns singular, a dense pivoted QR of C chooses. The others are kept:
q_kept = y, q_slave = -C_s^{-1} C_k y. So T is the identity on the kept
coordinates and, for the usual multi-point constraints (each slave in one row), as sparse as C. The structure
in y is a LinearStructure of n - m coordinates,

    M_y = T^T M T,   K_y = T^T K T,   f_y = T^T f,   and the same alpha, beta,

because T^T (alpha M + beta K) T = alpha M_y + beta K_y: Rayleigh damping stays Rayleigh, and every method
that runs a LinearStructure (the exact damping flows, the implicit ones, noise) runs it exactly. A lumped M
stays lumped where every slave follows one kept coordinate (tied DOFs). Back in the structure's coordinates,
q = T y and p = M T M_y^{-1} p_y (the momenta of the velocity T y').
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["Tie", "tie"]

# A pivot below this fraction of its row's largest entry is not taken as a slave (the choice would amplify).
_PIVOT_FRACTION = 0.1
# T's entries below this times its largest are rounding of exact zeros (a slave that follows no kept DOF).
_DROP = 1e-14


class Tie:
    """A LinearStructure with C q = 0 eliminated: ``reduced`` is the structure in the kept coordinates y,
    ``T`` (n x r, scipy.sparse CSC) maps them back, q = T y; ``kept`` and ``slaves`` are the coordinates'
    indices. Run ``reduced`` like any LinearStructure, with ``reduce_state`` for the initial state and
    ``reduce_load`` / ``reduce_influence`` for loads; ``expand`` gives q and p of the structure."""

    def __init__(self, structure, constraints, T, kept: np.ndarray, slaves: np.ndarray):
        self.structure = structure
        self.C = constraints
        self.T = T
        self.kept = kept
        self.slaves = slaves
        mass = _symmetric(T.T @ structure.M @ T)
        stiffness = _symmetric(T.T @ structure.K @ T)
        self.reduced = type(structure)(mass, stiffness, alpha=structure.alpha, beta=structure.beta,
                                       f=self.reduce_load(structure.f) if structure.f.any() else None,
                                       allow_indefinite_stiffness=structure.allow_indefinite_stiffness)

    def __repr__(self) -> str:
        return f"Tie({self.C.shape[0]} constraints: n = {self.T.shape[0]} -> {self.T.shape[1]})"

    def residual(self, q) -> np.ndarray:
        """C q for each row of q (..., n): how far q is from the constraints."""
        q = np.asarray(q, dtype=float)
        return (self.C @ q.reshape(-1, q.shape[-1]).T).T.reshape(*q.shape[:-1], self.C.shape[0])

    def reduce_state(self, q0, p0) -> tuple[np.ndarray, np.ndarray]:
        """(y0, p_y0) of a state (q0, p0) of the structure: C q0 = 0 and C M^{-1} p0 = 0, each to 1e-12 of its
        size (refused otherwise, naming the worst row)."""
        q0 = self._vector("q0", q0)
        p0 = self._vector("p0", p0)
        self._require_on("q0", q0)
        self._require_on("p0", _solve_mass(self.structure.M, p0), what="its velocity M^-1 p0")
        return q0[self.kept].copy(), self.T.T @ p0

    def reduce_load(self, f) -> np.ndarray:
        """f_y = T^T f: a load of the structure as the reduced structure takes it (the same virtual work)."""
        return self.T.T @ self._vector("f", f)

    def reduce_influence(self, r) -> np.ndarray:
        """r_y with T r_y = r, for a ground motion's influence vector r (a rigid-body motion satisfies C r = 0,
        as a diaphragm's or a tie's does): then -M_y r_y a_g = T^T (-M r a_g)."""
        r = self._vector("r", r)
        self._require_on("r", r)
        return r[self.kept].copy()

    def expand(self, y, p_y=None) -> tuple[np.ndarray, np.ndarray | None]:
        """(q, p) of the structure from rows of y (..., r) and of p_y: q = T y, p = M T M_y^{-1} p_y."""
        y = np.asarray(y, dtype=float)
        q = (self.T @ y.reshape(-1, y.shape[-1]).T).T.reshape(*y.shape[:-1], self.T.shape[0])
        if p_y is None:
            return q, None
        p_y = np.asarray(p_y, dtype=float)
        flat = p_y.reshape(-1, p_y.shape[-1]).T
        velocity = self.T @ _solve_mass(self.reduced.M, flat)
        p = (self.structure.M @ velocity).T.reshape(*p_y.shape[:-1], self.T.shape[0])
        return q, p

    def _vector(self, name: str, value) -> np.ndarray:
        n = self.T.shape[0]
        try:
            out = np.asarray(value, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            raise ValueError(f"{name} must be a vector of {n} numbers") from None
        if out.shape != (n,) or not np.isfinite(out).all():
            raise ValueError(f"{name} must be a vector of {n} finite numbers")
        return out

    def _require_on(self, name: str, x: np.ndarray, what: str = "it") -> None:
        r = self.C @ x
        size = abs(self.C) @ np.abs(x)
        bad = np.flatnonzero(np.abs(r) > 1e-12 * np.maximum(size, np.finfo(float).tiny))
        if bad.size:
            i = int(bad[np.argmax(np.abs(r[bad]))])
            raise ValueError(f"{name}: {what} does not satisfy constraints[{i}]: (C {name})[{i}] = {r[i]:.3g}")


def tie(structure, constraints) -> Tie:
    """Eliminate the linear constraints C q = 0 (m x n: a scipy.sparse matrix or an array) from a
    LinearStructure; see :class:`Tie` and the module's docstring."""
    import scipy.sparse as sparse

    n = structure.dim
    if sparse.issparse(constraints):
        C = sparse.csr_matrix(constraints, dtype=float)
    else:
        try:
            array = np.asarray(constraints, dtype=float)
        except (TypeError, ValueError):
            raise ValueError("constraints: must be a matrix C (m x n) of numbers, C q = 0") from None
        if array.ndim == 1:
            array = array.reshape(1, -1)
        if array.ndim != 2:
            raise ValueError(f"constraints: must be a matrix C (m x n), got shape {array.shape}")
        C = sparse.csr_matrix(array)
    C.sum_duplicates()
    C.eliminate_zeros()
    m = C.shape[0]
    if C.shape[1] != n:
        raise ValueError(f"constraints: C must have n = {n} columns (the structure's coordinates), got {C.shape[1]}")
    if m == 0 or m >= n:
        raise ValueError(f"constraints: C must have 1 to {n - 1} rows, got {m}")
    if not np.isfinite(C.data).all():
        raise ValueError("constraints: C must be finite")
    empty = np.flatnonzero(np.diff(C.indptr) == 0)
    if empty.size:
        raise ValueError(f"constraints[{int(empty[0])}]: the row is zero (it constrains nothing)")
    slaves = _greedy_slaves(C)
    factor = _factor(C, slaves) if slaves is not None else None
    if factor is None:
        slaves = _pivoted_slaves(C)
        factor = _factor(C, slaves)
        if factor is None:  # pragma: no cover - the QR's pivots were checked
            raise ValueError("constraints: C's rows are dependent")
    kept = np.setdiff1d(np.arange(n), slaves)
    T = _basis(C, slaves, kept, factor)
    return Tie(structure, C, T, kept, np.asarray(slaves))


def _greedy_slaves(C) -> list[int] | None:
    counts = np.bincount(C.indices, minlength=C.shape[1])
    taken: set[int] = set()
    slaves = []
    for i in range(C.shape[0]):
        cols = C.indices[C.indptr[i]:C.indptr[i + 1]]
        values = np.abs(C.data[C.indptr[i]:C.indptr[i + 1]])
        best, key = -1, None
        for j, v in zip(cols, values):
            if j in taken or v < _PIVOT_FRACTION * values.max():
                continue
            candidate = (counts[j], -v, j)
            if key is None or candidate < key:
                best, key = int(j), candidate
        if best < 0:
            return None
        taken.add(best)
        slaves.append(best)
    return slaves


def _pivoted_slaves(C) -> list[int]:
    from scipy.linalg import qr

    _, R, pivots = qr(C.toarray(), mode="economic", pivoting=True)
    m = C.shape[0]
    diagonal = np.abs(np.diag(R))
    rank = int(np.sum(diagonal > 1e-12 * diagonal[0]))
    if rank < m:
        raise ValueError(f"constraints: C's rows are dependent (rank {rank} < {m} rows); give independent ones")
    return [int(j) for j in pivots[:m]]


def _factor(C, slaves):
    from scipy.sparse.linalg import splu

    block = C[:, slaves].tocsc()
    try:
        lu = splu(block)
    except RuntimeError:  # exactly singular
        return None
    pivots = np.abs(lu.U.diagonal())
    if not (pivots > 1e-12 * max(pivots.max(), np.finfo(float).tiny)).all():
        return None
    return lu


def _basis(C, slaves, kept, lu):
    import scipy.sparse as sparse

    n = C.shape[1]
    free = C[:, kept].tocsc()
    touched = np.flatnonzero(np.diff(free.indptr))  # kept columns some constraint involves
    rows = [kept]
    cols = [np.arange(kept.size)]
    values = [np.ones(kept.size)]
    if touched.size:
        block = -lu.solve(free[:, touched].toarray())  # slaves in terms of the kept coordinates they follow
        block[np.abs(block) < _DROP * max(np.abs(block).max(), np.finfo(float).tiny)] = 0.0
        r, c = np.nonzero(block)
        rows.append(np.asarray(slaves)[r])
        cols.append(touched[c])
        values.append(block[r, c])
    return sparse.csc_matrix((np.concatenate(values), (np.concatenate(rows), np.concatenate(cols))),
                             shape=(n, kept.size))


def _symmetric(matrix):
    return ((matrix + matrix.T) * 0.5).tocsc()


def _solve_mass(mass, rhs) -> Any:
    from scipy.sparse.linalg import splu

    return splu(mass.tocsc()).solve(np.asarray(rhs, dtype=float))
