"""raydamp.LinearStructure: a sparse linear structure (finite-element model) with Rayleigh damping.

    H = 1/2 p^T M^{-1} p + V(q),   V = 1/2 q^T K q - f^T q,
    p' = -grad V - C M^{-1} p,     C = alpha M + beta K,

so in the paper's form p' = -grad V - eps D M^{-1} p it is eps = 1, D = C (alpha = beta = 0
is undamped, and "sv" may run). ``raydamp.rayleigh_coefficients(omega1, omega2, zeta1,
zeta2)`` gives (alpha, beta) for chosen damping ratios at two circular frequencies; a mode of
frequency omega then has the damping ratio alpha / (2 omega) + beta omega / 2.

Sparse from end to end: M and K stay scipy.sparse / Eigen::SparseMatrix; M is factorised once
(sparse Cholesky; or, lumped, inverted elementwise). The exact damping flows
exp(-t C M^{-1}) p = e^{-t alpha} exp(-t beta K M^{-1}) p and the kick+damp flow (with phi1)
are Chebyshev expansions in K M^{-1} on [0, L], L an upper bound of the largest squared
frequency (Lanczos, with a 5% margin; for a lumped M also the Gershgorin bound), of the
lowest degree that leaves out less than 1e-13 of the function (about sqrt(35 t beta L) + 10
products with K and solves with M per flow), coefficients cached per sub-step length.

A small structure (n <= 32 coordinates) keeps K dense as well, and its damping flows are those of its
modes: with M = L L^T and L^{-1} K L^{-T} = V Lambda V^T (one eigendecomposition when it is built),
f(C M^{-1}) = L V f(alpha + beta Lambda) V^T L^{-1}, so each flow is one n x n product with a matrix made
once per sub-step length, exact at any t beta L. It then steps like a System of its size (a 2-DOF
structure, a 10-storey shear frame); the results equal the Chebyshev path's to rounding, and
``chebyshev_degrees`` still gives the degrees that path would use. An ensemble's members may differ by
``alpha``, ``beta`` and ``K_scale`` (a factor on K: one SDOF per period of a response spectrum), made in
C++ from the shared M and spectral bound, without another build.

Thermal noise (``temperature=kT`` with 3s, 2s, baoab): each damping flow over t gets the noise of its
exact Ornstein-Uhlenbeck flow, covariance kT (M - E M E^T) = kT (I - e^{-2tA}) M = 2t kT phi1(-2tA) C
(A = C M^{-1}). The noise is sqrt(kT) psi(A) R xi with C = R R^T (a sparse Cholesky factor of C, once
per run), psi(x) = sqrt((1 - e^{-2tx}) / x) and xi standard normal: psi is smooth and bounded on
[0, rho] (no square-root branch point at 0, unlike the symmetric root M^{1/2} (I - e^{-2tS})^{1/2}),
so its Chebyshev series costs about what the damping flow's does, and the noise is within 1e-10
(relative, in the M^{-1} norm) of the exact one. With beta = 0 it is sqrt(kT (1 - e^{-2 alpha t}))
times a root of M. With alpha = 0, C = beta K must be positive definite (a supported structure); a
free one (rigid-body modes) refuses a temperature unless alpha > 0.

Which method when (rho = alpha + beta L, the largest damping rate):

- h rho small (weak damping of every mode that the step resolves): 3s and 2s are explicit,
  order 2, and cost one gradient and one or two Chebyshev flows per step.
- h rho large (stiff beta K: the high modes, damping ratio beta omega / 2, are overdamped over
  one step): the exact flows stay stable and exact, but 3s and 2s lose their order (order
  reduction: the splitting error constants grow with h rho, and in the range h rho >> 1 the
  error of a mode with h omega not small decays only like h); also the Chebyshev degree grows
  like sqrt(h beta L). rks with ``tableau="midpoint"`` (implicit midpoint on the kick+damp
  part) keeps its order there at one sparse Cholesky solve per step (M + (h/2) C, factorised
  once per run). benchmarks/bench_structure.py shows both ranges.
- Every explicit method here (3s, 2s, rks) is Stormer-Verlet in its drift and kick, so
  h omega_max < 2 (omega_max^2 = L without the margin) is needed for stability of the
  undamped part, whatever the damping.
- h omega_max >> 1 (a fine mesh, whose highest modes carry almost nothing of the answer):
  the implicit methods on the whole system, which only this kind runs. "midpoint" (implicit
  midpoint rule; for free vibration it is Newmark's average acceleration) and "gauss4" (the
  2-stage Gauss method, order 4) are A-stable (any h), symplectic when undamped, keep
  quadratic invariants, and balance energy exactly over each step,
  H(z1) - H(z0) = -h sum_i b_i V_i^T C V_i (V_i the stage velocities, the midpoint velocity
  for "midpoint"; H with the load's potential). A step is one sparse solve with
  M + c C + c^2 K (c = h/2; complex c = h / (3 + i sqrt 3) for gauss4), factorised once per
  run by raydamp's sparse LDL^T. "gauss4" is the one to reach a tight tolerance
  (benchmarks/bench_vs_opensees.py); "midpoint" composes (``composition="yoshida4"``) where
  the backward sub-step's M - (|s|/2) C + (s^2/4) K stays positive definite (beta = 0).
"""

from __future__ import annotations

import io
import os
from typing import Any

import numpy as np

from .. import _core
from .._validation import _short, flag, real, vector
from .kinds import MemberModels
from .matrix_market import read_header
from .models import SharedModel

__all__ = ["LinearStructure", "MAX_PLAIN_ENTRIES", "read_matrix"]

# The plain (JSON) form carries matrices as COO triplets; past this many stored entries per matrix
# a structure belongs in a Matrix Market file, not in a JSON document.
MAX_PLAIN_ENTRIES = 1_000_000
PLAIN_KEYS = ("kind", "M", "K", "alpha", "beta", "f", "allow_indefinite_stiffness")
# Structures of at most this many degrees of freedom step by dense products, with the exact damping flows
# of their modes (a few DOF step like a System); larger ones by sparse products and Chebyshev flows. A test
# sets it to 0 to compare the two paths.
_DENSE_LIMIT: int = _core.STRUCTURE_DENSE_LIMIT
# What an ensemble may vary per member: Rayleigh's alpha and beta, and a factor on K (one SDOF per period).
_MEMBER_PARAMETERS = {"alpha": 1, "beta": 1, "K_scale": 1}


def _scipy_sparse():
    try:
        import scipy.sparse as sparse
    except ImportError as error:  # pragma: no cover - scipy comes with the structures extra
        raise ImportError("raydamp.LinearStructure needs scipy (pip install 'raydamp[structures]')") from error
    return sparse


def read_matrix(value, name: str = "matrix"):
    """A scipy.sparse CSC matrix from what LinearStructure takes for M or K (an array, a scipy.sparse
    matrix, a Matrix Market path or binary file object): a matrix read once serves many structures."""
    return _read_matrix(name, value)


def _read_matrix(name: str, value):
    """A scipy.sparse CSC matrix from a dense array, a scipy.sparse matrix, or a Matrix Market path or
    binary file object."""
    sparse = _scipy_sparse()
    if hasattr(value, "read"):  # an open Matrix Market file (the service hands over uploaded bytes)
        import scipy.io

        if not (hasattr(value, "seekable") and value.seekable()):
            value = io.BytesIO(value.read())
        read_header(value, name)  # before the reader allocates what the header announces
        try:
            value = scipy.io.mmread(value)
        except Exception as error:  # noqa: BLE001 - say what the reader said
            raise ValueError(f"{name}: cannot read it as Matrix Market: {error}") from None
    elif isinstance(value, (str, os.PathLike)):
        import scipy.io

        path = os.fspath(value)
        read_header(path, name)
        try:
            value = scipy.io.mmread(path)
        except Exception as error:  # noqa: BLE001 - say what the reader said
            raise ValueError(f"{name}: cannot read {path!r} as Matrix Market: {error}") from None
    if sparse.issparse(value):
        if value.dtype.kind not in "biuf":  # a complex file: its imaginary part would be dropped silently
            raise ValueError(f"{name} must be a real matrix, got entries of type {value.dtype}")
        matrix = sparse.csc_matrix(value, dtype=float)
    else:
        try:
            array = np.asarray(value)
        except (TypeError, ValueError):
            array = None
        if array is None or array.dtype.kind not in "iuf":
            raise ValueError(f"{name} must be a real matrix (NumPy array, scipy.sparse or a Matrix Market path), "
                             f"got {type(value).__name__}")
        if array.ndim != 2:
            raise ValueError(f"{name} must be a 2-D matrix, got shape {array.shape}")
        matrix = sparse.csc_matrix(array.astype(float))
    if matrix.shape[0] != matrix.shape[1] or matrix.shape[0] == 0:
        raise ValueError(f"{name} must be square and non-empty, got shape {matrix.shape}")
    matrix.sum_duplicates()
    if not np.isfinite(matrix.data).all():
        raise ValueError(f"{name} must be finite")
    return matrix


def _is_diagonal(matrix) -> bool:
    coo = matrix.tocoo()
    return bool(np.all(coo.row[coo.data != 0] == coo.col[coo.data != 0]))



def load_vector(f, n: int) -> np.ndarray:
    """The constant load f of a structure of n coordinates, checked: n finite real numbers."""
    try:  # numbers only: asarray(dtype=float) read "1" as 1.0 and failed on 1j with a TypeError
        load = np.asarray(f)
    except (TypeError, ValueError):
        load = None
    if load is None or load.dtype.kind not in "iuf":
        raise ValueError(f"f must be None or a vector of {n} real numbers, got {_short(f)}")
    load = load.astype(float).reshape(-1)
    if load.shape != (n,):
        raise ValueError(f"f must be None or a vector of length {n}")
    if not np.isfinite(load).all():
        raise ValueError("f must be finite")
    return load


class LinearStructure(SharedModel):
    """A linear structure M q'' + (alpha M + beta K) q' + K q = f, sparse, run by every method.

    Parameters
    ----------
    M : mass matrix, n x n symmetric positive definite: a dense array, a scipy.sparse matrix
        or the path of a Matrix Market (.mtx) file. A diagonal M (lumped mass) is kept as its
        diagonal; any other (consistent mass) is factorised once by a sparse Cholesky
        factorisation.
    K : stiffness matrix, n x n symmetric positive semi-definite, same forms as M.
    alpha, beta : Rayleigh coefficients of C = alpha M + beta K, >= 0 (see
        :func:`raydamp.rayleigh_coefficients`).
    f : constant load vector (length n), or None for no load.
    allow_indefinite_stiffness : K is checked positive semi-definite (a negative eigenvalue of
        M^{-1} K below -1e-10 L, L the spectral bound, is refused: the structure would blow up);
        True accepts an indefinite K (a buckled or prestressed structure whose growth you mean to
        see), and to_dict() then records it.

    The module docstring says how the damping flows are computed and which method suits
    which damping (``help(raydamp.systems.structure)``). ``chebyshev_degrees(t)`` gives the degrees
    the flows over time t use; ``spectral_bound`` the bound L of the squared frequencies.
    """

    name = "linear_structure"

    def __init__(self, M, K, *, alpha: float = 0.0, beta: float = 0.0, f=None,
                 allow_indefinite_stiffness: bool = False):
        alpha = real("alpha", alpha, nonnegative=True)
        beta = real("beta", beta, nonnegative=True)
        mass = _read_matrix("M", M)
        stiffness = _read_matrix("K", K)
        n = mass.shape[0]
        if stiffness.shape != mass.shape:
            raise ValueError(f"K must have the shape of M, {mass.shape}, got {stiffness.shape}")
        _require_symmetric("M", mass)  # the core's Cholesky factorisation reads one triangle only
        load = np.zeros(0) if f is None else load_vector(f, n)
        lumped = _is_diagonal(mass)
        object.__setattr__(self, "alpha", alpha)
        object.__setattr__(self, "beta", beta)
        object.__setattr__(self, "_mass", mass)
        object.__setattr__(self, "_stiffness", stiffness)
        object.__setattr__(self, "_load", load if load.size else np.zeros(n))
        try:
            if lumped:
                core = _core.LinearStructure_lumped(np.asarray(mass.diagonal(), dtype=float), stiffness, load,
                                                    alpha, beta, dense_limit=_DENSE_LIMIT)
            else:
                core = _core.LinearStructure_consistent(mass, stiffness, load, alpha, beta, dense_limit=_DENSE_LIMIT)
        except ValueError as error:  # the core names M, K or f first
            raise ValueError(str(error)) from None
        object.__setattr__(self, "_core_model", core)
        allow_indefinite_stiffness = flag("allow_indefinite_stiffness", allow_indefinite_stiffness)
        object.__setattr__(self, "allow_indefinite_stiffness", allow_indefinite_stiffness)
        if not allow_indefinite_stiffness:
            _require_semidefinite(stiffness, mass, core.spectral_bound)
        self._freeze()

    # -- what it is ---------------------------------------------------------
    @property
    def parameters(self) -> dict[str, Any]:
        return {"alpha": self.alpha, "beta": self.beta}

    # -- ensembles ------------------------------------------------------------
    def member_parameters(self) -> dict[str, int]:
        """alpha, beta and K_scale (member i runs K_scale[i] K with C = alpha[i] M + beta[i] K)."""
        return dict(_MEMBER_PARAMETERS)

    def member_models(self, parameters, members: int) -> MemberModels:
        """One core model per distinct (alpha, beta, K_scale), made from this one in C++: M, f and the
        certified spectral bound (scaled by K_scale) are shared, nothing is estimated or factorised again
        (a spectrum of 100 periods costs about 1 ms here, not 100 LinearStructure builds)."""
        if not parameters:
            return MemberModels.shared(self, members)
        columns = []
        for name, default in (("alpha", self.alpha), ("beta", self.beta), ("K_scale", 1.0)):
            values = parameters.get(name)
            if values is None:
                columns.append(np.full(members, default))
                continue
            bad = np.flatnonzero(~(values > 0) if name == "K_scale" else ~(values >= 0))
            if bad.size:
                rule = "> 0" if name == "K_scale" else ">= 0"
                raise ValueError(f"parameters.{name} must be {rule}, got {name}[{bad[0]}] = "
                                 f"{float(values[bad[0]])!r}")
            columns.append(np.asarray(values, dtype=float))
        rows, index = np.unique(np.column_stack(columns), axis=0, return_inverse=True)
        models = [_Member(self._core_model.with_parameters(float(a), float(b), float(k))) for a, b, k in rows]
        return MemberModels(models, np.asarray(index, dtype=np.int64).reshape(-1), [], np.zeros((members, 0)))

    @property
    def M(self):
        """The mass matrix (scipy.sparse CSC)."""
        return self._mass.copy()

    @property
    def K(self):
        """The stiffness matrix (scipy.sparse CSC)."""
        return self._stiffness.copy()

    @property
    def f(self) -> np.ndarray:
        """The load vector."""
        return self._load.copy()

    @property
    def eps(self) -> float:
        """1 when damped (D = alpha M + beta K), 0 when alpha = beta = 0."""
        return self._core_model.eps

    def mass_product(self, r) -> np.ndarray:
        """M r."""
        return self._mass @ vector("r", r, self.dim)  # scipy's "dimension mismatch" named nothing

    @property
    def mass_kind(self) -> str:
        """"lumped" (diagonal M) or "consistent" (sparse SPD M, factorised)."""
        return self._core_model.mass_kind

    @property
    def spectral_bound(self) -> float:
        """L >= the largest eigenvalue of M^{-1} K (squared circular frequency): the Chebyshev interval."""
        return self._core_model.spectral_bound

    @property
    def damping_rate_bound(self) -> float:
        """alpha + beta L: at least the largest damping rate (spectral radius of C M^{-1})."""
        return self._core_model.damping_rate_bound

    def chebyshev_degrees(self, t: float) -> tuple[int, int]:
        """(degree of exp(-t C M^{-1}), degree of t phi1(-t C M^{-1})): products with K per flow of length t.
        Raises :class:`raydamp.ChebyshevDegreeError` past degree 8192 (t beta lambda_max above about 1e7)."""
        return tuple(self._core_model.chebyshev_degrees(real("t", t)))

    # -- the plain form -------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """The structure as plain JSON-ready data (matrices as COO triplets, a lumped M as its
        diagonal); ``LinearStructure.from_dict`` inverts it. It is the service's ``"system"``."""
        mass = ({"diagonal": self._mass.diagonal().tolist()} if self.mass_kind == "lumped"
                else {"coo": _coo_plain(self._mass)})
        return {"kind": "linear_structure", "M": mass, "K": {"coo": _coo_plain(self._stiffness)},
                "alpha": self.alpha, "beta": self.beta,
                "f": self._load.tolist() if self._load.any() else None,
                **({"allow_indefinite_stiffness": True} if self.allow_indefinite_stiffness else {})}

    @classmethod
    def from_dict(cls, data, *, files=None) -> LinearStructure:
        """Build from ``to_dict()``'s form; a bad field raises ValueError starting with its path (``K.coo.rows``).

        A matrix may also be ``{"file": ref}``: by default ref is the path of a Matrix Market file;
        ``files(ref)`` (the service's uploaded files) may instead return anything ``M``/``K`` take,
        or an open binary Matrix Market file, and raises ValueError for an unknown ref."""
        if not isinstance(data, dict):
            raise ValueError("a linear structure must be an object with the keys " + ", ".join(PLAIN_KEYS))
        unknown = [k for k in data if k not in PLAIN_KEYS]
        if unknown:
            raise ValueError(f"{unknown[0]}: unknown key (known: {', '.join(PLAIN_KEYS)})")
        if data.get("kind") != "linear_structure":
            raise ValueError(f"kind: expected 'linear_structure', got {data.get('kind')!r}")
        for key in ("M", "K"):
            if key not in data:
                raise ValueError(f"{key}: missing")
        n = None
        matrices = {}
        for key in ("M", "K"):
            matrices[key] = _matrix_from_plain(key, data[key], n, files)
            n = matrices[key].shape[0]
        f = data.get("f")
        if f is not None and (not isinstance(f, list) or len(f) != n
                              or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in f)):
            raise ValueError(f"f: must be null or a list of {n} numbers")
        return cls(matrices["M"], matrices["K"], alpha=data.get("alpha", 0.0), beta=data.get("beta", 0.0), f=f,
                   allow_indefinite_stiffness=data.get("allow_indefinite_stiffness", False) is True)

    def replace(self, **changes) -> LinearStructure:
        unknown = set(changes) - {"M", "K", "alpha", "beta", "f", "allow_indefinite_stiffness"}
        if unknown:
            raise ValueError(f"{sorted(unknown)[0]}: LinearStructure has no such argument (M, K, alpha, beta, f)")
        args = {"M": self._mass, "K": self._stiffness, "alpha": self.alpha, "beta": self.beta,
                "f": self._load, "allow_indefinite_stiffness": self.allow_indefinite_stiffness, **changes}
        return LinearStructure(args.pop("M"), args.pop("K"), **args)

    def __repr__(self) -> str:
        return (f"LinearStructure(n={self.dim}, mass={self.mass_kind}, nnz(K)={self._stiffness.nnz}, "
                f"alpha={self.alpha!r}, beta={self.beta!r})")

    # -- linear constraints ------------------------------------------------------
    def tie(self, constraints):
        """Eliminate linear constraints C q = 0 (multi-point constraints, rigid links, a rigid diaphragm; C a
        scipy.sparse matrix or an array, m x n): a :class:`raydamp.systems.linear_constraints.Tie` whose
        ``reduced`` LinearStructure (q = T y, T sparse) every method runs exactly, and whose ``expand`` gives
        q and p back."""
        from .linear_constraints import tie

        if type(self) is not LinearStructure:  # the reduced model is a LinearStructure: springs would be dropped
            raise ValueError(f"constraints: tie eliminates constraints from a LinearStructure; a "
                             f"{type(self).__name__}'s springs are not reduced with it")
        return tie(self, constraints)

    # -- natural frequencies and modes -------------------------------------------
    def frequencies(self, k: int | None = None) -> np.ndarray:
        """The k lowest natural circular frequencies sqrt(eig(K, M)), ascending (rigid modes are 0); all of
        them when k is None. What ``raydamp.rayleigh_coefficients`` takes. See :meth:`modes`."""
        return self.modes(k)[0]

    def modes(self, k: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(omega, phi): the k lowest natural circular frequencies, ascending, and their mode shapes as the
        columns of phi (n, k), normalised to phi^T M phi = I (so q = phi x splits the free motion into
        uncoupled modes x_i'' + (alpha + beta omega_i^2) x_i' + omega_i^2 x_i = 0). All of them when k is
        None. A dense eigensolver below 500 DOF or when k >= n - 1; shift-invert Lanczos (scipy's ARPACK)
        at 0 otherwise, shifted just below 0 for a singular (free-free) K."""
        if k is None:
            k = self.dim
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 1 <= k <= self.dim:
            raise ValueError(f"k must be an integer from 1 to {self.dim} (the DOF), got {_short(k)}")
        return _lowest_modes(self._stiffness, self._mass, int(k), self._core_model.spectral_bound)


class _Member:
    """An ensemble member's core model (what integrate_ensemble runs of a member)."""

    __slots__ = ("_core_model",)

    def __init__(self, core) -> None:
        self._core_model = core


_SYMMETRY_TOLERANCE = 1e-12  # relative to the largest entry: a matrix assembled in floating point
_DEFINITENESS_SHIFT = 1e-10  # relative to L: rounding in a singular K (free-free) stays above -shift L


def _require_symmetric(name: str, matrix) -> None:
    """Both triangles compared: a solver reading one of them would silently use another matrix."""
    difference = abs(matrix - matrix.T)
    worst = difference.max() if difference.nnz else 0.0
    if worst > _SYMMETRY_TOLERANCE * max(abs(matrix).max(), np.finfo(float).tiny):
        raise ValueError(f"{name}: must be symmetric (max |{name} - {name}^T| = {worst:.3g})")


def _require_semidefinite(stiffness, mass, bound: float) -> None:
    """K + s M with s = 1e-10 L is positive definite iff every eigenvalue of M^{-1} K exceeds -s: its
    LU factorisation without row exchanges (the diagonal kept as pivot, a symmetric ordering) has
    positive pivots then, and a negative or zero pivot shows a negative eigenvalue (Sylvester's law
    of inertia)."""
    from scipy.sparse.linalg import splu

    off_diagonal = abs(stiffness).sum(axis=1).A1 - abs(stiffness.diagonal())
    if (stiffness.diagonal() >= off_diagonal).all():
        return  # diagonally dominant with a non-negative diagonal: semi-definite by Gershgorin (a chain)
    shift = _DEFINITENESS_SHIFT * max(bound, 1.0)
    shifted = (stiffness + shift * mass).tocsc()
    try:
        lu = splu(shifted, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                  options={"SymmetricMode": True})
        pivots = lu.U.diagonal()
        exchanged = not np.array_equal(lu.perm_r, lu.perm_c)
    except RuntimeError:  # exactly singular: K + s M is not definite
        pivots, exchanged = np.array([-1.0]), False
    if exchanged or not (pivots > 0).all():
        raise ValueError("K: must be positive semi-definite (M^{-1} K has a negative eigenvalue below "
                         f"-{shift:.3g}: the structure would grow without bound); pass "
                         "allow_indefinite_stiffness=True if that is what you mean to simulate")


def _coo_plain(matrix) -> dict[str, Any]:
    coo = matrix.tocoo()
    return {"shape": list(coo.shape), "rows": coo.row.tolist(), "cols": coo.col.tolist(), "values": coo.data.tolist()}


_FLOAT_MAX_INT = int(np.finfo(float).max)  # an int past it does not convert to a float


def _numbers(path: str, value, *, integer: bool = False) -> np.ndarray:
    if not isinstance(value, list):
        raise ValueError(f"{path}: must be a list of numbers")
    if len(value) > MAX_PLAIN_ENTRIES:
        raise ValueError(f"{path}: {len(value)} entries, more than the limit {MAX_PLAIN_ENTRIES}; "
                         "give such a structure as Matrix Market files to raydamp.LinearStructure")
    kinds = (int,) if integer else (int, float)
    for i, x in enumerate(value):
        if isinstance(x, bool) or not isinstance(x, kinds):
            raise ValueError(f"{path}[{i}]: must be {'an integer' if integer else 'a number'}, got {x!r}")
    try:
        array = np.asarray(value, dtype=np.int64 if integer else float)
    except OverflowError:  # an integer such as 10**400: name the entry, not "int too large to convert to float"
        limit = 2**63 if integer else _FLOAT_MAX_INT
        i = next(i for i, x in enumerate(value) if not -limit <= x < limit)
        raise ValueError(f"{path}[{i}]: an integer of {abs(value[i]).bit_length()} bits, beyond the largest "
                         f"{'64-bit integer' if integer else 'float'}") from None
    if not integer and not np.isfinite(array).all():
        raise ValueError(f"{path}[{int(np.argmin(np.isfinite(array)))}]: must be finite")
    return array


def _matrix_from_file(key: str, ref, n: int | None, files):
    if not isinstance(ref, str) or not ref:
        raise ValueError(f"{key}.file: must be a non-empty string")
    try:
        source = ref if files is None else files(ref)
    except ValueError as error:
        raise ValueError(f"{key}.file: {error}") from None
    if isinstance(source, tuple):  # the service's parse of an uploaded record: (t, values)
        raise ValueError(f"{key}.file: file {ref} is a record (a load's history or a vector), not a Matrix Market "
                         "matrix")
    try:
        matrix = _read_matrix(key, source)
    except ValueError as error:  # "K must be square ..." or "K: cannot read ..."
        raise ValueError(f"{key}.file: {str(error).removeprefix(key).lstrip(': ')}") from None
    if n is not None and matrix.shape[0] != n:
        raise ValueError(f"{key}.file: the matrix is {matrix.shape[0]} x {matrix.shape[1]}; it must be {n} x {n} "
                         "(the size of M)")
    return matrix


def _matrix_from_plain(key: str, value, n: int | None, files=None):
    sparse = _scipy_sparse()
    if not isinstance(value, dict) or len(value) != 1 or next(iter(value)) not in ("coo", "diagonal", "file"):
        raise ValueError(f'{key}: must be {{"coo": {{"shape", "rows", "cols", "values"}}}}, {{"diagonal": [...]}} '
                         'or {"file": "<Matrix Market file>"}')
    if "file" in value:
        return _matrix_from_file(key, value["file"], n, files)
    if "diagonal" in value:
        diagonal = _numbers(f"{key}.diagonal", value["diagonal"])
        if diagonal.size == 0 or (n is not None and diagonal.size != n):
            raise ValueError(f"{key}.diagonal: must have {n if n is not None else 'at least one'} entries")
        return sparse.diags(diagonal).tocsc()
    coo = value["coo"]
    if not isinstance(coo, dict) or set(coo) != {"shape", "rows", "cols", "values"}:
        raise ValueError(f"{key}.coo: must have exactly the keys shape, rows, cols, values")
    shape = coo["shape"]
    if (not isinstance(shape, list) or len(shape) != 2 or not all(isinstance(x, int) and not isinstance(x, bool)
                                                                  for x in shape)
            or shape[0] != shape[1] or shape[0] < 1):
        raise ValueError(f"{key}.coo.shape: must be [n, n] with n >= 1")
    if n is not None and shape[0] != n:
        raise ValueError(f"{key}.coo.shape: must be [{n}, {n}] (the size of M)")
    rows = _numbers(f"{key}.coo.rows", coo["rows"], integer=True)
    cols = _numbers(f"{key}.coo.cols", coo["cols"], integer=True)
    values = _numbers(f"{key}.coo.values", coo["values"])
    if not rows.size == cols.size == values.size:
        raise ValueError(f"{key}.coo: rows, cols and values must have the same length")
    for name, index in (("rows", rows), ("cols", cols)):
        bad = np.flatnonzero((index < 0) | (index >= shape[0]))
        if bad.size:
            raise ValueError(f"{key}.coo.{name}[{bad[0]}]: index {index[bad[0]]} outside 0..{shape[0] - 1}")
    return sparse.csc_matrix((values, (rows, cols)), shape=tuple(shape))


_DENSE_MODES_BELOW = 500  # DOF: all modes from a dense eigensolver below this


def _lowest_modes(stiffness, mass, k: int, bound: float) -> tuple[np.ndarray, np.ndarray]:
    """The k lowest eigenpairs of (K, M): frequencies (negative rounding clipped to 0) and M-normalised shapes."""
    n = stiffness.shape[0]
    if n < _DENSE_MODES_BELOW or k >= n - 1:
        import scipy.linalg

        w2, phi = scipy.linalg.eigh(stiffness.toarray(), mass.toarray(), subset_by_index=[0, k - 1])
    else:
        import scipy.sparse.linalg as sla

        try:  # shift-invert at 0: K definite (a supported structure)
            w2, phi = sla.eigsh(stiffness, k=k, M=mass, sigma=0.0, which="LM", tol=1e-12)
        except RuntimeError:  # singular K (free-free): shift just below its rigid modes
            w2, phi = sla.eigsh(stiffness, k=k, M=mass, sigma=-1e-12 * bound, which="LM", tol=1e-12)
        order = np.argsort(w2)
        w2, phi = w2[order], phi[:, order]
        phi = phi / np.sqrt(np.einsum("ij,ij->j", phi, mass @ phi))
    w2 = np.where(w2 > 1e-13 * bound, w2, 0.0)  # rigid modes: zero to rounding (1e-13 of the largest)
    return np.sqrt(w2), phi

