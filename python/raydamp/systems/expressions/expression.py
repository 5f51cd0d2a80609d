"""Expression: a parsed, validated expression, made by ``parse`` (parser.py turns the text into a tree) and
turned into SymEngine by symbolic.py."""

from __future__ import annotations

from collections.abc import Mapping

import symengine as se

from .parser import parse_tree
from .symbolic import to_symengine
from .tree import Node

__all__ = ["Expression", "parse"]


def parse(text: str, *, field: str = "expression", names: Mapping[str, str] | None = None) -> Expression:
    """Parse ``text`` into an Expression that may use the ``names`` (name -> kind, such
    as "coordinate", "parameter" or "momentum"), the constant ``pi`` (unless ``names``
    has its own "pi") and the FUNCTIONS. Raises ValueError "<field>: ...".
    """
    tree, used, kinds = parse_tree(text, str(field), names)
    return Expression(text, tree, used, str(field), kinds)


class Expression:
    """A parsed, validated expression. Made by ``parse``; immutable.

    ``text`` is the original text, ``tree`` the root node (constants folded), ``names``
    the names it uses (not 'pi', not functions), ``field`` what its messages start with.
    """

    __slots__ = ("text", "tree", "names", "field", "_kinds")

    def __init__(self, text: str, tree: Node, names: frozenset[str], field: str, kinds: Mapping[str, str]):
        for slot, value in (("text", text), ("tree", tree), ("names", frozenset(names)), ("field", field),
                            ("_kinds", dict(kinds))):
            object.__setattr__(self, slot, value)

    def __setattr__(self, name, value):
        raise AttributeError("Expression is immutable")

    def __delattr__(self, name):
        raise AttributeError("Expression is immutable")

    def to_symengine(self, symbols: Mapping[str, object]) -> se.Basic:
        """The SymEngine expression, with ``symbols[name]`` for each name in ``names``:
        a SymEngine expression (usually a Symbol) to keep it symbolic, or a real number
        (int, float, se.Integer, se.RealDouble, ...) to substitute.

        Raises ValueError "<field>: ..." if a value is missing or not real, or if the
        values make something undefined or over a limit (x/k with k = 0, x^k with
        k = 10**6), or if SymEngine's simplification leaves no finite real value
        (1/(x - x) is 1/0)."""
        return to_symengine(self.tree, self.names, self.field, symbols)

    def __str__(self) -> str:
        return self.text

    def __repr__(self) -> str:
        return f"Expression({self.text!r}, field={self.field!r})"

    # Equality by text and names: the tree is a function of them. (Comparing trees
    # would recurse as deep as the tree.)
    def __eq__(self, other) -> bool:
        if not isinstance(other, Expression):
            return NotImplemented
        return self.text == other.text and self.names == other.names

    def __hash__(self) -> int:
        return hash((self.text, self.names))

    def __copy__(self) -> Expression:
        return self

    def __deepcopy__(self, memo) -> Expression:
        return self

    def __reduce__(self):
        # Pickled as its text and re-parsed on load: the tree may be deeper than
        # pickle's recursion limit, and a loaded expression gets validated again.
        return (_rebuild, (self.text, self.field, dict(self._kinds)))


def _rebuild(text: str, field: str, kinds: dict[str, str]) -> Expression:
    return parse(text, field=field, names=kinds)
