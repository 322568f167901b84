"""A restricted expression language, parsed into a small syntax tree and evaluated into CasADi.

Grammar (never ``eval``)::

    expr    := term (('+' | '-') term)*
    term    := unary (('*' | '/') unary)*
    unary   := ('-' | '+') unary | power
    power   := atom ('^' unary)?              # right associative, binds tighter than unary minus
    atom    := NUMBER ['deg'] | NAME | NAME '(' expr (',' expr)* ')' | '(' expr ')'

``**`` is read as ``^``.  So ``-2^2`` is -4, ``2^3^2`` is 512 and ``1 - 2 - 3`` is -4.
Names are parameters, the sweep variable, ``pi`` and ``deg`` (pi/180).  ``25 deg`` is 25 degrees.
Functions: ``sin cos tan asin acos atan atan2 sqrt abs exp log min max`` and the geometric
measures ``length(P, Q)``, ``angle(P, Q, R)`` (at Q, between Q->P and Q->R, 0..pi), ``angle(P, Q)``
(the direction of P->Q from the x axis, -pi..pi), ``x(P)``, ``y(P)``, whose arguments are point names.  ``min`` and ``max`` with one argument are taken over
the whole stroke (an aggregate); with two or more, element by element.  ``start(e)`` and
``end(e)`` are e at the stroke's first and last sample (the sweep's ``from`` and ``to``): one
value per stroke, like an aggregate.

Evaluation works on scalars and on rows of samples alike (CasADi operations are element-wise),
so the same tree gives a value per sample or, through the aggregates, one value per stroke.
Every mistake (syntax, an unknown name or function, a wrong number of arguments) raises
:class:`~optdesign.errors.ExpressionError` before CasADi sees the expression.

Why one module: the grammar's tables, syntax tree, parser and evaluator change together (a new
function is one entry in the tables, one case in the argument check and one in the evaluator).
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..errors import ExpressionError
from .where import located_error, near_miss, show

_TOKEN = re.compile(
    r"\s*(?:(?P<num>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)|(?P<name>[A-Za-z_][A-Za-z_0-9]*)"
    r"|(?P<op>\*\*|[-+*/^(),]))"
)

CONSTANTS = {"pi": math.pi, "deg": math.pi / 180.0}
UNARY = {
    "sin": ca.sin, "cos": ca.cos, "tan": ca.tan, "asin": ca.asin, "acos": ca.acos,
    "atan": ca.atan, "sqrt": ca.sqrt, "abs": ca.fabs, "exp": ca.exp, "log": ca.log,
}
GEOMETRIC = {"length": 2, "angle": 3, "x": 1, "y": 1, "pin_force": 1, "pin_force_x": 1, "pin_force_y": 1,
             "slider_normal": 1, "slider_moment": 1}  # the joint forces: model/quantities.py
AGGREGATES = ("min", "max")
STROKE_ENDS = ("start", "end")  # the value at the sweep's from / to: one value per stroke too
FUNCTIONS = sorted(set(UNARY) | set(GEOMETRIC) | {"atan2"} | set(AGGREGATES) | set(STROKE_ENDS))


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
        """Every plain name used, except the constants ``pi`` and ``deg`` (point arguments of
        geometric measures are not names: see :meth:`points`)."""
        return _collect(self.tree, points=False) - set(CONSTANTS)

    def points(self) -> set[str]:
        """Every point named as an argument of a geometric measure."""
        return _collect(self.tree, points=True)

    @property
    def is_aggregate(self) -> bool:
        """True when the expression holds a one-argument ``min``/``max`` over the stroke, or a
        ``start``/``end`` value (one value per stroke)."""
        return _has_aggregate(self.tree)

    @property
    def is_constant_number(self) -> bool:
        return isinstance(self.tree, Num)

    def aggregate_calls(self) -> list:
        """The one-argument ``min``/``max`` calls over the stroke, in order: (func, inner tree)."""
        out = []

        def walk(node):
            if _is_aggregate_call(node):
                if node.func in AGGREGATES:  # (start/end: a value at a stroke end, no extreme)
                    out.append((node.func, node.args[0]))
            else:
                for child in _children(node):
                    walk(child)

        walk(self.tree)
        return out

    def outside_aggregates(self) -> tuple[set, set]:
        """(names, points) used outside every one-argument ``min``/``max``: for an aggregate
        expression these must not vary along the stroke."""
        return _outside(self.tree)


def _children(node):
    if isinstance(node, Neg):
        return (node.operand,)
    if isinstance(node, BinOp):
        return (node.left, node.right)
    if isinstance(node, Call):
        return () if node.func in GEOMETRIC else node.args
    return ()


def _collect(node, points):
    if isinstance(node, Name):
        return set() if points else {node.name}
    if isinstance(node, Call) and node.func in GEOMETRIC:
        return {a.name for a in node.args} if points else set()
    out = set()
    for child in _children(node):
        out |= _collect(child, points)
    return out


def _is_aggregate_call(node):
    """A value per stroke: a one-argument ``min``/``max``, or ``start``/``end``."""
    return isinstance(node, Call) and (node.func in STROKE_ENDS or (node.func in AGGREGATES and len(node.args) == 1))


def _has_aggregate(node):
    return _is_aggregate_call(node) or any(_has_aggregate(c) for c in _children(node))


def _outside(node):
    if _is_aggregate_call(node):
        return set(), set()
    if isinstance(node, Name):
        return {node.name} - set(CONSTANTS), set()
    if isinstance(node, Call) and node.func in GEOMETRIC:
        return set(), {a.name for a in node.args}
    names, pts = set(), set()
    for child in _children(node):
        n, p = _outside(child)
        names |= n
        pts |= p
    return names, pts


def _describe(node) -> str:
    """A short rendering of a parsed argument, for messages."""
    if isinstance(node, Num):
        return f"{node.value:g}"
    if isinstance(node, Name):
        return node.name
    if isinstance(node, Call):
        return f"{node.func}(...)"
    return "an expression"


# --- parser --------------------------------------------------------------------------------
def parse(text, where: str = "expression") -> Expression:
    """Parse a number or a string into an :class:`Expression`; ``where`` names it in errors."""
    if isinstance(text, Expression):
        return text
    if isinstance(text, bool) or not isinstance(text, (int, float, str)):
        kind = {list: "a list", tuple: "a list", dict: "a table", bool: "a boolean"}.get(
            type(text), type(text).__name__)
        raise located_error(
            ExpressionError, where,
            f"expected a number or an expression string such as \"2*r\" or \"25 deg\", "
            f"found {show(text)} ({kind})")
    if isinstance(text, (int, float)):
        if not math.isfinite(text):
            raise located_error(ExpressionError, where, f"expected a finite number, found {text!r}")
        return Expression(repr(text), Num(float(text)))
    nesting = max(_nesting(text), 0)
    if nesting > MAX_NESTING:
        raise located_error(ExpressionError, where, f"{show(text[:60] + ('...' if len(text) > 60 else ''))}: "
                            f"parentheses nested {nesting} deep; at most {MAX_NESTING}")
    try:
        tree = _Parser(text, where).parse()
    except RecursionError:
        tree = None
    depth = _depth(tree) if tree is not None else None
    if depth is None or depth > MAX_DEPTH:
        raise located_error(ExpressionError, where, f"{show(text[:60] + ('...' if len(text) > 60 else ''))}: "
                            f"nested too deeply ({'' if depth is None else f'{depth} '}operations inside one "
                            f"another; at most {MAX_DEPTH}): split it into named parameters")
    return Expression(text, tree)


MAX_DEPTH = 200      # operations inside one another (a sum of n terms is n deep); every walker recurses
MAX_NESTING = 100    # parentheses inside one another (the parser recurses about 5 frames per level)


def _nesting(text: str) -> int:
    deepest = level = 0
    for ch in text:
        level += (ch == "(") - (ch == ")")
        deepest = max(deepest, level)
    return deepest


def _depth(tree) -> int:
    """The depth of a syntax tree, without recursion (it guards the recursive walkers)."""
    stack, deepest = [(tree, 1)], 0
    while stack:
        node, d = stack.pop()
        deepest = max(deepest, d)
        if isinstance(node, BinOp):
            stack += [(node.left, d + 1), (node.right, d + 1)]
        elif isinstance(node, Neg):
            stack.append((node.operand, d + 1))
        elif isinstance(node, Call):
            stack += [(a, d + 1) for a in node.args]
    return deepest


class _Parser:
    def __init__(self, text, where):
        self.text, self.where = text, where
        self.tokens = self._tokenize(text)
        self.i = 0

    def _fail(self, message):
        raise located_error(ExpressionError, self.where, f"{self.text!r}: {message}")

    def _tokenize(self, text):
        tokens, pos = [], 0
        text = text.rstrip()
        while pos < len(text):
            m = _TOKEN.match(text, pos)
            if not m or m.end() == pos:
                bad = text[pos:].strip()[:1]
                degrees = "; write degrees as deg, e.g. \"25 deg\"" if bad == "\u00b0" else ""
                self._fail(
                    f"unexpected character {bad!r} at position {text.index(bad, pos)}"
                    f" (an expression holds numbers, names, + - * / ^, parentheses and function calls){degrees}")
            kind = m.lastgroup
            value = m.group(kind)
            if kind == "num" and not math.isfinite(float(value)):
                self._fail(f"the number {value} is too large")
            tokens.append((kind, "^" if value == "**" else value))
            pos = m.end()
        if not tokens:
            self._fail("empty expression: expected a number or a formula")
        return tokens

    def _peek(self):
        return self.tokens[self.i] if self.i < len(self.tokens) else (None, None)

    def _take(self, value=None):
        kind, tok = self._peek()
        if kind is None:
            after = f" after {self.tokens[-1][1]!r}" if self.tokens else ""
            self._fail(f"the expression ends too early{after}: expected "
                       + (repr(value) if value else "a number, a name or '('"))
        if value is not None and tok != value:
            self._fail(f"expected {value!r}, found {tok!r}")
        self.i += 1
        return kind, tok

    def parse(self):
        node = self.expr()
        if self.i != len(self.tokens):
            tok = self._peek()[1]
            if tok == "deg":
                self._fail("'deg' after something other than a number: write '25 deg' for a "
                           "literal angle, or 'name*deg'")
            if self._peek()[0] == "name" and self.tokens[self.i - 1][0] == "num":  # "15 t": a unit
                from .unit_hints import hint

                self._fail(hint(self.tokens[self.i - 1][1], " ".join(t for _, t in self.tokens[self.i:])))
            self._fail(f"unexpected {tok!r} after a complete expression (a missing operator?)")
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
        self._fail(f"unexpected {tok!r}: expected a number, a name or '('")

    def call(self, func):
        if func not in FUNCTIONS:
            hint = near_miss(func, FUNCTIONS)
            self._fail(f"unknown function {func!r}" + (hint or f"; known functions: {', '.join(FUNCTIONS)}"))
        self._take("(")
        if self._peek()[1] == ")":
            self._fail(f"{func}() needs an argument")
        args = [self.expr()]
        while self._peek()[1] == ",":
            self._take()
            args.append(self.expr())
        self._take(")")
        self._check_arguments(func, args)
        return Call(func, tuple(args))

    def _check_arguments(self, func, args):
        n = len(args)
        if func in GEOMETRIC:
            pin = func.startswith("pin_force")   # angle(P, Q): a direction; pin_force(P, Q): on the party P->Q
            if n != (2 if n == 2 and (func == "angle" or pin) else GEOMETRIC[func]):
                told = "2 or 3" if func == "angle" else ("1 or 2" if pin else GEOMETRIC[func])
                self._fail(f"{func}() takes {told} point name{'' if told == 1 else 's'}, found {n} argument{'s' * (n != 1)}")
            for a in args:
                if not isinstance(a, Name) or a.name in CONSTANTS:
                    zero = isinstance(a, Num) and re.search(r"(?<![\w.])0\d", self.text)   # '04' for 'O4'
                    self._fail(f"{func}() takes point names as arguments, found {_describe(a)}"
                               + (" (a point name starts with a letter: the digit 0 written for the letter O?)"
                                  if zero else ""))
        elif func in UNARY and n != 1:
            self._fail(f"{func}() takes 1 argument, found {n}")
        elif func == "atan2" and n != 2:
            self._fail(f"atan2() takes 2 arguments (y, x), found {n}")
        elif func in STROKE_ENDS and n != 1:
            self._fail(f"{func}() takes 1 argument (its value at the stroke's {'first' if func == 'start' else 'last'} "
                       f"sample), found {n}")
        if func in STROKE_ENDS or (func in AGGREGATES and n == 1):
            if _has_aggregate(args[0]):
                self._fail(f"{func}(...) over the stroke holds another value per stroke (min/max with one "
                           "argument, start, end); they do not nest: write each over a per-sample expression")


# --- evaluation ----------------------------------------------------------------------------
def evaluate(expr: Expression, values: dict, points: dict | None = None, where: str = ""):
    """Evaluate ``expr`` with ``values`` (name -> number or CasADi scalar/row) and ``points``
    (name -> 2 x N CasADi matrix).  Unknown names raise :class:`ExpressionError`."""
    return _Evaluator(values, points or {}, where or expr.source, expr.source).run(expr.tree)


class _Evaluator:
    def __init__(self, values, points, where, source):
        self.values, self.points, self.where, self.source = values, points, where, source

    def _unknown(self, name, kind, known):
        tail = near_miss(name, known) or (
            f"; known {kind}s: {', '.join(sorted(known))}" if known else f"; no {kind}s exist here"
        )
        raise located_error(ExpressionError, self.where, f"{self.source!r}: unknown {kind} {name!r}{tail}")

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
            return _arithmetic(node.op, self.run(node.left), self.run(node.right))
        return self.call(node)

    def call(self, node):
        f, args = node.func, node.args
        if f == "length":
            p, q = (self.point(a.name) for a in args)
            d = p - q
            return ca.sqrt(d[0, :] ** 2 + d[1, :] ** 2)
        if f == "angle" and len(args) == 2:   # the direction of P->Q
            d = self.point(args[1].name) - self.point(args[0].name)
            return ca.atan2(d[1, :], d[0, :])
        if f == "angle":
            p, q, r = (self.point(a.name) for a in args)
            u, v = p - q, r - q
            cross = u[0, :] * v[1, :] - u[1, :] * v[0, :]
            dot = u[0, :] * v[0, :] + u[1, :] * v[1, :]
            return ca.atan2(ca.fabs(cross), dot)
        if f in ("x", "y"):
            return self.point(args[0].name)[0 if f == "x" else 1, :]
        if f in GEOMETRIC:  # a joint force: a name that model/quantities.py gives
            return self.run(Name(f"{f}({', '.join(a.name for a in args)})"))
        vals = [self.run(a) for a in args]
        if f in UNARY:
            return UNARY[f](vals[0])
        if f == "atan2":
            return ca.atan2(vals[0], vals[1])
        if f in STROKE_ENDS:  # the first or last sample of a row (the stroke's ends)
            v = vals[0]
            if isinstance(v, (int, float)):
                return v
            return v[:, 0] if f == "start" else v[:, v.shape[1] - 1]
        if len(vals) == 1:  # aggregate over the stroke
            return ca.mmax(vals[0]) if f == "max" else ca.mmin(vals[0])
        fold = ca.fmax if f == "max" else ca.fmin
        out = vals[0]
        for v in vals[1:]:
            out = fold(out, v)
        return out


_OPERATORS = {"+": lambda a, b: a + b, "-": lambda a, b: a - b, "*": lambda a, b: a * b,
              "/": lambda a, b: a / b, "^": lambda a, b: a**b}


def _arithmetic(op, a, b):
    """``a op b``.  Two plain numbers follow IEEE rules like CasADi does (1/0 is inf, (-8)^(1/3)
    is nan) instead of raising Python's ZeroDivisionError or returning a complex number."""
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        with np.errstate(all="ignore"):
            return float(_OPERATORS[op](np.float64(a), np.float64(b)))
    return _OPERATORS[op](a, b)


def constant_value(expr: Expression, values: dict, where) -> float:
    """Evaluate an expression that must be a plain, finite number (no sweep, no points)."""
    out = evaluate(expr, values, {}, where)
    try:
        if isinstance(out, (ca.SX, ca.MX, ca.DM)) and (out.numel() != 1 or not out.is_constant()):
            raise TypeError("not a constant")  # float() of a CasADi symbol would give nan
        number = float(out)
    except (TypeError, RuntimeError, NotImplementedError):
        raise located_error(
            ExpressionError, where,
            f"{expr.source!r} must evaluate to a number here (it may use earlier parameters, pi "
            "and deg, but not the sweep or points)") from None
    if not math.isfinite(number):
        raise located_error(
            ExpressionError, where,
            f"{expr.source!r} evaluates to {number} (a division by zero, or a square root or "
            "logarithm out of its domain?); expected a finite number")
    return number
