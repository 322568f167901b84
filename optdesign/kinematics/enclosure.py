"""Rigorous enclosures of a CasADi SX Function (s, p) over intervals of the sweep value s.

The same instruction program the model runs (``f.instruction_id(k)`` and its operands) is
evaluated in interval arithmetic, vectorised with numpy over many intervals at once: each
operation gives [lo, hi] containing every value the operation takes when its operands range
over their intervals, widened outward by one unit in the last place (two for the library's
elementary functions, exp, sin, atan2 ..., whose results numpy does not round correctly but to
within an ulp).  So the enclosure of an output over [a, b] holds every value the Function takes
at any s in [a, b], to floating-point outward rounding.  Work that does not depend on s (the
parameters' own) is done once per parameter vector, as point intervals.

Non-smooth operations are tracked per interval: a comparison, if_else, sign or floor whose
outcome is not decided over the interval (a jump of the output may lie inside it), an atan2
whose box crosses its branch cut.  :func:`bounds` uses the mean-value and Taylor forms, which
need a continuous (resp. continuously differentiable) output on the interval, only where no
such jump lies in the output's dependencies; the plain enclosure holds everywhere.

An operation without an enclosure here (fmod, remainder, a call, an MX graph) makes
:func:`interval_program` return None with the reason: the caller says that its certificate is
not available, never pretends one.
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


def _down(x, ulps=1):
    return x - (np.abs(x) * (ROUND if ulps == 1 else ROUND_LIB) + TINY)


def _up(x, ulps=1):
    return x + (np.abs(x) * (ROUND if ulps == 1 else ROUND_LIB) + TINY)


def _out(lo, hi, ulps=1):
    """[lo, hi] widened outward by the rounding of one operation (``ulps`` > 1: an elementary function)."""
    return _down(lo, ulps), _up(hi, ulps)


def _hull(*xs):
    return np.minimum.reduce(xs), np.maximum.reduce(xs)


def _mul(a, b, c, d):
    """[a, b] * [c, d], 0 * inf taken as 0."""
    if np.ndim(c) == 0 and c == d:   # by a point (a constant or a parameter): two products
        return _out(a * c, b * c) if c >= 0 else _out(b * c, a * c)
    p1, p2, p3, p4 = a * c, a * d, b * c, b * d
    return _out(np.fmin(np.fmin(p1, p2), np.fmin(p3, p4)), np.fmax(np.fmax(p1, p2), np.fmax(p3, p4)))


def _div(a, b, c, d):
    if np.ndim(c) == 0 and c == d and c != 0:
        return _out(a / c, b / c) if c > 0 else _out(b / c, a / c)
    lo, hi = _mul(a, b, *_out(1.0 / d, 1.0 / c))   # 1/[c, d] when 0 is outside it
    zero = (c <= 0) & (d >= 0)
    if np.any(zero):
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
            hi = np.minimum(hi, _up(np.maximum(np.abs(a), np.abs(b)) ** n, 2))
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
        return np.maximum(lo, 0.0), np.where(b < 0, np.nan, hi), None
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
        return (*_monotone(np.log, np.maximum(a, 0.0), b), None)
    if op in (ca.OP_ASIN, ca.OP_ACOS):   # defined on [-1, 1]: the argument's enclosure cut there
        f = np.arcsin if op == ca.OP_ASIN else np.arccos
        lo, hi = _monotone(f, np.clip(a, -1.0, 1.0), np.clip(b, -1.0, 1.0), op == ca.OP_ASIN)
        return lo, np.where((a > 1) | (b < -1), np.nan, hi), None
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
        return (*_monotone(np.log1p, np.maximum(a, -1.0), b), None)
    if op == ca.OP_EXPM1:
        return (*_monotone(np.expm1, a, b), None)
    if op in (ca.OP_FLOOR, ca.OP_CEIL):
        f = np.floor if op == ca.OP_FLOOR else np.ceil
        return f(a), f(b), f(a) != f(b)
    if op == _op("OP_ERF"):
        from scipy.special import erf

        return (*_monotone(erf, a, b), None)
    raise NotImplementedError(op)


_BINARY_OPS = {_op(n) for n in ("OP_ADD", "OP_SUB", "OP_MUL", "OP_DIV", "OP_POW", "OP_CONSTPOW", "OP_ATAN2",
                                "OP_FMIN", "OP_FMAX", "OP_HYPOT", "OP_LT", "OP_LE", "OP_EQ", "OP_NE",
                                "OP_AND", "OP_OR", "OP_IF_ELSE_ZERO")} - {None}
_UNARY_OPS = {_op(n) for n in ("OP_NEG", "OP_ASSIGN", "OP_TWICE", "OP_SQ", "OP_SQRT", "OP_INV", "OP_FABS",
                               "OP_SIGN", "OP_NOT", "OP_SIN", "OP_COS", "OP_EXP", "OP_LOG", "OP_ASIN",
                               "OP_ACOS", "OP_ATAN", "OP_TAN", "OP_TANH", "OP_SINH", "OP_COSH", "OP_LOG1P",
                               "OP_EXPM1", "OP_FLOOR", "OP_CEIL", "OP_ERF")} - {None}


class IntervalProgram:
    """An SX Function (s, p) -> outputs (column vectors), evaluated over intervals of s.

    Build it with :func:`interval_program`.  Calling it with arrays ``lo``, ``hi`` (the
    intervals) and the parameter vector ``p`` gives, per output, (lo, hi) arrays (output rows x
    intervals) and ``jump`` (output rows x intervals, bool): where a jump of that output's
    dependencies may lie inside the interval."""

    def __init__(self, func: ca.Function):
        self.n_work = func.sz_w()
        self.shapes = [func.size1_out(j) for j in range(func.n_out())]
        self.rows = [func.sparsity_out(j).row() for j in range(func.n_out())]
        # a value is read from its CasADi work slot when it varies with s, else from the
        # parameters' own store (index n_work + its instruction number: the slot itself may be
        # reused by the time the varying work runs, as the parameters' work is done first)
        varies = [False] * self.n_work     # the work slot depends on s
        deps = [0] * self.n_work           # bitmask of the jump instructions it depends on
        made_by = [None] * self.n_work     # instruction that wrote the slot
        self.fixed, self.varying = [], []
        jumps, consumers, prog = 0, {}, []
        for k in range(func.n_instructions()):
            op, i, o = func.instruction_id(k), func.instruction_input(k), func.instruction_output(k)
            if op == ca.OP_OUTPUT:
                slot = i[0]   # read in program order: a later instruction may reuse the slot
                where = slot if varies[slot] else self.n_work + made_by[slot]
                prog.append((k, op, (o[0], o[1], deps[slot] if varies[slot] else 0), None, [where], True, None, None))
                continue
            if op not in (ca.OP_INPUT, ca.OP_CONST) and op not in _BINARY_OPS and op not in _UNARY_OPS:
                raise NotImplementedError(f"operation {_name(op)} has no interval enclosure here")
            slots = [] if op in (ca.OP_INPUT, ca.OP_CONST) else list(i[:2] if op in _BINARY_OPS else i[:1])
            for slot in slots:
                consumers.setdefault(made_by[slot], set()).add(op)
            v = (op == ca.OP_INPUT and i[0] == 0) or any(varies[x] for x in slots)
            ins = [x if varies[x] else self.n_work + made_by[x] for x in slots]
            d = 0
            for x in slots:
                d |= deps[x] if varies[x] else 0
            bit = None
            if v and op in JUMPS:
                bit, jumps = jumps, jumps + 1
                d |= 1 << bit
            const = float(func.instruction_constant(k)) if op == ca.OP_CONST else None
            prog.append((k, op, i, o[0] if v else self.n_work + k, ins, v, bit, const))
            varies[o[0]], deps[o[0]], made_by[o[0]] = v, d, k
        for k, op, i, out, ins, v, bit, const in prog:
            periodic = op == ca.OP_ATAN2 and consumers.get(k, {None}) <= PERIODIC
            (self.varying if v else self.fixed).append((op, i, out, ins, bit, const, periodic))
        self.n_store = self.n_work + func.n_instructions()
        self.n_jumps = jumps
        self._p_key, self._p_work = None, None

    def _fixed_work(self, p):
        """The values that do not depend on s, at parameters p (point intervals), cached."""
        p = np.asarray(p, float).ravel()
        key = p.tobytes()
        if key != self._p_key:
            work = [None] * self.n_store
            self._run(self.fixed, work, None, p, None)
            self._p_key, self._p_work = key, work
        return self._p_work

    def _run(self, program, work, s, p, undecided):
        with np.errstate(all="ignore"):
            for op, i, out, ins, bit, const, periodic in program:
                if op == ca.OP_OUTPUT:
                    self._store.append((i, work[ins[0]]))
                    continue
                if op == ca.OP_INPUT:
                    work[out] = s if i[0] == 0 else (p[i[1]], p[i[1]])
                    continue
                if op == ca.OP_CONST:
                    work[out] = (const, const)
                    continue
                if len(ins) == 2:
                    (a, b), (c, d) = work[ins[0]], work[ins[1]]
                    lo, hi, und = _binary(op, a, b, c, d, periodic)
                else:
                    lo, hi, und = _unary(op, *work[ins[0]])
                work[out] = (lo, hi)
                if bit is not None and undecided is not None:
                    undecided[bit] = und

    def __call__(self, lo, hi, p):
        lo, hi = np.asarray(lo, float).ravel(), np.asarray(hi, float).ravel()
        n = len(lo)
        work = list(self._fixed_work(p))
        undecided = [None] * self.n_jumps
        self._store = []
        self._run(self.varying, work, (lo, hi), p, undecided)
        out = [(np.zeros((m, n)), np.zeros((m, n)), np.zeros((m, n), bool)) for m in self.shapes]
        for (j, nz, deps), (a, b) in self._store:
            row = self.rows[j][nz]
            out[j][0][row], out[j][1][row] = a, b
            bit = 0
            while deps:
                if deps & 1 and undecided[bit] is not None:
                    out[j][2][row] |= undecided[bit]
                deps >>= 1
                bit += 1
        return out


def _name(op):
    for k in dir(ca):
        if k.startswith("OP_") and getattr(ca, k) == op:
            return k[3:].lower()
    return str(op)


def interval_program(func):
    """:class:`IntervalProgram` of ``func``, or (None, reason) where it has none: returns
    (program, reason) with exactly one of them None."""
    if func is None:
        return None, "no Function to enclose"
    if not func.is_a("SXFunction"):
        return None, "the graph is not SX (a Newton-closed loop: CasADi's rootfinder has no interval enclosure here)"
    try:
        return IntervalProgram(func), None
    except NotImplementedError as exc:
        return None, str(exc)


def _upper_correction(d1_lo, d1_hi, d2_hi, r):
    """sup over t in [-r, r] of d1 t + d2_hi t^2 / 2 for d1 in [d1_lo, d1_hi] (the Taylor form's
    term beyond v(m)), rounded up generously (a few operations, 1e-12 of itself)."""
    b = 0.5 * d2_hi

    def g(a):   # sup over u in [0, r] of a u + b u^2
        end = np.maximum(a * r + b * r * r, 0.0)
        with np.errstate(all="ignore"):
            inner = np.where((b < 0) & (a > 0) & (a < -2 * b * r), a * a / (-4 * b), end)
        return np.where(b >= 0, end, inner)

    c = np.maximum(g(d1_hi), g(-d1_lo))
    return c + np.abs(c) * 1e-12


class Enclosure:
    """Bounds of quantities v (rows) over intervals of s from an :class:`IntervalProgram` of
    (s, p) -> (v, dv/ds, d2v/ds2), the one the certification's Newton steps evaluate.

    ``bounds(lo, hi)`` returns (L, U), rows x intervals: L <= v(s) <= U for every s in [lo, hi]
    and every row, the tightest of the plain enclosure, the mean-value form v(m) + v'([lo, hi])
    (s - m) (where no jump of v may lie inside) and the Taylor form v(m) + v'(m) (s - m) +
    v''([lo, hi]) (s - m)^2 / 2 (where no jump of v or v' may lie inside), m the midpoint."""

    def __init__(self, program: IntervalProgram, p):
        self.program, self.p = program, np.asarray(p, float).ravel()

    def bounds(self, lo, hi):
        lo, hi = np.asarray(lo, float), np.asarray(hi, float)
        n = len(lo)
        m = 0.5 * (lo + hi)
        r = _up(np.maximum(hi - m, m - lo))
        (v_lo, v_hi, v_jump), (d_lo, d_hi, d_jump), (e_lo, e_hi, _) = self.program(np.r_[lo, m], np.r_[hi, m], self.p)
        whole, mid = slice(0, n), slice(n, 2 * n)
        L, U = v_lo[:, whole], v_hi[:, whole]
        vm_lo, vm_hi = v_lo[:, mid], v_hi[:, mid]
        smooth0 = ~v_jump[:, whole]
        smooth1 = smooth0 & ~d_jump[:, whole]
        with np.errstate(all="ignore"):
            # mean-value form
            mv = r * np.maximum(d_hi[:, whole], -d_lo[:, whole])
            mv = mv + np.abs(mv) * 1e-12
            U_mv, L_mv = _up(vm_hi + mv), _down(vm_lo - mv)
            # Taylor form, for v and for -v
            U_t = _up(vm_hi + _upper_correction(d_lo[:, mid], d_hi[:, mid], e_hi[:, whole], r))
            L_t = _down(vm_lo - _upper_correction(-d_hi[:, mid], -d_lo[:, mid], -e_lo[:, whole], r))
        U = np.where(smooth0 & (U_mv < U), U_mv, U)
        L = np.where(smooth0 & (L_mv > L), L_mv, L)
        U = np.where(smooth1 & (U_t < U), U_t, U)
        L = np.where(smooth1 & (L_t > L), L_t, L)
        return L, U, vm_lo, vm_hi


class Unavailable:
    """No enclosure, and why: :func:`~.peaks.certify` reports its quantities as not certified."""

    def __init__(self, reason: str):
        self.reason = reason

    def __repr__(self):
        return f"Unavailable({self.reason!r})"


class Enclosures:
    """The interval program of one Function (s, p) -> (v, dv/ds, d2v/ds2), built once; ``at(p)``
    gives its :class:`Enclosure` at parameters p, or :class:`Unavailable` with the reason."""

    def __init__(self, func):
        self.program, self.reason = interval_program(func)

    def at(self, p):
        return Unavailable(self.reason) if self.program is None else Enclosure(self.program, p)
