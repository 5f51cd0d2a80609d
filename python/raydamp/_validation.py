"""Argument checks that name the offending argument in a ValueError."""

from __future__ import annotations

import math
import numbers

import numpy as np


_MAX_REPR = 200  # characters of a bad value quoted in a message


def _short(value) -> str:
    """repr(value), cut short: a message must not carry a megabyte-long list back."""
    if isinstance(value, np.ndarray) and value.size > _MAX_REPR:
        return f"an array of shape {value.shape}"
    if isinstance(value, (list, tuple)) and len(value) > _MAX_REPR:
        return f"a {type(value).__name__} of {len(value)} items starting {value[:5]!r}"
    text = repr(value)
    return text if len(text) <= _MAX_REPR else f"{text[:_MAX_REPR]}... ({len(text)} characters)"


def real(name: str, value, *, positive: bool = False, nonnegative: bool = False) -> float:
    # Exact-type fast path first: the ABC check costs microseconds on every short call.
    if type(value) is not float and type(value) is not int and (
            isinstance(value, bool) or not isinstance(value, numbers.Real)):
        raise ValueError(f"{name} must be a real number, got {_short(value)}")
    x = float(value)
    if not math.isfinite(x):
        raise ValueError(f"{name} must be finite, got {x!r}")
    if positive and not x > 0:
        raise ValueError(f"{name} must be > 0, got {x!r}")
    if nonnegative and not x >= 0:
        raise ValueError(f"{name} must be >= 0, got {x!r}")
    return x


def integer(name: str, value, *, minimum: int = 1, maximum: int | None = None) -> int:
    # 10.0 is refused like 10.5: a count given as a float is usually a computed value that was
    # meant to be rounded, and h=True is refused the same way.
    if type(value) is not int and (isinstance(value, bool) or not isinstance(value, numbers.Integral)):
        raise ValueError(f"{name} must be an integer, got {_short(value)}")
    if value < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value}")
    if maximum is not None and value > maximum:
        raise ValueError(f"{name} must be <= {maximum}, got {value}")
    return int(value)


def vector(name: str, value, dim: int) -> np.ndarray:
    # Only numbers: np.asarray would read None as nan, True as 1.0 and "1.0" as 1.0.
    if isinstance(value, np.ndarray) and value.dtype == np.float64:
        array = value
    else:
        try:
            array = np.asarray(value)
        except (TypeError, ValueError):
            array = None
        if array is None or array.dtype.kind not in "iuf":
            raise ValueError(f"{name} must be an array of {dim} real numbers, got {_short(value)}") from None
        array = array.astype(float)
    if array.ndim == 0 and dim == 1:
        array = array.reshape(1)
    if array.shape != (dim,):
        raise ValueError(f"{name} must have length {dim} for this model, got shape {array.shape}")
    finite = np.isfinite(array)
    if not finite.all():
        first = int(np.argmin(finite))
        raise ValueError(f"{name} must be finite, got {name}[{first}] = {float(array[first])!r}")
    return np.ascontiguousarray(array)


MAX_SEED = 2**64 - 1


def thermal(temperature, seed, stream: int = 0) -> tuple[float, int, int]:
    """(kT, seed, stream) checked; kT 0 for no noise. A temperature without a seed gets a fresh one
    from the operating system (kept in the run's provenance, so the run can be repeated)."""
    kT = 0.0 if temperature is None else real("temperature", temperature, nonnegative=True)
    if seed is None:
        import secrets

        seed = secrets.randbits(64) if kT > 0 else 0
    elif isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise ValueError(f"seed must be an integer in [0, 2^64), got {_short(seed)}")
    elif not 0 <= int(seed) <= MAX_SEED:
        raise ValueError(f"seed must be an integer in [0, 2^64), got {int(seed)}")
    if isinstance(stream, bool) or not isinstance(stream, (int, np.integer)) or not 0 <= int(stream) <= MAX_SEED:
        raise ValueError(f"stream must be an integer in [0, 2^64), got {_short(stream)}")
    return kT, int(seed), int(stream)
