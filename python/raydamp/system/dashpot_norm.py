"""Whether one dashpot's rank-one rate a(q) = grad g(q)^T M^{-1} grad g(q) is a constant.

A single dashpot on g(q) gives A = eps c grad g (M^{-1} grad g)^T, whose one nonzero
eigenvalue is eps c a(q); its exact flows need phi1(-t eps c a(q)) (and phi2 for
kick+damp). For a dashpot on a distance (|q|, |q_i - q_j|, a coordinate difference)
|grad g| is constant and a(q) is a number (1/m, 1/m_i + 1/m_j): then the step loop can
take phi1 and phi2 once per sub-step length, as the built-in radial damping does, and
each flow needs only the gradient. This module proves it symbolically (a(q) as one
fraction whose numerator is a constant multiple of its denominator) and checks the
constant numerically at a few points through the compiled gradient; anything it
cannot prove keeps the general path, which is exact for every g.
"""

from __future__ import annotations

import math
from typing import Any, Callable

import numpy as np
import symengine as se

__all__ = ["constant_dashpot_norm", "NORM_TOLERANCE"]

NORM_TOLERANCE = 1e-12  # relative; the numeric check of the symbolic constant
_RATIO_TOLERANCE = 1e-14  # relative; coefficient ratios with double (not exact) coefficients
_CHECK_POINTS = 4


def _exact_or_double(value: float) -> se.Basic:
    """An integer, the reciprocal of an integer, or a double: the entries of M^{-1}
    for the common masses (1, 2, 1/2) stay exact, so a(q) simplifies exactly."""
    if value.is_integer() and abs(value) <= 2**53:
        return se.Integer(int(value))
    reciprocal = 1.0 / value
    if reciprocal.is_integer() and abs(reciprocal) <= 2**53:
        return se.Rational(1, int(reciprocal))
    return se.RealDouble(value)


def _quadratic_form(gradient: list[se.Basic], inverse_mass: np.ndarray) -> se.Basic:
    n = len(gradient)
    total: se.Basic = se.Integer(0)
    for i in range(n):
        for j in range(n):
            if inverse_mass[i, j] != 0.0:
                total += _exact_or_double(float(inverse_mass[i, j])) * gradient[i] * gradient[j]
    return total


def _coefficients(poly: se.Basic) -> dict[se.Basic, se.Basic]:
    return {k: v for k, v in se.expand(poly).as_coefficients_dict().items() if v != 0}


def _symbolic_constant(a: se.Basic) -> float | None:
    """a as a float if it is provably constant, else None."""
    if a.is_Number:
        return float(a)
    numerator, denominator = a.as_numer_denom()
    top, bottom = _coefficients(numerator), _coefficients(denominator)
    if not bottom or top.keys() != bottom.keys():
        return None
    ratios = [top[k] / bottom[k] for k in bottom]
    if not all(r.is_Number for r in ratios):
        return None
    first = float(ratios[0])
    if any(abs(float(r) - first) > _RATIO_TOLERANCE * abs(first) for r in ratios[1:]):
        return None
    return first


def constant_dashpot_norm(gradient: list[se.Basic], inverse_mass: np.ndarray,
                          compiled_gradient: Callable[[np.ndarray], Any]) -> float | None:
    """a = grad g^T M^{-1} grad g when it is the same number at every q, else None.

    ``gradient`` is grad g as SymEngine expressions, ``inverse_mass`` M^{-1}, and
    ``compiled_gradient(q)`` the compiled grad g: the constant must also be what the
    compiled code gives at a few points (to NORM_TOLERANCE), or the general path is
    kept. Points where g is outside its domain are skipped; none left: None.
    """
    free = set().union(*(e.free_symbols for e in gradient))
    a = _symbolic_constant(_quadratic_form(gradient, inverse_mass))
    if a is None or not math.isfinite(a):
        return None
    if not free:
        return a
    points = np.random.default_rng(20261123).normal(size=(_CHECK_POINTS, inverse_mass.shape[0]))
    checked = 0
    for q in points:
        g = np.asarray(compiled_gradient(q), dtype=float).reshape(-1)
        if not np.isfinite(g).all():
            continue
        if abs(float(g @ inverse_mass @ g) - a) > NORM_TOLERANCE * max(1.0, abs(a)):
            return None
        checked += 1
    return a if checked else None
