#!/usr/bin/env python3
"""raydamp against OpenSees on linear structures (issue 25): time to 1e-6 relative error.

Two structures, each at about 200, 2,000 and 20,000 degrees of freedom, run in one process,
the tools interleaved size by size:

- chain: a shear building of n storeys (unit masses, unit storey springs, fixed base; lumped M);
  in OpenSees a 1-D model of zeroLength springs ("-doRayleigh 1").
- beam: a 2-D cantilever of n/3 Euler-Bernoulli beam elements (u, w, theta per node; length 1,
  E = 1, rho = 1, a 0.05 x 1 section; consistent mass); in OpenSees elasticBeamColumn with
  "-cMass" and a Linear transformation.

Both have 2% Rayleigh damping in modes 1 and 3 (raydamp.rayleigh_coefficients; OpenSees
ops.rayleigh(alpha, beta, 0, 0)), and the same M, K and C in both tools, checked: the full
matrices at 200 DOF (OpenSees' GimmeMCK integrator and printA), and products with random vectors
at every size (ops.reactions of set displacements, velocities and accelerations) to 1e-12.

The problem: free vibration from the static deflection under a unit tip (top-storey) load, at rest,
over two periods of mode 1, saved at 10 equally spaced times. Error: the largest over those times
of ||q - q_exact|| / ||q0||. q_exact is the exact modal solution: for the chain its modes in closed
form (K is the path graph's: omega_j = 2 sin(theta_j / 2), phi_j(i) = sin(i theta_j),
theta_j = (2j - 1) pi / (2n + 1)), at every size; for the beam the exact modal solution of the same
float K, M and q0 from its lowest modes computed in extended precision (benchmarks/modal_reference.py:
subspace iteration in numpy's longdouble, K^-1 by iterative refinement with double-double residuals,
Rayleigh-Ritz in mpmath, and a printed bound on the modes left out). Its self-checks are printed: at
201 DOF against the same computation in mpmath at 32 digits and against dense eigh, at 2,001 DOF
against dense eigh (which is off by about u cond(K) there, far above 1e-6). At 20,001 DOF a double
factorisation of K is itself off by about 1e-3: that row gives raydamp's floor against the exact
solution and the cost per step at equal h. The sensitivity to a one-ulp change of K's entries, printed
for every size, is what a K assembled apart (OpenSees') contributes.

For each tool, the largest h that reaches 1e-6 is found by a short search (one coarse run, then
steps predicted from the method's order, then a bisection to within ~10% of the step count), and
the time of the run at that h is reported; it includes the factorisations (and OpenSees' analysis
set-up), not building the model (raydamp.LinearStructure's constructor, shown apart; OpenSees'
nodes and elements) nor reading results out. OpenSees runs Newmark average acceleration
(gamma = 1/2, beta = 1/4) with algorithm Linear -factorOnce and the fastest of its linear-system
solvers for the structure (timed at the start); raydamp runs gauss4 (order 4: its best method) and,
for comparison, midpoint (the same method as Newmark's average acceleration).

    .venv/bin/pip install openseespy                           # optional
    .venv/bin/python benchmarks/bench_vs_opensees.py           # everything: about an hour on 2 cores
    .venv/bin/python benchmarks/bench_vs_opensees.py --quick   # 200 and 2,000 DOF only
    .venv/bin/python benchmarks/bench_vs_opensees.py --models beam --quick   # with the beam reference's self-checks
    .venv/bin/python benchmarks/bench_vs_opensees.py --models beam --sizes 20001   # one size
    .venv/bin/pip install mpmath                               # the beam's reference needs it
    .venv/bin/python benchmarks/bench_vs_opensees.py --models ground   # the ground-motion case alone (seconds)
    .venv/bin/python benchmarks/bench_vs_opensees.py --models plate    # the 10^5-DOF plate alone (minutes)
    .venv/bin/python benchmarks/bench_vs_opensees.py --models ida      # 20 records x 10 scales (about 25 min)
    .venv/bin/python benchmarks/bench_vs_opensees.py --models ida --quick   # 2 records x 3 scales

The plate: the clamped 2-D plate of tests/fe_plate.py (plane stress, linear triangles, consistent mass)
at 100,488 DOF, raydamp alone (gauss4, its best method), 2% Rayleigh damping in modes 1 and 3, from
q0 in the span of modes 1-3 at rest, so that the modal solution of those modes (scipy's eigsh) is
the exact reference; the time to 1e-6 includes the factorisation.

The IDA case (benchmarks/ida_frame.py, issue 42): incremental dynamic analysis of a 10-storey Bilinear shear
frame (Steel01 in OpenSees), 20 records x 10 scales of 40 s at dt = 0.01; each tool at the largest h = dt/k
within 1e-3 of its own reference at dt/16 in every peak interstorey drift, the references agreeing to 1e-4; the
analysis timed alone, per record-run, and raydamp on 1 and 2 threads. Not in the default --models.

The ground-motion case (benchmarks/ground_motion_frame.py, issue 26): a 10-storey shear frame with 5%
Rayleigh damping under a 20 s record as uniform base excitation, OpenSees' UniformExcitation beside
raydamp.GroundMotion, error against the exact piecewise-linear response and time at several h.

OpenSeesPy's Linux wheel links the LAPACK and BLAS it carries in
<site-packages>/openseespylinux/lib, which the dynamic loader finds only on LD_LIBRARY_PATH: the
script re-executes itself with that directory on LD_LIBRARY_PATH (or run it so yourself). Without
OpenSeesPy it prints raydamp's figures alone. It prints figures and exits 0 whatever they are.
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import os
import sys
import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.sparse as sparse
import scipy.sparse.linalg as sla

import raydamp

TOLERANCE = 1e-6
SAVES = 10


def _reexec_with_opensees_libraries() -> None:
    spec = importlib.util.find_spec("openseespylinux")
    if spec is None or not spec.submodule_search_locations:
        return
    lib = os.path.join(list(spec.submodule_search_locations)[0], "lib")
    paths = os.environ.get("LD_LIBRARY_PATH", "").split(os.pathsep)
    if os.path.isdir(lib) and lib not in paths:
        env = dict(os.environ, LD_LIBRARY_PATH=os.pathsep.join([lib] + [p for p in paths if p]))
        os.execve(sys.executable, [sys.executable] + sys.argv, env)


# -- the structures ------------------------------------------------------------------------------

@dataclass
class Structure:
    name: str
    M: sparse.csc_matrix
    K: sparse.csc_matrix
    tip: int                  # the dof of the tip (top-storey) load
    lumped: bool

    @property
    def n(self) -> int:
        return self.K.shape[0]


def chain(n: int) -> Structure:
    main = np.full(n, 2.0)
    main[-1] = 1.0
    K = sparse.diags([-np.ones(n - 1), main, -np.ones(n - 1)], [-1, 0, 1]).tocsc()
    return Structure("chain", sparse.identity(n, format="csc"), K, n - 1, True)


BEAM = {"length": 1.0, "E": 1.0, "rho": 1.0, "A": 0.05, "I": 0.05 ** 3 / 12}


def beam(elements: int) -> Structure:
    """Euler-Bernoulli frame elements along x, node 0 clamped; the consistent mass of OpenSees'
    ElasticBeam2d with -cMass (rho A L / 420 times the cubic-Hermite and linear-axial matrices)."""
    L = BEAM["length"] / elements
    EA, EI, m = BEAM["E"] * BEAM["A"], BEAM["E"] * BEAM["I"], BEAM["rho"] * BEAM["A"] * L / 420.0
    ke = np.array([[EA / L, 0, 0, -EA / L, 0, 0],
                   [0, 12 * EI / L ** 3, 6 * EI / L ** 2, 0, -12 * EI / L ** 3, 6 * EI / L ** 2],
                   [0, 6 * EI / L ** 2, 4 * EI / L, 0, -6 * EI / L ** 2, 2 * EI / L],
                   [-EA / L, 0, 0, EA / L, 0, 0],
                   [0, -12 * EI / L ** 3, -6 * EI / L ** 2, 0, 12 * EI / L ** 3, -6 * EI / L ** 2],
                   [0, 6 * EI / L ** 2, 2 * EI / L, 0, -6 * EI / L ** 2, 4 * EI / L]])
    me = m * np.array([[140, 0, 0, 70, 0, 0],
                       [0, 156, 22 * L, 0, 54, -13 * L],
                       [0, 22 * L, 4 * L * L, 0, 13 * L, -3 * L * L],
                       [70, 0, 0, 140, 0, 0],
                       [0, 54, 13 * L, 0, 156, -22 * L],
                       [0, -13 * L, -3 * L * L, 0, -22 * L, 4 * L * L]])
    dofs = 3 * (np.arange(elements)[:, None] - 1) + np.arange(6)[None, :]   # node 0's dofs are -3..-1: dropped
    rows, cols = np.repeat(dofs, 6, axis=1).ravel(), np.tile(dofs, (1, 6)).ravel()
    keep = (rows >= 0) & (cols >= 0)
    n = 3 * elements
    K = sparse.csc_matrix((np.tile(ke.ravel(), elements)[keep], (rows[keep], cols[keep])), shape=(n, n))
    M = sparse.csc_matrix((np.tile(me.ravel(), elements)[keep], (rows[keep], cols[keep])), shape=(n, n))
    K.eliminate_zeros()
    M.eliminate_zeros()
    return Structure("beam", M, K, n - 2, False)


def lowest_frequencies(s: Structure, k: int = 3) -> np.ndarray:
    w2 = sla.eigsh(s.K, k=k, M=s.M, sigma=0.0, which="LM", return_eigenvectors=False)
    return np.sqrt(np.sort(w2))


# -- the exact modal solution --------------------------------------------------------------------

class ModalSolution:
    """q(t) = sum_j phi_j eta_j(t) for M q'' + C q' + K q = 0 from (q0, 0), C = alpha M + beta K, modes in
    blocks of columns (so a chain of 20,000 storeys needs 20,000 x block numbers at a time)."""

    def __init__(self, blocks, M, alpha, beta):
        self.blocks, self.M, self.alpha, self.beta = blocks, M, alpha, beta   # blocks(): (w2, phi) pairs

    def at(self, q0, times):
        out = np.zeros((len(times), len(q0)))
        Mq0 = self.M @ q0
        for w2, phi in self.blocks():
            a = phi.T @ Mq0
            c = self.alpha + self.beta * w2
            disc = np.sqrt((c ** 2 / 4 - w2).astype(complex))
            r2 = -c / 2 - disc
            r1 = w2 / r2                       # the other root without cancellation (r1 r2 = w2)
            A = -r2 * a / (r1 - r2)            # eta = A e^{r1 t} + (a - A) e^{r2 t}, eta(0) = a, eta'(0) = 0
            for k, t in enumerate(times):
                eta = (A * np.exp(r1 * t) + (a - A) * np.exp(r2 * t)).real
                out[k] += phi @ eta
        return out


def chain_modes(n: int, block: int = 2000):
    def blocks():
        i = np.arange(1, n + 1)[:, None]
        for start in range(0, n, block):
            j = np.arange(start + 1, min(n, start + block) + 1)[None, :]
            theta = (2 * j - 1) * np.pi / (2 * n + 1)
            phi = np.sin(i * theta)
            phi /= np.linalg.norm(phi, axis=0)
            yield (4 * np.sin(theta / 2) ** 2).ravel(), phi
    return blocks


def dense_modes(s: Structure):
    w2, phi = scipy.linalg.eigh(s.K.toarray(), s.M.toarray())
    return lambda: iter([(w2, phi)])


# -- raydamp -------------------------------------------------------------------------------------

@dataclass
class Problem:
    structure: Structure
    alpha: float
    beta: float
    q0: np.ndarray
    T: float                  # the span: two periods of mode 1

    @property
    def times(self) -> np.ndarray:
        return self.T * np.arange(1, SAVES + 1) / SAVES


def raydamp_runner(problem: Problem, method: str):
    s = problem.structure
    start = time.perf_counter()
    model = raydamp.LinearStructure(s.M, s.K, alpha=problem.alpha, beta=problem.beta)
    build = time.perf_counter() - start
    p0 = np.zeros(s.n)

    def run(m: int):
        h = problem.T / (SAVES * m)
        start = time.perf_counter()
        sol = raydamp.integrate(model, problem.q0, p0, method=method, h=h, n_steps=SAVES * m, save_every=m)
        seconds = time.perf_counter() - start
        assert sol.status == "completed", sol.message
        return seconds, sol.q[1:]
    return run, build


# -- OpenSees ------------------------------------------------------------------------------------

def opensees():
    try:
        import openseespy.opensees as ops
    except ImportError:
        return None
    return ops


def opensees_model(ops, problem: Problem) -> None:
    s = problem.structure
    ops.wipe()
    if s.name == "chain":
        ops.model("basic", "-ndm", 1, "-ndf", 1)
        for i in range(s.n + 1):
            ops.node(i, 0.0)
        ops.fix(0, 1)
        for i in range(1, s.n + 1):
            ops.mass(i, 1.0)
        ops.uniaxialMaterial("Elastic", 1, 1.0)
        for i in range(1, s.n + 1):
            ops.element("zeroLength", i, i - 1, i, "-mat", 1, "-dir", 1, "-doRayleigh", 1)
    else:
        elements = s.n // 3
        ops.model("basic", "-ndm", 2, "-ndf", 3)
        for i in range(elements + 1):
            ops.node(i, i * BEAM["length"] / elements, 0.0)
        ops.fix(0, 1, 1, 1)
        ops.geomTransf("Linear", 1)
        for e in range(elements):
            ops.element("elasticBeamColumn", e + 1, e, e + 1, BEAM["A"], BEAM["E"], BEAM["I"], 1,
                        "-mass", BEAM["rho"] * BEAM["A"], "-cMass")
    ops.rayleigh(problem.alpha, problem.beta, 0.0, 0.0)


def _ndf(problem: Problem) -> int:
    return 1 if problem.structure.name == "chain" else 3


def opensees_set_state(ops, problem: Problem, q, v, a) -> None:
    ndf = _ndf(problem)
    for node in range(1, problem.structure.n // ndf + 1):
        for d in range(ndf):
            i = ndf * (node - 1) + d
            ops.setNodeDisp(node, d + 1, float(q[i]), "-commit")
            ops.setNodeVel(node, d + 1, float(v[i]), "-commit")
            ops.setNodeAccel(node, d + 1, float(a[i]), "-commit")


def opensees_displacements(ops, problem: Problem, read=None) -> np.ndarray:
    ndf = _ndf(problem)
    read = read or ops.nodeDisp
    return np.array([read(node) for node in range(1, problem.structure.n // ndf + 1)]).ravel()


def opensees_matrices(ops, problem: Problem):
    """The beam's M and K as OpenSees applies them, bit for bit: its nodal forces for displacement
    (accelerations) set to the sum of every 11th unit vector are 11 columns of K (M) at once, since a
    column has no entry more than 5 rows from its diagonal (3 dof a node, neighbouring nodes only)."""
    s = problem.structure
    n, period = s.n, 11
    rows = np.arange(n)
    out = []
    for dynamic in (False, True):
        opensees_model(ops, problem)
        entries = ([], [], [])
        for colour in range(period):
            probe = np.zeros(n)
            probe[colour::period] = 1.0
            zero = np.zeros(n)
            opensees_set_state(ops, problem, zero if dynamic else probe, zero, probe if dynamic else zero)
            ops.reactions("-dynamic") if dynamic else ops.reactions()
            force = opensees_displacements(ops, problem, ops.nodeReaction)
            offset = (rows - colour) % period
            columns = np.where(offset <= 5, rows - offset, rows - offset + period)
            keep = (force != 0.0) & (columns < n)
            for target, values in zip(entries, (rows[keep], columns[keep], force[keep])):
                target.append(values)
        out.append(sparse.csc_matrix((np.concatenate(entries[2]), (np.concatenate(entries[0]),
                                                                     np.concatenate(entries[1]))), shape=(n, n)))
    ops.wipe()
    K, M = out
    return M, K


def compare_matrices(ops, problem: Problem) -> str:
    """How far OpenSees' M, K and C are from the ones assembled here (largest relative difference):
    the full matrices from OpenSees' GimmeMCK integrator (n <= 2,100), and for the beam the matrices
    its nodal forces apply (opensees_matrices) at every size. (A zeroLength spring updates its force
    only inside an analysis step, so the chain's are compared in full only; they are integers.)"""
    s = problem.structure
    C = problem.alpha * s.M + problem.beta * s.K
    worst, how = 0.0, []

    def relative(theirs, ours):
        return abs(theirs - ours).max() / abs(ours).max()
    if s.n <= 2100:
        for coefficients, ours in (((1, 0, 0), s.M), ((0, 0, 1), s.K), ((0, 1, 0), C)):
            opensees_model(ops, problem)
            ops.system("FullGeneral")
            ops.numberer("Plain")
            ops.constraints("Plain")
            ops.algorithm("Linear")
            ops.integrator("GimmeMCK", *map(float, coefficients))
            ops.analysis("Transient")
            ops.analyze(1, 0.0)
            theirs = np.array(ops.printA("-ret")).reshape(s.n, s.n)
            worst = max(worst, relative(theirs, ours.toarray()))
        ops.wipe()
        how.append("assembled (GimmeMCK)")
    if s.name == "beam":
        M, K = opensees_matrices(ops, problem)
        worst = max(worst, relative(M, s.M), relative(K, s.K))
        how.append("as its nodal forces apply them")
    if not how:
        return "- (not compared at this size: the same-method check below compares their runs)"
    return f"{worst:.1e} ({', '.join(how)})"


def opensees_runner(ops, problem: Problem, system: str):
    s = problem.structure
    # Newmark starts from the committed acceleration: the equilibrium one, M a0 = -K q0 (at rest).
    a0 = sla.spsolve(s.M.tocsc(), -(s.K @ problem.q0))

    def run(m: int):
        h = problem.T / (SAVES * m)
        opensees_model(ops, problem)
        opensees_set_state(ops, problem, problem.q0, np.zeros(s.n), a0)
        saved = []
        start = time.perf_counter()
        ops.constraints("Plain")
        ops.numberer("RCM")
        ops.system(system)
        ops.algorithm("Linear", "-factorOnce")
        ops.integrator("Newmark", 0.5, 0.25)
        ops.analysis("Transient")
        seconds = 0.0
        for _ in range(SAVES):
            if ops.analyze(m, h) != 0:
                raise RuntimeError("OpenSees analyze failed")
            seconds += time.perf_counter() - start
            saved.append(opensees_displacements(ops, problem))   # not timed
            start = time.perf_counter()
        ops.wipe()
        return seconds, np.array(saved)
    return run


def fastest_opensees_system(ops, problem: Problem) -> tuple[str, dict]:
    run_for = {name: opensees_runner(ops, problem, name) for name in ("BandSPD", "ProfileSPD", "SparseSYM", "UmfPack")}
    times = {}
    for name, run in run_for.items():
        try:
            times[name] = min(run(20)[0] for _ in range(2))
        except Exception:  # noqa: BLE001 - a solver this build lacks
            continue
    return min(times, key=times.get), times


# -- the search ----------------------------------------------------------------------------------

def time_to_tolerance(run, reference, norm, order: int, m_start: int, tolerance: float, shrink: float = 0.7,
                      max_runs: int = 9):
    """The fewest steps per saved interval m (the largest h = T / (10 m)) whose error is <= tolerance,
    within about 10%: a run at m_start, then m predicted from the order until one passes (or, if
    m_start passes, m shrunk by `shrink` until one fails), then a bisection. Returns (m or None,
    {m: (error, seconds)} of every run)."""
    tried = {}

    def evaluate(m):
        if m not in tried:
            seconds, q = run(m)
            tried[m] = (float(np.max(np.linalg.norm(q - reference, axis=1)) / norm), seconds)
        return tried[m][0]

    m = m_start
    error = evaluate(m)
    while error > tolerance and len(tried) < max_runs:
        previous = error
        m = max(m + 1, math.ceil(m * (error / tolerance) ** (1.0 / order) * 1.1))
        error = evaluate(m)
        if error > 0.7 * previous:  # more steps no longer help: the method's rounding floor
            break
    if error > tolerance:
        return None, tried
    lo = max((k for k, (e, _) in tried.items() if e > tolerance and k < m), default=None)
    if lo is None:  # passed at once: look below
        lo = m
        while lo > 1 and len(tried) < max_runs:
            lo = max(1, math.floor(lo * shrink))
            if evaluate(lo) > tolerance:
                break
            m = lo
    while lo < m - max(1, 0.1 * m) and len(tried) < max_runs:
        mid = (lo + m) // 2
        if evaluate(mid) <= tolerance:
            m = mid
        else:
            lo = mid
    return m, tried


def best_time(run, m: int, searched: float) -> float:
    """The run at m timed again (best of 3, with the search's run) when a run takes under 10 s."""
    if searched >= 10.0:
        return searched
    return min([searched] + [run(m)[0] for _ in range(2)])


# -- the plate, raydamp alone --------------------------------------------------------------------

PLATE = (316, 158)   # elements along x and y: 2 nx (ny + 1) = 100,488 DOF


def plate_structure(nx: int, ny: int) -> Structure:
    """The clamped 2-D plate of tests/fe_plate.py (plane stress, linear triangles, consistent mass)."""
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests"))
    from fe_plate import plate

    pl = plate(nx, ny)
    return Structure("plate", pl.M, pl.K, int(pl.tip[-1]), False)


def run_plate(nx: int, ny: int) -> dict:
    """gauss4 (raydamp's best method) to 1e-6 on a plate of about 10^5 DOF, from q0 in the span of modes
    1-3 at rest: the modal solution of those three modes (eigsh, shift-invert) is then exact to the
    modes' own accuracy, printed as their residual. midpoint is shown at gauss4's h for its cost per step
    (at order 2 it would need about 100x gauss4's steps to reach 1e-6 here)."""
    start = time.perf_counter()
    s = plate_structure(nx, ny)
    w2, phi = sla.eigsh(s.K, k=3, M=s.M, sigma=0.0, which="LM", tol=0.0)
    order = np.argsort(w2)
    w2, phi = w2[order], phi[:, order]
    residual = max(np.linalg.norm(s.K @ phi[:, j] - w2[j] * (s.M @ phi[:, j])) / np.linalg.norm(s.K @ phi[:, j])
                   for j in range(3))
    w = np.sqrt(w2)
    alpha, beta = raydamp.rayleigh_coefficients(w[0], w[2], 0.02, 0.02)
    q0 = phi @ np.array([1.0, 0.5, 0.25])
    problem = Problem(s, alpha, beta, q0, 2 * (2 * np.pi / w[0]))
    reference = ModalSolution(lambda: iter([(w2, phi)]), s.M, alpha, beta).at(q0, problem.times)
    setup = time.perf_counter() - start
    omega_max = np.sqrt(raydamp.LinearStructure(s.M, s.K).spectral_bound / 1.05)
    print(f"\nplate (raydamp alone), n = {s.n}, nnz(K) = {s.K.nnz}: omega_1 = {w[0]:.4g}, omega_3 = {w[2]:.4g}, "
          f"omega_max = {omega_max:.4g}, alpha = {alpha:.3g}, beta = {beta:.3g}, T = 2 periods of mode 1 = "
          f"{problem.T:.4g}")
    print(f"    q0 = phi_1 + phi_2 / 2 + phi_3 / 4 at rest; reference: their exact modal solution (eigsh residual "
          f"||K phi - w^2 M phi|| / ||K phi|| <= {residual:.1e}); plate, modes and reference built in {setup:.1f} s")
    run_gauss, build = raydamp_runner(problem, "gauss4")
    run_mid, _ = raydamp_runner(problem, "midpoint")
    print(f"    raydamp.LinearStructure built in {build:.3f} s (not in the times below)")
    for label, run in (("gauss4", run_gauss), ("midpoint", run_mid)):
        seconds, _ = run(1)                       # 10 steps: the factorisation and a few solves
        print(f"    {label:<8} 10 steps (its factorisation and 10 solves): {seconds:.2f} s")
    norm = np.linalg.norm(q0)
    m, tried = time_to_tolerance(run_gauss, reference, norm, 4, 8, TOLERANCE)
    runs = ", ".join(f"{SAVES * k}: {e:.1e}" for k, (e, _) in sorted(tried.items()))
    row = {"model": "plate", "n": s.n, "tolerance": TOLERANCE}
    if m is None:
        print(f"    gauss4   did not reach {TOLERANCE:g} [{runs}]")
        return row
    error, seconds = tried[m]
    seconds = best_time(run_gauss, m, seconds)
    h = problem.T / (SAVES * m)
    print(f"    gauss4   {SAVES * m:>8} steps (h = {h:.3g}, h omega_max = {h * omega_max:.3g}), error {error:.2e}, "
          f"{seconds:9.3f} s, {1e6 * seconds / (SAVES * m):9.1f} us/step   [steps: error of {len(tried)} runs: "
          f"{runs}]")
    row["raydamp gauss4"] = (SAVES * m, seconds)
    mid_seconds, q = run_mid(m)
    mid_error = float(np.max(np.linalg.norm(q - reference, axis=1)) / norm)
    print(f"    midpoint {SAVES * m:>8} steps (the same h), error {mid_error:.2e}, {mid_seconds:9.3f} s, "
          f"{1e6 * mid_seconds / (SAVES * m):9.1f} us/step")
    return row


# -- main ----------------------------------------------------------------------------------------

SIZES = {"chain": [200, 2000, 20000], "beam": [67, 667, 6667]}   # beam: elements (3 DOF each)
COLUMNS = ["raydamp gauss4", "raydamp midpoint", "OpenSees Newmark"]


def sensitivity(problem: Problem, m: int) -> float:
    """How much a random relative change of one rounding unit in every entry of K moves the solution
    (gauss4, 10 m steps): what double precision can tell of this system at all."""
    s = problem.structure
    K = s.K.tocoo()
    change = 1.0 + np.finfo(float).eps * np.random.default_rng(0).uniform(-1.0, 1.0, K.nnz)
    perturbed = sparse.csc_matrix((K.data * change, (K.row, K.col)), shape=K.shape)
    perturbed = (0.5 * (perturbed + perturbed.T)).tocsc()
    other = Problem(Structure(s.name, s.M, perturbed, s.tip, s.lumped), problem.alpha, problem.beta, problem.q0,
                    problem.T)
    a, b = raydamp_runner(problem, "gauss4")[0](m)[1], raydamp_runner(other, "gauss4")[0](m)[1]
    return float(np.max(np.linalg.norm(a - b, axis=1)) / np.linalg.norm(problem.q0))


def reference_states(problem: Problem, out=print):
    """(states at the saved times, their estimated relative error, what they are). The chain's modes are known in
    closed form; the beam's come from benchmarks/modal_reference.py: its lowest modes in extended precision, the
    exact modal solution of the very float K, M and q0 (a double route, dense eigh or a spsolve, is off by about
    u cond(K): 4e-8 at 201 DOF, 1e-5 to 2e-4 at 2,001). Its self-checks are printed: at 201 DOF against the same
    computation in mpmath at 32 digits and against dense eigh, at 2,001 against dense eigh."""
    s, norm = problem.structure, np.linalg.norm(problem.q0)
    if s.name == "chain":
        return (ModalSolution(chain_modes(s.n), s.M, problem.alpha, problem.beta).at(problem.q0, problem.times),
                1e-12, "exact modal solution (closed-form modes)")
    try:
        from modal_reference import modal_reference
    except ImportError as error:
        raise SystemExit(f"the beam's reference needs mpmath ({error}): .venv/bin/pip install mpmath") from None

    def distance(a, b):
        return float(np.max(np.linalg.norm(a - b, axis=1)) / norm)
    ref = modal_reference(s.M, s.K, problem.alpha, problem.beta, problem.q0, problem.times)
    out(f"    reference: {ref.describe()}")
    error = ref.tail
    if s.n <= 300:
        high = modal_reference(s.M, s.K, problem.alpha, problem.beta, problem.q0, problem.times, precision="mp",
                               digits=32, start=ref.vectors)
        error = max(error, distance(ref.states, high.states))
        out(f"    self-check, the same in {high.describe()}: {distance(ref.states, high.states):.1e} apart")
    if s.n <= 3000:
        dense = ModalSolution(dense_modes(s), s.M, problem.alpha, problem.beta).at(problem.q0, problem.times)
        out(f"    self-check, the dense-eigh (double) modal solution: {distance(dense, ref.states):.1e} from it "
            "(eigh resolves lambda_1 only to about u cond(K))")
    checked = "mpmath-checked" if s.n <= 300 else "the mpmath check runs at 201 DOF; error here: the tail bound"
    return ref.states, error, f"extended-precision modal solution (benchmarks/modal_reference.py; {checked})"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="200 and 2,000 DOF only")
    parser.add_argument("--sizes", help="only these sizes, comma-separated DOF counts (e.g. 20001)")
    parser.add_argument("--models", default="chain,beam,ground,plate",
                        help="any of chain, beam, ground (the 10-storey frame under a record), plate (about 10^5 "
                             "DOF, raydamp alone), ida (a yielding frame's incremental dynamic analysis; with "
                             "--quick 2 records x 3 scales), comma-separated")
    args = parser.parse_args()
    ops = opensees()
    print(f"raydamp {raydamp.__version__}; OpenSeesPy "
          f"{ops.version() if ops and hasattr(ops, 'version') else 'not installed (pip install openseespy)'}; "
          f"error: max over {SAVES} saved times of ||q - q_exact|| / ||q0||, tolerance {TOLERANCE:g} "
          "(unless the row says otherwise)")
    rows = []
    names = args.models.split(",")
    if "ground" in names:
        import ground_motion_frame

        ground_motion_frame.run(ops)
    if "ida" in names:
        import ida_frame

        ida_frame.run(ops, quick=args.quick)
    for name in (n for n in names if n not in ("ground", "plate", "ida")):
        for size in SIZES[name][: 2 if args.quick else 3]:
            if args.sizes and str(size * (3 if name == "beam" else 1)) not in args.sizes.split(","):
                continue
            s = chain(size) if name == "chain" else beam(size)
            w = lowest_frequencies(s)
            alpha, beta = raydamp.rayleigh_coefficients(w[0], w[2], 0.02, 0.02)
            q0 = sla.spsolve(s.K.tocsc(), np.eye(s.n)[s.tip])
            problem = Problem(s, alpha, beta, q0, 2 * (2 * np.pi / w[0]))
            omega_max = np.sqrt(raydamp.LinearStructure(s.M, s.K).spectral_bound / 1.05)
            print(f"\n{name}, n = {s.n}: omega_1 = {w[0]:.4g}, omega_3 = {w[2]:.4g}, omega_max = {omega_max:.4g}, "
                  f"alpha = {alpha:.3g}, beta = {beta:.3g}, T = 2 periods of mode 1 = {problem.T:.4g}")
            if ops is not None:
                print(f"    M, K, C: OpenSees' differ from those assembled here by at most "
                      f"{compare_matrices(ops, problem)}")
                if name == "beam":  # both tools then integrate the very same numbers
                    M, K = opensees_matrices(ops, problem)
                    problem.structure = Structure(name, M, K, s.tip, s.lumped)
                    print("    raydamp and the reference use OpenSees' M and K (as its nodal forces apply them)")
            start = time.perf_counter()
            norm = np.linalg.norm(q0)
            reference, reference_error, reference_note = reference_states(problem)
            print(f"    reference: {reference_note}, estimated error {reference_error:.0e}, "
                  f"in {time.perf_counter() - start:.1f} s")
            # How far the answer moves when K changes by its rounding: what a K assembled apart contributes (two
            # codes that assemble K, or OpenSees' stiffness in its damping and in its element forces), not what
            # one tool resolves of its own K.
            ulp = sensitivity(problem, 256)
            print(f"    a one-ulp random change of K's entries moves the solution by {ulp:.1e} (what a K assembled "
                  "apart contributes)")
            # Past 10^4 DOF a double factorisation of the beam's K is off by about u cond(K) ~ 1e-3 itself: the
            # row reports the floor against the exact solution and the cost per step.
            tolerance = TOLERANCE if s.n < 10_000 or name == "chain" else 1e-2
            row = {"model": name, "n": s.n, "tolerance": tolerance}
            run_gauss, build = raydamp_runner(problem, "gauss4")
            run_mid, _ = raydamp_runner(problem, "midpoint")
            print(f"    raydamp.LinearStructure built in {build:.3f} s (not in the times below)")
            tools = [("raydamp gauss4", run_gauss, 4, 4, 0.7), ("raydamp midpoint", run_mid, 2, 16, 0.7)]
            if ops is not None:
                system, system_times = fastest_opensees_system(ops, problem)
                print("    OpenSees' linear solvers, 200 steps: " +
                      ", ".join(f"{k} {v:.3f} s" for k, v in system_times.items()) + f": {system}")
                run_ops = opensees_runner(ops, problem, system)
                same = np.max(np.linalg.norm(run_ops(4)[1] - run_mid(4)[1], axis=1)) / norm
                print(f"    the same method at the same h (40 steps): OpenSees Newmark and raydamp midpoint differ "
                      f"by {same:.1e}")
                tools.append(("OpenSees Newmark", run_ops, 2, None, 0.92))
            found = {}
            if tolerance >= 1e-2:
                print("    ** not timed to a tolerance: the floor against the exact solution, then the cost of "
                      f"{SAVES * 256} steps (h = {problem.T / (SAVES * 256):.3g}) **")
                floor = []
                for m in (32, 64, 128, 256):
                    floor.append(f"{SAVES * m}: "
                                 f"{np.max(np.linalg.norm(run_gauss(m)[1] - reference, axis=1)) / norm:.1e}")
                print(f"    raydamp gauss4 against the exact solution, steps: error  {', '.join(floor)}")
                for label, run, *_ in tools:
                    seconds, q = run(256)
                    error = np.max(np.linalg.norm(q - reference, axis=1)) / norm
                    print(f"    {label:<18} {seconds:9.3f} s, {1e6 * seconds / (SAVES * 256):9.1f} us/step, "
                          f"error {error:.1e}")
                    row[label + " per step"] = seconds / (SAVES * 256)
                tools = []
            for label, run, order, m_start, shrink in tools:
                # Newmark average acceleration is raydamp's midpoint: its search starts at midpoint's h.
                m_start = m_start or found.get("raydamp midpoint") or 16
                m, tried = time_to_tolerance(run, reference, norm, order, m_start, tolerance, shrink)
                runs = ", ".join(f"{SAVES * k}: {e:.1e}" for k, (e, _) in sorted(tried.items()))
                if m is None:
                    print(f"    {label:<18} did not reach {tolerance:g} [{runs}]")
                    continue
                found[label] = m
                error, seconds = tried[m]
                seconds = best_time(run, m, seconds)
                print(f"    {label:<18} {SAVES * m:>8} steps (h = {problem.T / (SAVES * m):.3g}, h omega_max = "
                      f"{problem.T / (SAVES * m) * omega_max:.3g}), error {error:.2e}, {seconds:9.3f} s, "
                      f"{1e6 * seconds / (SAVES * m):9.1f} us/step   [steps: error of {len(tried)} runs: {runs}]")
                row[label] = (SAVES * m, seconds)
            rows.append(row)
    if "plate" in names:
        rows.append(run_plate(*PLATE))
    if not rows:  # ground and ida print their own tables
        return
    print("\ntime to the tolerance, seconds [steps] (a row whose system resolves nothing finer than 1e-2: time per "
          "step at equal h)")
    print(f"{'model':<6} {'DOF':>6} {'tolerance':>9} " + " ".join(f"{c:>22}" for c in COLUMNS)
          + f" {'OpenSees / gauss4':>18}")
    for row in rows:
        cells = [f"{row[c][1]:>11.3f} [{row[c][0]:>8}]" if c in row
                 else f"{1e6 * row[c + ' per step']:>14.1f} us/step" if c + " per step" in row
                 else f"{'-':>22}" for c in COLUMNS]
        ratio = (f"{row['OpenSees Newmark'][1] / row['raydamp gauss4'][1]:.0f}"
                 if "OpenSees Newmark" in row and "raydamp gauss4" in row else "-")
        print(f"{row['model']:<6} {row['n']:>6} {row['tolerance']:>9.0e} " + " ".join(cells) + f" {ratio:>18}")


if __name__ == "__main__":
    _reexec_with_opensees_libraries()
    main()
