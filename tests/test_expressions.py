"""raydamp.expressions: our own parser for user expressions, its limits, its constant
folding, and the SymEngine expressions built from its trees (never from text)."""

from __future__ import annotations

import builtins
import math
import pickle

import pytest
import symengine as se

from raydamp.systems.expressions import (
    FUNCTIONS,
    MAX_DEPTH,
    MAX_EXPONENT,
    MAX_LENGTH,
    MAX_NODES,
    Binary,
    Expression,
    Name,
    Number,
    Unary,
    parse,
)

ELASTIC = {"x": "coordinate", "y": "coordinate", "z": "coordinate",
           "k": "parameter", "l": "parameter", "m": "parameter", "g": "parameter"}
ELASTIC_V = "k/2*(sqrt(x^2+y^2+z^2) - l)^2 - m*g*z"


def potential_error(text, names=ELASTIC) -> str:
    with pytest.raises(ValueError) as info:
        parse(text, field="potential", names=names)
    message = str(info.value)
    assert message.startswith("potential: ")
    message.encode("utf-8")  # every message must be encodable, whatever the input was
    return message


def value(text: str, **point: float) -> float:
    """The expression at a point, computed twice: symbolically (Symbols, then subs) and
    by substituting the numbers in to_symengine (constant folding); both must agree."""
    expr = parse(text, names={name: "coordinate" for name in point})
    symbols = {name: se.Symbol(name) for name in point}
    symbolic = float(expr.to_symengine(symbols).subs({symbols[n]: v for n, v in point.items()}))
    numeric = float(expr.to_symengine(point))
    assert math.isclose(symbolic, numeric, rel_tol=1e-15, abs_tol=1e-300)
    return numeric


# --- grammar: precedence, associativity, numbers, functions -------------------------

@pytest.mark.parametrize("text,point,expected", [
    ("-x^2", dict(x=3), -9.0),                  # power binds tighter than unary minus
    ("(-x)^2", dict(x=3), 9.0),
    ("2^3^2", {}, 512.0),                       # right-associative
    ("(2^3)^2", {}, 64.0),
    ("2**3**2", {}, 512.0),
    ("x**2", dict(x=3), 9.0),
    ("a-b-c", dict(a=10, b=3, c=2), 5.0),       # left-associative
    ("a/b/c", dict(a=12, b=3, c=2), 2.0),
    ("a-b+c", dict(a=10, b=3, c=2), 9.0),
    ("a/b*c", dict(a=12, b=3, c=2), 8.0),
    ("a+b*c", dict(a=10, b=3, c=2), 16.0),
    ("a*b^c", dict(a=10, b=3, c=2), 90.0),
    ("-a*b", dict(a=10, b=3), -30.0),
    ("+x", dict(x=3), 3.0),
    ("-+-x", dict(x=3), 3.0),
    ("--x", dict(x=3), 3.0),
    ("a*-b", dict(a=10, b=3), -30.0),
    ("2^-1", {}, 0.5),                          # a signed exponent
    ("x^-2", dict(x=4), 1 / 16),
    ("2^-x^2", dict(x=2), 1 / 16),              # 2^(-(x^2))
    ("x^-12", dict(x=2), 2.0 ** -12),
    ("atan2(y, x)", dict(y=1, x=-1), 3 * math.pi / 4),
    ("atan2(x, y)", dict(y=1, x=-1), -math.pi / 4),
    ("pi", {}, math.pi),
    ("2*pi*x", dict(x=0.5), math.pi),
    ("  x\t*\n2 \r\n", dict(x=3), 6.0),         # whitespace anywhere
    ("2.5 + .5 + 1e-3 + 1.5E+4 + 2.", {}, 2.5 + 0.5 + 1e-3 + 1.5e4 + 2.0),
    ("((((x))))", dict(x=7), 7.0),
    ("sqrt(x^2 + y^2)", dict(x=3, y=4), 5.0),
    ("exp(log(x))", dict(x=2.5), 2.5),
])
def test_values(text, point, expected):
    assert math.isclose(value(text, **point), expected, rel_tol=1e-15)


def test_power_spellings_give_the_same_expression():
    x = se.Symbol("x")
    names = {"x": "coordinate"}
    assert parse("x**2", names=names).to_symengine({"x": x}) == parse("x^2", names=names).to_symengine({"x": x}) \
        == x ** 2
    for text in ("x**2", "x^2"):
        tree = parse(text, names=names).tree
        assert (tree.op, tree.left, tree.right.value) == ("^", Name("x", 1), 2.0)


@pytest.mark.parametrize("name", sorted(FUNCTIONS))
def test_every_function_matches_math(name):
    arity, description = FUNCTIONS[name]
    assert arity in (1, 2) and description
    x = 0.37 if name != "acosh" else 1.37
    expected = {"cbrt": x ** (1 / 3), "atan2": math.atan2(x, 0.5)}.get(name) or getattr(math, name)(x)
    call = "{}({}, 0.5)" if arity == 2 else "{}({})"
    assert math.isclose(value(call.format(name, "x"), x=x), expected, rel_tol=1e-14)
    # A constant argument is folded at parse time to the same value.
    folded = parse(call.format(name, x)).tree
    assert isinstance(folded, Number) and math.isclose(folded.value, expected, rel_tol=1e-15)


def test_expression_attributes():
    expr = parse(ELASTIC_V, field="potential", names=ELASTIC)
    assert expr.text == ELASTIC_V and str(expr) == ELASTIC_V
    assert expr.names == frozenset("xyzklmg")
    assert isinstance(expr.names, frozenset)
    assert repr(expr) == f"Expression({ELASTIC_V!r}, field='potential')"
    assert parse("2*pi*sin(q10) + p_x", names={"q10": "coordinate", "p_x": "momentum"}).names == {"q10", "p_x"}
    # The caller's own 'pi' wins over the constant.
    own = parse("pi*x", names={"pi": "parameter", "x": "coordinate"})
    assert own.names == {"pi", "x"}
    assert float(own.to_symengine({"pi": 2, "x": 5})) == 10.0
    with pytest.raises(AttributeError):
        expr.text = "x"


def test_tree_shape_and_constant_folding():
    names = {"x": "coordinate"}
    assert parse("-x^2", names=names).tree == Unary("-", Binary("^", Name("x", 2), Number(2.0, 4), 3), 1)
    # Subtrees without names become one Number, at the column where they start.
    assert parse("2*3 + x", names=names).tree == Binary("+", Number(6.0, 1), Name("x", 7), 5)
    assert parse("(1 + 2)^2^-1", names=names).tree == Number(math.sqrt(3.0), 2)
    assert parse("-2^2").tree == Number(-4.0, 1)


def test_numbers_become_exact_integers_or_doubles():
    x = se.Symbol("x")
    names = {"x": "coordinate", "k": "parameter"}

    def build(text, **values):
        return parse(text, names=names).to_symengine({"x": x, **values})

    square = build("x^2")
    assert square.is_Pow and square.args == (x, se.Integer(2))  # an exact integer power
    assert build("x^-12") == x ** se.Integer(-12)
    assert build("x/2") == x * se.Rational(1, 2)
    assert build("x*2^53").args[0] == se.Integer(2 ** 53)
    assert isinstance(build("x*2^54").args[0], se.RealDouble)   # beyond 2^53: a double
    assert isinstance(build("x*0.5").args[0], se.RealDouble)
    assert build("x^k", k=se.Integer(3)) == x ** 3
    assert build("k/2*x^2", k=3) == se.RealDouble(1.5) * x ** 2  # k/2 folded with k's value


def test_elastic_pendulum_gradient_matches_hand_written():
    expr = parse(ELASTIC_V, field="potential", names=ELASTIC)
    q = [se.Symbol(f"_q{i}") for i in range(3)]
    params = dict(k=40.0, l=1.0, m=0.7, g=9.81)
    V = expr.to_symengine({"x": q[0], "y": q[1], "z": q[2], "k": se.Integer(40), "l": se.Integer(1),
                           "m": se.RealDouble(0.7), "g": se.RealDouble(9.81)})
    gradient = se.Lambdify(q, [se.diff(V, qi) for qi in q], backend="llvm", real=True)
    potential = se.Lambdify(q, [V], backend="llvm", real=True)
    for point in ([0.3, -0.4, 1.2], [1.1, 0.2, -0.9], [-0.05, 0.7, 0.01]):
        r = math.sqrt(sum(c * c for c in point))
        stretch = params["k"] * (r - params["l"])
        hand = [stretch * c / r for c in point]
        hand[2] -= params["m"] * params["g"]
        for got, want in zip(gradient(point), hand):
            assert math.isclose(got, want, rel_tol=1e-14, abs_tol=1e-14)
        v_hand = params["k"] / 2 * (r - params["l"]) ** 2 - params["m"] * params["g"] * point[2]
        assert math.isclose(float(potential(point)[0]), v_hand, rel_tol=1e-14, abs_tol=1e-14)


# --- errors: field, column, message -------------------------------------------------

KNOWN = "(coordinates: x, y, z; parameters: k, l, m, g)"
FUNCTION_LIST = ", ".join(FUNCTIONS)


@pytest.mark.parametrize("text,message", [
    ("k2*x", f"unknown name 'k2' at column 1 {KNOWN}"),
    ("x + foo(y)", f"unknown function 'foo' at column 5 (known: {FUNCTION_LIST})"),
    ("k(x + 1)", "parameter 'k' at column 1 is not a function (write k*(...) for a product)"),
    ("pi(x)", "'pi' at column 1 is a constant, not a function (write pi*(...) for a product)"),
    ("sin + x", "function 'sin' at column 1 must be called with parentheses: sin(...)"),
    ("2*sin x", "function 'sin' at column 3 must be called with parentheses: sin(...)"),
    ("atan2(x)", "atan2() at column 1 takes 2 arguments, got 1"),
    ("1 + sin(x, y)", "sin() at column 5 takes 1 argument, got 2"),
    ("exp()", "exp() at column 1 takes 1 argument, got 0"),
    ("sin(x + (y)", "expected ')' at column 12 (to close the '(' at column 4)"),
    ("(x + y z", "expected ')' at column 8 (to close the '(' at column 1)"),
    ("x +* 2", "unexpected '*' at column 4"),
    ("x+*2", "unexpected '*' at column 3"),
    ("*x", "unexpected '*' at column 1"),
    ("x + ", "unexpected end of expression at column 5"),
    ("x y", "unexpected 'y' at column 3 (missing operator?)"),
    ("x)", "unexpected ')' at column 2"),
    ("x, y", "unexpected ',' at column 2"),
    ("()", "unexpected ')' at column 2"),
    ("x^^2", "unexpected '^' at column 3"),
    ("x***2", "unexpected '*' at column 4"),
    ("", "empty expression"),
    (" \t\n ", "empty expression"),
    ("sin(x) + 'y'", "unexpected character \"'\" at column 10"),
    ("x == y", "unexpected character '=' at column 3"),
    ("[x]", "unexpected character '[' at column 1"),
    ("2x", "malformed number '2x' at column 1"),
    ("1e+", "malformed number '1e' at column 1"),
    ("1.2.3", "malformed number '1.2.3' at column 1"),
    ("x + 1e999", "number '1e999' at column 5 is too large"),
    ("__x", "name '__x' at column 1 starts with '__', which is not allowed"),
    ("1/0", "the constant subexpression at column 1 divides by zero"),
    ("x + (2 - 2)^-1", "the constant subexpression at column 6 divides by zero"),
    ("x/(1 - 1)", "division by zero at column 2"),
    ("exp(1000)", "the constant subexpression at column 1 overflows"),
    ("exp(700)*exp(700)*x", "the constant subexpression at column 1 overflows"),   # exp(700)^2 is inf
    ("10^400 + x", "the constant subexpression at column 1 overflows"),
    ("x*sqrt(-4)", "the constant subexpression at column 3 is not a real number (sqrt of a negative number)"),
    ("log(0)*x", "the constant subexpression at column 1 is not a real number (log of zero or a negative number)"),
    ("asin(2)", "the constant subexpression at column 1 is not a real number (asin of a number outside [-1, 1])"),
    ("x + (-8)^(1/3)",
     "the constant subexpression at column 6 is not a real number (a negative number to a non-integer power)"),
    ("x^1001", f"exponent 1001 at column 3 is too large: |exponent| <= {MAX_EXPONENT} is the limit"),
    ("x^-1001", "exponent -1001 at column 3 is too large: |exponent| <= 1000 is the limit"),
    ("x^(10*101)", "exponent 1010 at column 4 is too large: |exponent| <= 1000 is the limit"),
    ("(x^10)^101", "the power at column 7 raises to the power 1010 in all (nested exponents multiply), "
                   "above the limit 1000"),
    ("((2*x)^1000)^1000", "the power at column 13 raises to the power 1000000 in all (nested exponents multiply), "
                          "above the limit 1000"),
])
def test_error_messages(text, message):
    assert potential_error(text) == "potential: " + message


def test_unknown_name_lists_names_by_kind_and_pluralises():
    names = {"q0": "coordinate", "p_q0": "momentum", "p_q1": "momentum", "c": "parameter"}
    assert potential_error("q1", names) == ("potential: unknown name 'q1' at column 1 "
                                            "(coordinates: q0; momenta: p_q0, p_q1; parameters: c)")
    assert potential_error("x", {}) == "potential: unknown name 'x' at column 1 (no names are defined)"
    many = {f"q{i}": "coordinate" for i in range(30)}
    assert potential_error("w", many).endswith("q18, q19, ... (10 more))")


def test_offending_text_is_truncated():
    message = potential_error("a" * 500 + " + x")
    assert message == f"potential: unknown name '{'a' * 37}...' at column 1 {KNOWN}"
    assert len(potential_error("2" + "x" * 5000)) < 200


@pytest.mark.parametrize("bad,shown", [("\x00", r"'\x00'"), ("\ud800", r"'\ud800'"), ("\u00e9", r"'\xe9'"),
                                       ("\u2212", r"'\u2212'"), ("\x7f", r"'\x7f'"), ("\x0b", r"'\x0b'")])
def test_non_ascii_and_control_characters_are_named_safely(bad, shown):
    message = potential_error("x + " + bad + " y")
    assert message == f"potential: unexpected character {shown} at column 5 (only printable ASCII is allowed)"
    assert message.encode("utf-8").isascii()


@pytest.mark.parametrize("text", [3.0, None, b"x", ["x"], 42])
def test_non_string_input(text):
    assert potential_error(text) == f"potential: must be a string (an expression), got {type(text).__name__}"


def test_default_field_name():
    with pytest.raises(ValueError, match=r"^expression: empty expression$"):
        parse("")
    with pytest.raises(ValueError, match=r"^damping\.dampers\[1\]\.on: unexpected '\)' at column 1$"):
        parse(")", field="damping.dampers[1].on")


# --- hostile input and limits -------------------------------------------------------

def _quick(text) -> str:
    # Bounded work is shown by where each message says the parser stopped (the column of
    # the first character over a limit), not by timing: tests never assert on wall time.
    return potential_error(text)


def test_code_injection_is_just_a_syntax_error():
    assert _quick("__import__('os').system('x')") == \
        "potential: name '__import__' at column 1 starts with '__', which is not allowed"
    assert _quick("x.real") == "potential: unexpected character '.' at column 2"
    assert _quick("().__class__") == "potential: unexpected character '.' at column 3"
    assert _quick("lambda") == f"potential: unknown name 'lambda' at column 1 {KNOWN}"
    assert _quick("lambda: x") == "potential: unexpected character ':' at column 7"
    assert _quick("x if y else z") == "potential: unexpected 'if' at column 3 (missing operator?)"


def test_huge_powers_are_refused_before_anything_computes_them():
    message = "exponent 1099511627776 at column {} is too large: |exponent| <= 1000 is the limit"
    assert _quick("2^2^40") == "potential: " + message.format(3)
    assert _quick("2**2**40") == "potential: " + message.format(4)
    assert _quick("x^2^40") == "potential: " + message.format(3)
    assert _quick("9^9^9^9") == "potential: " + message.replace("1099511627776", "387420489").format(5)
    assert _quick("10^400") == "potential: the constant subexpression at column 1 overflows"


def test_length_limit_is_checked_first():
    assert MAX_LENGTH == 10_000
    message = _quick("x" * 10**6)
    assert message == "potential: expression too long at column 10001: 1000000 characters, over the limit of 10000"
    assert _quick("(" * 10_000 + "x" + ")" * 10_000).startswith("potential: expression too long")
    assert _quick("+".join(["x"] * 6000)).startswith("potential: expression too long")
    assert parse("x" + " " * (MAX_LENGTH - 1), names={"x": "coordinate"}).names == {"x"}


def test_depth_limit():
    assert MAX_DEPTH == 100
    x = {"x": "coordinate"}
    assert parse("(" * MAX_DEPTH + "x" + ")" * MAX_DEPTH, names=x).tree == Name("x", MAX_DEPTH + 1)
    deep = "potential: expression nested too deeply at column 101: over the limit of 100 levels " \
           "(parentheses, calls, signs and powers)"
    assert _quick("(" * 101 + "x" + ")" * 101) == deep
    assert _quick("(" * 4999 + "x" + ")" * 4999) == deep   # within MAX_LENGTH: the depth refuses it
    assert _quick("-" * 5000 + "x") == deep
    assert _quick("sin(" * 101 + "x" + ")" * 101).startswith("potential: expression nested too deeply at column 401")
    assert _quick("x" + "^x" * 101).startswith("potential: expression nested too deeply at column 202")
    assert _quick("sin(" * 5000 + ")").startswith("potential: expression too long")


def test_node_limit_and_long_chains():
    assert MAX_NODES == 5000
    x = {"x": "coordinate", "y": "coordinate"}
    assert _quick("+".join(["x"] * 3000)) == ("potential: expression too large at column 5000: over the limit of "
                                               "5000 nodes (numbers, names, operators and calls)")
    # The longest chain that fits: a left-deep tree 2499 levels deep, far past
    # Python's recursion limit, must still fold, build and pickle without recursion.
    chain = "-".join(["x", "y"] * 1250)
    expr = parse(chain, names=x)
    X, Y = se.symbols("x y")
    assert expr.to_symengine({"x": X, "y": Y}) == -1248 * X - 1250 * Y
    assert float(expr.to_symengine({"x": 1.0, "y": 0.5})) == -1248 * 1.0 - 1250 * 0.5
    assert pickle.loads(pickle.dumps(expr)) == expr
    # A long constant chain folds to one number.
    assert parse("+".join(["1"] * 2500)).tree == Number(2500.0, 1)


def test_exponent_limit():
    x = {"x": "coordinate"}
    X = se.Symbol("x")
    assert parse(f"x^{MAX_EXPONENT}", names=x).to_symengine({"x": X}) == X ** 1000
    assert parse("x^-12", names=x).to_symengine({"x": X}) == X ** -12
    assert parse("x^-1000", names=x).tree.right == Number(-1000.0, 3)
    assert parse("(x^10)^100", names=x).to_symengine({"x": X}) == X ** 1000
    assert parse("2^1000*x", names=x).tree.left == Number(2.0 ** 1000, 1)
    assert potential_error("x^1001", x).startswith("potential: exponent 1001 at column 3 is too large")


# --- to_symengine: values, and what SymEngine's simplification can do ---------------

def test_to_symengine_checks_substituted_values():
    names = {"x": "coordinate", "k": "parameter", "n": "parameter"}
    X = se.Symbol("x")

    def error(text, **values):
        with pytest.raises(ValueError) as info:
            parse(text, field="potential", names=names).to_symengine({"x": X, **values})
        return str(info.value)

    assert error("x/k", k=0) == "potential: division by zero at column 2 (with the values given for its names)"
    assert error("x^n", n=10**6) == ("potential: exponent 1000000 at column 3 is too large: |exponent| <= 1000 "
                                     "is the limit (with the values given for its names)")
    assert error("k^n*x", k=2, n=2**40).startswith("potential: exponent 1099511627776 at column 3")
    assert error("(2*x)^n", n=1001).startswith("potential: exponent 1001 at column 7 is too large")
    assert error("exp(k)*x", k=800) == ("potential: the constant subexpression at column 1 overflows "
                                        "(with the values given for its names)")
    assert error("k*x") == "potential: to_symengine needs a value for 'k'"
    # A string is never parsed by SymEngine: it is refused.
    assert error("k*x", k="2**2**40") == ("potential: the value for 'k' must be a SymEngine expression or a "
                                          "real number, got str")
    assert error("k*x", k=True).endswith("got bool")
    assert error("k*x", k=float("nan")) == "potential: the value for 'k' is not a finite real number"
    assert error("k*x", k=se.I) == "potential: the value for 'k' is not a finite real number"


@pytest.mark.parametrize("text,column,what", [
    ("1/(x - x)", 2, "infinite (zoo, as from 1/0 or log(0))"),
    ("x + (x - x)^-1", 12, "infinite (zoo, as from 1/0 or log(0))"),
    ("log(x - x)", 1, "infinite (zoo, as from 1/0 or log(0))"),
    ("sqrt(x - x - 1)", 1, "I"),
    ("acos(x - x + 2)", 1, "acos(2)"),
    ("atan2(x - x, x - x)", 1, "undefined (nan)"),
])
def test_simplification_to_an_undefined_constant_is_refused(text, column, what):
    expr = parse(text, field="potential", names={"x": "coordinate"})
    with pytest.raises(ValueError) as info:
        expr.to_symengine({"x": se.Symbol("x")})
    assert str(info.value) == (f"potential: the subexpression at column {column} has no finite real value "
                               f"once simplified: it is {what}")


def test_coefficients_symengine_multiplies_to_infinity_are_refused():
    expr = parse("x*exp(700)*exp(700)", field="potential", names={"x": "coordinate"})
    with pytest.raises(ValueError) as info:
        expr.to_symengine({"x": se.Symbol("x")})
    assert str(info.value) == ("potential: the subexpression at column 11 has no finite real value once "
                               "simplified: it is inf.0*x")


def test_simplification_to_a_finite_constant_is_fine():
    expr = parse("sin(x - x + 1) + x", names={"x": "coordinate"})
    X = se.Symbol("x")
    assert float(expr.to_symengine({"x": X}).subs({X: 0.25})) == pytest.approx(math.sin(1) + 0.25, rel=1e-15)


def test_no_eval_or_exec(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("eval/exec called")

    monkeypatch.setattr(builtins, "eval", refuse)
    monkeypatch.setattr(builtins, "exec", refuse)
    monkeypatch.setattr(se, "sympify", refuse)
    expr = parse(ELASTIC_V, field="potential", names=ELASTIC)
    V = expr.to_symengine(dict(x=se.Symbol("x"), y=0, z=0, k=2, l=1, m=1, g=9.81))
    assert float(V.subs({se.Symbol("x"): 3.0})) == 4.0   # k/2 (3 - l)^2


def test_equality_hash_pickle_copy():
    import copy
    a = parse(ELASTIC_V, field="potential", names=ELASTIC)
    b = parse(ELASTIC_V, field="potential", names=dict(ELASTIC, extra="parameter"))
    assert a == b and hash(a) == hash(b)
    assert a != parse("x", names=ELASTIC)
    assert copy.copy(a) is a and copy.deepcopy(a) is a
    restored = pickle.loads(pickle.dumps(a))
    assert restored == a and restored.field == "potential" and restored.tree == a.tree
    assert isinstance(restored, Expression)
