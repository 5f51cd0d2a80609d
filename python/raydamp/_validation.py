"""Argument checks that name the offending argument in a ValueError."""

from __future__ import annotations

import math
from numbers import Integral, Real

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
            isinstance(value, bool) or not isinstance(value, Real)):
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
    if type(value) is not int and (isinstance(value, bool) or not isinstance(value, Integral)):
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
        array = numeric_array(value)
        if array is None:
            raise ValueError(f"{name} must be an array of {dim} real numbers, got {_short(value)}") from None
        # A list mixing bools and numbers converts to floats (True -> 1.0): [True, 0.5, 1.0] ran as 1.0.
        if isinstance(value, (list, tuple)) and any(isinstance(x, (bool, np.bool_)) for x in value):
            raise ValueError(f"{name} must be an array of {dim} real numbers, got a bool in {_short(value)}")
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


def thermal(temperature, seed, stream: int = 0, stream_name: str = "stream") -> tuple[float, int, int]:
    """(kT, seed, stream) checked, the stream's errors naming stream_name; kT 0 for no noise. A temperature
    without a seed gets a fresh one from the operating system (kept in the run's provenance, so the run can
    be repeated)."""
    kT = 0.0 if temperature is None else real("temperature", temperature, nonnegative=True)
    if temperature is None:  # (a temperature of 0 may carry them: a sweep over temperatures from 0)
        for name, value in (("seed", seed), (stream_name, None if stream == 0 else stream)):
            if value is not None:
                raise ValueError(f"{name}: given without a temperature, and a run without one draws no noise; "
                                 "give temperature=, or leave it out")
    if seed is None:
        import secrets

        seed = secrets.randbits(64) if kT > 0 else 0
    elif isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise ValueError(f"seed must be an integer in [0, 2^64), got {_short(seed)}")
    elif not 0 <= int(seed) <= MAX_SEED:
        raise ValueError(f"seed must be an integer in [0, 2^64), got {int(seed)}")
    if isinstance(stream, bool) or not isinstance(stream, (int, np.integer)) or not 0 <= int(stream) <= MAX_SEED:
        raise ValueError(f"{stream_name} must be an integer in [0, 2^64), got {_short(stream)}")
    return kT, int(seed), int(stream)


# Step counts travel as C++ long; far beyond any run that could finish.
MAX_STEPS = 2**62


def span(h: float, t_end: float | None, n_steps: int | None) -> tuple[int, float]:
    """(the number of steps, the size of the last) for exactly one of t_end and n_steps."""
    if (t_end is None) == (n_steps is None):  # the message names the field to remove (both) or to give
        both = t_end is not None
        raise ValueError(("n_steps" if both else "t_end") + ": give exactly one of t_end and n_steps"
                         + (", not both" if both else ""))
    if n_steps is None:
        return steps_for(t_end, h)
    n_steps = integer("n_steps", n_steps, maximum=MAX_STEPS)
    if not math.isfinite(n_steps * h):  # the times would pass the largest float: t = inf, "completed"
        raise ValueError(f"h: {n_steps} steps of h = {h:g} end beyond the largest float, so the times would "
                         "not be finite; lower h or n_steps")
    return n_steps, h


def steps_for(t_end: float, h: float) -> tuple[int, float]:
    """The number of steps of size ``h`` that reach ``t_end``, and the size of the last.

    A ``t_end`` within 1e-9 relative of a whole multiple of ``h`` takes whole steps;
    otherwise the last step is shortened to land exactly on ``t_end``."""
    t_end = real("t_end", t_end, positive=True)
    h = real("h", h, positive=True)
    ratio = t_end / h
    if not ratio <= MAX_STEPS:  # also catches ratio = inf
        raise ValueError(f"t_end: reaching t_end = {t_end:g} with h = {h:g} takes {ratio:.3g} steps, "
                         f"more than {MAX_STEPS:.3g}")
    nearest = round(ratio)
    if nearest >= 1 and abs(ratio - nearest) <= 1e-9 * max(1.0, ratio):
        n, h_last = nearest, h
    else:
        n = max(1, math.ceil(ratio))
        h_last = t_end - (n - 1) * h
    return n, h_last


def instance(name: str, value, kind, what: str):
    """``value`` when it is a ``kind``; otherwise a ValueError naming ``name`` and ``what`` was expected
    (a wrong object reached an attribute lookup or an index first: AttributeError, IndexError)."""
    if not isinstance(value, kind):
        raise ValueError(f"{name}: expected {what}, got {type(value).__name__}")
    return value


def numeric_array(value) -> np.ndarray | None:
    """value as an array when its entries are real numbers (ints or floats, not bools), else None: the callers
    refuse it in their own words. np.asarray(value, dtype=float) would read "1" as 1.0 and None as NaN."""
    try:
        array = np.asarray(value)
    except (TypeError, ValueError):
        return None
    return array if array.dtype.kind in "iuf" else None


def values(name: str, value, *, minimum: float = 0.0, what: str | None = None) -> np.ndarray:
    """A number or a vector of numbers as a float vector, each finite and > minimum (>= minimum when minimum is
    not 0): periods, scales, target ductilities. `what` names one item in the empty-list message."""
    array = numeric_array(value)
    if array is None or array.ndim > 1:
        raise ValueError(f"{name} must be a number or a vector of numbers, got {_short(value)}")
    array = np.atleast_1d(array).astype(float)
    if array.size == 0:
        raise ValueError(f"{name}: empty; give at least one {what or name[:-1]}")
    above = array > minimum if minimum == 0.0 else array >= minimum
    bad = np.flatnonzero(~(np.isfinite(array) & above))
    if bad.size:
        bound = "> 0" if minimum == 0.0 else f">= {minimum:g}"
        raise ValueError(f"{name} must be finite and {bound}, got {name}[{int(bad[0])}] = {float(array[bad[0]])!r}")
    return array


def real_array(name: str, value) -> np.ndarray:
    """An array of real numbers of any shape (a scipy.sparse matrix made dense), as floats. Only numbers:
    np.asarray(dtype=float) read "1" as 1.0, and failed on "x" or an object with a message naming nothing."""
    if hasattr(value, "toarray") and type(value).__module__.startswith("scipy.sparse"):
        value = value.toarray()
    array = numeric_array(value)
    if array is None:
        raise ValueError(f"{name} must be an array of real numbers, got {_short(value)}")
    return array.astype(float)



def flag(name: str, value) -> bool:
    """True or False (NumPy's too); a string such as "no" was truthy, so it ran as True."""
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be True or False, got {_short(value)}")
    return bool(value)


def replaceable_store(name: str, path) -> None:
    """A Zarr store's path must be a directory (replaced) or free: a plain file there was FileExistsError."""
    import os

    if os.path.exists(path) and not os.path.isdir(path):
        raise ValueError(f"{name}: {os.fspath(path)!r} is a file, not a Zarr store (a directory); remove it or "
                         "choose another path")
