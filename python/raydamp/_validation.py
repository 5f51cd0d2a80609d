"""Argument checks that name the offending argument in a ValueError."""

from __future__ import annotations

import math
import numbers

import numpy as np


def real(name: str, value, *, positive: bool = False, nonnegative: bool = False) -> float:
    # Exact-type fast path first: the ABC check costs microseconds on every short call.
    if type(value) is not float and type(value) is not int and (
            isinstance(value, bool) or not isinstance(value, numbers.Real)):
        raise ValueError(f"{name} must be a real number, got {value!r}")
    x = float(value)
    if not math.isfinite(x):
        raise ValueError(f"{name} must be finite, got {x!r}")
    if positive and not x > 0:
        raise ValueError(f"{name} must be > 0, got {x!r}")
    if nonnegative and not x >= 0:
        raise ValueError(f"{name} must be >= 0, got {x!r}")
    return x


def integer(name: str, value, *, minimum: int = 1, maximum: int | None = None) -> int:
    if type(value) is not int and (isinstance(value, bool) or not isinstance(value, numbers.Integral)):
        if isinstance(value, float) and value.is_integer():
            value = int(value)
        else:
            raise ValueError(f"{name} must be an integer, got {value!r}")
    if value < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value}")
    if maximum is not None and value > maximum:
        raise ValueError(f"{name} must be <= {maximum}, got {value}")
    return int(value)


def vector(name: str, value, dim: int) -> np.ndarray:
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be an array of {dim} real numbers, got {value!r}") from None
    if array.ndim == 0 and dim == 1:
        array = array.reshape(1)
    if array.shape != (dim,):
        raise ValueError(f"{name} must have length {dim} for this model, got shape {array.shape}")
    if not np.isfinite(array).all():
        raise ValueError(f"{name} must be finite, got {array.tolist()}")
    return np.ascontiguousarray(array)
