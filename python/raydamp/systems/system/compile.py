"""From a validated SystemSpec to machine code: SymEngine expressions built from our
own expression trees (never from text), differentiated symbolically, and compiled
by SymEngine's LLVM JIT with common-subexpression elimination. The C++ step loop
calls the compiled functions through plain C pointers, with no Python and the GIL
released.
"""

from __future__ import annotations

import collections
import contextlib
import contextvars
import ctypes
import hashlib
import io
import json
import math
import pickle
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
import symengine as se

from ... import _core
from .dashpot_norm import constant_dashpot_norm
from .errors import SpecError
from .spec import SystemSpec

__all__ = ["CompiledSystemFunctions", "NotCompiled", "compile_key", "compile_system", "compiled_elsewhere",
           "fused_body", "load_compiled", "number"]


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
    # The constraints (constraints.py): q -> (g, scales), q -> G's non-zeros at (rows, cols),
    # (q, v) -> v^T Hess g_i v.
    constraint_values: Any | None = None
    constraint_jacobian: Any | None = None
    constraint_pattern: tuple[tuple[int, ...], tuple[int, ...]] = ((), ())
    constraint_curvature: Any | None = None

    @classmethod
    def of(cls, potential: Any, gradient: Any, hessian_product: Any, damper_gradients: Any | None = None,
           momenta: Any | None = None, damper_norm: float | None = None, damper_projection: Any | None = None,
           damp_then_3s_body: Any | None = None, constraint_values: Any | None = None,
           constraint_jacobian: Any | None = None,
           constraint_pattern: tuple[tuple[int, ...], tuple[int, ...]] = ((), ()),
           constraint_curvature: Any | None = None) -> CompiledSystemFunctions:
        """The functions with their addresses, taken from the functions themselves: after a compile, and
        after loading them in another process (an address is of this process's copy of the code)."""
        functions = (potential, gradient, hessian_product, damper_gradients, momenta, damper_projection,
                     damp_then_3s_body)
        addresses = tuple(a for fn in functions for a in _address(fn))
        return cls(addresses, potential, gradient, hessian_product, damper_gradients, momenta, damper_norm,
                   damper_projection, damp_then_3s_body, constraint_values, constraint_jacobian,
                   (tuple(constraint_pattern[0]), tuple(constraint_pattern[1])), constraint_curvature)

    @property
    def constraint_addresses(self) -> tuple[int, ...]:
        """(function, data) of the constraints' values, their Jacobian and their curvature, as the bindings
        take them."""
        return (*_address(self.constraint_values), *_address(self.constraint_jacobian),
                *_address(self.constraint_curvature))

    def to_bytes(self) -> bytes:
        """The compiled functions as bytes (their object code, as SymEngine pickles an LLVM Lambdify: a few kB
        each) for another process of this machine to load with :meth:`from_bytes`, without compiling again."""
        functions = [getattr(self, name) for name in _FUNCTIONS]
        pattern = [list(self.constraint_pattern[0]), list(self.constraint_pattern[1])]
        return pickle.dumps((_FORMAT, functions, self.damper_norm, pattern), protocol=pickle.HIGHEST_PROTOCOL)

    @classmethod
    def from_bytes(cls, data: bytes) -> CompiledSystemFunctions:
        """What :meth:`to_bytes` wrote, loaded into this process, the addresses derived again.

        Only for bytes that a process of our own wrote: loading maps the object code they carry into this
        process and runs it when the model is stepped. The unpickler admits nothing but SymEngine's loader
        of LLVM functions and NumPy's float64 (no other callable is reachable), but the machine code itself
        cannot be checked: bytes from a client, a file or the network must never come here.
        """
        found = _TrustedUnpickler(io.BytesIO(data)).load()
        if not (isinstance(found, tuple) and len(found) == 4 and found[0] == _FORMAT
                and isinstance(found[1], list) and len(found[1]) == len(_FUNCTIONS)
                and isinstance(found[3], list) and len(found[3]) == 2
                and all(isinstance(i, int) for side in found[3] for i in side)):
            raise ValueError("compiled system functions: not what CompiledSystemFunctions.to_bytes writes")
        _, functions, damper_norm, pattern = found
        return cls.of(*functions[:5], damper_norm, *functions[5:9], constraint_pattern=(pattern[0], pattern[1]),
                      constraint_curvature=functions[9])


# The order of the functions in to_bytes, and that form's version.
_FUNCTIONS = ("potential", "gradient", "hessian_product", "damper_gradients", "momenta", "damper_projection",
              "damp_then_3s_body", "constraint_values", "constraint_jacobian", "constraint_curvature")
_FORMAT = "raydamp.compiled_system.3"
# What an LLVM Lambdify's pickle names (SymEngine's llvm_loading_func rebuilds it from its object code).
_LOADABLE = {("symengine.lib.symengine_wrapper", "llvm_loading_func"), ("numpy", "float64"), ("numpy", "dtype")}


class _TrustedUnpickler(pickle.Unpickler):
    def find_class(self, module: str, name: str) -> Any:
        if (module, name) not in _LOADABLE:
            raise pickle.UnpicklingError(f"compiled system functions: {module}.{name} is not loadable here")
        return super().find_class(module, name)


def _address(fn: Any | None) -> tuple[int, int]:
    """(function, data) of a compiled function as the C++ bindings call it; (0, 0) where absent."""
    if fn is None:
        return 0, 0
    cfunc, data = fn.as_ctypes()
    return ctypes.cast(cfunc, ctypes.c_void_p).value, data.value or 0


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
# And their terms: a sum or product of n terms is one node but n - 1 instructions. The Hessian product of
# q0*q1*...*q69 is 5,040 nodes holding 333,000 factors, and took 14 s; of 50 coordinates, 120,000 and 3.7 s.
MAX_TERMS = 150_000


def _operations(outputs: list[se.Basic], limit: int, terms_limit: int = MAX_TERMS) -> int:
    """Distinct sub-expressions of outputs, counted up to limit + 1; limit + 1 as soon as their terms (a node of
    n arguments counted n - 1, anything else 1) pass terms_limit."""
    seen: set[se.Basic] = set()
    terms = 0
    stack = list(outputs)
    while stack and len(seen) <= limit:
        node = stack.pop()
        if node not in seen:
            seen.add(node)
            args = node.args
            terms += max(1, len(args) - 1)
            if terms > terms_limit:
                return limit + 1
            stack.extend(args)
    return len(seen)


# Numbers no compiled function can compute with: complex ones (a negative base to a variable power
# differentiates to log(-2)), infinities and NaN (0^x differentiates to log(0)).
_NOT_REAL = frozenset({"ImaginaryUnit", "Complex", "ComplexDouble", "ComplexMPC", "ComplexInfinity", "Infinity",
                       "NegativeInfinity", "NaN"})


def _unusable_constant(outputs: list[se.Basic]) -> str | None:
    """Why a number in outputs cannot be a double, or None. SymEngine keeps exact integers and rationals:
    (4x)^600 becomes 4^600 x^600, and 4^600 overflows a double (the compiled value was inf * 0 = NaN), as
    (x/3)^700's 3^-700 underflows to 0 (the value was 0)."""
    seen: set[se.Basic] = set()
    stack = list(outputs)
    while stack:
        node = stack.pop()
        if node in seen:
            continue
        seen.add(node)
        kind = type(node).__name__
        if kind in _NOT_REAL:
            return f"a value that is not a finite real number ({node})"
        if isinstance(node, (se.Integer, se.Rational, se.RealDouble)):
            value = float(node)
            if not math.isfinite(value) or (value == 0.0 and node != 0):
                shown = str(node) if len(str(node)) <= 40 else f"a number of {len(str(node))} digits"
                return f"the constant {shown}, beyond a double's range"
        stack.extend(node.args)
    return None


def _jit(inputs: list[se.Symbol], outputs: list[se.Basic], what: tuple[str, ...]) -> tuple[Any, int, int]:
    """Compiled outputs(inputs); what is the spec's path the outputs come from (a too large one is its error).
    Counted first, then checked, then rewritten: the rewrite of a tree past the bound took over a minute."""
    if _operations(outputs, MAX_OPERATIONS) > MAX_OPERATIONS:
        raise SpecError(what, f"after differentiation more than {MAX_OPERATIONS} distinct operations (or {MAX_TERMS} "
                              "terms of sums and products) in one compiled "
                              "function; write it with fewer couplings, or use a Chain or LinearStructure for a "
                              "large system")
    unusable = _unusable_constant(outputs)
    if unusable is not None:
        raise SpecError(what, f"the compiled function (or its derivative) holds {unusable}; rewrite the "
                              "expression (a negative or zero base to a variable power, or a huge power of a scaled "
                              "coordinate: write (c*x)^n as c^n*x^n with c^n a representable number)")
    outputs = [_without_half_powers(e) for e in outputs]
    fn = se.Lambdify(inputs, outputs, backend="llvm", cse=True, real=True)
    return (fn, *_address(fn))


class NotCompiled(LookupError):
    """Within compiled_elsewhere(): a system whose functions were not loaded (load_compiled) is not compiled."""

    def __init__(self, key: str):
        super().__init__(f"the functions of this system (key {key[:12]}) were not compiled in this process's stead")
        self.key = key


# Compiled functions by compile_key, the most recently used last: a System built again with the same
# expressions (another eps, damping coefficient or initial state; the same system in another job) shares
# them, and functions compiled in another process (load_compiled) are found here.
_CACHE_SIZE = 64
_cache: collections.OrderedDict[str, CompiledSystemFunctions] = collections.OrderedDict()
_cache_lock = threading.Lock()
_elsewhere = contextvars.ContextVar("raydamp_compiled_elsewhere", default=False)


def compile_key(spec: SystemSpec) -> str:
    """What the compiled functions depend on (names, expressions as written, parameters, M, and the table
    the fused body is read from), hashed: two specs with one key compile to the same functions. eps, the
    damping's coefficients and the name are not compiled in."""
    plain = {"coordinates": list(spec.coordinates), "potential": spec.potential.text,
             "parameters": sorted(spec.parameters.items()), "mass": spec.mass.tolist(),
             "dampers": [d.on.text for d in spec.dampers],
             "momenta": [(name, e.text) for name, e in spec.momenta.items()],
             "constraints": [c.text for c in spec.constraints],
             "fused_table": [list(row) for row in _core.splitting(FUSED_METHOD)] if len(spec.dampers) == 1 else None}
    return hashlib.sha256(json.dumps(plain, separators=(",", ":")).encode()).hexdigest()


def _remember(key: str, compiled: CompiledSystemFunctions) -> None:
    with _cache_lock:
        _cache[key] = compiled
        _cache.move_to_end(key)
        while len(_cache) > _CACHE_SIZE:
            _cache.popitem(last=False)


def load_compiled(key: str, data: bytes) -> None:
    """Functions another process of ours compiled (CompiledSystemFunctions.to_bytes), for the systems of
    this key built from now on (already there: kept, not loaded again). Trusted bytes only: see
    CompiledSystemFunctions.from_bytes."""
    with _cache_lock:
        if key in _cache:
            _cache.move_to_end(key)
            return
    _remember(key, CompiledSystemFunctions.from_bytes(data))


@contextlib.contextmanager
def compiled_elsewhere() -> Iterator[None]:
    """Within it (in this thread), a System whose functions are not loaded or cached raises NotCompiled
    instead of compiling: for a process that must not hold its interpreter lock for a compile."""
    token = _elsewhere.set(True)
    try:
        yield
    finally:
        _elsewhere.reset(token)


def compile_system(spec: SystemSpec) -> CompiledSystemFunctions:
    """The compiled functions of spec: from the cache by compile_key, or compiled (and then cached)."""
    key = compile_key(spec)
    with _cache_lock:
        found = _cache.get(key)
        if found is not None:
            _cache.move_to_end(key)
            return found
    if _elsewhere.get():
        raise NotCompiled(key)
    # Kept as its object code reloaded: the same machine code, without the compiler's state that a freshly
    # compiled LLVM function holds on to (3 MB for a two-coordinate system; 0.3 MB reloaded).
    compiled = CompiledSystemFunctions.from_bytes(_compile(spec).to_bytes())
    _remember(key, compiled)
    return compiled


def _compile(spec: SystemSpec) -> CompiledSystemFunctions:
    n = spec.n
    # Internal symbol names, so a user's coordinate called, say, "I" or "E" never
    # meets a SymEngine built-in.
    q = [se.Symbol(f"_q{i}") for i in range(n)]
    p = [se.Symbol(f"_p{i}") for i in range(n)]
    v = [se.Symbol(f"_v{i}") for i in range(n)]
    symbols: dict[str, se.Basic] = {name: number(value) for name, value in spec.parameters.items()}
    symbols.update(zip(spec.coordinates, q))

    potential = spec.potential.to_symengine(symbols)
    pot_fn = _jit(q, [potential], ("potential",))[0]
    gradient = [se.diff(potential, qi) for qi in q]
    grad_fn = _jit(q, gradient, ("potential",))[0]  # before the Hessian's product, which grows a power faster
    # Hess V v = grad_q (grad V . v): n derivatives of one scalar instead of n^2.
    directional = sum((g * vi for g, vi in zip(gradient, v)), se.Integer(0))
    hessian_product = [se.diff(directional, qi) for qi in q]
    hv_fn = _jit(q + v, hessian_product, ("potential",))[0]

    damper_fn = damper_norm = projection_fn = fused_fn = None
    if spec.dampers:
        # k rows of n: the gradient of each dashpot's function, row-major.
        rows = []
        functions = [damper.on.to_symengine(symbols) for damper in spec.dampers]
        for g in functions:
            rows.extend(se.diff(g, qi) for qi in q)
        damper_fn = _jit(q, rows, ("damping", "dampers"))[0]
        if len(spec.dampers) == 1:
            inverse = np.linalg.inv(spec.mass)
            damper_norm = constant_dashpot_norm(rows, inverse, lambda x: evaluate(damper_fn, x))
            if damper_norm is not None:
                projection = _projection(functions[0], rows, q, p, inverse)
                projection_fn = _jit(q + p, projection, ("damping", "dampers"))[0]
                scalars, fused = fused_body(_fused_table(), projection, gradient, q, p, inverse)
                fused_fn = _jit(q + p + scalars, fused, ("damping", "dampers"))[0]

    momenta_fn = None
    if spec.momenta:
        with_p = dict(symbols)
        with_p.update({f"p_{name}": pi for name, pi in zip(spec.coordinates, p)})
        outputs = [expr.to_symengine(with_p) for expr in spec.momenta.values()]
        momenta_fn = _jit(q + p, outputs, ("momenta",))[0]
    values_fn = jacobian_fn = curvature_fn = None
    pattern: tuple[tuple[int, ...], tuple[int, ...]] = ((), ())
    if spec.constraints:
        from .constraints import constraint_functions
        values, nonzeros, curvatures, pattern = constraint_functions(spec, symbols, q, v)
        values_fn = _jit(q, values, ("constraints",))[0]
        jacobian_fn = _jit(q, nonzeros, ("constraints",))[0]
        curvature_fn = _jit(q + v, curvatures, ("constraints",))[0]
    return CompiledSystemFunctions.of(pot_fn, grad_fn, hv_fn, damper_fn, momenta_fn, damper_norm, projection_fn,
                                      fused_fn, values_fn, jacobian_fn, pattern, curvature_fn)


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
