"""Safe expressions from user text: our own parser, our own validated tree, and
SymEngine expressions built from that tree through SymEngine's Python API.

User text never reaches eval/exec, SymPy's parse_expr/sympify or SymEngine's own
string parser (which dies with SIGFPE on ``2**2**40``)::

    >>> from raydamp.systems.expressions import parse
    >>> expr = parse("k/2*(sqrt(x^2+y^2+z^2) - l)^2 - m*g*z", field="potential",
    ...              names={"x": "coordinate", "y": "coordinate", "z": "coordinate",
    ...                     "k": "parameter", "l": "parameter", "m": "parameter", "g": "parameter"})
    >>> sorted(expr.names)
    ['g', 'k', 'l', 'm', 'x', 'y', 'z']

``expr.to_symengine({name: Symbol or number})`` gives the SymEngine expression. Every
error is a ValueError "<field>: ... at column N ...".
"""

from .expression import Expression, parse
from .tree import FUNCTIONS, MAX_DEPTH, MAX_EXPONENT, MAX_LENGTH, MAX_NODES, Binary, Call, Name, Node, Number, Unary

__all__ = ["parse", "Expression", "FUNCTIONS", "MAX_LENGTH", "MAX_NODES", "MAX_DEPTH", "MAX_EXPONENT",
           "Node", "Number", "Name", "Unary", "Binary", "Call"]
