"""Interval arithmetic of CasADi's operations, over numpy arrays of intervals [lo, hi].

Each operation returns an interval holding every value it takes when its operands range over
theirs, moved outward by the rounding of the operation (:func:`_out`); the operations whose
outcome jumps (comparisons, if_else, sign, floor, atan2's branch cut) also say where it is not
decided over the interval.  NaN (at both ends) is no enclosure: a function undefined on the
whole interval (sqrt, log, asin... outside their domain), and the arithmetic and functions of
it (a comparison with it is undecided, [0, 1], as CasADi's comparison with NaN is false), so that
no interval where the function is undefined ever closes.  Used by
:mod:`.enclosure`, which runs a Function's instruction program with them.
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

INF = np.inf
TWO_PI = 2 * math.pi


def _op(name):
    return getattr(ca, name, None)


# operations whose value jumps where their outcome changes
JUMPS = {_op(n) for n in ("OP_LT", "OP_LE", "OP_EQ", "OP_NE", "OP_NOT", "OP_AND", "OP_OR", "OP_SIGN",
                          "OP_IF_ELSE_ZERO", "OP_FLOOR", "OP_CEIL", "OP_ATAN2")} - {None}
PERIODIC = {ca.OP_SIN, ca.OP_COS}


# Outward rounding: a result rounded to nearest is within half an ulp of the exact value
# (IEEE +, -, *, /, sqrt), numpy's elementary functions within an ulp or so; an ulp of x is at
# most 2^-52 |x| (normal numbers).  Moving x out by |x| 2^-50 (2^-48 for the elementary
# functions) plus 1e-300 (subnormals, zero) covers it, with room for the rounding of the move
# itself; cheaper than np.nextafter over large arrays.
ROUND = 2.0 ** -50
ROUND_LIB = 2.0 ** -48
TINY = 1e-300


BIG = np.finfo(float).max


# A result that overflowed to +inf as a lower bound (1 / 2e-313) stands for a finite value above
# BIG: BIG is its lower bound (inf - inf would give NaN); -inf as an upper bound likewise.  An
# infinite bound on its own side (hi = inf, lo = -inf) stays infinite, a NaN stays NaN.
def _down(x, ulps=1):
    x = np.minimum(x, BIG)
    return x - (np.abs(x) * (ROUND if ulps == 1 else ROUND_LIB) + TINY)


def _up(x, ulps=1):
    x = np.maximum(x, -BIG)
    return x + (np.abs(x) * (ROUND if ulps == 1 else ROUND_LIB) + TINY)


def _out(lo, hi, ulps=1):
    """[lo, hi] widened outward by the rounding of one operation (``ulps`` > 1: an elementary function)."""
    return _down(lo, ulps), _up(hi, ulps)


def _hull(*xs):
    return np.minimum.reduce(xs), np.maximum.reduce(xs)


# A NaN end of an operand (no enclosure: a function undefined on the whole interval, e.g. sqrt
# of a negative interval) gives NaN at both ends of a product or quotient: the four products'
# fmin/fmax, which take 0 * inf as 0, would drop it, and a NaN at one end only would be lost by a
# later negation.  numpy's minimum/maximum keep a NaN: the products' fmin/fmax (and the test of
# the operands) are taken only where they give one, which is rare.
def _both_nan(lo, hi):
    """[lo, hi] with NaN at both ends where either end is NaN."""
    if not np.isnan(lo + hi).any():   # (NaN where either is, or -inf + inf)
        return lo, hi
    bad = np.isnan(lo) | np.isnan(hi)
    return np.where(bad, np.nan, lo), np.where(bad, np.nan, hi)


def _four(a, b, c, d, p1, p2, p3, p4):
    """The hull of four products (or quotients) of [a, b] and [c, d], outward; 0 * inf (inf /
    inf) taken as 0 (dropped), NaN where an operand has a NaN end."""
    lo = np.minimum(np.minimum(p1, p2), np.minimum(p3, p4))
    hi = np.maximum(np.maximum(p1, p2), np.maximum(p3, p4))
    if np.isnan(lo).any():
        bad = np.isnan(a) | np.isnan(b) | np.isnan(c) | np.isnan(d)
        lo = np.where(bad, np.nan, np.fmin(np.fmin(p1, p2), np.fmin(p3, p4)))
        hi = np.where(bad, np.nan, np.fmax(np.fmax(p1, p2), np.fmax(p3, p4)))
    return _out(lo, hi)


def _mul(a, b, c, d):
    """[a, b] * [c, d], 0 * inf taken as 0; NaN where an operand has a NaN end."""
    if np.ndim(a) == 0 and a == b and np.ndim(c) != 0:   # a point times an interval array
        a, b, c, d = c, d, a, b
    if np.ndim(c) == 0 and c == d and c != 0 and math.isfinite(c):   # by a point (a constant or a parameter)
        return _both_nan(*(_out(a * c, b * c) if c > 0 else _out(b * c, a * c)))
    return _four(a, b, c, d, a * c, a * d, b * c, b * d)


def _div(a, b, c, d):
    """[a, b] / [c, d]: where 0 is outside [c, d], between the quotients of the ends (each
    correctly rounded: one rounding, as a product's); the whole line where it is inside; NaN
    where an operand has a NaN end."""
    if np.ndim(c) == 0 and c == d and c != 0 and math.isfinite(c):
        return _both_nan(*(_out(a / c, b / c) if c > 0 else _out(b / c, a / c)))
    lo, hi = _four(a, b, c, d, a / c, a / d, b / c, b / d)
    zero = (c <= 0) & (d >= 0)
    if np.any(zero):   # (an operand with a NaN end stays NaN)
        zero = zero & ~(np.isnan(a) | np.isnan(b) | np.isnan(c) | np.isnan(d))
        lo, hi = np.where(zero, -INF, lo), np.where(zero, INF, hi)
    return lo, hi


def _monotone(f, a, b, increasing=True, ulps=2):
    fa, fb = f(a), f(b)
    return _out(fa, fb, ulps) if increasing else _out(fb, fa, ulps)


def _contains(a, b, centre):
    """Whether [a, b] (conservatively) holds a point centre + 2 k pi."""
    slack = 1e-9 * (1.0 + np.abs(a) + np.abs(b))
    return np.floor((b - centre) / TWO_PI + slack) >= np.ceil((a - centre) / TWO_PI - slack)


def _sin(a, b, shift=0.0):
    """sin over [a, b] (cos: shift pi/2, cos x = sin(x + pi/2), the extremes tested at shifted points)."""
    f = np.cos if shift else np.sin
    fa, fb = f(a), f(b)
    lo, hi = _out(np.minimum(fa, fb), np.maximum(fa, fb), 2)
    top = math.pi / 2 - shift
    hi = np.where(_contains(a, b, top), 1.0, np.minimum(hi, 1.0))
    lo = np.where(_contains(a, b, top + math.pi), -1.0, np.maximum(lo, -1.0))
    wide = (b - a) >= TWO_PI
    return np.where(wide, -1.0, lo), np.where(wide, 1.0, hi)


def _sq(a, b):
    a2, b2 = a * a, b * b
    lo = np.where((a <= 0) & (b >= 0), 0.0, np.minimum(a2, b2))
    return np.maximum(_down(lo), 0.0), _up(np.maximum(a2, b2))


def _pow(a, b, c, d):
    """[a, b] ** [c, d]: an integer exponent (a point) exactly, otherwise exp(y log x), x >= 0."""
    if np.ndim(c) == 0 and c == d and float(c).is_integer() and abs(c) <= 64:
        n = int(c)
        if n == 0:
            return np.ones_like(a * 1.0), np.ones_like(b * 1.0)
        lo, hi = (a * 0 + 1.0, b * 0 + 1.0)
        base = (a, b)
        for _ in range(abs(n)):   # repeated products: exact enclosure of x^n up to dependency
            lo, hi = _mul(lo, hi, *base)
        if n % 2 == 0:
            lo = np.maximum(lo, 0.0)
            lo = np.where((a <= 0) & (b >= 0), 0.0, lo)
            # x^n for even n over an interval holding 0 is [0, max]; as products it may be wider
            hi = np.minimum(hi, _up(np.maximum(np.abs(a), np.abs(b)) ** abs(n), 2))   # x^|n| before 1/x
        return _div(1.0, 1.0, lo, hi) if n < 0 else (lo, hi)
    la, lb = _monotone(np.log, np.maximum(a, 0.0), np.maximum(b, 0.0))
    lo, hi = _monotone(np.exp, *_mul(la, lb, c, d))
    negative = a < 0   # a negative base to a power not known to be an integer: no enclosure here
    return np.where(negative, np.nan, lo), np.where(negative, np.nan, hi)


def _atan2(ya, yb, xa, xb, periodic):
    """atan2 over the box [ya, yb] x [xa, xb]: at its corners unless the box holds the origin or
    crosses the branch cut (x < 0, y = 0); then [-pi, pi], or, when only sin/cos use the angle
    (``periodic``), the corners' angles on one branch (y < 0 ones + 2 pi).  Returns (lo, hi, cut)."""
    corners = [np.arctan2(y, x) for y in (ya, yb) for x in (xa, xb)]
    lo, hi = _out(np.minimum.reduce(corners), np.maximum.reduce(corners), 2)
    cut = (xa < 0) & (ya < 0) & (yb > 0)
    origin = (xa <= 0) & (xb >= 0) & (ya <= 0) & (yb >= 0)
    if periodic:
        wrapped = [np.where(c < 0, c + TWO_PI, c) for c in corners]
        wlo, whi = _out(np.minimum.reduce(wrapped), np.maximum.reduce(wrapped), 3)
        lo, hi = np.where(cut, wlo, lo), np.where(cut, whi, hi)
        cut = origin
    lo = np.where(origin | cut, -math.pi - 1e-15, lo)
    hi = np.where(origin | cut, math.pi + 1e-15, hi)
    return lo, hi, cut | origin


def _truth(a, b):
    """(certainly true, certainly false) of a value in [a, b] as a condition (nonzero)."""
    return (a > 0) | (b < 0), (a == 0) & (b == 0)


def _bool(true, false):
    """The interval of a 0/1 outcome: [1, 1], [0, 0] or [0, 1]; and where it is undecided."""
    lo = np.where(true, 1.0, 0.0)
    hi = np.where(false, 0.0, 1.0)
    return lo, hi, ~(true | false)


def _binary(op, a, b, c, d, periodic=False):
    """Operation ``op`` of [a, b] and [c, d]: (lo, hi, undecided or None)."""
    if op == ca.OP_ADD:
        return (*_out(a + c, b + d), None)
    if op == ca.OP_SUB:
        return (*_out(a - d, b - c), None)
    if op == ca.OP_MUL:
        return (*_mul(a, b, c, d), None)
    if op == ca.OP_DIV:
        return (*_div(a, b, c, d), None)
    if op in (ca.OP_POW, ca.OP_CONSTPOW):
        return (*_pow(a, b, c, d), None)
    if op == ca.OP_ATAN2:
        return _atan2(a, b, c, d, periodic)
    if op == ca.OP_FMIN:
        return np.minimum(a, c), np.minimum(b, d), None
    if op == ca.OP_FMAX:
        return np.maximum(a, c), np.maximum(b, d), None
    if op == ca.OP_HYPOT:
        lo, hi = _sq(a, b)
        lo2, hi2 = _sq(c, d)
        return (*_monotone(np.sqrt, *_out(lo + lo2, hi + hi2)), None)
    if op == ca.OP_LT:
        return _bool(b < c, a >= d)
    if op == ca.OP_LE:
        return _bool(b <= c, a > d)
    if op == ca.OP_EQ:
        return _bool((a == b) & (b == c) & (c == d), (b < c) | (d < a))
    if op == ca.OP_NE:
        return _bool((b < c) | (d < a), (a == b) & (b == c) & (c == d))
    t1, f1 = _truth(a, b)
    t2, f2 = _truth(c, d)
    if op == ca.OP_AND:
        return _bool(t1 & t2, f1 | f2)
    if op == ca.OP_OR:
        return _bool(t1 | t2, f1 & f2)
    if op == ca.OP_IF_ELSE_ZERO:
        lo, hi = np.minimum(c, 0.0), np.maximum(d, 0.0)
        lo, hi = np.where(t1, c, np.where(f1, 0.0, lo)), np.where(t1, d, np.where(f1, 0.0, hi))
        return lo, hi, ~(t1 | f1)
    raise NotImplementedError(op)


def _outside(lo, hi, outside):
    """(lo, hi, None) with NaN at both ends where the interval lies outside the function's
    domain (no enclosure: a NaN at one end only would be lost by a later negation or product)."""
    return np.where(outside, np.nan, lo), np.where(outside, np.nan, hi), None


def _unary(op, a, b):
    """Operation ``op`` of [a, b]: (lo, hi, undecided or None)."""
    if op == ca.OP_NEG:
        return -b, -a, None
    if op == ca.OP_ASSIGN:
        return a, b, None
    if op == ca.OP_TWICE:
        return 2.0 * a, 2.0 * b, None
    if op == ca.OP_SQ:
        return (*_sq(a, b), None)
    if op == ca.OP_SQRT:   # a function defined on the interval: its argument's enclosure cut at 0
        lo, hi = _monotone(np.sqrt, np.maximum(a, 0.0), b, ulps=1)
        return _outside(np.maximum(lo, 0.0), hi, b < 0)
    if op == ca.OP_INV:
        return (*_div(1.0, 1.0, a, b), None)
    if op == ca.OP_FABS:
        lo = np.where((a <= 0) & (b >= 0), 0.0, np.minimum(np.abs(a), np.abs(b)))
        return lo, np.maximum(np.abs(a), np.abs(b)), None
    if op == ca.OP_SIGN:
        return np.sign(a), np.sign(b), np.sign(a) != np.sign(b)
    if op == ca.OP_NOT:
        t, f = _truth(a, b)
        return _bool(f, t)
    if op == ca.OP_SIN:
        return (*_sin(a, b), None)
    if op == ca.OP_COS:
        return (*_sin(a, b, math.pi / 2), None)
    if op == ca.OP_EXP:
        return (*_monotone(np.exp, a, b), None)
    if op == ca.OP_LOG:
        return _outside(*_monotone(np.log, np.maximum(a, 0.0), b), b < 0)
    if op in (ca.OP_ASIN, ca.OP_ACOS):   # defined on [-1, 1]: the argument's enclosure cut there
        f = np.arcsin if op == ca.OP_ASIN else np.arccos
        lo, hi = _monotone(f, np.clip(a, -1.0, 1.0), np.clip(b, -1.0, 1.0), op == ca.OP_ASIN)
        return _outside(lo, hi, (a > 1) | (b < -1))
    if op == ca.OP_ATAN:
        return (*_monotone(np.arctan, a, b), None)
    if op == ca.OP_TAN:
        lo, hi = _monotone(np.tan, a, b)
        pole = _contains(a, b, math.pi / 2) | _contains(a, b, -math.pi / 2) | (b - a >= math.pi)
        return np.where(pole, -INF, lo), np.where(pole, INF, hi), None
    if op == ca.OP_TANH:
        return (*_monotone(np.tanh, a, b), None)
    if op == ca.OP_SINH:
        return (*_monotone(np.sinh, a, b), None)
    if op == ca.OP_COSH:
        lo, hi = _monotone(np.cosh, *_hull(np.abs(a), np.abs(b)))
        return np.where((a <= 0) & (b >= 0), 1.0, lo), hi, None
    if op == ca.OP_LOG1P:
        return _outside(*_monotone(np.log1p, np.maximum(a, -1.0), b), b < -1)
    if op == ca.OP_EXPM1:
        return (*_monotone(np.expm1, a, b), None)
    if op in (ca.OP_FLOOR, ca.OP_CEIL):
        f = np.floor if op == ca.OP_FLOOR else np.ceil
        return f(a), f(b), f(a) != f(b)
    if op == _op("OP_ERF"):
        from scipy.special import erf

        return (*_monotone(erf, a, b), None)
    raise NotImplementedError(op)


