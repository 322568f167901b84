"""A restricted expression language, parsed into a small syntax tree and evaluated into CasADi.

Grammar (never ``eval``)::

    expr    := term (('+' | '-') term)*
    term    := unary (('*' | '/') unary)*
    unary   := ('-' | '+') unary | power
    power   := atom ('^' unary)?              # right associative, binds tighter than unary minus
    atom    := NUMBER ['deg'] | NAME | NAME '(' expr (',' expr)* ')' | '(' expr ')'

Names are parameters, the sweep variable, ``pi`` and ``deg`` (pi/180).  ``25 deg`` is 25 degrees.
Functions: ``sin cos tan asin acos atan atan2 sqrt abs exp log min max`` and the geometric
measures ``length(P, Q)``, ``angle(P, Q, R)`` (at Q, between Q->P and Q->R, 0..pi), ``x(P)``,
``y(P)``, whose arguments are point names.  ``min`` and ``max`` with one argument are taken over
the whole stroke (an aggregate); with two or more, element by element.

Evaluation works on scalars and on rows of samples alike (CasADi operations are element-wise),
so the same tree gives a value per sample or, through the aggregates, one value per stroke.
"""
from __future__ import annotations

import difflib
import math
import re
from dataclasses import dataclass

import casadi as ca

from .errors import ExpressionError

_TOKEN = re.compile(
    r"\s*(?:(?P<num>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)|(?P<name>[A-Za-z_][A-Za-z_0-9]*)"
    r"|(?P<op>\*\*|[-+*/^(),]))"
)

CONSTANTS = {"pi": math.pi, "deg": math.pi / 180.0}
UNARY = {
    "sin": ca.sin, "cos": ca.cos, "tan": ca.tan, "asin": ca.asin, "acos": ca.acos,
    "atan": ca.atan, "sqrt": ca.sqrt, "abs": ca.fabs, "exp": ca.exp, "log": ca.log,
}
GEOMETRIC = {"length": 2, "angle": 3, "x": 1, "y": 1}
FUNCTIONS = sorted(set(UNARY) | set(GEOMETRIC) | {"atan2", "min", "max"})


# --- syntax tree ---------------------------------------------------------------------------
@dataclass(frozen=True)
class Num:
    value: float


@dataclass(frozen=True)
class Name:
    name: str


@dataclass(frozen=True)
class Call:
    func: str
    args: tuple


@dataclass(frozen=True)
class BinOp:
    op: str
    left: object
    right: object


@dataclass(frozen=True)
class Neg:
    operand: object


@dataclass(frozen=True)
class Expression:
    """A parsed expression: its source text and its tree."""

    source: str
    tree: object

    def names(self) -> set[str]:
        """Every plain name used (not point arguments of geometric measures)."""
        return _collect(self.tree, points=False)

    def points(self) -> set[str]:
        """Every point named as an argument of a geometric measure."""
        return _collect(self.tree, points=True)

    @property
    def is_aggregate(self) -> bool:
        """True when the expression holds a one-argument ``min``/``max`` over the stroke."""
        return _has_aggregate(self.tree)

    @property
    def is_constant_number(self) -> bool:
        return isinstance(self.tree, Num)


def _collect(node, points):
    if isinstance(node, Name):
        return set() if points else {node.name}
    if isinstance(node, Num):
        return set()
    if isinstance(node, Neg):
        return _collect(node.operand, points)
    if isinstance(node, BinOp):
        return _collect(node.left, points) | _collect(node.right, points)
    if isinstance(node, Call):
        if node.func in GEOMETRIC:
            return {a.name for a in node.args} if points else set()
        out = set()
        for a in node.args:
            out |= _collect(a, points)
        return out
    raise TypeError(node)


def _has_aggregate(node):
    if isinstance(node, Call):
        if node.func in ("min", "max") and len(node.args) == 1:
            return True
        return any(_has_aggregate(a) for a in node.args)
    if isinstance(node, BinOp):
        return _has_aggregate(node.left) or _has_aggregate(node.right)
    if isinstance(node, Neg):
        return _has_aggregate(node.operand)
    return False


# --- parser --------------------------------------------------------------------------------
def parse(text, where: str = "expression") -> Expression:
    """Parse a number or a string into an :class:`Expression`; ``where`` names it in errors."""
    if isinstance(text, bool) or not isinstance(text, (int, float, str)):
        raise ExpressionError(
            f"{where}: expected a number or an expression string, found {text!r} "
            f"({type(text).__name__})"
        )
    if isinstance(text, (int, float)):
        if not math.isfinite(text):
            raise ExpressionError(f"{where}: expected a finite number, found {text!r}")
        return Expression(repr(text), Num(float(text)))
    return Expression(text, _Parser(text, where).parse())


class _Parser:
    def __init__(self, text, where):
        self.text, self.where = text, where
        self.tokens = self._tokenize(text)
        self.i = 0

    def _fail(self, message):
        raise ExpressionError(f"{self.where}: {message} in {self.text!r}")

    def _tokenize(self, text):
        tokens, pos = [], 0
        text = text.rstrip()
        while pos < len(text):
            m = _TOKEN.match(text, pos)
            if not m or m.end() == pos:
                bad = text[pos:].strip()[:1]
                self._fail(f"unexpected character {bad!r} at position {pos}")
            kind = m.lastgroup
            value = m.group(kind)
            tokens.append((kind, "^" if value == "**" else value))
            pos = m.end()
        if not tokens:
            self._fail("empty expression")
        return tokens

    def _peek(self):
        return self.tokens[self.i] if self.i < len(self.tokens) else (None, None)

    def _take(self, value=None):
        kind, tok = self._peek()
        if kind is None:
            self._fail("unexpected end" + (f", expected {value!r}" if value else ""))
        if value is not None and tok != value:
            self._fail(f"expected {value!r}, found {tok!r}")
        self.i += 1
        return kind, tok

    def parse(self):
        node = self.expr()
        if self.i != len(self.tokens):
            self._fail(f"unexpected {self._peek()[1]!r}")
        return node

    def expr(self):
        node = self.term()
        while self._peek()[1] in ("+", "-"):
            _, op = self._take()
            node = BinOp(op, node, self.term())
        return node

    def term(self):
        node = self.unary()
        while self._peek()[1] in ("*", "/"):
            _, op = self._take()
            node = BinOp(op, node, self.unary())
        return node

    def unary(self):
        if self._peek()[1] == "-":
            self._take()
            return Neg(self.unary())
        if self._peek()[1] == "+":
            self._take()
            return self.unary()
        return self.power()

    def power(self):
        node = self.atom()
        if self._peek()[1] == "^":
            self._take()
            node = BinOp("^", node, self.unary())
        return node

    def atom(self):
        kind, tok = self._take()
        if kind == "num":
            node = Num(float(tok))
            if self._peek() == ("name", "deg"):
                self._take()
                node = Num(float(tok) * math.pi / 180.0)
            return node
        if kind == "name":
            if self._peek()[1] == "(":
                return self.call(tok)
            return Name(tok)
        if tok == "(":
            node = self.expr()
            self._take(")")
            return node
        self._fail(f"unexpected {tok!r}")

    def call(self, func):
        if func not in FUNCTIONS:
            hint = difflib.get_close_matches(func, FUNCTIONS, n=1)
            self._fail(
                f"unknown function {func!r}"
                + (f" (did you mean {hint[0]!r}?)" if hint else f"; known: {', '.join(FUNCTIONS)}")
            )
        self._take("(")
        args = [self.expr()]
        while self._peek()[1] == ",":
            self._take()
            args.append(self.expr())
        self._take(")")
        n = len(args)
        if func in GEOMETRIC:
            if n != GEOMETRIC[func]:
                self._fail(f"{func}() takes {GEOMETRIC[func]} point names, found {n} arguments")
            if not all(isinstance(a, Name) for a in args):
                self._fail(f"{func}() takes point names as arguments")
        elif func in UNARY and n != 1:
            self._fail(f"{func}() takes 1 argument, found {n}")
        elif func == "atan2" and n != 2:
            self._fail(f"atan2() takes 2 arguments (y, x), found {n}")
        return Call(func, tuple(args))


# --- evaluation ----------------------------------------------------------------------------
def evaluate(expr: Expression, values: dict, points: dict | None = None, where: str = ""):
    """Evaluate ``expr`` with ``values`` (name -> number or CasADi scalar/row) and ``points``
    (name -> 2 x N CasADi matrix).  Unknown names raise :class:`ExpressionError`."""
    return _Evaluator(values, points or {}, where or expr.source, expr.source).run(expr.tree)


class _Evaluator:
    def __init__(self, values, points, where, source):
        self.values, self.points, self.where, self.source = values, points, where, source

    def _unknown(self, name, kind, known):
        hint = difflib.get_close_matches(name, list(known), n=1)
        tail = f"; did you mean {hint[0]!r}?" if hint else (
            f"; known {kind}s: {', '.join(sorted(known))}" if known else f"; no {kind}s exist yet"
        )
        raise ExpressionError(f"{self.where}: unknown {kind} {name!r} in {self.source!r}{tail}")

    def point(self, name):
        if name not in self.points:
            self._unknown(name, "point", self.points)
        return self.points[name]

    def run(self, node):
        if isinstance(node, Num):
            return node.value
        if isinstance(node, Name):
            if node.name in self.values:
                return self.values[node.name]
            if node.name in CONSTANTS:
                return CONSTANTS[node.name]
            self._unknown(node.name, "name", set(self.values) | set(CONSTANTS))
        if isinstance(node, Neg):
            return -self.run(node.operand)
        if isinstance(node, BinOp):
            a, b = self.run(node.left), self.run(node.right)
            if node.op == "+":
                return a + b
            if node.op == "-":
                return a - b
            if node.op == "*":
                return a * b
            if node.op == "/":
                return a / b
            return a**b
        return self.call(node)

    def call(self, node):
        f, args = node.func, node.args
        if f == "length":
            p, q = (self.point(a.name) for a in args)
            d = p - q
            return ca.sqrt(d[0, :] ** 2 + d[1, :] ** 2)
        if f == "angle":
            p, q, r = (self.point(a.name) for a in args)
            u, v = p - q, r - q
            cross = u[0, :] * v[1, :] - u[1, :] * v[0, :]
            dot = u[0, :] * v[0, :] + u[1, :] * v[1, :]
            return ca.atan2(ca.fabs(cross), dot)
        if f in ("x", "y"):
            return self.point(args[0].name)[0 if f == "x" else 1, :]
        vals = [self.run(a) for a in args]
        if f in UNARY:
            return UNARY[f](vals[0])
        if f == "atan2":
            return ca.atan2(vals[0], vals[1])
        if len(vals) == 1:  # aggregate over the stroke
            return ca.mmax(vals[0]) if f == "max" else ca.mmin(vals[0])
        fold = ca.fmax if f == "max" else ca.fmin
        out = vals[0]
        for v in vals[1:]:
            out = fold(out, v)
        return out


def constant_value(expr: Expression, values: dict, where: str) -> float:
    """Evaluate an expression that must be a plain number (no sweep, no points)."""
    out = evaluate(expr, values, {}, where)
    try:
        return float(out)
    except (TypeError, RuntimeError, NotImplementedError):
        raise ExpressionError(
            f"{where}: {expr.source!r} must evaluate to a number here (it may use earlier "
            "parameters, pi and deg, but not the sweep or points)"
        ) from None
