"""The implicit methods of a LinearStructure ("midpoint" and "gauss4", issue 25): the exact discrete
energy balance, their orders (and yoshida4 over midpoint), unconditional stability, the exact modal
solution, Newmark average acceleration, a quadratic momentum map, and what they refuse."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse as sparse
import scipy.sparse.linalg as sla
from fe_plate import plate
from paper import fitted_slope

import raydamp
from raydamp.methods.catalogue import linear_structure_methods
from raydamp.models import DampedPendulum

IMPLICIT = ["midpoint", "gauss4"]


def shear_building(n: int):
    """n unit storey masses joined by unit springs, fixed at the base: (M, K)."""
    main = np.full(n, 2.0)
    main[-1] = 1.0
    K = sparse.diags([-np.ones(n - 1), main, -np.ones(n - 1)], [-1, 0, 1]).tocsc()
    return sparse.identity(n, format="csc"), K


def rayleigh_2_percent(M, K):
    """(alpha, beta) for 2% damping in modes 1 and 3."""
    w = np.sqrt(scipy.linalg.eigh(K.toarray(), M.toarray(), eigvals_only=True))
    return raydamp.rayleigh_coefficients(w[0], w[2], 0.02, 0.02)


class Modal:
    """The exact solution of M q'' + C q' + K q = f (f constant) by the full modal decomposition."""

    def __init__(self, M, K, alpha, beta, f):
        w2, self.phi = scipy.linalg.eigh(K.toarray(), M.toarray())
        self.c, self.w2 = alpha + beta * w2, w2
        self.M = M
        self.static = np.linalg.solve(K.toarray(), f)

    def q(self, q0, p0, t):
        a = self.phi.T @ (self.M @ (q0 - self.static))
        b = self.phi.T @ p0                      # Phi^T M qdot
        disc = np.sqrt((self.c ** 2 / 4 - self.w2).astype(complex))
        r1, r2 = -self.c / 2 + disc, -self.c / 2 - disc
        A = (b - r2 * a) / (r1 - r2)             # eta = A e^{r1 t} + (a - A) e^{r2 t}; no repeated roots here
        eta = (A * np.exp(r1 * t) + (a - A) * np.exp(r2 * t)).real
        return self.static + self.phi @ eta


# -- the energy balance --------------------------------------------------------------------------

def damped_plate(nx, ny, mode, load_seed):
    """plate(nx, ny) with 2% damping in modes 1 and `mode` and a random constant load 1e-3 N(0, 1):
    (plate, structure, load, alpha, beta)."""
    pl = plate(nx, ny)
    w = np.sqrt(np.sort(sla.eigsh(pl.K, k=mode, M=pl.M, sigma=0.0, which="LM", return_eigenvectors=False)))
    alpha, beta = raydamp.rayleigh_coefficients(w[0], w[mode - 1], 0.02, 0.02)
    f = 1e-3 * np.random.default_rng(load_seed).standard_normal(pl.n)
    return pl, raydamp.LinearStructure(pl.M, pl.K, alpha=alpha, beta=beta, f=f), f, alpha, beta


@pytest.fixture(scope="module")
def plate_10k():
    """A plate of 9,940 DOF (consistent mass), 2% damping in modes 1 and 6, a random constant load."""
    return damped_plate(70, 70, 6, 3)


def test_midpoint_energy_balance_holds_per_step_to_rounding(plate_10k):
    # H(z1) - H(z0) = -h vbar^T C vbar + h f^T vbar with H = 1/2 p^T M^{-1} p + 1/2 q^T K q and
    # vbar = (q1 - q0) / h, computed here from the saved states alone.
    pl, s, f, alpha, beta = plate_10k
    rng = np.random.default_rng(4)
    q0, p0 = 1e-3 * rng.standard_normal(pl.n), 1e-3 * rng.standard_normal(pl.n)
    h = 10.0 / np.sqrt(s.spectral_bound)               # h omega_max about 10: far past any explicit method
    sol = raydamp.integrate(s, q0, p0, method="midpoint", h=h, n_steps=10)
    elastic = sol.energy + sol.q @ f                    # Solution.energy includes the load's potential -f^T q
    C = alpha * pl.M + beta * pl.K
    for k in range(10):
        vbar = (sol.q[k + 1] - sol.q[k]) / h
        balance = -h * vbar @ (C @ vbar) + h * f @ vbar
        assert elastic[k + 1] - elastic[k] == pytest.approx(balance, abs=1e-13 * elastic[0])


@pytest.mark.parametrize("method", IMPLICIT)
def test_energy_and_damping_work_balance_to_rounding(plate_10k, method):
    # The step adds its own damping work (h sum_i b_i V_i^T C V_i, its stage velocities), so
    # H(t) - H(0) + W(t) (H with the load's potential) is zero up to rounding at every step.
    pl, s, f, _, _ = plate_10k
    rng = np.random.default_rng(5)
    q0, p0 = 1e-3 * rng.standard_normal(pl.n), 1e-3 * rng.standard_normal(pl.n)
    h = 10.0 / np.sqrt(s.spectral_bound)
    sol = raydamp.integrate(s, q0, p0, method=method, h=h, n_steps=10, work=True)
    assert sol.work[-1] > 0.0
    assert np.max(np.abs(sol.energy_balance)) <= 1e-13 * abs(sol.energy[0])


# -- orders and the exact solution ---------------------------------------------------------------

def chain_problem(n=8, *, beta_zero=False, load=False):
    M, K = shear_building(n)
    alpha, beta = rayleigh_2_percent(M, K)
    if beta_zero:
        alpha, beta = 0.02, 0.0
    f = np.linspace(0.1, 0.3, n) if load else np.zeros(n)
    q0 = np.linalg.solve(K.toarray(), np.eye(n)[-1])   # the static deflection under a top load
    p0 = 0.05 * np.ones(n)
    s = raydamp.LinearStructure(M, K, alpha=alpha, beta=beta, f=f if load else None)
    return s, Modal(M, K, alpha, beta, f), q0, p0


@pytest.mark.parametrize(("method", "composition", "order", "hs"), [
    ("midpoint", None, 2, [0.2, 0.1, 0.05]),
    ("gauss4", None, 4, [0.4, 0.2, 0.1]),
    ("midpoint", "yoshida4", 4, [0.4, 0.2, 0.1]),
])
def test_order(method, composition, order, hs):
    s, modal, q0, p0 = chain_problem(beta_zero=composition is not None, load=True)
    t_end = 20.0
    exact = modal.q(q0, p0, t_end)
    errors = [np.linalg.norm(raydamp.integrate(s, q0, p0, method=method, composition=composition, h=h,
                                               t_end=t_end).q[-1] - exact) for h in hs]
    assert fitted_slope(hs, errors) == pytest.approx(order, abs=0.15), errors


@pytest.mark.parametrize(("method", "h"), [("midpoint", 2e-4), ("gauss4", 5e-3)])
def test_equals_the_exact_modal_solution_at_small_h(method, h):
    s, modal, q0, p0 = chain_problem(load=True)
    sol = raydamp.integrate(s, q0, p0, method=method, h=h, t_end=20.0, save_every=round(2.0 / h))
    assert len(sol.t) == 11
    error = max(np.linalg.norm(q - modal.q(q0, p0, t)) for t, q in zip(sol.t, sol.q)) / np.linalg.norm(q0)
    assert error <= 1e-8


def test_midpoint_is_newmark_average_acceleration_in_free_vibration():
    # Newmark (gamma = 1/2, beta_N = 1/4) written out: K_eff = K + (2/h) C + (4/h^2) M.
    M, K = shear_building(8)
    alpha, beta = rayleigh_2_percent(M, K)
    C = (alpha * M + beta * K).toarray()
    M, K = M.toarray(), K.toarray()
    q0, v0, h, steps = np.linspace(0.0, 1.0, 8), np.linspace(0.5, -0.5, 8), 0.3, 50
    solve = scipy.linalg.lu_factor(K + (2 / h) * C + (4 / h ** 2) * M)
    q, v = q0.copy(), v0.copy()
    a = np.linalg.solve(M, -C @ v - K @ q)
    for _ in range(steps):
        q_new = scipy.linalg.lu_solve(solve, M @ ((4 / h ** 2) * q + (4 / h) * v + a) + C @ ((2 / h) * q + v))
        a_new = (4 / h ** 2) * (q_new - q) - (4 / h) * v - a
        q, v, a = q_new, v + 0.5 * h * (a + a_new), a_new
    sol = raydamp.integrate(raydamp.LinearStructure(M, K, alpha=alpha, beta=beta), q0, M @ v0, method="midpoint",
                            h=h, n_steps=steps)
    np.testing.assert_allclose(sol.q[-1], q, rtol=0, atol=1e-12 * np.abs(q0).max())
    np.testing.assert_allclose(np.linalg.solve(M, sol.p[-1]), v, rtol=0, atol=1e-12 * np.abs(v0).max())


# -- stability -----------------------------------------------------------------------------------

@pytest.mark.parametrize("method", IMPLICIT)
@pytest.mark.parametrize("damped", [False, True])
def test_unconditionally_stable_at_h_omega_max_1e4(method, damped):
    pl = plate(20, 10)
    alpha, beta = rayleigh_2_percent(pl.M, pl.K) if damped else (0.0, 0.0)
    s = raydamp.LinearStructure(pl.M, pl.K, alpha=alpha, beta=beta)
    h = 1e4 / np.sqrt(s.spectral_bound / 1.05)          # the bound has a 5% margin over omega_max^2
    q0 = 1e-3 * np.random.default_rng(6).standard_normal(pl.n)
    sol = raydamp.integrate(s, q0, np.zeros(pl.n), method=method, h=h, n_steps=200)
    assert sol.status == "completed"
    H = sol.energy
    if not damped:  # a quadratic invariant: kept to rounding at any h
        assert np.max(np.abs(H - H[0])) <= 1e-11 * H[0]
    else:           # H(z1) - H(z0) = -h vbar^T C vbar <= 0 at every step, and it decays
        assert np.all(np.diff(H) <= 1e-12 * H[0])
        assert H[-1] < H[0]


# -- a quadratic momentum map --------------------------------------------------------------------

@pytest.mark.parametrize("method", IMPLICIT)
def test_rotation_momentum_map_of_two_identical_copies_is_kept(method):
    # Two identical copies of a structure, M = diag(M0, M0), K = diag(K0, K0), are invariant under
    # the rotations (q1, q2) -> (c q1 - s q2, s q1 + c q2); the momentum map J = q1^T p2 - q2^T p1
    # is a quadratic invariant, which Gauss methods keep exactly. (A single LinearStructure has no
    # symmetry in general, and Rayleigh damping does not keep J: alpha M damps it at the rate
    # alpha, and beta K exerts a torque -beta (q1^T K0 v2 - q2^T K0 v1); hence undamped here.)
    pl = plate(6, 3)
    M = sparse.block_diag([pl.M, pl.M]).tocsc()
    K = sparse.block_diag([pl.K, pl.K]).tocsc()
    n = pl.n
    rng = np.random.default_rng(7)
    q0, p0 = rng.standard_normal(2 * n), rng.standard_normal(2 * n)
    s = raydamp.LinearStructure(M, K)
    sol = raydamp.integrate(s, q0, p0, method=method, h=3.0 / np.sqrt(s.spectral_bound), n_steps=1000,
                            save_every=10)
    J = np.einsum("ti,ti->t", sol.q[:, :n], sol.p[:, n:]) - np.einsum("ti,ti->t", sol.q[:, n:], sol.p[:, :n])
    assert abs(J[0]) > 1.0
    assert np.max(np.abs(J - J[0])) <= 1e-12 * np.linalg.norm(q0) * np.linalg.norm(p0)


# -- the catalogue and what is refused -----------------------------------------------------------

def test_catalogue_lists_the_implicit_methods():
    rows = {m.name: m for m in raydamp.methods() if m.name in IMPLICIT}
    assert linear_structure_methods() == set(IMPLICIT)
    assert (rows["midpoint"].order, rows["gauss4"].order) == (2, 4)
    assert not rows["midpoint"].explicit and not rows["gauss4"].explicit
    assert rows["midpoint"].symmetric and not rows["gauss4"].symmetric
    assert "Newmark average acceleration" in rows["midpoint"].description
    assert "H(z1) - H(z0) = -h vbar^T C vbar + h f^T vbar" in rows["midpoint"].description


@pytest.mark.parametrize("method", IMPLICIT)
def test_other_kinds_refuse_them_naming_the_method(method):
    with pytest.raises(ValueError, match=f"method: '{method}'.*LinearStructure"):
        raydamp.integrate(DampedPendulum(), [1.0], [0.0], method=method, h=0.1, n_steps=3)


def test_composition_refused_where_the_backward_matrix_is_indefinite():
    # beta K damping: M - (|s|/2) C + (s^2/4) K is indefinite once |s| < 2 beta.
    M, K = shear_building(50)
    s = raydamp.LinearStructure(M, 100 * K, alpha=0.0, beta=0.5)   # omega_max about 20
    with pytest.raises(ValueError, match="composition: 'yoshida4'.*not positive definite.*beta"):
        raydamp.integrate(s, np.ones(50), np.zeros(50), method="midpoint", composition="yoshida4", h=0.1,
                          n_steps=3)
    with pytest.raises(ValueError, match="composition: 'yoshida4'"):
        raydamp.integrate(s, np.ones(50), np.zeros(50), method="gauss4", composition="yoshida4", h=0.1,
                          n_steps=3)


def test_the_last_short_step_gets_its_own_factorisation():
    s, _, q0, p0 = chain_problem()
    full = raydamp.integrate(s, q0, p0, method="gauss4", h=0.3, t_end=1.0)
    assert full.steps == 4 and full.t[-1] == 1.0
    three = raydamp.integrate(s, q0, p0, method="gauss4", h=0.3, n_steps=3)
    last = raydamp.integrate(s, three.q[-1], three.p[-1], method="gauss4", h=1.0 - 3 * 0.3, n_steps=1)
    np.testing.assert_array_equal(full.q[-1], last.q[-1])
