"""The modal error model behind raydamp.advise: a method's error on a linear structure, mode by mode.

With Rayleigh damping C = alpha M + beta K every method here is a function of M^{-1} K, so in the modal
coordinates q = phi x (phi^T M phi = I) one step of it is, for each mode i, a 2 x 2 matrix S_i(h) acting
on (x_i, p_i): the same matrix as one step on a modal copy of the structure (M = I, K = diag(omega_i^2),
the same alpha and beta). advise takes S_i from the core itself (two one-step runs on the copy), so the
model knows each method's phase and amplitude errors, its damping error and its behaviour past
h omega = 1 (gauss4 and midpoint keep an overdamped mode at amplitude about 1) without a formula.
After n steps the method is at S_i^n z_i and the structure at exp(A_i n h) z_i, and the error

    e(t_n) = || sum_i phi_i (S_i^n z_i - exp(A_i t_n) z_i)_x ||  (Euclidean, over the DOF)

is evaluated at the steps (all of them up to _ALL_STEPS, otherwise a dense start and an even sample),
the damping decay included. Powers of S_i come from its eigenvalues, written so that a double or
near-double eigenvalue keeps its accuracy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

_ALL_STEPS = 800            # up to this many steps the error is evaluated at every step
_SAMPLES = 600              # beyond: the first _DENSE_START steps and this many more, evenly spread
_DENSE_START = 100


@dataclass(frozen=True)
class ModalMotion:
    """The motion advise weights its error model with: modes (frequency, rate, shape) and their starts."""

    omega: np.ndarray        # (m,) circular frequencies
    rate: np.ndarray         # (m,) damping rates alpha + beta omega^2
    shape: np.ndarray        # (m, m) R with ||phi d|| = ||R d|| (the R of phi's QR): the Euclidean norm
    x0: np.ndarray           # (m,) modal displacements at the start
    v0: np.ndarray           # (m,) modal velocities
    scale: float             # the error is relative to this (the start's ||q0||, or the response's peak)


def select_modes(omega, phi, x0, v0, scale: float, tolerance: float, alpha: float, beta: float) -> ModalMotion:
    """The modes whose share of the motion can matter at this tolerance (a stable method's error in a mode is
    at most about twice its amplitude): those left out add at most 1e-2 of the tolerance."""
    norms = np.linalg.norm(phi, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        amplitude = np.where(omega > 0, np.hypot(x0, np.divide(v0, omega, where=omega > 0, out=np.zeros_like(v0))),
                             np.inf)  # a rigid mode moving: always kept
    amplitude = np.where((omega == 0) & (x0 == 0) & (v0 == 0), 0.0, amplitude)
    weight = 2 * amplitude * norms
    keep = weight > 1e-2 * tolerance * scale / max(1, omega.size)
    if not keep.any():
        keep[np.argmax(weight)] = True
    index = np.flatnonzero(keep)
    index = index[np.argsort(omega[index], kind="stable")]
    shape = np.linalg.qr(phi[:, index], mode="r")
    return ModalMotion(omega[index], alpha + beta * omega[index] ** 2, shape, x0[index], v0[index], scale)


def sample_steps(steps: int) -> np.ndarray:
    """The step counts n at which the error is evaluated."""
    if steps <= _ALL_STEPS:
        return np.arange(1, steps + 1)
    spread = np.linspace(1, steps, _SAMPLES).round().astype(np.int64)
    return np.unique(np.concatenate([np.arange(1, _DENSE_START + 1), spread]))


def _power_coefficients(m, s, n):
    """A_n = (l+^n - l-^n) / (l+ - l-) for l+- = m +- s (complex; (modes, 1) against n (1, samples)):
    S^n = A_n S - det(S) A_{n-1} I by Cayley-Hamilton. With mu and delta the mean and half-difference of
    log l+-, A_n = e^{n mu} sinh(n delta) / s: delta = atanh(s / m) when s is small against m (no
    cancellation: a double eigenvalue's limit n m^{n-1} is the same formula), and where n delta is large
    the two powers apart (so e^{n mu} cannot underflow against an overflowing sinh)."""
    with np.errstate(all="ignore"):
        u = np.where(m != 0, s / np.where(m != 0, m, 1), np.inf)
        close = np.abs(u) < 0.5
        uc = np.where(close, u, 0.25)
        plus, minus = np.log(m + s), np.log(m - s)
        delta = np.where(close, np.arctanh(uc), (plus - minus) / 2)
        mu = np.where(close, np.log(np.where(m != 0, m, 1)) + 0.5 * np.log1p(-uc * uc), (plus + minus) / 2)
        delta_over_s = np.where(close & (np.abs(uc) < 1e-8), 1 / np.where(m != 0, m, 1),
                                delta / np.where(s != 0, s, 1))
        nd = n * delta
        sinhc = np.where(np.abs(nd) < 1e-4, n * (1 + nd * nd / 6), np.sinh(nd) / np.where(delta != 0, delta, 1))
        moderate = np.exp(n * mu) * sinhc * delta_over_s
        apart = (np.exp(n * plus) - np.exp(n * minus)) / (2 * np.where(s != 0, s, 1))
        out = np.where(np.abs(nd.real) > 20, apart, moderate)
        return np.where((m == 0) & (s == 0), np.where(n == 1, 1.0, 0.0), out)  # S nilpotent


def numerical_x(S: np.ndarray, x0: np.ndarray, v0: np.ndarray, n: np.ndarray) -> np.ndarray:
    """x after n steps of the step matrices S (modes, 2, 2) acting on (x, v): (modes, samples).
    S^n = A_n S - det(S) A_{n-1} I with A_n = (l+^n - l-^n) / (l+ - l-), l+- = m +- s its eigenvalues.
    Complex conjugate eigenvalues (every oscillating mode) in real arithmetic: l+ = r e^{i theta}, s = i sigma,
    A_n = r^n sin(n theta) / sigma. Other well-separated ones: the two powers apart, a complex exponential
    each. The rest (near-double eigenvalues) by _power_coefficients."""
    a, b, c, d = S[:, 0, 0], S[:, 0, 1], S[:, 1, 0], S[:, 1, 1]
    half_trace = (a + d) / 2
    disc = ((a - d) / 2) ** 2 + b * c
    m = half_trace.astype(complex)
    s = np.sqrt(disc.astype(complex))
    det = a * d - b * c
    first = a * x0 + b * v0
    out = np.empty((S.shape[0], n.size))
    with np.errstate(all="ignore"):
        apart = np.abs(s) > 1e-3 * np.abs(m)
        k = n[None, :].astype(float)
        rotating = apart & (disc < 0)
        if rotating.any():
            sigma = np.sqrt(-disc[rotating])[:, None]
            log_r = 0.5 * np.log(half_trace[rotating] ** 2 + sigma[:, 0] ** 2)[:, None]
            theta = np.arctan2(sigma[:, 0], half_trace[rotating])[:, None]
            angle = k * theta
            power = np.exp(k * log_r) * np.sin(angle) / sigma                                  # A_n
            before = np.exp((k - 1) * log_r) * (np.sin(angle) * np.cos(theta)
                                                  - np.cos(angle) * np.sin(theta)) / sigma  # A_{n-1}
            out[rotating] = power * first[rotating][:, None] - det[rotating][:, None] * before * x0[rotating][:, None]
        real = apart & ~rotating
        if real.any():
            mm, ss = m[real][:, None], s[real][:, None]
            plus, minus = np.log(mm + ss), np.log(mm - ss)
            high, low = np.exp((k - 1) * plus), np.exp((k - 1) * minus)   # l^{n-1}
            power = (high * (mm + ss) - low * (mm - ss)) / (2 * ss)      # A_n
            before = (high - low) / (2 * ss)                              # A_{n-1}
            out[real] = np.real(power * first[real][:, None] - det[real][:, None] * before * x0[real][:, None])
        rest = ~apart
        if rest.any():
            mm, ss = m[rest][:, None], s[rest][:, None]
            out[rest] = np.real(_power_coefficients(mm, ss, k) * first[rest][:, None]
                                - det[rest][:, None] * _power_coefficients(mm, ss, k - 1) * x0[rest][:, None])
    return out


def exact_x(omega: np.ndarray, rate: np.ndarray, x0: np.ndarray, v0: np.ndarray, t: np.ndarray) -> np.ndarray:
    """x(t) of x'' + rate x' + omega^2 x = 0 from (x0, v0): (modes, samples). Underdamped modes in real
    cosines and sines; the others with the exponentials of the two roots -rate/2 +- kappa, so that an
    overdamped mode neither overflows nor cancels."""
    out = np.empty((omega.size, t.size))
    disc = rate ** 2 / 4 - omega ** 2
    under = disc < 0
    tt = t[None, :]
    with np.errstate(all="ignore"):
        if under.any():
            wd, half = np.sqrt(-disc[under])[:, None], (rate[under] / 2)[:, None]
            decay, cos, sin = np.exp(-half * tt), np.cos(wd * tt), np.sin(wd * tt)
            out[under] = decay * (x0[under][:, None] * (cos + half / wd * sin) + v0[under][:, None] * sin / wd)
        rest = ~under
        if rest.any():
            kappa, half = np.sqrt(disc[rest])[:, None], (rate[rest] / 2)[:, None]
            plus, minus = np.exp((kappa - half) * tt), np.exp((-kappa - half) * tt)
            small = kappa * tt < 1e-6
            sinh_over = np.where(small, np.exp(-half * tt) * tt * (1 + (kappa * tt) ** 2 / 6),
                                 (plus - minus) / (2 * np.where(kappa > 0, kappa, 1)))
            cosh = np.where(small, np.exp(-half * tt) * (1 + (kappa * tt) ** 2 / 2), (plus + minus) / 2)
            out[rest] = x0[rest][:, None] * (cosh + half * sinh_over) + v0[rest][:, None] * sinh_over
    return out


def predicted_error(motion: ModalMotion, S: np.ndarray, h: float, steps: int) -> float:
    """max over the sampled steps of ||q_method - q_exact|| / scale; inf when the method grows without bound."""
    n = sample_steps(steps)
    difference = numerical_x(S, motion.x0, motion.v0, n) - exact_x(motion.omega, motion.rate, motion.x0, motion.v0,
                                                                     n * h)
    with np.errstate(all="ignore"):
        norms = np.linalg.norm(motion.shape @ difference, axis=0)
        worst = float(np.max(norms)) / motion.scale
    return worst if math.isfinite(worst) else math.inf


def free_peak(motion: ModalMotion, t_end: float, samples: int = 2000) -> float:
    """max over [0, t_end] of ||q_exact(t)||."""
    t = np.linspace(0.0, t_end, samples)
    return float(np.max(np.linalg.norm(motion.shape @ exact_x(motion.omega, motion.rate, motion.x0, motion.v0, t),
                                       axis=0)))


def forced_response(omega: np.ndarray, rate: np.ndarray, forces: np.ndarray, dt: float) -> np.ndarray:
    """Exact modal displacements x_i(t_k) from rest under modal forces linear between the samples t_k = k dt
    (forces (samples, modes)): the state (x, v, f, f') over one interval is exp(dt B) of the 4 x 4 matrix B
    of x'' + rate x' + omega^2 x = f, f'' = 0, computed once per mode."""
    import scipy.linalg

    m = omega.size
    B = np.zeros((m, 4, 4))
    B[:, 0, 1] = 1.0
    B[:, 1, 0] = -omega ** 2
    B[:, 1, 1] = -rate
    B[:, 1, 2] = 1.0
    B[:, 2, 3] = 1.0
    E = np.stack([scipy.linalg.expm(dt * B[i]) for i in range(m)])       # (m, 4, 4)
    # x, v after one interval depend linearly on x, v, f_k and the slope (f_{k+1} - f_k) / dt
    Exx, Exv, Exf, Exs = E[:, 0, 0], E[:, 0, 1], E[:, 0, 2], E[:, 0, 3]
    Evx, Evv, Evf, Evs = E[:, 1, 0], E[:, 1, 1], E[:, 1, 2], E[:, 1, 3]
    out = np.zeros((forces.shape[0], m))
    x, v = np.zeros(m), np.zeros(m)
    slopes = np.diff(forces, axis=0) / dt
    for k in range(forces.shape[0] - 1):
        f, g = forces[k], slopes[k]
        x, v = Exx * x + Exv * v + Exf * f + Exs * g, Evx * x + Evv * v + Evf * f + Evs * g
        out[k + 1] = x
    return out


def leading_error(motion: ModalMotion, model: tuple[int, float], h: float, t_end: float) -> float:
    """The sum over the modes of the leading phase error C (h omega)^p omega t_end (at most 2) times each mode's
    amplitude: for runs too long for the step-matrix powers (rounding, not the method, then sets the error)."""
    order, constant = model
    with np.errstate(all="ignore"):
        amplitude = np.hypot(motion.x0, np.divide(motion.v0, motion.omega, where=motion.omega > 0,
                                                  out=np.zeros_like(motion.v0)))
        phase = np.minimum(2.0, constant * (h * motion.omega) ** order * motion.omega * t_end)
        total = float(np.sum(phase * amplitude * np.linalg.norm(motion.shape, axis=0))) / motion.scale
    return total if math.isfinite(total) else math.inf
