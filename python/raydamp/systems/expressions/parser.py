"""User text -> validated expression tree, by our own small parser.

User text is never given to eval/exec, SymPy's parse_expr/sympify or SymEngine's
string parser (SymEngine dies with SIGFPE on ``2**2**40``). This module accepts a
deliberately small grammar and refuses everything else with a ValueError that starts
with the caller's field name and gives the 1-based column:

    expression := term (('+' | '-') term)*
    term       := unary (('*' | '/') unary)*
    unary      := ('+' | '-') unary | power
    power      := atom (('^' | '**') unary)?      right-associative; -x^2 is -(x^2); 2^-1 is allowed
    atom       := number | name | function '(' expression (',' expression)* ')' | '(' expression ')'

Limits (tree.MAX_*) are checked as the text is read, so hostile input costs at
most MAX_LENGTH characters of work: the length before anything else, nesting depth
on every '(' / call / sign / power (so the recursive descent stays far from Python's
recursion limit), and the node count on every node made.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from typing import NamedTuple

from .tree import FUNCTIONS, MAX_DEPTH, MAX_LENGTH, MAX_NODES, Binary, Call, Name, Node, Number, Unary, fold

__all__ = ["parse_tree"]

# Printable ASCII plus the whitespace we allow ('\r' too, so CRLF text pastes fine).
_NOT_ALLOWED = re.compile(r"[^\x20-\x7e\t\n\r]")
_SPACE = re.compile(r"[ \t\n\r]*")
_TOKEN = re.compile(r"""
      (?P<number> (?:[0-9]+\.?[0-9]*|\.[0-9]+) (?:[eE][+-]?[0-9]+)? )
    | (?P<name>   [A-Za-z_][A-Za-z0-9_]* )
    | (?P<op>     \*\*|[-+*/^(),] )
    """, re.VERBOSE)
# Characters that may not touch the end of a number: '2x', '1.2.3', '1e' are typos,
# not a number followed by something.
_NUMBER_TAIL = re.compile(r"[A-Za-z0-9_.]+")

_SHOW = 40  # characters of offending text echoed in a message


class _Token(NamedTuple):
    kind: str          # "number", "name", "op" or "end"
    text: str          # as written
    column: int        # 1-based
    value: object = None  # the float of a number; the operator of an op ('**' -> '^')


def _show(text: str) -> str:
    """Offending text for a message: quoted, truncated, and escaped to ASCII so the
    message can always be encoded (a lone surrogate would break UTF-8)."""
    return ascii(text if len(text) <= _SHOW else text[:_SHOW - 3] + "...")


def _plural(kind: str) -> str:
    return {"momentum": "momenta"}.get(kind, kind + "s")


def parse_tree(text: str, field: str, names: Mapping[str, str] | None) -> tuple[Node, frozenset[str], dict[str, str]]:
    """The folded tree of ``text`` (expression.parse), the names it uses, and their kinds."""
    field = str(field)
    if not isinstance(text, str):
        # The type only: the repr of an arbitrary object may be huge or hostile.
        raise ValueError(f"{field}: must be a string (an expression), got {type(text).__name__}")
    if len(text) > MAX_LENGTH:
        raise ValueError(f"{field}: expression too long at column {MAX_LENGTH + 1}: {len(text)} characters, "
                         f"over the limit of {MAX_LENGTH}")
    bad = _NOT_ALLOWED.search(text)
    if bad:
        raise ValueError(f"{field}: unexpected character {_show(bad.group())} at column {bad.start() + 1} "
                         f"(only printable ASCII is allowed)")
    if not text.strip(" \t\n\r"):
        raise ValueError(f"{field}: empty expression")

    allowed = {str(name): str(kind) for name, kind in (names or {}).items()}
    parser = _Parser(_tokenize(text, field), field, allowed)
    try:
        tree = parser.parse()
    except RecursionError:
        # Not expected: MAX_DEPTH keeps the descent to a few hundred frames. But a
        # caller already deep in its own stack must still get a clean error.
        raise ValueError(f"{field}: expression nested too deeply") from None
    tree = fold(tree, field)
    used = frozenset(parser.used)
    return tree, used, {name: allowed[name] for name in used}


def _tokenize(text: str, field: str) -> list[_Token]:
    tokens = []
    pos, end = 0, len(text)
    while True:
        pos = _SPACE.match(text, pos).end()
        if pos == end:
            break
        column = pos + 1
        match = _TOKEN.match(text, pos)
        if match is None:
            raise ValueError(f"{field}: unexpected character {_show(text[pos])} at column {column}")
        word, kind = match.group(), match.lastgroup
        if kind == "number":
            tail = _NUMBER_TAIL.match(text, match.end())
            if tail:
                raise ValueError(f"{field}: malformed number {_show(text[pos:tail.end()])} at column {column}")
            value = float(word)
            if not math.isfinite(value):
                raise ValueError(f"{field}: number {_show(word)} at column {column} is too large")
            tokens.append(_Token("number", word, column, value))
        elif kind == "name":
            if word.startswith("__"):
                raise ValueError(f"{field}: name {_show(word)} at column {column} starts with '__', "
                                 f"which is not allowed")
            tokens.append(_Token("name", word, column))
        else:
            tokens.append(_Token("op", word, column, "^" if word == "**" else word))
        pos = match.end()
    tokens.append(_Token("end", "", end + 1))
    return tokens


class _Parser:
    """Recursive descent over the token list, one method per grammar rule."""

    def __init__(self, tokens: list[_Token], field: str, names: dict[str, str]):
        self.tokens = tokens
        self.i = 0
        self.field = field
        self.names = names
        self.used: set[str] = set()
        self.depth = 0
        self.nodes = 0

    # --- helpers -----------------------------------------------------------------
    def fail(self, message: str):
        raise ValueError(f"{self.field}: {message}")

    def peek(self) -> _Token:
        return self.tokens[self.i]

    def advance(self) -> _Token:
        token = self.tokens[self.i]
        self.i += 1
        return token

    def at(self, ops: str) -> bool:
        token = self.tokens[self.i]
        return token.kind == "op" and token.value in ops

    def node(self, node: Node) -> Node:
        self.nodes += 1
        if self.nodes > MAX_NODES:
            self.fail(f"expression too large at column {node.column}: over the limit of {MAX_NODES} nodes "
                      f"(numbers, names, operators and calls)")
        return node

    def enter(self, column: int) -> None:
        self.depth += 1
        if self.depth > MAX_DEPTH:
            self.fail(f"expression nested too deeply at column {column}: over the limit of {MAX_DEPTH} levels "
                      f"(parentheses, calls, signs and powers)")

    def unexpected(self, token: _Token):
        if token.kind == "end":
            self.fail(f"unexpected end of expression at column {token.column}")
        self.fail(f"unexpected {_show(token.text)} at column {token.column}")

    def close(self, opening: _Token) -> None:
        token = self.advance()
        if not (token.kind == "op" and token.value == ")"):
            self.fail(f"expected ')' at column {token.column} (to close the '(' at column {opening.column})")

    def known_names(self) -> str:
        """'coordinates: x, y; parameters: k' (a long list cut short)."""
        groups: dict[str, list[str]] = {}
        for name, kind in self.names.items():
            groups.setdefault(kind, []).append(name)
        if not groups:
            return "no names are defined"
        parts = []
        for kind, members in groups.items():
            listing = ", ".join(members[:20]) + (f", ... ({len(members) - 20} more)" if len(members) > 20 else "")
            parts.append(f"{_plural(kind)}: {listing}")
        return "; ".join(parts)

    # --- grammar -------------------------------------------------------------------
    def parse(self) -> Node:
        tree = self.expression()
        token = self.peek()
        if token.kind != "end":
            hint = " (missing operator?)" if token.kind != "op" or token.value == "(" else ""
            self.fail(f"unexpected {_show(token.text)} at column {token.column}{hint}")
        return tree

    def expression(self) -> Node:
        # Chains are loops, not recursion: a + b + c + ... costs no depth.
        left = self.term()
        while self.at("+-"):
            op = self.advance()
            left = self.node(Binary(op.value, left, self.term(), op.column))
        return left

    def term(self) -> Node:
        left = self.unary()
        while self.at("*/"):
            op = self.advance()
            left = self.node(Binary(op.value, left, self.unary(), op.column))
        return left

    def unary(self) -> Node:
        # Signs are read in a loop, but each is a level of depth, so '-' * 5000 + 'x'
        # stops at the 101st sign instead of building a 5000-deep tree.
        signs = []
        while self.at("+-"):
            sign = self.advance()
            self.enter(sign.column)
            signs.append(sign)
        operand = self.power()
        for sign in reversed(signs):
            operand = self.node(Unary(sign.value, operand, sign.column))
        self.depth -= len(signs)
        return operand

    def power(self) -> Node:
        base = self.atom()
        if not self.at("^"):
            return base
        op = self.advance()
        self.enter(op.column)
        exponent = self.unary()  # unary -> power: right-associative, and a signed exponent
        self.depth -= 1
        return self.node(Binary("^", base, exponent, op.column))

    def atom(self) -> Node:
        token = self.advance()
        if token.kind == "number":
            return self.node(Number(token.value, token.column))
        if token.kind == "name":
            return self.call(token) if self.at("(") else self.name(token)
        if token.kind == "op" and token.value == "(":
            self.enter(token.column)
            inner = self.expression()
            self.close(token)
            self.depth -= 1
            return inner
        self.unexpected(token)

    def name(self, token: _Token) -> Node:
        name, column = token.text, token.column
        if name in self.names:  # the caller's names first: a user's "pi" wins
            self.used.add(name)
            return self.node(Name(name, column))
        if name == "pi":
            return self.node(Number(math.pi, column))
        if name in FUNCTIONS:
            self.fail(f"function '{name}' at column {column} must be called with parentheses: {name}(...)")
        self.fail(f"unknown name {_show(name)} at column {column} ({self.known_names()})")

    def call(self, token: _Token) -> Node:
        name, column = token.text, token.column
        if name not in FUNCTIONS:
            if name in self.names:
                self.fail(f"{self.names[name]} '{name}' at column {column} is not a function "
                          f"(write {name}*(...) for a product)")
            if name == "pi":
                self.fail(f"'pi' at column {column} is a constant, not a function (write pi*(...) for a product)")
            self.fail(f"unknown function {_show(name)} at column {column} (known: {', '.join(FUNCTIONS)})")
        opening = self.advance()
        self.enter(column)
        args = []
        if not self.at(")"):
            args.append(self.expression())
            while self.at(","):
                self.advance()
                args.append(self.expression())
        self.close(opening)
        self.depth -= 1
        arity = FUNCTIONS[name][0]
        if len(args) != arity:
            self.fail(f"{name}() at column {column} takes {arity} argument{'s' if arity != 1 else ''}, "
                      f"got {len(args)}")
        return self.node(Call(name, tuple(args), column))
