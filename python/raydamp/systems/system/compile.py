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

from ... import _core
from .dashpot_norm import constant_dashpot_norm
from .errors import SpecError
from .spec import SystemSpec

__all__ = ["CompiledSystemFunctions", "compile_system", "fused_body", "number"]


def number(value: float) -> se.Basic:
    """A parameter's value as a SymEngine constant: integers stay exact (so k/2 stays
    a rational and x^2 a square), everything else is a double."""
    if float(value).is_integer() and abs(value) <= 2**53:
        return se.Integer(int(value))
    return se.RealDouble(float(value))


@dataclass(frozen=True)
class CompiledSystemFunctions:
    """The compiled functions; ``addresses`` are (function, data) pairs in the order
    the C++ bindings expect (potential, gradient, hessian_product, damper_gradients,
    momenta, damper_projection, damp_then_3s_body; 0 where absent). The Lambdify objects own the machine
    code: whoever holds a model holds this. ``damper_norm`` is a = grad g^T M^{-1}
    grad g of a single dashpot when it is the same number at every q (dashpot_norm.py),
    else None; then ``damper_projection`` is (q, u) -> grad g (grad g^T M^{-1} u), which
    the dashpot's decay exp(-t eps D M^{-1}) p takes (damper_damping.hpp), and
    ``damp_then_3s_body`` that decay followed by 3s's drift, kick, drift, in one
    function (compiled_system.hpp), derived from the 3s table (fused_body)."""

    addresses: tuple[int, ...]
    potential: Any
    gradient: Any
    hessian_product: Any
    damper_gradients: Any | None
    momenta: Any | None
    damper_norm: float | None = None
    damper_projection: Any | None = None
    damp_then_3s_body: Any | None = None


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


# Distinct operations in one compiled function, after differentiation. LLVM's time grows faster than
# linearly in them: 1,200 took 0.2 s, 4,400 took 1.2 s, and a 128-coordinate all-to-all quartic (some
# 17,000, from a 790-byte potential) half a minute (issue 27, F1). A Chain or LinearStructure carries
# large systems without expressions.
MAX_OPERATIONS = 8_000


def _operations(outputs: list[se.Basic], limit: int) -> int:
    """Distinct sub-expressions of outputs, counted up to limit + 1."""
    seen: set[se.Basic] = set()
    stack = list(outputs)
    while stack and len(seen) <= limit:
        node = stack.pop()
        if node not in seen:
            seen.add(node)
            stack.extend(node.args)
    return len(seen)


def _jit(inputs: list[se.Symbol], outputs: list[se.Basic], what: tuple[str, ...]) -> tuple[Any, int, int]:
    """Compiled outputs(inputs); what is the spec's path the outputs come from (a too large one is its error)."""
    outputs = [_without_half_powers(e) for e in outputs]
    if _operations(outputs, MAX_OPERATIONS) > MAX_OPERATIONS:
        raise SpecError(what, f"after differentiation more than {MAX_OPERATIONS} distinct operations in one compiled "
                              "function; write it with fewer couplings, or use a Chain or LinearStructure for a "
                              "large system")
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

    pot_fn, pot_f, pot_d = _jit(q, [potential], ("potential",))
    grad_fn, grad_f, grad_d = _jit(q, gradient, ("potential",))
    hv_fn, hv_f, hv_d = _jit(q + v, hessian_product, ("potential",))
    addresses = [pot_f, pot_d, grad_f, grad_d, hv_f, hv_d]

    damper_fn = damper_norm = projection_fn = fused_fn = None
    projection_address = [0, 0, 0, 0]
    if spec.dampers:
        # k rows of n: the gradient of each dashpot's function, row-major.
        rows = []
        functions = [damper.on.to_symengine(symbols) for damper in spec.dampers]
        for g in functions:
            rows.extend(se.diff(g, qi) for qi in q)
        damper_fn, f, d = _jit(q, rows, ("damping", "dampers"))
        addresses += [f, d]
        if len(spec.dampers) == 1:
            inverse = np.linalg.inv(spec.mass)
            damper_norm = constant_dashpot_norm(rows, inverse, lambda x: evaluate(damper_fn, x))
            if damper_norm is not None:
                projection = _projection(functions[0], rows, q, p, inverse)
                projection_fn, f, d = _jit(q + p, projection, ("damping", "dampers"))
                scalars, fused = fused_body(_fused_table(), projection, gradient, q, p, inverse)
                fused_fn, f2, d2 = _jit(q + p + scalars, fused, ("damping", "dampers"))
                projection_address = [f, d, f2, d2]
    else:
        addresses += [0, 0]

    momenta_fn = None
    if spec.momenta:
        with_p = dict(symbols)
        with_p.update({f"p_{name}": pi for name, pi in zip(spec.coordinates, p)})
        outputs = [expr.to_symengine(with_p) for expr in spec.momenta.values()]
        momenta_fn, f, d = _jit(q + p, outputs, ("momenta",))
        addresses += [f, d]
    else:
        addresses += [0, 0]
    addresses += projection_address
    return CompiledSystemFunctions(tuple(addresses), pot_fn, grad_fn, hv_fn, damper_fn, momenta_fn, damper_norm,
                                   projection_fn, fused_fn)


# The method whose merged steps a System with one constant-norm dashpot runs in one
# call: compiled_system.hpp's damp_then_3s_body, called from composed_step.hpp's
# join_then_body for this table only.
FUSED_METHOD = "3s"

# What each sub-flow does to (q, p), as expressions: damp (p <- p - k P(q, p), the
# decay exp(-t eps D M^{-1}) p of the dashpot, whose factor k the C++ computes once
# per duration), drift (q <- q + t M^{-1} p) and kick (p <- p - t grad V(q)). The
# scalar's name prefix: a damp takes its factor k, the others their duration t.
_SCALAR_OF_FLOW = {"damp": "_k", "drift": "_t", "kick": "_t"}


def _fused_table() -> list[tuple[str, float]]:
    """FUSED_METHOD's table from the compiled catalogue, checked against what the C++
    caller fills in: the join's damp factor and three inner durations."""
    table = [(flow, fraction) for flow, fraction in _core.splitting(FUSED_METHOD)]
    if table[0][0] != "damp" or len(table) != 5:
        raise RuntimeError(f"fused body: compiled_system.hpp passes a damp's factor and three durations; "
                           f"the table of {FUSED_METHOD!r} is {table}")
    return table


def fused_body(table: list[tuple[str, float]], projection: list[se.Basic], gradient: list[se.Basic],
               q: list[se.Symbol], p: list[se.Symbol],
               inverse: np.ndarray) -> tuple[list[se.Symbol], list[se.Basic]]:
    """The join and body of a symmetric splitting's merged steps as one map, read off
    its table [(sub-flow, fraction of h), ...] in the order applied (``_core.splitting``).

    Between two steps that save nothing, the step loop runs the table's end sub-flow
    once for the summed time (the trailing one of a step and the leading one of the
    next: the join) and then the next step's inner sub-flows in table order (the body)
    (composed_step.hpp, join_then_body). Returns the scalar inputs, one per sub-flow of
    join then body in that order (a damp its factor k, a drift or kick its duration),
    and the 2n expressions of (q, p) after them, in (q, p, scalars). For 3s: scalars
    (k, t0, t1, t2), p <- p - k P(q, p), drift t0, kick t1, drift t2: the positional
    contract of compiled_system.hpp (in[2n] = the join's k, in[2n + 1 + j] = the
    duration of inner sub-flow j). Built by substitution; Lambdify's CSE shares repeats.
    """
    flows = [flow for flow, _ in table]
    if len(table) < 3 or table != table[::-1]:
        raise ValueError(f"fused body: the table {table} is not a symmetric table of three or more sub-flows, "
                         "so its steps do not merge")
    unknown = sorted(set(flows) - set(_SCALAR_OF_FLOW))
    if unknown:
        raise ValueError(f"fused body: no symbolic form for the sub-flow(s) {unknown}")
    join_then_body = [flows[0]] + flows[1:-1]
    scalars = [se.Symbol(_SCALAR_OF_FLOW[flows[0]])] + [se.Symbol(f"{_SCALAR_OF_FLOW[f]}{j}")
                                                         for j, f in enumerate(flows[1:-1])]
    qs, ps = list(q), list(p)
    for flow, s in zip(join_then_body, scalars):
        if flow == "damp":
            at = _at(projection, q + p, qs + ps)
            ps = [pi - s * e for pi, e in zip(ps, at)]
        elif flow == "drift":
            qs = [qi + s * vi for qi, vi in zip(qs, _times_inverse(inverse, ps))]
        else:  # kick
            ps = [pi - s * g for pi, g in zip(ps, _at(gradient, q, qs))]
    return scalars, qs + ps


def _at(exprs: list[se.Basic], symbols: list[se.Symbol], values: list[se.Basic]) -> list[se.Basic]:
    """exprs with symbols replaced by values (left alone where values are the symbols)."""
    if all(s == v for s, v in zip(symbols, values)):
        return exprs
    at = dict(zip(symbols, values))
    return [e.subs(at) for e in exprs]


def _times_inverse(inverse: np.ndarray, vector: list[se.Basic]) -> list[se.Basic]:
    """M^{-1} vector as expressions, M^{-1}'s zeros left out."""
    n = len(vector)
    return [sum((number(inverse[j, i]) * vector[i] for i in range(n) if inverse[j, i] != 0.0), se.Integer(0))
            for j in range(n)]


def _projection(g: se.Basic, gradient: list[se.Basic], q: list[se.Symbol], u: list[se.Symbol],
                inverse: np.ndarray) -> list[se.Basic]:
    """P(q, u) = grad g (grad g . v), v = M^{-1} u, as n expressions in (q, u).

    grad g . v is taken as the derivative of g(q + lam v) at lam = 0 rather than as a
    sum of products: for g built on a root, g = sqrt(s), the chain rule makes it one
    product (s' . v) s^(-1/2)/2, and times grad g_i = s_i' s^(-1/2)/2 SymEngine adds
    the exponents, so P of a distance dashpot, (q.v) q / |q|^2, has no square root.
    """
    v = _times_inverse(inverse, u)
    lam = se.Symbol("_lam")
    along = g.subs({qi: qi + lam * vi for qi, vi in zip(q, v)})
    directional = se.diff(along, lam).subs({lam: se.Integer(0)})
    return [directional * gi for gi in gradient]


def evaluate(fn: Any, x: np.ndarray) -> np.ndarray:
    """Call a compiled function from Python (checks and diagnostics, not the step loop)."""
    return np.asarray(fn(np.ascontiguousarray(x, dtype=float)), dtype=float).reshape(-1)
