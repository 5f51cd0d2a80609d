"""The SymEngine form of a parsed expression (expression.Expression.to_symengine), built from its tree.

SymEngine objects are made only through its Python API (Symbol, +, *, **, se.sin,
...), never from text. Before SymEngine sees a tree, ``tree.fold`` has computed every
constant subtree in floating point, also after substituting the numbers the caller
passes for names, so SymEngine never does exact arithmetic on a huge number.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping

import symengine as se

from .tree import FUNCTIONS, OPERATORS, Binary, Call, Name, Node, Number, Unary, fold, postorder

__all__ = ["number", "to_symengine"]

_ONE_THIRD = se.Rational(1, 3)
_INFINITY = se.RealDouble(math.inf)

_SYMENGINE = {
    "sin": se.sin, "cos": se.cos, "tan": se.tan,
    "asin": se.asin, "acos": se.acos, "atan": se.atan,
    "sinh": se.sinh, "cosh": se.cosh, "tanh": se.tanh,
    "asinh": se.asinh, "acosh": se.acosh, "atanh": se.atanh,
    "exp": se.exp, "log": se.log, "sqrt": se.sqrt,
    "cbrt": lambda x: x ** _ONE_THIRD,  # see tree.FUNCTIONS: x^(1/3), real for x >= 0
    "atan2": se.atan2,
}
assert _SYMENGINE.keys() == FUNCTIONS.keys()


def number(value: float) -> se.Basic:
    """A folded constant for SymEngine: an integer value stays exact (x^2 is a square,
    k/2 a rational, good for differentiation and code); any other value is a double."""
    if value.is_integer() and abs(value) <= 2**53:
        return se.Integer(int(value))
    return se.RealDouble(value)


# SymEngine's names for values that are not finite reals, in words for messages.
_UNDEFINED = {"zoo": "infinite (zoo, as from 1/0 or log(0))", "nan": "undefined (nan)",
              "oo": "infinite", "-oo": "infinite"}


def _finite_real(value: se.Basic) -> bool:
    try:
        return math.isfinite(float(value))
    except (RuntimeError, TypeError, ValueError, OverflowError):  # zoo, I, log(-1), ...
        return False


def to_symengine(tree: Node, names: frozenset[str], field: str, symbols: Mapping[str, object]) -> se.Basic:
    """The SymEngine expression of a parsed tree (Expression.to_symengine), with ``symbols[name]`` for each of
    its ``names``."""
    numeric: dict[str, float] = {}
    symbolic: dict[str, se.Basic] = {}
    for name in sorted(names):
        if name not in symbols:
            raise ValueError(f"{field}: to_symengine needs a value for {name!r}")
        value = symbols[name]
        if isinstance(value, bool) or not isinstance(value, (numbers.Real, se.Basic)):
            # Strings in particular: se.sympify would parse them, which is what
            # this package exists to avoid.
            raise ValueError(f"{field}: the value for {name!r} must be a SymEngine expression or a real "
                             f"number, got {type(value).__name__}")
        if isinstance(value, numbers.Real) or value.is_Number:
            if not _finite_real(value):
                raise ValueError(f"{field}: the value for {name!r} is not a finite real number")
            numeric[name] = float(value)
        else:
            symbolic[name] = value

    tree = fold(tree, field, numeric)
    result = _build(tree, symbolic, field, find_infinity=False)
    if result.has(_INFINITY) or result.has(-_INFINITY):
        # Rare, so found cheaply here and located by a second, slower build.
        _build(tree, symbolic, field, find_infinity=True)
    return result


def _build(tree: Node, symbolic: Mapping[str, se.Basic], field: str, find_infinity: bool) -> se.Basic:
    """The SymEngine expression of a folded tree whose names are all in ``symbolic``."""

    def visit(node: Node, args: list[se.Basic]) -> se.Basic:
        if isinstance(node, Number):
            return number(node.value)
        if isinstance(node, Name):
            return symbolic[node.name]
        if isinstance(node, Unary):
            result = -args[0] if node.op == "-" else args[0]
        elif isinstance(node, Binary):
            result = OPERATORS[node.op](*args)
        else:
            result = _SYMENGINE[node.function](*args)
        # SymEngine simplifies as it builds (x - x is 0), so an operation on
        # non-constant parts can still come out as zoo (1/0), nan, I or acos(2),
        # which would fail later in LLVM or at run time. Numbers are cheap to test;
        # powers and calls are where a constant can appear without being a Number.
        # It also multiplies and adds its doubles: x*1e200*1e200 is inf*x (looked
        # for here only when the whole expression has an inf).
        if result.is_Number:
            bad = not _finite_real(result)
        elif isinstance(node, Call) or (isinstance(node, Binary) and node.op == "^"):
            bad = not result.free_symbols and not _finite_real(result)
        else:
            bad = False
        if find_infinity and not bad:
            bad = result.has(_INFINITY) or result.has(-_INFINITY)
        if bad:
            shown = _UNDEFINED.get(str(result)) or str(result)
            shown = shown if len(shown) <= 40 else shown[:37] + "..."
            raise ValueError(f"{field}: the subexpression at column {node.column} has no finite real value "
                             f"once simplified: it is {shown}")
        return result

    return postorder(tree, visit)
