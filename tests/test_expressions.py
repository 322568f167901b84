"""The restricted expression language: precedence, units, functions, aggregates, no eval.

Reference values are Python's own arithmetic and ``math`` functions, numpy on explicit point
coordinates, or values written out by hand.  Tolerances: 1e-15 relative where the same IEEE
operations are done in the same order (the parser must build exactly that tree); 1e-14 where
CasADi's C math and Python's ``math`` compute the same function (both libm, round-off only).
"""
import builtins
import math

import casadi as ca
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from optdesign.errors import ExpressionError
from optdesign.scene.expressions import constant_value, evaluate, parse


def value(text, **names):
    return float(evaluate(parse(text), names))


# --- precedence and associativity ------------------------------------------------------------
@pytest.mark.parametrize("text, expected", [
    ("-2^2", -4.0),            # ^ binds tighter than unary minus
    ("2^3^2", 512.0),          # ^ is right associative: 2^(3^2)
    ("(2^3)^2", 64.0),
    ("1 - 2 - 3", -4.0),       # - is left associative
    ("2*3/4", 1.5),            # (2*3)/4
    ("8/4/2", 1.0),            # (8/4)/2, not 8/(4/2) = 4
    ("2 + 3*4", 14.0),
    ("(2 + 3)*4", 20.0),
    ("2^-1", 0.5),             # a unary minus in the exponent
    ("-3^2 + 10", 1.0),
    ("2**3", 8.0),             # ** is read as ^
    ("--2", 2.0),
    ("+2 - -2", 4.0),
    ("2*-3", -6.0),
    ("1e-3 * 1E3", 1.0),
    (".5 + 1.", 1.5),
])
def test_precedence(text, expected):
    assert value(text) == expected


def test_degrees_literal_and_constant():
    assert value("25 deg") == pytest.approx(25 * math.pi / 180, rel=1e-15)
    assert value("25deg") == pytest.approx(25 * math.pi / 180, rel=1e-15)
    assert value("-60 deg") == pytest.approx(-math.pi / 3, rel=1e-15)
    assert value("deg") == pytest.approx(math.pi / 180, rel=1e-15)
    assert value("90*deg") == pytest.approx(math.pi / 2, rel=1e-15)
    assert value("pi") == math.pi
    assert value("2*pi - 90 deg") == pytest.approx(1.5 * math.pi, rel=1e-15)
    # a name followed by 'deg' is not a literal angle: an error that says how to write it
    with pytest.raises(ExpressionError, match=r"'deg' after something other than a number.*name\*deg"):
        parse("alpha deg", "[points] A, polar angle")


@pytest.mark.parametrize("name, reference, args", [
    ("sin", math.sin, (0.7,)), ("cos", math.cos, (0.7,)), ("tan", math.tan, (0.7,)),
    ("asin", math.asin, (0.3,)), ("acos", math.acos, (0.3,)), ("atan", math.atan, (2.5,)),
    ("sqrt", math.sqrt, (2.0,)), ("abs", abs, (-3.25,)), ("exp", math.exp, (1.3,)),
    ("log", math.log, (3.0,)), ("atan2", math.atan2, (-1.0, -2.0)), ("atan2", math.atan2, (1.0, -2.0)),
    ("min", min, (3.0, -1.0, 2.0)), ("max", max, (3.0, -1.0, 2.0)), ("max", max, (1.0, 2.0)),
])
def test_functions_against_math(name, reference, args):
    text = f"{name}({', '.join(repr(a) for a in args)})"
    assert value(text) == pytest.approx(reference(*args), rel=1e-14, abs=1e-300)


def test_names_are_looked_up_and_constants_are_not_names():
    e = parse("r*cos(alpha + pi/2) + 25 deg")
    assert e.names() == {"r", "alpha"}
    assert value("r*cos(alpha)", r=2.0, alpha=0.5) == pytest.approx(2 * math.cos(0.5), rel=1e-15)
    g = parse("angle(D, B, A) + length(D, B) + x(C) - y(C)")
    assert g.names() == set()
    assert g.points() == {"A", "B", "C", "D"}


# --- geometric measures and aggregates over rows of samples -----------------------------------
def _points(n=7, seed=3):
    rng = np.random.default_rng(seed)
    return {k: rng.normal(size=(2, n)) for k in "PQR"}


def test_geometric_measures_against_numpy():
    raw = _points()
    pts = {k: ca.DM(v) for k, v in raw.items()}
    P, Q, R = raw["P"], raw["Q"], raw["R"]
    length = np.asarray(evaluate(parse("length(P, Q)"), {}, pts)).ravel()
    assert np.allclose(length, np.hypot(*(P - Q)), rtol=1e-15, atol=0)
    angle = np.asarray(evaluate(parse("angle(P, Q, R)"), {}, pts)).ravel()
    u, v = P - Q, R - Q
    cosine = (u * v).sum(0) / np.hypot(*u) / np.hypot(*v)
    assert np.allclose(angle, np.arccos(np.clip(cosine, -1, 1)), rtol=0, atol=1e-12)  # arccos loses digits
    assert np.all((angle >= 0) & (angle <= math.pi))
    assert np.array_equal(np.asarray(evaluate(parse("x(P)"), {}, pts)).ravel(), P[0])
    assert np.array_equal(np.asarray(evaluate(parse("y(P)"), {}, pts)).ravel(), P[1])


def test_one_argument_min_max_aggregate_over_the_row():
    raw = _points()
    pts = {k: ca.DM(v) for k, v in raw.items()}
    lengths = np.hypot(*(raw["P"] - raw["Q"]))
    ratio = parse("max(length(P, Q)) / min(length(P, Q))")
    assert ratio.is_aggregate
    assert float(evaluate(ratio, {}, pts)) == pytest.approx(lengths.max() / lengths.min(), rel=1e-15)
    assert float(evaluate(parse("max(x(P))"), {}, pts)) == raw["P"][0].max()
    assert float(evaluate(parse("min(y(Q))"), {}, pts)) == raw["Q"][1].min()
    # two or more arguments: element by element, not an aggregate
    both = parse("max(x(P), x(Q))")
    assert not both.is_aggregate
    assert np.array_equal(np.asarray(evaluate(both, {}, pts)).ravel(), np.maximum(raw["P"][0], raw["Q"][0]))
    # the sweep variable as a row works the same way
    s = ca.DM(np.linspace(0.0, 1.0, 5)[None, :])
    assert float(evaluate(parse("max(s^2) - min(s)"), {"s": s})) == 1.0


def test_outside_aggregates_finds_what_varies():
    e = parse("max(length(D, B)) / min(length(D, B)) + k*s + x(C)")
    names, points = e.outside_aggregates()
    assert names == {"k", "s"} and points == {"C"}
    assert parse("max(x(A))/2 + pi").outside_aggregates() == (set(), set())


# --- never eval ----------------------------------------------------------------------------
@pytest.mark.parametrize("text", [
    "__import__('os')", "__import__(os)", "os.system", "open('x')", "lambda: 1", "[1, 2]",
    "x if y else z", "a; b", "a = 1", "'abc'", "exec(1)", "eval(1)", "globals()",
])
def test_no_python_is_evaluated(text, monkeypatch):
    def forbidden(*args, **kwargs):
        raise AssertionError("eval/exec/__import__ must never be called by the expression parser")

    monkeypatch.setattr(builtins, "eval", forbidden)
    monkeypatch.setattr(builtins, "exec", forbidden)
    with pytest.raises(ExpressionError) as info:
        evaluate(parse(text, "[parameters] k"), {"x": 1.0, "y": 1.0, "z": 1.0, "a": 1.0, "b": 1.0})
    assert "[parameters] k" in str(info.value)


# --- malformed expressions: ExpressionError with a clear message, never a CasADi error --------
@pytest.mark.parametrize("text, words", [
    ("sin(1, 2)", ["sin() takes 1 argument, found 2"]),
    ("atan2(1)", ["atan2() takes 2 arguments (y, x), found 1"]),
    ("2 +", ["ends too early after '+'", "expected a number, a name or '('"]),
    ("(1 + 2", ["ends too early", "expected ')'"]),
    ("1 + 2)", ["unexpected ')'"]),
    ("2 3", ["unexpected '3' after a complete expression", "missing operator"]),
    ("length(A)", ["length() takes 2 point names, found 1 argument"]),
    ("angle(A, B, C, D)", ["angle() takes 2 or 3 point names, found 4 arguments"]),
    ("pin_force(A, B, C)", ["pin_force() takes 1 or 2 point names, found 3 arguments"]),
    ("pin_force_x(A, 2)", ["pin_force_x() takes point names as arguments, found 2"]),
    ("slider_normal(A, B)", ["slider_normal() takes 1 point name, found 2 arguments"]),
    ("x(3)", ["x() takes point names as arguments, found 3"]),
    ("y(A + B)", ["y() takes point names as arguments, found an expression"]),
    ("x(pi)", ["x() takes point names as arguments, found pi"]),
    ("sinn(alpha)", ["unknown function 'sinn'", "did you mean 'sin'?"]),
    ("lenght(A, B)", ["unknown function 'lenght'", "did you mean 'length'?"]),
    ("foo(1)", ["unknown function 'foo'", "known functions: abs, acos"]),
    ("min()", ["min() needs an argument"]),
    ("", ["empty expression"]),
    ("   ", ["empty expression"]),
    ("2 $ 3", ["unexpected character '$' at position 2"]),
    ("1e999", ["too large"]),
    ("*2", ["unexpected '*'"]),
])
def test_malformed_expressions(text, words):
    with pytest.raises(ExpressionError) as info:
        parse(text, "[drive] speed")
    message = str(info.value)
    assert message.startswith("[drive] speed: ")
    assert repr(text) in message  # the expression as written
    for w in words:
        assert w in message, message


@pytest.mark.parametrize("value_, kind", [(True, "a boolean"), ([1, 2], "a list"), ({"a": 1}, "a table"),
                                          (None, "NoneType")])
def test_non_numbers_are_rejected(value_, kind):
    with pytest.raises(ExpressionError, match=rf"expected a number or an expression string.*\({kind}\)"):
        parse(value_, "[parameters] k")


@pytest.mark.parametrize("bad", [float("inf"), float("nan")])
def test_non_finite_numbers_are_rejected(bad):
    with pytest.raises(ExpressionError, match="expected a finite number"):
        parse(bad, "[parameters] k")


def test_unknown_names_and_points_at_evaluation_suggest_the_near_miss():
    with pytest.raises(ExpressionError, match=r"'alpah \+ 1': unknown name 'alpah'; did you mean 'alpha'\?"):
        evaluate(parse("alpah + 1"), {"alpha": 1.0}, {}, "[points] A, polar angle")
    with pytest.raises(ExpressionError, match=r"unknown point 'BB'; did you mean 'B'\?"):
        evaluate(parse("length(A, BB)"), {}, {"A": ca.DM([0, 0]), "B": ca.DM([1, 0])}, "here")


def test_constant_value_must_be_a_finite_number():
    assert constant_value(parse("2*a"), {"a": 1.5}, "k") == 3.0
    for text in ("sqrt(-1)", "1/0", "log(0)"):
        with pytest.raises(ExpressionError, match=r"evaluates to (nan|inf|-inf).*expected a finite number"):
            constant_value(parse(text), {}, "[parameters] k")
    with pytest.raises(ExpressionError, match="must evaluate to a number here"):
        constant_value(parse("s"), {"s": ca.SX.sym("s")}, "[parameters] k")


# --- property: the parser's grouping is the usual mathematical one -----------------------------
PREC = {"+": 1, "-": 1, "*": 2, "/": 2, "neg": 3, "^": 4}


def _leaf():
    return st.integers(1, 4).map(lambda n: ("num", float(n)))


def _exponent():
    # an integer exponent (or a tower of two) keeps every power real and finite
    return st.one_of(st.integers(0, 3).map(lambda n: ("num", float(n))),
                     st.tuples(st.just("^"), st.integers(1, 3).map(lambda n: ("num", float(n))),
                               st.integers(0, 2).map(lambda n: ("num", float(n)))))


trees = st.recursive(
    _leaf(),
    lambda kids: st.one_of(
        st.tuples(st.sampled_from("+-*/"), kids, kids),
        st.tuples(st.just("neg"), kids),
        st.tuples(st.just("^"), kids, _exponent()),
    ),
    max_leaves=8,
)


def _prec(t):
    return 5 if t[0] == "num" else PREC[t[0]]


def _render(t):
    """Fewest parentheses under the usual rules (independent of the parser under test)."""
    if t[0] == "num":
        return str(int(t[1]))
    if t[0] == "neg":
        inner = _render(t[1])
        return f"-({inner})" if _prec(t[1]) < PREC["^"] else f"-{inner}"
    op, a, b = t
    left, right = _render(a), _render(b)
    if op == "^":
        left = f"({left})" if _prec(a) <= PREC["^"] else left       # (-2)^2, (2^3)^2
        right = f"({right})" if _prec(b) < PREC["^"] else right     # 2^3^2 is 2^(3^2)
    else:
        left = f"({left})" if _prec(a) < PREC[op] else left
        right = f"({right})" if _prec(b) <= PREC[op] and b[0] != "neg" or _prec(b) < PREC[op] else right
    return f"{left} {op} {right}"


def _reference(t):
    if t[0] == "num":
        return t[1]
    if t[0] == "neg":
        return -_reference(t[1])
    op, a, b = t
    x, y = _reference(a), _reference(b)
    return {"+": lambda: x + y, "-": lambda: x - y, "*": lambda: x * y, "/": lambda: x / y,
            "^": lambda: x ** y}[op]()


@settings(max_examples=50, deadline=None)
@given(trees)
def test_parser_groups_like_mathematics(tree):
    try:
        expected = _reference(tree)
    except (ZeroDivisionError, OverflowError):
        assume(False)
    assume(math.isfinite(expected))
    text = _render(tree)
    got = float(evaluate(parse(text), {}))
    assert got == pytest.approx(expected, rel=1e-15, abs=0), text
