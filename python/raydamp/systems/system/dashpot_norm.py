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
from collections.abc import Callable
from typing import Any

import numpy as np
import symengine as se

__all__ = ["constant_dashpot_norm", "NORM_TOLERANCE"]

NORM_TOLERANCE = 1e-12  # relative; the numeric check of the symbolic constant
_RATIO_TOLERANCE = 1e-14  # relative; coefficient ratios with double (not exact) coefficients
_CHECK_POINTS = 4
_MAX_RADICALS = 2  # distinct radicals in a(q) up to which the symbolic proof is tried


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


def _numeric_values(inverse_mass: np.ndarray, compiled_gradient: Callable[[np.ndarray], Any]) -> list[float]:
    """a at a few seeded points, through the compiled gradient (points outside g's domain skipped)."""
    points = np.random.default_rng(20261123).normal(size=(_CHECK_POINTS, inverse_mass.shape[0]))
    values = []
    for q in points:
        g = np.asarray(compiled_gradient(q), dtype=float).reshape(-1)
        if np.isfinite(g).all():
            values.append(float(g @ inverse_mass @ g))
    return values


def _radicals(expr: se.Basic) -> int:
    """How many distinct non-integer powers (square roots and the like) expr holds."""
    seen: set[se.Basic] = set()
    stack, radicals = [expr], set()
    while stack:
        node = stack.pop()
        if node in seen:
            continue
        seen.add(node)
        if isinstance(node, se.Pow) and not isinstance(node.args[1], se.Integer):
            radicals.add(node.args[0])
        stack.extend(node.args)
    return len(radicals)


def constant_dashpot_norm(gradient: list[se.Basic], inverse_mass: np.ndarray,
                          compiled_gradient: Callable[[np.ndarray], Any]) -> float | None:
    """a = grad g^T M^{-1} grad g when it is the same number at every q, else None.

    ``gradient`` is grad g as SymEngine expressions, ``inverse_mass`` M^{-1}, and
    ``compiled_gradient(q)`` the compiled grad g. Cheap tests first, so that building a
    System stays fast whatever g is: a must take one value at a few points (to
    NORM_TOLERANCE, through the compiled code); and the symbolic proof is tried only when
    a holds at most _MAX_RADICALS distinct radicals, since putting a over one common
    denominator multiplies out their product (a dashpot on the sum of 8 segment lengths
    took 109 s there). Points where g is outside its domain are skipped; none left: None.
    """
    free = set().union(*(e.free_symbols for e in gradient))
    values = _numeric_values(inverse_mass, compiled_gradient) if free else []
    if free and (not values or max(values) - min(values) > NORM_TOLERANCE * max(1.0, abs(values[0]))):
        return None
    form = _quadratic_form(gradient, inverse_mass)
    if _radicals(form) > _MAX_RADICALS:
        return None
    a = _symbolic_constant(form)
    if a is None or not math.isfinite(a):
        return None
    if any(abs(v - a) > NORM_TOLERANCE * max(1.0, abs(a)) for v in values):
        return None
    return a
