"""advise's modal error model against plain linear algebra: S^n from matrix powers, the exact motion from expm.

numerical_x writes S^n through its eigenvalues (real arithmetic for a rotation, the two powers apart for real ones,
a series for near-double ones) and exact_x the damped motion through cosines or the two exponentials; neither was
tested alone, only through the advise runs they predict."""

import numpy as np
import pytest
import scipy.linalg

from raydamp.run import advise_modal as modal


def step_matrices():
    rng = np.random.default_rng(5)
    out = []
    for theta, r in ((0.3, 0.999), (2.9, 0.9999), (1e-4, 1.0), (1.0, 0.5)):   # complex conjugate eigenvalues
        P = rng.standard_normal((2, 2))
        rotation = r * np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])
        out.append(P @ rotation @ np.linalg.inv(P))
    for l1, l2 in ((0.9, -0.5), (0.999, 0.2), (-1.0, 0.3), (0.7, 0.7000001), (0.5, 0.5)):  # real; near-double
        P = rng.standard_normal((2, 2))
        out.append(P @ np.diag([l1, l2]) @ np.linalg.inv(P))
    out.append(np.array([[0.6, 1.0], [0.0, 0.6]]))                       # a Jordan block
    return np.array(out), rng.standard_normal(len(out)), rng.standard_normal(len(out))


def test_numerical_x_is_the_matrix_power():
    S, x0, v0 = step_matrices()
    n = np.array([1, 2, 3, 7, 50, 333, 1000])
    got = modal.numerical_x(S, x0, v0, n)
    for i in range(S.shape[0]):
        reference = np.array([(np.linalg.matrix_power(S[i], int(k)) @ [x0[i], v0[i]])[0] for k in n])
        # measured: at most 1.5e-13 of the largest value (r = 0.9999, 1000 steps: matrix_power's own rounding)
        assert np.abs(got[i] - reference).max() <= 1e-12 * np.abs(reference).max(), i


@pytest.mark.parametrize("omega, rate", [(1.0, 0.04), (3.0, 0.0), (2.0, 4.0), (1.0, 40.0), (1e-3, 1e-3)])
def test_exact_x_is_the_matrix_exponential(omega, rate):
    # underdamped, undamped, critically damped, overdamped (zeta = 20), and a slow mode
    t = np.array([0.0, 0.1, 1.0, 7.5, 40.0])
    x0, v0 = 0.7, -1.3
    got = modal.exact_x(np.array([omega]), np.array([rate]), np.array([x0]), np.array([v0]), t)[0]
    A = np.array([[0.0, 1.0], [-omega ** 2, -rate]])
    reference = np.array([(scipy.linalg.expm(A * s) @ [x0, v0])[0] for s in t])
    assert np.abs(got - reference).max() <= 1e-12 * np.abs(reference).max()
