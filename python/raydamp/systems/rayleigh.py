"""Rayleigh damping C = alpha M + beta K calibrated from two modal damping ratios.

A mode of circular frequency omega under C = alpha M + beta K has the damping ratio
zeta(omega) = alpha / (2 omega) + beta omega / 2: mass-proportional damping acts on the low
modes, stiffness-proportional on the high ones. Asking for zeta1 at omega1 and zeta2 at omega2
gives two linear equations for (alpha, beta):

    alpha = 2 omega1 omega2 (zeta1 omega2 - zeta2 omega1) / (omega2^2 - omega1^2)
    beta  = 2 (zeta2 omega2 - zeta1 omega1) / (omega2^2 - omega1^2)

(with zeta1 = zeta2 = zeta: alpha = 2 zeta omega1 omega2 / (omega1 + omega2), beta = 2 zeta /
(omega1 + omega2)). In raydamp's form p' = -grad V - eps D M^{-1} p this is eps = 1, D = C:
``raydamp.System(..., mass=M, damping={"matrix": (alpha * M + beta * K).tolist()}, eps=1)``.
"""

from __future__ import annotations

import math

from .._validation import real

__all__ = ["rayleigh_coefficients", "modal_damping_ratio"]


def rayleigh_coefficients(omega1: float, omega2: float, zeta1: float, zeta2: float) -> tuple[float, float]:
    """(alpha, beta) of C = alpha M + beta K with damping ratio zeta1 at circular frequency omega1
    and zeta2 at omega2 (rad per unit time, omega1 != omega2).

    A pair that needs a negative alpha or beta (zeta2/zeta1 outside [omega1/omega2, omega2/omega1]
    for omega1 < omega2) would make C indefinite, feeding energy into some modes: refused."""
    omega1 = real("omega1", omega1, positive=True)
    omega2 = real("omega2", omega2, positive=True)
    zeta1 = real("zeta1", zeta1, nonnegative=True)
    zeta2 = real("zeta2", zeta2, nonnegative=True)
    if omega1 == omega2:
        raise ValueError("omega2 must differ from omega1: one frequency cannot fix both coefficients")
    try:
        alpha, beta = _coefficients(omega1, omega2, zeta1, zeta2)
    except (OverflowError, ZeroDivisionError):  # omega ** 2 past 1.3e154, or omega2^2 - omega1^2 = 0 below 1e-162
        alpha = beta = math.inf
    if not (math.isfinite(alpha) and math.isfinite(beta)):
        raise ValueError(_not_representable(omega1, omega2, zeta1, zeta2))
    # Rounding may leave -1e-18 where the exact coefficient is 0 (zeta proportional to omega or 1/omega).
    scale = max(abs(alpha), abs(beta) * omega1 * omega2, 1e-300)
    if alpha < -1e-12 * scale or beta < -1e-12 * scale:
        raise ValueError(f"zeta2: damping ratios {zeta1:g} at omega1 = {omega1:g} and {zeta2:g} at omega2 = "
                         f"{omega2:g} need alpha = {alpha:.3g}, beta = {beta:.3g}; a negative coefficient makes "
                         "C indefinite (energy fed into some modes)")
    return max(alpha, 0.0), max(beta, 0.0)


def _coefficients(omega1: float, omega2: float, zeta1: float, zeta2: float) -> tuple[float, float]:
    denominator = omega2 ** 2 - omega1 ** 2
    alpha = 2.0 * omega1 * omega2 * (zeta1 * omega2 - zeta2 * omega1) / denominator
    beta = 2.0 * (zeta2 * omega2 - zeta1 * omega1) / denominator
    return alpha, beta


def _not_representable(omega1: float, omega2: float, zeta1: float, zeta2: float) -> str:
    """Why (alpha, beta) overflow, naming the arguments to blame: (alpha, beta) is linear in the ratios, so
    if ratios scaled to at most 1 give finite coefficients, the ratios are too large; else the frequencies."""
    top = max(zeta1, zeta2)
    try:
        unit = _coefficients(omega1, omega2, *((zeta1 / top, zeta2 / top) if top > 0 else (1.0, 1.0)))
    except (OverflowError, ZeroDivisionError):
        unit = (math.inf, math.inf)
    if all(math.isfinite(x) for x in unit):
        return (f"zeta1, zeta2: damping ratios {zeta1:g} and {zeta2:g} give coefficients (alpha, beta) beyond the "
                "largest float")
    return (f"omega1, omega2: frequencies {omega1:g} and {omega2:g} give coefficients (alpha, beta) that are not "
            "finite in floating point (a product of them overflows, or omega2^2 - omega1^2 rounds to 0); measure "
            "time in other units to bring them nearer 1")


def modal_damping_ratio(omega: float, alpha: float, beta: float) -> float:
    """zeta(omega) = alpha / (2 omega) + beta omega / 2: the damping ratio a mode of frequency omega gets."""
    omega = real("omega", omega, positive=True)
    alpha, beta = real("alpha", alpha, nonnegative=True), real("beta", beta, nonnegative=True)
    zeta = alpha / (2.0 * omega) + beta * omega / 2.0
    if not math.isfinite(zeta):  # alpha / 2 omega past the largest float at a tiny omega, beta omega / 2 at a huge one
        raise ValueError(f"omega: the damping ratio alpha / (2 omega) + beta omega / 2 at omega = {omega:g} "
                         f"(alpha = {alpha:g}, beta = {beta:g}) is beyond the largest float")
    return zeta
