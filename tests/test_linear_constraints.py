"""Linear constraints C q = 0 of a LinearStructure by elimination (issue 45): tied DOFs and a rigid diaphragm
against the reduced models built by hand, and against the constrained equations with their multipliers
(solve_ivp); bad input names its argument."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sparse
from scipy.integrate import solve_ivp

import raydamp

ALPHA, BETA = 0.3, 2e-3


def shear_frame(masses, springs):
    n = len(masses)
    K = np.zeros((n, n))
    for i, k in enumerate(springs):
        K[i, i] += k
        if i > 0:
            K[i - 1, i - 1] += k
            K[i - 1, i] -= k
            K[i, i - 1] -= k
    return np.diag(masses), K


def constrained_reference(M, K, C, q0, v0, t_end):
    """M q'' + (alpha M + beta K) q' + K q = -C^T lambda with C q'' = 0 (the multipliers eliminated)."""
    D = ALPHA * M + BETA * K
    Minv = np.linalg.inv(M)
    S = C @ Minv @ C.T
    n = len(q0)

    def rhs(t, z):
        q, v = z[:n], z[n:]
        force = -D @ v - K @ q
        lam = np.linalg.solve(S, C @ Minv @ force)
        return np.concatenate([v, Minv @ (force - C.T @ lam)])

    sol = solve_ivp(rhs, (0, t_end), np.concatenate([q0, v0]), method="DOP853", rtol=1e-12, atol=1e-14)
    return sol.y[:n, -1]


def test_two_tied_storeys_equal_the_reduced_frame_built_by_hand():
    # A 3-storey frame whose top two floors are tied by a rigid link: q1 = q2.
    masses, springs = [2.0, 1.5, 1.0], [300.0, 200.0, 100.0]
    M, K = shear_frame(masses, springs)
    structure = raydamp.LinearStructure(M, K, alpha=ALPHA, beta=BETA)
    C = sparse.csr_matrix([[0.0, 1.0, -1.0]])
    tied = structure.tie(C)
    assert list(tied.kept) == [0, 2] and list(tied.slaves) == [1]
    # by hand, in (q0, q2): the tied floors' masses add, the spring between them does nothing
    M_hand = np.diag([2.0, 2.5])
    K_hand = np.array([[500.0, -200.0], [-200.0, 200.0]])
    np.testing.assert_allclose(tied.reduced.M.toarray(), M_hand, rtol=0, atol=1e-14)
    np.testing.assert_allclose(tied.reduced.K.toarray(), K_hand, rtol=0, atol=1e-12)
    assert tied.reduced.mass_kind == "lumped"  # a tie keeps a lumped mass lumped
    q0 = np.array([0.01, 0.02, 0.02])
    v0 = np.array([0.0, 0.1, 0.1])
    y0, py0 = tied.reduce_state(q0, M @ v0)
    options = dict(method="3s", h=1e-3, t_end=1.0, save_every=100)
    sol = raydamp.integrate(tied.reduced, y0, py0, **options)
    hand = raydamp.integrate(raydamp.LinearStructure(M_hand, K_hand, alpha=ALPHA, beta=BETA), [0.01, 0.02],
                             [0.0, 0.25], **options)
    np.testing.assert_allclose(sol.q, hand.q, rtol=0, atol=1e-15)
    q, p = tied.expand(sol.q, sol.p)
    np.testing.assert_array_equal(q[:, 1], q[:, 2])
    np.testing.assert_allclose(p[:, 1] / 1.5, p[:, 2] / 1.0, rtol=1e-13)  # one velocity for the tied floors
    # and against the constrained equations with their multipliers: 3s's error, order 2
    exact = constrained_reference(M, K, C.toarray(), q0, v0, 1.0)
    errors = []
    for h in (2e-3, 1e-3):
        run = raydamp.integrate(tied.reduced, y0, py0, method="3s", h=h, t_end=1.0, save_every=10_000)
        errors.append(float(np.max(np.abs(tied.expand(run.q[-1])[0] - exact))))
    assert 3.6 <= errors[0] / errors[1] <= 4.4, errors
    assert errors[1] <= 1e-5 * np.max(np.abs(q0)), errors  # measured 6.2e-6


def diaphragm(corners, masses, kx, ky, centre_mass, centre_inertia):
    """A floor slab: four corner nodes (ux, uy each) on columns of their own stiffness, and its centre
    (ux_c, uy_c, theta_c), last. The diaphragm is rigid in its plane: ux_i = ux_c - y_i theta, uy_i = uy_c + x_i
    theta."""
    n = 2 * len(corners) + 3
    M = np.diag([m for m in masses for _ in (0, 1)] + [centre_mass, centre_mass, centre_inertia])
    K = np.diag([k for pair in zip(kx, ky) for k in pair] + [0.0, 0.0, 0.0])
    rows = []
    for i, (x, y) in enumerate(corners):
        for axis, arm in ((0, -y), (1, x)):
            row = np.zeros(n)
            row[2 * i + axis] = 1.0
            row[-3 + axis] = -1.0
            row[-1] = -arm
            rows.append(row)
    return M, K, sparse.csr_matrix(np.array(rows))


def test_a_rigid_diaphragm_equals_its_three_dof_model_built_by_hand():
    corners = [(2.0, 1.5), (-2.0, 1.5), (-2.0, -1.5), (2.0, -1.5)]
    masses, kx, ky = [1.0, 1.2, 0.8, 1.1], [100.0, 150.0, 120.0, 90.0], [80.0, 110.0, 140.0, 100.0]
    m_c, j_c = 3.0, 2.0
    M, K, C = diaphragm(corners, masses, kx, ky, m_c, j_c)
    tied = raydamp.LinearStructure(M, K, alpha=ALPHA, beta=BETA).tie(C)
    assert list(tied.kept) == [8, 9, 10]  # the corners follow the centre
    x, y = np.array(corners).T
    m, kx, ky = np.array(masses), np.array(kx), np.array(ky)
    total = m_c + m.sum()
    M_hand = np.array([[total, 0, -(m * y).sum()], [0, total, (m * x).sum()],
                       [-(m * y).sum(), (m * x).sum(), j_c + (m * (x**2 + y**2)).sum()]])
    K_hand = np.array([[kx.sum(), 0, -(kx * y).sum()], [0, ky.sum(), (ky * x).sum()],
                       [-(kx * y).sum(), (ky * x).sum(), (kx * y**2 + ky * x**2).sum()]])
    np.testing.assert_allclose(tied.reduced.M.toarray(), M_hand, rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(tied.reduced.K.toarray(), K_hand, rtol=1e-14, atol=1e-12)
    # a displaced, turning floor
    y0 = np.array([0.01, -0.005, 0.002])
    q0 = tied.expand(y0)[0]
    v0 = tied.expand(np.array([0.0, 0.05, -0.03]))[0]
    assert np.max(np.abs(C @ q0)) <= 1e-17
    ry0, rp0 = tied.reduce_state(q0, M @ v0)
    np.testing.assert_array_equal(ry0, y0)
    options = dict(method="2s", h=1e-3, t_end=1.0, save_every=50)
    sol = raydamp.integrate(tied.reduced, ry0, rp0, **options)
    hand = raydamp.integrate(raydamp.LinearStructure(M_hand, K_hand, alpha=ALPHA, beta=BETA), y0,
                             M_hand @ [0.0, 0.05, -0.03], **options)
    np.testing.assert_allclose(sol.q, hand.q, rtol=0, atol=1e-14)
    q, _ = tied.expand(sol.q, sol.p)
    assert np.max(np.abs(tied.residual(q))) <= 1e-16
    exact = constrained_reference(M, K, C.toarray(), q0, v0, 1.0)
    errors = []
    for h in (2e-3, 1e-3):
        run = raydamp.integrate(tied.reduced, ry0, rp0, method="2s", h=h, t_end=1.0, save_every=10_000)
        errors.append(float(np.max(np.abs(tied.expand(run.q[-1])[0] - exact))))
    assert 3.6 <= errors[0] / errors[1] <= 4.4, errors
    assert errors[1] <= 5e-5 * np.max(np.abs(q0)), errors  # measured 2.6e-5


def test_a_load_and_a_ground_motion_reach_the_reduced_structure_as_their_virtual_work():
    M, K = shear_frame([2.0, 1.5, 1.0], [300.0, 200.0, 100.0])
    f = np.array([1.0, 2.0, 3.0])
    tied = raydamp.LinearStructure(M, K, f=f).tie([[0.0, 1.0, -1.0]])
    np.testing.assert_allclose(tied.reduced.f, [1.0, 5.0])
    r = tied.reduce_influence(np.ones(3))  # a rigid ground motion: every floor moves with the ground
    np.testing.assert_allclose(tied.reduced.mass_product(r), tied.T.T @ (M @ np.ones(3)))


@pytest.mark.parametrize("C,message", [
    (np.zeros((1, 4)), r"^constraints\[0\]: the row is zero"),
    (np.ones((1, 3)), r"^constraints: C must have n = 4 columns"),
    (np.array([[1.0, -1.0, 0, 0], [2.0, -2.0, 0, 0]]), r"^constraints: C's rows are dependent"),
    (np.ones((4, 4)), r"^constraints: C must have 1 to 3 rows"),
    ("x", r"^constraints: must be a matrix"),
])
def test_bad_constraints_are_refused_naming_them(C, message):
    M, K = shear_frame([1.0] * 4, [10.0] * 4)
    with pytest.raises(ValueError, match=message):
        raydamp.LinearStructure(M, K).tie(C)


def test_a_state_off_the_constraints_is_refused_naming_the_row():
    M, K = shear_frame([2.0, 1.5, 1.0], [300.0, 200.0, 100.0])
    tied = raydamp.LinearStructure(M, K).tie([[0.0, 1.0, -1.0]])
    with pytest.raises(ValueError, match=r"^q0: it does not satisfy constraints\[0\]"):
        tied.reduce_state([0.0, 0.01, 0.02], np.zeros(3))
    with pytest.raises(ValueError, match=r"^p0: its velocity M\^-1 p0 does not satisfy constraints\[0\]"):
        tied.reduce_state(np.zeros(3), [0.0, 1.0, 1.0])


def test_a_structure_with_springs_is_refused_not_reduced_without_them():
    # The reduced model is a LinearStructure: tying a yielding Structure would have dropped its springs silently.
    from raydamp.materials import ElasticPlastic

    frame = raydamp.Structure(np.eye(2), np.array([[2.0, -1.0], [-1.0, 1.0]]),
                              springs=[raydamp.Spring((0,), ElasticPlastic(1.0, 0.1))])
    with pytest.raises(ValueError, match=r"^constraints: tie eliminates constraints from a LinearStructure; a "
                                         r"Structure's springs"):
        frame.tie([[1.0, -1.0]])
