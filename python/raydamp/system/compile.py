"""From a validated SystemSpec to machine code: SymEngine expressions built from our
own expression trees (never from text), differentiated symbolically, and compiled
by SymEngine's LLVM JIT with common-subexpression elimination. The C++ step loop
calls the compiled functions through plain C pointers, with no Python and the GIL
released.
"""

from __future__ import annotations

import ctypes
from dataclasses import dataclass
from typing import Any

import numpy as np
import symengine as se

from .dashpot_norm import constant_dashpot_norm
from .spec import SystemSpec

__all__ = ["CompiledSystemFunctions", "compile_system", "number"]


def number(value: float) -> se.Basic:
    """A parameter's value as a SymEngine constant: integers stay exact (so k/2 stays
    a rational and x^2 a square), everything else is a double."""
    if float(value).is_integer() and abs(value) <= 2**53:
        return se.Integer(int(value))
    return se.RealDouble(float(value))


@dataclass(frozen=True)
class CompiledSystemFunctions:
    """The compiled functions; ``addresses`` are (function, data) pairs in the order
    the C++ SystemFunctions expects (potential, gradient, hessian_product,
    damper_gradients, momenta; 0 where absent). The Lambdify objects own the machine
    code: whoever holds a model holds this. ``damper_norm`` is a = grad g^T M^{-1}
    grad g of a single dashpot when it is the same number at every q (dashpot_norm.py),
    else None."""

    addresses: tuple[int, ...]
    potential: Any
    gradient: Any
    hessian_product: Any
    damper_gradients: Any | None
    momenta: Any | None
    damper_norm: float | None = None


_HALF = se.Rational(1, 2)


def _without_half_powers(expr: se.Basic) -> se.Basic:
    """expr with every b^(n/2), n odd and not 1, written as |sqrt(b)|^n.

    SymEngine writes 1/sqrt(b) as b^(-1/2), and its LLVM backend compiles any
    non-integer power to a call of pow(), some 20 ns, while sqrt is one
    instruction and an integer power a few multiplications. Such powers are in
    every gradient of a potential or dashpot built on a distance (a spring,
    gravity). The abs (one instruction) keeps SymEngine from folding sqrt(b)^n
    back into b^(n/2); for b < 0 both forms are NaN. Iterative, like the tree code.
    """
    done: dict[se.Basic, se.Basic] = {}
    stack = [expr]
    while stack:
        node = stack[-1]
        if node in done:
            stack.pop()
            continue
        pending = [a for a in node.args if a not in done]
        if pending:
            stack.extend(pending)
            continue
        stack.pop()
        args = [done[a] for a in node.args]
        if isinstance(node, se.Pow) and isinstance(node.args[1], se.Rational) and not isinstance(
                node.args[1], se.Integer):
            exponent = node.args[1]
            twice = exponent * 2
            if isinstance(twice, se.Integer) and exponent != _HALF:
                done[node] = se.Abs(se.sqrt(args[0])) ** twice
                continue
        done[node] = node.func(*args) if node.args else node
    return done[expr]


def _jit(inputs: list[se.Symbol], outputs: list[se.Basic]) -> tuple[Any, int, int]:
    outputs = [_without_half_powers(e) for e in outputs]
    fn = se.Lambdify(inputs, outputs, backend="llvm", cse=True, real=True)
    cfunc, data = fn.as_ctypes()
    return fn, ctypes.cast(cfunc, ctypes.c_void_p).value, data.value or 0


def compile_system(spec: SystemSpec) -> CompiledSystemFunctions:
    n = spec.n
    # Internal symbol names, so a user's coordinate called, say, "I" or "E" never
    # meets a SymEngine built-in.
    q = [se.Symbol(f"_q{i}") for i in range(n)]
    p = [se.Symbol(f"_p{i}") for i in range(n)]
    v = [se.Symbol(f"_v{i}") for i in range(n)]
    symbols: dict[str, se.Basic] = {name: number(value) for name, value in spec.parameters.items()}
    symbols.update(zip(spec.coordinates, q))

    potential = spec.potential.to_symengine(symbols)
    gradient = [se.diff(potential, qi) for qi in q]
    # Hess V v = grad_q (grad V . v): n derivatives of one scalar instead of n^2.
    directional = sum((g * vi for g, vi in zip(gradient, v)), se.Integer(0))
    hessian_product = [se.diff(directional, qi) for qi in q]

    pot_fn, pot_f, pot_d = _jit(q, [potential])
    grad_fn, grad_f, grad_d = _jit(q, gradient)
    hv_fn, hv_f, hv_d = _jit(q + v, hessian_product)
    addresses = [pot_f, pot_d, grad_f, grad_d, hv_f, hv_d]

    damper_fn = damper_norm = None
    if spec.dampers:
        # k rows of n: the gradient of each dashpot's function, row-major.
        rows = []
        for damper in spec.dampers:
            g = damper.on.to_symengine(symbols)
            rows.extend(se.diff(g, qi) for qi in q)
        damper_fn, f, d = _jit(q, rows)
        addresses += [f, d]
        if len(spec.dampers) == 1:
            damper_norm = constant_dashpot_norm(rows, np.linalg.inv(spec.mass), lambda x: evaluate(damper_fn, x))
    else:
        addresses += [0, 0]

    momenta_fn = None
    if spec.momenta:
        with_p = dict(symbols)
        with_p.update({f"p_{name}": pi for name, pi in zip(spec.coordinates, p)})
        outputs = [expr.to_symengine(with_p) for expr in spec.momenta.values()]
        momenta_fn, f, d = _jit(q + p, outputs)
        addresses += [f, d]
    else:
        addresses += [0, 0]
    return CompiledSystemFunctions(tuple(addresses), pot_fn, grad_fn, hv_fn, damper_fn, momenta_fn, damper_norm)


def evaluate(fn: Any, x: np.ndarray) -> np.ndarray:
    """Call a compiled function from Python (checks and diagnostics, not the step loop)."""
    return np.asarray(fn(np.ascontiguousarray(x, dtype=float)), dtype=float).reshape(-1)
