"""System.from_functions: a system whose potential and gradient are the user's own NumPy
callables, for users who already have gradient code.

The slower path, and documented as such: each call of V, grad V or a dashpot gradient from
the C++ step loop goes through a ctypes callback that takes the GIL and runs Python (a few
microseconds instead of a few nanoseconds). Everything else (the exact flows, every method,
the work integral, blow-up handling) is the same compiled code as for expression systems,
because the callbacks are plain C function pointers to the same model kinds.
"""

from __future__ import annotations

import ctypes
import math
import numbers
import threading
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from .errors import SpecError
from .spec import (
    MAX_COORDINATES,
    MAX_DAMPERS,
    MAX_DENSE_DAMPING,
    MAX_MOMENTA,
    SystemSpec,
    _damping,
    _mass,
    _real,
    damping_strength,
)

__all__ = ["PythonFunctions", "build_from_functions"]

_CFUNC = ctypes.CFUNCTYPE(None, ctypes.POINTER(ctypes.c_double), ctypes.POINTER(ctypes.c_double), ctypes.c_void_p)


class PythonFunctions:
    """The callbacks of one function-defined system and the first error any of them raised.

    A callback that raises or returns the wrong shape writes NaN, so the step loop stops
    at that step with status "non_finite" and keeps what it computed; ``take_error()``
    then says which function failed and why."""

    def __init__(self) -> None:
        self._callbacks: list[Any] = []  # keeps the ctypes thunks (and their code) alive
        self._lock = threading.Lock()
        self._error: str | None = None

    def take_error(self) -> str | None:
        with self._lock:
            error, self._error = self._error, None
            return error

    def _record(self, message: str) -> None:
        with self._lock:
            if self._error is None:
                self._error = message

    def wrap(self, name: str, fn: Callable[..., Any], n_in: int, n_out: int, split: int = 0) -> tuple[int, int]:
        """A C function pointer calling fn(x) (or fn(x[:split], x[split:])), as a (function, data) pair."""

        def call(out, inp, _data):
            target = np.ctypeslib.as_array(out, shape=(n_out,))
            try:
                x = np.ctypeslib.as_array(inp, shape=(n_in,)).copy()
                value = fn(x[:split], x[split:]) if split else fn(x)
                if np.iscomplexobj(value):  # float() would drop the imaginary part, with only a warning
                    raise ValueError("returned complex numbers; it must return real ones")
                y = np.asarray(value, dtype=float).reshape(-1)
                if y.size != n_out:
                    raise ValueError(f"returned {y.size} values, expected {n_out}")
                target[:] = y
            except BaseException as error:  # noqa: BLE001 - reported through take_error()
                self._record(f"{name} raised {type(error).__name__}: {error}")
                target[:] = math.nan

        thunk = _CFUNC(call)
        self._callbacks.append(thunk)
        return ctypes.cast(thunk, ctypes.c_void_p).value, 0


def _callable(path: tuple, value) -> Callable:
    if not callable(value):
        raise SpecError(path, f"must be a callable, got {value!r}")
    return value


def _finite_difference_hessian(gradient: Callable, n: int) -> Callable:
    # Only the modified-Hamiltonian diagnostic uses Hess V v; a central difference of the
    # user's gradient is accurate to about 1e-10 there.
    def product(q, v):
        norm = float(np.linalg.norm(v))
        if norm == 0.0:
            return np.zeros(n)
        step = 1e-6 * (1.0 + float(np.linalg.norm(q))) / norm
        plus = np.asarray(gradient(q + step * v), dtype=float)
        minus = np.asarray(gradient(q - step * v), dtype=float)
        return (plus - minus) / (2.0 * step)

    return product


def build_from_functions(n, *, potential, gradient, mass=1.0, damping=None, eps=0.0, momenta=None,
                         hessian_product=None, coordinates=None, name=None):
    """Validate the pieces; return (spec, addresses, PythonFunctions, damper count)."""
    if isinstance(n, bool) or not isinstance(n, numbers.Integral) or not 1 <= n <= MAX_COORDINATES:
        raise SpecError(("n",), f"must be an integer between 1 and {MAX_COORDINATES}, got {n!r}")
    n = int(n)
    if coordinates is None:
        coords = tuple(f"q{i}" for i in range(n))
    else:
        coords = tuple(str(c) for c in coordinates)
        if len(coords) != n or len(set(coords)) != n:
            raise SpecError(("coordinates",), f"must be {n} distinct names")
    potential = _callable(("potential",), potential)
    gradient = _callable(("gradient",), gradient)
    hessian_product = (_finite_difference_hessian(gradient, n) if hessian_product is None
                       else _callable(("hessian_product",), hessian_product))
    m, mass_form = _mass(mass, n)
    dampers: list[tuple[Callable, float]] = []
    if isinstance(damping, Mapping) and list(damping) == ["dampers"]:
        body = damping["dampers"]
        if not isinstance(body, (list, tuple)) or not 1 <= len(body) <= MAX_DAMPERS:
            raise SpecError(("damping", "dampers"), f"must be a list of 1 to {MAX_DAMPERS} dashpots "
                                                    '{"gradient": callable, "c": c}')
        if n > MAX_DENSE_DAMPING:
            raise SpecError(("damping", "dampers"), f"dashpots are supported up to n = {MAX_DENSE_DAMPING}")
        for i, item in enumerate(body):
            if not isinstance(item, Mapping) or set(item) - {"gradient", "c"} or "gradient" not in item:
                raise SpecError(("damping", "dampers", i),
                                'must be {"gradient": callable returning grad g(q), "c": c} '
                                "(from_functions takes the dashpot's gradient, not an expression)")
            dampers.append((_callable(("damping", "dampers", i, "gradient"), item["gradient"]),
                            _real(("damping", "dampers", i, "c"), item.get("c", 1.0), nonnegative=True)))
        d_form, d_scalar, d_matrix = "dampers", 0.0, np.zeros((0, 0))
    else:
        d_form, d_scalar, d_matrix, _ = _damping(damping, n, m, {})
    eps = damping_strength(eps, d_form)
    momenta = dict(momenta or {})
    if len(momenta) > MAX_MOMENTA:
        raise SpecError(("momenta",), f"at most {MAX_MOMENTA} momentum maps")
    for key, fn in momenta.items():
        _callable(("momenta", str(key)), fn)

    functions = PythonFunctions()
    addresses = [*functions.wrap("potential", lambda q: [potential(q)], n, 1),
                 *functions.wrap("gradient", gradient, n, n),
                 *functions.wrap("hessian_product", hessian_product, 2 * n, n, split=n)]
    if dampers:
        def damper_rows(q):
            return np.concatenate([np.asarray(g(q), dtype=float).reshape(n) for g, _ in dampers])
        addresses += functions.wrap("damping.dampers[].gradient", damper_rows, n, n * len(dampers))
    else:
        addresses += [0, 0]
    if momenta:
        fns = list(momenta.values())
        addresses += functions.wrap("momenta", lambda q, p: [float(f(q, p)) for f in fns], 2 * n, len(fns), split=n)
    else:
        addresses += [0, 0]
    addresses += [0, 0, 0, 0]  # no damper projection, no fused 3s body: the sub-flows one by one
    spec = SystemSpec(coords, coordinates is None, None, {}, m, mass_form, d_form, d_scalar, d_matrix, (), eps, {},
                      name)
    direct = {"potential": potential, "gradient": gradient, "dampers": dampers}
    return spec, tuple(addresses), functions, [c for _, c in dampers], tuple(momenta), direct
