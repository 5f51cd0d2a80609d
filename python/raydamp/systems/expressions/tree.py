"""The expression tree, the functions it may call, its limits, and constant folding.

The parser builds these nodes from user text; ``fold`` computes their constant parts;
``symbolic`` turns them into SymEngine expressions. Nodes carry the 1-based column of the text they came from, so every
later error can point at it.

A long chain such as ``a + b + c + ...`` is a left-deep tree as deep as it is long
(up to MAX_NODES), far deeper than Python's recursion limit, so nothing in this
package walks a tree recursively: ``postorder`` does it with an explicit stack. (The
dataclasses' generated ``==`` and ``repr`` do recurse; they are for small trees in
tests and debugging, and the package itself never calls them.)
"""

from __future__ import annotations

import math
import operator
from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple, TypeVar

__all__ = ["Number", "Name", "Unary", "Binary", "Call", "Node", "FUNCTIONS", "OPERATORS", "MAX_LENGTH",
           "MAX_NODES",
           "MAX_DEPTH", "MAX_EXPONENT", "children", "postorder", "fold"]

# Limits. Each one bounds the work some hostile text could cause; each is checked
# while parsing, and the messages quote them.
MAX_LENGTH = 10_000    # characters; checked before anything else looks at the text
MAX_NODES = 5_000      # nodes of the tree as parsed (before constant folding)
MAX_DEPTH = 100        # nested parentheses, calls, unary signs and powers
MAX_EXPONENT = 1000    # |numeric exponent|, and the product of nested numeric exponents


@dataclass(frozen=True)
class Number:
    value: float  # always a finite float
    column: int


@dataclass(frozen=True)
class Name:
    name: str     # a name from the caller's `names` (never 'pi' unless the caller defined it)
    column: int


@dataclass(frozen=True)
class Unary:
    op: str       # '-' or '+'
    operand: Node
    column: int   # of the sign


@dataclass(frozen=True)
class Binary:
    op: str       # '+', '-', '*', '/' or '^' ('**' in the text is '^' here)
    left: Node
    right: Node
    column: int   # of the operator


@dataclass(frozen=True)
class Call:
    function: str          # a key of FUNCTIONS
    args: tuple[Node, ...]
    column: int            # of the function's name


Node = Number | Name | Unary | Binary | Call

# name -> (number of arguments, description). The float version of each is below
# (FLOAT_FUNCTIONS, for constant folding), the SymEngine one in symbolic.py; both
# are checked against this table's keys at import.
FUNCTIONS: dict[str, tuple[int, str]] = {
    "sin": (1, "sine"),
    "cos": (1, "cosine"),
    "tan": (1, "tangent"),
    "asin": (1, "arcsine, for -1 <= x <= 1"),
    "acos": (1, "arccosine, for -1 <= x <= 1"),
    "atan": (1, "arctangent"),
    "sinh": (1, "hyperbolic sine"),
    "cosh": (1, "hyperbolic cosine"),
    "tanh": (1, "hyperbolic tangent"),
    "asinh": (1, "inverse hyperbolic sine"),
    "acosh": (1, "inverse hyperbolic cosine, for x >= 1"),
    "atanh": (1, "inverse hyperbolic tangent, for -1 < x < 1"),
    "exp": (1, "exponential"),
    "log": (1, "natural logarithm, for x > 0"),
    "sqrt": (1, "square root, for x >= 0"),
    # SymEngine has no real cube root with a derivative it can compile, so cbrt is
    # x^(1/3) everywhere (also when folding constants): real only for x >= 0.
    "cbrt": (1, "cube root x^(1/3), for x >= 0"),
    "atan2": (2, "atan2(y, x): the angle of the point (x, y), in (-pi, pi]"),
}


# What each binary operator computes, on floats (constant folding) and on SymEngine expressions alike.
OPERATORS: dict[str, Callable] = {"+": operator.add, "-": operator.sub, "*": operator.mul, "/": operator.truediv,
                                  "^": operator.pow}


def children(node: Node) -> tuple[Node, ...]:
    if isinstance(node, Binary):
        return (node.left, node.right)
    if isinstance(node, Unary):
        return (node.operand,)
    if isinstance(node, Call):
        return node.args
    return ()


T = TypeVar("T")


def postorder(root: Node, visit: Callable[[Node, list[T]], T]) -> T:
    """visit(node, results of its children, left to right) for every node, children
    first, and return the root's result. Iterative, so any depth is fine."""
    results: list[T] = []
    stack: list[tuple[Node, bool]] = [(root, False)]
    while stack:
        node, expanded = stack.pop()
        kids = children(node)
        if kids and not expanded:
            stack.append((node, True))
            stack.extend((kid, False) for kid in reversed(kids))
            continue
        if kids:
            args = results[-len(kids):]
            del results[-len(kids):]
        else:
            args = []
        results.append(visit(node, args))
    return results[0]


def format_number(value: float) -> str:
    """A float for a message: 1099511627776 rather than 1099511627776.0."""
    if value.is_integer() and abs(value) < 1e16:
        return str(int(value))
    return repr(value)


# The float meaning of each function, for constant folding. math raises ValueError
# outside a function's domain and OverflowError past the largest double; fold turns
# those into messages, with the domain text here for ValueError.
def _cube_root(x: float) -> float:
    return math.pow(x, 1 / 3)  # refuses x < 0, where the compiled x^(1/3) would give NaN


FLOAT_FUNCTIONS: dict[str, tuple[Callable[..., float], str]] = {
    "sin": (math.sin, ""),
    "cos": (math.cos, ""),
    "tan": (math.tan, ""),
    "asin": (math.asin, "asin of a number outside [-1, 1]"),
    "acos": (math.acos, "acos of a number outside [-1, 1]"),
    "atan": (math.atan, ""),
    "sinh": (math.sinh, ""),
    "cosh": (math.cosh, ""),
    "tanh": (math.tanh, ""),
    "asinh": (math.asinh, ""),
    "acosh": (math.acosh, "acosh of a number below 1"),
    "atanh": (math.atanh, "atanh of a number outside (-1, 1)"),
    "exp": (math.exp, ""),
    "log": (math.log, "log of zero or a negative number"),
    "sqrt": (math.sqrt, "sqrt of a negative number"),
    "cbrt": (_cube_root, "cbrt of a negative number; cbrt(x) is x^(1/3), real for x >= 0"),
    "atan2": (math.atan2, ""),
}
assert FLOAT_FUNCTIONS.keys() == FUNCTIONS.keys()


# --- Constant folding --------------------------------------------------------------
#
# The safety point of the package: every subtree without names is computed here, in
# floating point, so SymEngine never does exact arithmetic on numbers from the text
# (exact 2**2**40 is a number no machine can hold). A failing or non-finite constant
# is an error naming its column. The same pass runs again in to_symengine with the
# parameters' values substituted, so values cannot sneak a huge power past it either.
#
# Exponents: a numeric exponent must satisfy |e| <= MAX_EXPONENT, and so must the
# product of nested numeric exponents, because SymEngine distributes integer powers:
# ((2*x)^1000)^1000 would compute 2^1000000 exactly, one more ^1000 would not finish.


class _Undefined(Exception):
    """A constant subexpression has no finite real value; the reason ends the message."""


class _Folded(NamedTuple):
    node: Node
    start: int          # column where the subexpression's text starts (messages)
    weight: float       # product of the numeric exponents nested inside it, >= 1
    substituted: bool   # contains a name that was replaced by its value


def fold(root: Node, field: str, values: dict[str, float] | None = None) -> Node:
    """The tree with every subtree free of (unsubstituted) names replaced by a Number.

    ``values`` maps names to floats to substitute first. Raises ValueError
    "<field>: ..." naming the column of anything undefined or over a limit."""
    values = values or {}

    def fail(message: str, substituted: bool):
        suffix = " (with the values given for its names)" if substituted else ""
        raise ValueError(f"{field}: {message}{suffix}")

    def visit(node: Node, args: list[_Folded]) -> _Folded:
        if isinstance(node, Number):
            return _Folded(node, node.column, 1.0, False)
        if isinstance(node, Name):
            if node.name in values:
                return _Folded(Number(values[node.name], node.column), node.column, 1.0, True)
            return _Folded(node, node.column, 1.0, False)

        start = args[0].start if isinstance(node, Binary) else node.column
        substituted = any(a.substituted for a in args)
        weight = max(a.weight for a in args)
        if isinstance(node, Binary) and node.op == "^" and isinstance(args[1].node, Number):
            exponent = args[1].node.value
            if abs(exponent) > MAX_EXPONENT:
                fail(f"exponent {format_number(exponent)} at column {args[1].start} is too large: "
                     f"|exponent| <= {MAX_EXPONENT} is the limit", args[1].substituted)
            weight = args[0].weight * max(1.0, abs(exponent))
            if weight > MAX_EXPONENT:
                fail(f"the power at column {node.column} raises to the power {format_number(weight)} in all "
                     f"(nested exponents multiply), above the limit {MAX_EXPONENT}", substituted)

        if all(isinstance(a.node, Number) for a in args):
            try:
                value = _evaluate(node, [a.node.value for a in args])
            except _Undefined as err:
                fail(f"the constant subexpression at column {start} {err}", substituted)
            return _Folded(Number(value, start), start, 1.0, substituted)

        if isinstance(node, Binary) and node.op == "/" and isinstance(args[1].node, Number) \
                and args[1].node.value == 0:
            fail(f"division by zero at column {node.column}", args[1].substituted)

        # Rebuild only where a child changed (by identity: node == recurses), so an
        # unchanged tree comes back as it was.
        kids = tuple(a.node for a in args)
        if any(k is not c for k, c in zip(kids, children(node))):
            if isinstance(node, Unary):
                node = Unary(node.op, kids[0], node.column)
            elif isinstance(node, Binary):
                node = Binary(node.op, kids[0], kids[1], node.column)
            else:
                node = Call(node.function, kids, node.column)
        return _Folded(node, start, weight, substituted)

    return postorder(root, visit).node


def _evaluate(node: Node, args: list[float]) -> float:
    """The float value of one operator or call on finite floats; _Undefined if none."""
    try:
        if isinstance(node, Unary):
            result = -args[0] if node.op == "-" else args[0]
        elif isinstance(node, Binary):
            a, b = args
            if node.op == "/" and b == 0:
                raise _Undefined("divides by zero")
            if node.op == "^":
                if a == 0 and b < 0:
                    raise _Undefined("divides by zero")
                if a < 0 and not b.is_integer():
                    raise _Undefined("is not a real number (a negative number to a non-integer power)")
            result = OPERATORS[node.op](a, b)
        else:
            function, domain = FLOAT_FUNCTIONS[node.function]
            try:
                result = function(*args)
            except ValueError:
                raise _Undefined(f"is not a real number ({domain or node.function + ' is undefined there'})") \
                    from None
    except OverflowError:
        raise _Undefined("overflows") from None
    except ZeroDivisionError:
        raise _Undefined("divides by zero") from None
    if not math.isfinite(result):
        raise _Undefined("overflows")  # only overflow makes inf or nan from finite inputs
    return float(result)
