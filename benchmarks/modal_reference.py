"""An extended-precision modal reference for free vibration of a linear structure (issue 43, item 3).

The problem is M q'' + C q' + K q = 0, C = alpha M + beta K, from (q0, 0), for the float64 M, K and q0
given: its exact solution, not the solution of some nearby matrices. A double-precision route cannot give it
for a stiff structure. scipy.linalg.eigh of the dense pencil resolves the lowest eigenvalue only to about
u ||K|| / lambda_1 = u cond(K) (u = 2.2e-16; cond(K) ~ (L / l)^4 for a beam of elements of length l), and so
does a double sparse solve: at 2,001 DOF that is already about 1e-6 of the answer.

The route here: the lowest k eigenpairs of (K, M) by subspace iteration with p = 2k vectors (Y = K^-1 M X,
then Rayleigh-Ritz), every vector kept in extended precision, and the exact modal solution from them:

    q(t) = sum_{j <= k} phi_j a_j g(lambda_j, t),   a_j = phi_j^T M q0,
    g(lambda, t): the solution of g'' + (alpha + beta lambda) g' + lambda g = 0, g(0) = 1, g'(0) = 0.

- K^-1 is applied by iterative refinement: double precision's sparse LU (SuperLU) gives the corrections,
  and the residual b - K x is formed in double-double arithmetic (each product of a double entry of K and a
  part of x exact by Dekker's splitting, the sums compensated), so that x converges to the working precision
  while cond(K) u < 1 (measured contraction per step: 5e-10 at 201 DOF, 9e-7 at 2,001, 1e-3 at 20,001).
- Rayleigh-Ritz needs K only through K Y = M X: the projected matrices are Y^T M X and Y^T M Y (M is well
  conditioned), and their small generalized eigenproblem is solved in mpmath.
- The modes left out (j > k) are not neglected blindly: at each saved time their contribution is bounded by
  sup_{lambda >= lambda_{k+1}} |g(lambda, t)| ||(I - P_k) q0||_M / sqrt(mu_min(M)), printed as `tail`. With
  Rayleigh damping the higher modes decay at least as fast as exp(-min(zeta omega, 1 / beta) t), so from the
  first saved time on a dozen modes leave a tail far below the figures compared.

Two working precisions run the same code: "longdouble" (numpy's 80-bit extended type, 64-bit significand,
u = 5.4e-20) and "mp" (numpy object arrays of mpmath numbers, at mpmath's working precision, e.g. 40 digits):
the second checks the first. reference(..., check=...) gives both for the caller to compare.

    .venv/bin/python benchmarks/check_modal_reference.py    # the self-checks at 201 and 2,001 DOF
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import mpmath
import numpy as np
import scipy.sparse as sparse
import scipy.sparse.linalg as sla

__all__ = ["ModalReference", "modal_reference", "decay_bound"]

_SPLIT = 134217729.0  # 2^27 + 1: Dekker's splitter for float64


# -- double-double arithmetic on float64 arrays ----------------------------------------------------

def _two_sum(a, b):
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


def _split(a):
    c = _SPLIT * a
    hi = c - (c - a)
    return hi, a - hi


def _two_product(a, b):
    """a * b = p + e exactly (float64 a, b; no overflow)."""
    p = a * b
    ah, al = _split(a)
    bh, bl = _split(b)
    return p, ((ah * bh - p) + ah * bl + al * bh) + al * bl


def _dd_add(xh, xl, yh, yl):
    s, e = _two_sum(xh, yh)
    e = e + (xl + yl)
    return _two_sum(s, e)


# -- the matrices as padded rows: values (n, w) float64, columns (n, w) -------------------------------

@dataclass
class _Rows:
    values: np.ndarray
    columns: np.ndarray

    @classmethod
    def of(cls, A) -> _Rows:
        A = sparse.csr_matrix(A)
        n = A.shape[0]
        counts = np.diff(A.indptr)
        w = int(counts.max())
        values = np.zeros((n, w))
        columns = np.zeros((n, w), dtype=np.int64)
        for i in range(n):  # once per matrix
            a, b = A.indptr[i], A.indptr[i + 1]
            values[i, :b - a] = A.data[a:b]
            columns[i, :b - a] = A.indices[a:b]
            columns[i, b - a:] = i  # padding: value 0
        return cls(values, columns)

    def times(self, X):
        """A X in X's own arithmetic (longdouble, or mpmath objects: then each product and sum at mpmath's
        precision)."""
        out = None
        for j in range(self.values.shape[1]):
            term = X[self.columns[:, j]] * self.values[:, j, None].astype(X.dtype if X.dtype != object else float)
            out = term if out is None else out + term
        return out

    def residual_dd(self, B, X) -> np.ndarray:
        """B - A X for longdouble B and X, formed in double-double, rounded to float64 (relative to itself)."""
        xh = X.astype(np.float64)
        xl = (X - xh).astype(np.float64)  # exact: a longdouble's significand is 64 bits
        bh = B.astype(np.float64)
        bl = (B - bh).astype(np.float64)
        sh, sl = bh, bl
        for j in range(self.values.shape[1]):
            a = -self.values[:, j, None]
            ph, pl = _two_product(a, xh[self.columns[:, j]])
            pl = pl + a * xl[self.columns[:, j]]
            sh, sl = _dd_add(sh, sl, ph, pl)
        return sh + sl


# -- the working precisions ----------------------------------------------------------------------------

class _Working:
    """Vectors in the working precision: "longdouble" or "mp" (mpmath objects at mpmath.mp.dps digits)."""

    def __init__(self, precision: str, digits: int = 40):
        self.precision, self.digits = precision, digits
        self.mp = precision == "mp"
        self.eps = 10.0 ** -digits if self.mp else float(np.finfo(np.longdouble).eps)

    def array(self, x) -> np.ndarray:
        x = np.asarray(x, dtype=np.float64)
        if not self.mp:
            return x.astype(np.longdouble)
        out = np.empty(x.shape, dtype=object)
        out.flat[:] = [mpmath.mpf(float(v)) for v in x.flat]
        return out

    def plus_float(self, X, D):
        """X + D for a float64 correction D."""
        return X + (D.astype(np.longdouble) if not self.mp else self.array(D))

    def to_mp(self, x) -> mpmath.mpf:
        if self.mp:
            return mpmath.mpf(x)
        hi = float(x)
        return mpmath.mpf(hi) + mpmath.mpf(float(x - np.longdouble(hi)))

    def from_mp(self, values) -> np.ndarray:
        values = list(values)
        if self.mp:
            out = np.empty(len(values), dtype=object)
            out[:] = values
            return out
        hi = np.array([float(v) for v in values])
        lo = np.array([float(v - mpmath.mpf(h)) for v, h in zip(values, hi)])
        return hi.astype(np.longdouble) + lo.astype(np.longdouble)

    def to_float(self, X) -> np.ndarray:
        return X.astype(np.float64) if not self.mp else np.vectorize(float, otypes=[np.float64])(X)

    def norm(self, X) -> float:
        return float(np.sqrt(np.sum(self.to_float(X) ** 2)))


class _Solver:
    """x = K^-1 b in the working precision: double LU corrections, double-double (or mpmath) residuals."""

    def __init__(self, K, working: _Working):
        self.K = _Rows.of(K)
        self.lu = sla.splu(sparse.csc_matrix(K))
        self.working = working
        self.contraction = 0.0   # the largest ratio of successive corrections seen (cond(K) u, measured)
        self.steps = 0

    def solve(self, B) -> np.ndarray:
        w = self.working
        X = w.array(self.lu.solve(w.to_float(B)))
        previous, first = None, True
        for _ in range(60):
            if not w.mp:
                R = self.K.residual_dd(B, X)
            else:  # the residual at twice the working digits, as double-double is to longdouble
                with mpmath.workdps(2 * w.digits):
                    R = w.to_float(B - self.K.times(X))
            D = self.lu.solve(R)
            X = w.plus_float(X, D)
            self.steps += 1
            size, scale = float(np.abs(D).max()), float(np.abs(w.to_float(X)).max())
            if previous and first:  # the first ratio: later ones meet the residual's rounding floor
                self.contraction, first = max(self.contraction, size / previous), False
            if size <= 0.5 * w.eps * scale:
                return X
            if previous is not None and size > 0.5 * previous:
                # No longer shrinking: the residual's own rounding (double-double: 1e-32 cond(K)), or cond(K)
                # u_double near 1, where refinement does not converge at all.
                if size <= 1e4 * w.eps * scale:
                    return X
                raise RuntimeError(f"iterative refinement stalled (correction {size:.1e}, before {previous:.1e}): "
                                   "cond(K) u_double is not below 1")
            previous = size
        raise RuntimeError("iterative refinement did not converge in 60 steps")


# -- g(lambda, t) ---------------------------------------------------------------------------------------

def _g_mp(lam, t, alpha, beta):
    """g(lambda, t) in mpmath: g'' + c g' + lambda g = 0, g(0) = 1, g'(0) = 0, c = alpha + beta lambda; the roots
    r = -c/2 -+ sqrt(c^2/4 - lambda), written without cancellation, and the critical case as its limit."""
    c = alpha + beta * lam
    disc = c * c / 4 - lam
    if disc == 0:
        return (1 + c * t / 2) * mpmath.exp(-c * t / 2)
    root = mpmath.sqrt(disc)  # real or imaginary
    r2 = -c / 2 - root
    r1 = lam / r2
    value = (r1 * mpmath.exp(r2 * t) - r2 * mpmath.exp(r1 * t)) / (r1 - r2)
    return mpmath.re(value)


def decay_bound(lam_low: float, lam_high: float, t: float, alpha: float, beta: float, points: int = 20001) -> float:
    """sup of |g(lambda, t)| over lambda in [lam_low, lam_high], on a geometric grid of `points` values (g is
    smooth in lambda; the sup is taken with a factor 2 for what the grid misses)."""
    lam = np.geomspace(lam_low, lam_high, points)
    c = alpha + beta * lam
    root = np.sqrt((c * c / 4 - lam).astype(complex))
    r2 = -c / 2 - root
    r1 = lam / r2
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        apart = ((r1 * np.exp(r2 * t) - r2 * np.exp(r1 * t)) / (r1 - r2)).real
        # near critical damping (r1 = r2) the same function as e^{-ct/2} (cosh(st) + (c/2) sinh(st)/s), s = root
        st = root * t
        sinhc = np.where(np.abs(st) < 1e-6, t * (1 + st * st / 6), np.sinh(st) / np.where(root == 0, 1, root))
        near = (np.exp(-c * t / 2) * (np.cosh(st) + c / 2 * sinhc)).real
    g = np.where(np.abs(st) < 1.0, near, apart)
    g = np.where(np.isfinite(g), np.abs(g), 1.0)
    return float(min(1.0, 2 * g.max()))


# -- the reference ---------------------------------------------------------------------------------------

@dataclass
class ModalReference:
    states: np.ndarray        # (times, n) float64: q at the saved times
    frequencies: np.ndarray   # omega_j of the modes kept
    tail: float               # bound on the modes left out, relative to ||q0||, over the saved times
    residual: float           # max_j ||K phi_j - lambda_j M phi_j|| / (||K||_1 ||phi_j||), in double-double
    iterations: int
    contraction: float        # iterative refinement's measured contraction (cond(K) u_double)
    seconds: float
    precision: str
    vectors: np.ndarray       # (n, 2 modes) float64: the last Ritz vectors, rounded (a start for another run)

    def describe(self) -> str:
        return (f"{len(self.frequencies)} modes by subspace iteration in {self.precision} ({self.iterations} "
                f"iterations, eigen-residual {self.residual:.0e}, refinement contraction {self.contraction:.0e}), "
                f"tail bound {self.tail:.0e}, {self.seconds:.1f} s")


def modal_reference(M, K, alpha: float, beta: float, q0, times, modes: int = 12, precision: str = "longdouble",
                    digits: int = 40, seed: int = 0, max_iterations: int = 200, start=None) -> ModalReference:
    """The exact modal solution of M q'' + (alpha M + beta K) q' + K q = 0 from (q0, 0) at `times` (all > 0), for
    the float64 M, K (sparse, symmetric positive definite) and q0 as given, from the lowest `modes` eigenpairs
    computed in `precision` ("longdouble", or "mp" at `digits` digits), with the bound on the rest. `start`: the
    (n, 2 modes) vectors to begin with (another run's Ritz vectors, rounded to double: the iteration converges to
    the exact eigenvectors from any start; a near one saves iterations); default random."""
    began = time.perf_counter()
    with mpmath.workdps(digits if precision == "mp" else 30):
        w = _Working(precision, digits)
        M = sparse.csr_matrix(M)
        K = sparse.csr_matrix(K)
        n, k = K.shape[0], modes
        p = min(n, 2 * k)
        Mrows = _Rows.of(M)
        solver = _Solver(K, w)
        X = w.array(np.random.default_rng(seed).standard_normal((n, p)) if start is None else start)
        for iteration in range(1, max_iterations + 1):  # noqa: B007 - read after the loop (the count it took)
            MX = Mrows.times(X)
            Y = solver.solve(MX)
            MY = Mrows.times(Y)
            Kp = mpmath.matrix([[w.to_mp(v) for v in row] for row in (Y.T @ MX)])
            Mp = mpmath.matrix([[w.to_mp(v) for v in row] for row in (Y.T @ MY)])
            theta, Z = _ritz(Kp, Mp)
            before, X = X, Y @ _coefficients(w, Z)
            # Ritz vectors converge linearly (lambda_j / lambda_{p+1} an iteration), Ritz values twice as fast:
            # stop on the vectors, each compared with the previous one up to its sign.
            change = max(min(w.norm(X[:, j] - before[:, j]), w.norm(X[:, j] + before[:, j])) / w.norm(X[:, j])
                         for j in range(k))
            if change <= (1e3 * w.eps if not w.mp else 10.0 ** (10 - digits)):
                break
        else:
            raise RuntimeError(f"subspace iteration did not converge in {max_iterations} iterations")
        lam = [theta[j] for j in range(k)]
        phi = X[:, :k]  # M-orthonormal Ritz vectors
        MPhi = Mrows.times(phi)
        residual, norm_K = 0.0, float(sla.norm(K, 1))
        for j in range(k):
            lam_j = w.from_mp([lam[j]])[0]
            if not w.mp:  # lambda M phi - K phi in double-double
                r = solver.K.residual_dd(lam_j * MPhi[:, j:j + 1], phi[:, j:j + 1])
            else:
                r = w.to_float(lam_j * MPhi[:, j:j + 1] - solver.K.times(phi[:, j:j + 1]))
            residual = max(residual, float(np.linalg.norm(r)) / (norm_K * w.norm(phi[:, j])))
        q = w.array(q0)
        a = [w.to_mp(v) for v in (phi.T @ Mrows.times(q[:, None]))[:, 0]]
        states = np.empty((len(times), n))
        for i, t in enumerate(times):
            eta = [a[j] * _g_mp(lam[j], mpmath.mpf(float(t)), mpmath.mpf(alpha), mpmath.mpf(beta)) for j in range(k)]
            states[i] = w.to_float(phi @ w.from_mp(eta))
        # The modes left out: ||(I - P_k) q0||_M^2 = q0^T M q0 - sum a_j^2, resolved to the working precision.
        total = w.to_mp((q[:, None].T @ Mrows.times(q[:, None]))[0, 0])
        rest = max(total - sum(x * x for x in a), mpmath.mpf(0)) + 10 * w.eps * total
        mu_min = float(sla.eigsh(sparse.csc_matrix(M), k=1, sigma=0.0, which="LM", return_eigenvectors=False)[0])
        lam_next = 0.99 * float(theta[k])
        lam_max = float(sla.eigsh(sparse.csc_matrix(K), k=1, M=sparse.csc_matrix(M), which="LA",
                                  return_eigenvectors=False)[0]) * 1.1
        scale = float(mpmath.sqrt(rest)) / (math.sqrt(mu_min) * np.linalg.norm(q0))
        tail = max(decay_bound(lam_next, lam_max, float(t), alpha, beta) for t in times) * scale
    return ModalReference(states, np.sqrt(np.array([float(x) for x in lam])), tail, residual, iteration,
                          solver.contraction, time.perf_counter() - began, precision if precision != "mp" else
                          f"mpmath at {digits} digits", w.to_float(X))


def _ritz(Kp, Mp):
    """Eigenvalues (ascending) and M-orthonormal eigenvectors of the small pencil (Kp, Mp), in mpmath."""
    L = mpmath.cholesky(Mp)
    Linv = mpmath.inverse(L)
    A = Linv * Kp * Linv.T
    A = (A + A.T) / 2
    E, Q = mpmath.eigsy(A)
    order = sorted(range(len(E)), key=lambda j: E[j])
    Z = Linv.T * Q
    return [E[j] for j in order], [[Z[i, j] for j in order] for i in range(Z.rows)]


def _coefficients(w: _Working, Z) -> np.ndarray:
    rows = [w.from_mp(row) for row in Z]
    return np.array(rows, dtype=object if w.mp else np.longdouble)
