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

import casadi as ca
import numpy as np

from .intervals import INF, JUMPS, PERIODIC, _binary, _down, _op, _out, _unary, _up  # noqa: F401

CHUNK = 16384   # intervals per evaluation of Enclosure.bounds at most (many cases' share work: not fewer)

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
    intervals) and the parameter vector ``p`` (or one row of parameters per interval: an array
    intervals x parameters) gives, per output, (lo, hi) arrays (output rows x
    intervals) and ``jump`` (output rows x intervals, bool): where a jump of that output's
    dependencies may lie inside the interval."""

    def __init__(self, func: ca.Function):
        self.func = func
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
        condition, negation = {}, {}   # if_else_zero -> its condition's instruction; not -> its operand's
        producers, outputs = {}, []      # instruction -> the varying instructions it reads; (output, row)
        for k in range(func.n_instructions()):
            op, i, o = func.instruction_id(k), func.instruction_input(k), func.instruction_output(k)
            if op == ca.OP_OUTPUT:
                slot = i[0]   # read in program order: a later instruction may reuse the slot
                where = slot if varies[slot] else self.n_work + made_by[slot]
                prog.append((k, op, (o[0], o[1], deps[slot] if varies[slot] else 0), None, [where], True, None, None))
                producers[k] = [made_by[slot]] if varies[slot] else []
                outputs.append((k, o[0], self.rows[o[0]][o[1]]))
                continue
            if op not in (ca.OP_INPUT, ca.OP_CONST) and op not in _BINARY_OPS and op not in _UNARY_OPS:
                raise NotImplementedError(f"operation {_name(op)} has no interval enclosure here")
            slots = [] if op in (ca.OP_INPUT, ca.OP_CONST) else list(i[:2] if op in _BINARY_OPS else i[:1])
            for slot in slots:
                consumers.setdefault(made_by[slot], set()).add(op)
            v = (op == ca.OP_INPUT and i[0] == 0) or any(varies[x] for x in slots)
            ins = [x if varies[x] else self.n_work + made_by[x] for x in slots]
            producers[k] = [made_by[x] for x in slots if varies[x]]
            d = 0
            for x in slots:
                d |= deps[x] if varies[x] else 0
            bit = None
            if v and op in JUMPS:
                bit, jumps = jumps, jumps + 1
                d |= 1 << bit
            const = float(func.instruction_constant(k)) if op == ca.OP_CONST else None
            if v and op == ca.OP_ADD:   # if_else(c, x, y) = if_else_zero(c, x) + if_else_zero(!c, y)
                const = _select(made_by[slots[0]], made_by[slots[1]], condition, negation)
            prog.append((k, op, i, o[0] if v else self.n_work + k, ins, v, bit, const))
            if op == ca.OP_IF_ELSE_ZERO:
                condition[k] = made_by[slots[0]]   # (the producers of its condition, for _select)
            elif op == ca.OP_NOT:
                negation[k] = made_by[slots[0]]
            varies[o[0]], deps[o[0]], made_by[o[0]] = v, d, k
        for k, op, i, out, ins, v, bit, const in prog:
            periodic = op == ca.OP_ATAN2 and consumers.get(k, {None}) <= PERIODIC
            (self.varying if v else self.fixed).append((op, i, out, ins, bit, const, (periodic, k)))
        self.n_store = self.n_work + func.n_instructions()
        self.n_jumps = jumps
        self._p_key, self._p_work = None, None
        self._producers, self._outputs, self._subsets = producers, outputs, {}

    def _subset(self, rows, outputs=None):
        """The varying program cut to what the outputs of ``rows`` need (in the same order: an
        instruction left out wrote nothing that a kept one reads), cached per set of rows;
        ``outputs``: of those outputs only (indices: 0 v, 1 dv/ds, 2 d2v/ds2), else all."""
        key = (frozenset(int(r) for r in rows), None if outputs is None else frozenset(outputs))
        if key not in self._subsets:
            needed = set()
            stack = [k for k, j, row in self._outputs if row in key[0] and (outputs is None or j in key[1])]
            while stack:
                k = stack.pop()
                if k not in needed:
                    needed.add(k)
                    stack += self._producers.get(k, [])
            self._subsets[key] = [entry for entry in self.varying if entry[-1][1] in needed]
        return self._subsets[key]

    def _fixed_work(self, p):
        """The values that do not depend on s, at parameters p (point intervals), cached; p of
        shape (intervals, parameters): each interval's own parameters (not cached)."""
        p = np.asarray(p, float)
        if p.ndim == 2:
            work = [None] * self.n_store
            self._branches = {}
            self._run(self.fixed, work, None, np.ascontiguousarray(p.T), None)   # a parameter: p[i]
            return work
        p = p.ravel()
        key = p.tobytes()
        if key != self._p_key:
            work = [None] * self.n_store
            self._branches = {}
            self._run(self.fixed, work, None, p, None)
            self._p_key, self._p_work = key, work
        return self._p_work

    def _run(self, program, work, s, p, undecided):
        with np.errstate(all="ignore"):
            for op, i, out, ins, bit, const, (periodic, k) in program:
                if op == ca.OP_OUTPUT:
                    self._store.append((i, work[ins[0]]))
                    continue
                if op == ca.OP_INPUT:
                    work[out] = s if i[0] == 0 else (p[i[1]], p[i[1]])
                    continue
                if op == ca.OP_CONST:
                    work[out] = (const, const)
                    continue
                if op == ca.OP_ADD and const is not None and const[0] in self._branches and const[1] in self._branches:
                    # an if_else: where undecided, the hull of its two branches (not of each with 0)
                    (x_lo, x_hi, und), (y_lo, y_hi, _) = self._branches[const[0]], self._branches[const[1]]
                    (a, b), (c, d) = work[ins[0]], work[ins[1]]
                    lo, hi = _out(a + c, b + d)
                    lo, hi = np.where(und, np.minimum(x_lo, y_lo), lo), np.where(und, np.maximum(x_hi, y_hi), hi)
                    work[out] = (lo, hi)
                    continue
                if len(ins) == 2:
                    (a, b), (c, d) = work[ins[0]], work[ins[1]]
                    lo, hi, und = _binary(op, a, b, c, d, periodic)
                    if op == ca.OP_IF_ELSE_ZERO:
                        self._branches[k] = (c, d, und)
                else:
                    lo, hi, und = _unary(op, *work[ins[0]])
                work[out] = (lo, hi)
                if bit is not None and undecided is not None:
                    undecided[bit] = und

    def __call__(self, lo, hi, p, rows=None, outputs=None):
        """Every output over the intervals [lo, hi]; ``rows``: only those rows of the outputs
        (the others NaN), with only the instructions they need; ``outputs``: only those outputs
        (indices), idem.  ``p``: the parameter vector, or an array (intervals x parameters) of
        each interval's own (point intervals per interval: many parameter vectors in one
        call)."""
        lo, hi = np.asarray(lo, float).ravel(), np.asarray(hi, float).ravel()
        n = len(lo)
        work = list(self._fixed_work(p))
        undecided = [None] * self.n_jumps
        self._store, self._branches = [], {}
        if rows is None and outputs is None:
            program = self.varying
        else:
            program = self._subset(range(max(self.shapes, default=0)) if rows is None else rows, outputs)
        self._run(program, work, (lo, hi), p, undecided)
        out = [(np.full((m, n), np.nan), np.full((m, n), np.nan), np.zeros((m, n), bool)) for m in self.shapes]
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


def _select(k1, k2, condition, negation):
    """(k1, k2) when instructions k1 and k2 are if_else_zero(c, x) and if_else_zero(!c, y) of
    one condition c (in either order): their sum is an if_else; else None."""
    if k1 not in condition or k2 not in condition:
        return None
    c1, c2 = condition[k1], condition[k2]
    if c1 is None or c2 is None or not (negation.get(c2) == c1 or negation.get(c1) == c2):
        return None
    return (k1, k2)


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


def _upper_correction(d1_lo, d1_hi, d2_hi, r, r_below=None):
    """sup over t in [-r_below, r] (r_below: r by default) of d1 t + d2_hi t^2 / 2 for d1 in
    [d1_lo, d1_hi] (the Taylor form's term beyond v(m)), rounded up generously (a few
    operations, 1e-12 of itself)."""
    b = 0.5 * d2_hi
    r_below = r if r_below is None else r_below

    def g(a, r):   # sup over u in [0, r] of a u + b u^2
        end = np.maximum(a * r + b * r * r, 0.0)
        with np.errstate(all="ignore"):
            inner = np.where((b < 0) & (a > 0) & (a < -2 * b * r), a * a / (-4 * b), end)
        return np.where(b >= 0, end, inner)

    c = np.maximum(g(d1_hi, r), g(-d1_lo, r_below))
    return c + np.abs(c) * 1e-12


class Enclosure:
    """Bounds of quantities v (rows) over intervals of s from an :class:`IntervalProgram` of
    (s, p) -> (v, dv/ds, d2v/ds2), the one the certification's Newton steps evaluate.

    ``bounds(lo, hi)`` returns (L, U), rows x intervals: L <= v(s) <= U for every s in [lo, hi]
    and every row, the tightest of the plain enclosure, the mean-value form v(m) + v'([lo, hi])
    (s - m) (where no jump of v may lie inside), the Taylor form v(m) + v'(m) (s - m) +
    v''([lo, hi]) (s - m)^2 / 2 (where no jump of v or v' may lie inside), m the midpoint or the
    interval's given expansion point (a located maximum inside it: there v'(m) ~ 0, and where
    v'' is proven negative the form bounds v by v(m) itself, whatever the interval's width), and
    the monotone form: where no jump of v may lie inside and v' is proven of one sign over
    [lo, hi] (its plain enclosure, or where v' is continuous too v'(m) + v''([lo, hi]) (s - m)),
    v lies between its enclosures at the interval's two ends (an interval far from any maximum
    of v then bounds it by the larger end value, however wide)."""

    def __init__(self, program: IntervalProgram, p):
        """``p``: the parameter vector; or an array (cases x parameters) of many cases' own,
        with ``cases`` given to :meth:`bounds` (each interval's case: a row of p), or without
        it one row per interval."""
        p = np.asarray(p, float)
        self.program, self.p = program, p if p.ndim == 2 else p.ravel()
        self._varies = None

    def _varied(self) -> int:
        """A bitmask of the parameters (bit k: parameter k) that differ between the cases (rows of p)."""
        if self._varies is None:
            self._varies = 0
            for k in np.flatnonzero(np.any(self.p != self.p[:1], axis=0)):
                self._varies |= 1 << int(k)
        return self._varies

    def bounds(self, lo, hi, rows=None, cases=None, centre=None):
        """(L, U, vm_lo, vm_hi), rows x intervals: the bounds of v over [lo, hi] and the
        enclosure of v at the expansion point; ``rows``: those rows only (the others NaN);
        ``cases``: each interval's row of the parameters (an Enclosure of many cases);
        ``centre``: each interval's expansion point (NaN, or outside [lo, hi]: its midpoint;
        None: every midpoint)."""
        lo, hi = np.asarray(lo, float), np.asarray(hi, float)
        n = len(lo)
        if self.p.ndim == 2 and cases is None:   # one parameter row per interval
            cases = np.arange(n)
        if n > CHUNK:   # in pieces whose arrays stay in the processor's cache (each interval on its own)
            parts = [self.bounds(lo[i:i + CHUNK], hi[i:i + CHUNK], rows, None if cases is None else cases[i:i + CHUNK],
                                 None if centre is None else centre[i:i + CHUNK]) for i in range(0, n, CHUNK)]
            return tuple(np.concatenate(a, axis=1) for a in zip(*parts))
        m = 0.5 * (lo + hi)
        if centre is not None:
            with np.errstate(invalid="ignore"):
                m = np.where((lo <= centre) & (centre <= hi), centre, m)
        radii = np.empty((2, n))   # (r_above, r_below: one rounding of both)
        np.subtract(hi, m, out=radii[0])
        np.subtract(m, lo, out=radii[1])
        r_above, r_below = _up(radii)
        # the ends, each (case, value) once: neighbouring intervals share them
        if self.p.ndim == 1:
            ends, where_end = np.unique(np.concatenate((lo, hi)), return_inverse=True)
            p = p_cases = p_ends = self.p
        else:
            one = len(self.p) == 1   # one case: its parameter vector (the same bits, without a row per interval)
            if not one:
                cases = np.asarray(cases, int)
            ends, where_end, end_case = distinct_ends(lo, hi, None if one else cases)
            # each interval's parameters (over [lo, hi] and at its midpoint: the same rows), each end's
            p_cases, p_ends = (self.p[0], self.p[0]) if one else (self.p.take(cases, axis=0),
                                                                   self.p.take(end_case, axis=0))
            p = p_cases if one else None
        # over [lo, hi] everything; at the midpoints v and v' (the Taylor form's); at the ends v
        # (the monotone form's): each call runs only the instructions its outputs need
        # (numpy runs a program instruction by instruction, at a fixed cost per instruction and
        # call: there all of them in one call)
        compiled = getattr(self.program, "subsets_pay", False)
        if compiled:
            varied = self._varied() if p_cases.ndim == 2 else None   # (the parameters that differ between the cases)
            # (the C forms read only the rows asked for: the whole's and the ends' other rows left unset)
            fill = not hasattr(self.program, "forms")
            (L, U, v_jump), (d_lo, d_hi, d_jump), (e_lo, e_hi, _) = self.program(lo, hi, p_cases, rows, varied=varied,
                                                                                  fill=fill)
            (vm_lo, vm_hi, _), (dm_lo, dm_hi, _), _ = self.program(m, m, p_cases, rows, (0, 1), varied=varied)
            (at_lo, at_hi, _), _, _ = self.program(ends, ends, p_ends, rows, (0,), varied=varied, fill=fill)
        else:
            if p is None:   # (a row of parameters per interval, midpoint and end)
                p = np.concatenate((p_cases, p_cases, p_ends))
            (v_lo, v_hi, v_jump), (d_lo, d_hi, d_jump), (e_lo, e_hi, _) = self.program(
                np.concatenate((lo, m, ends)), np.concatenate((hi, m, ends)), p, rows)
            L, U, vm_lo, vm_hi, at_lo, at_hi = (v_lo[:, :n], v_hi[:, :n], v_lo[:, n:2 * n], v_hi[:, n:2 * n],
                                                v_lo[:, 2 * n:], v_hi[:, 2 * n:])
            dm_lo, dm_hi = d_lo[:, n:2 * n], d_hi[:, n:2 * n]
            v_jump, d_lo, d_hi, d_jump, e_lo, e_hi = (a[:, :n] for a in (v_jump, d_lo, d_hi, d_jump, e_lo, e_hi))
        if compiled and hasattr(self.program, "forms"):   # (compiled: the same bits)
            L, U = self.program.forms(rows, (L, U, v_jump, d_lo, d_hi, d_jump, e_lo, e_hi), (vm_lo, vm_hi, dm_lo, dm_hi),
                                      (at_lo, at_hi), where_end[:n], where_end[n:], r_above, r_below)
            return L, U, vm_lo, vm_hi
        r = np.maximum(r_above, r_below)
        smooth0 = ~v_jump
        smooth1 = smooth0 & ~d_jump
        with np.errstate(all="ignore"):
            # mean-value form
            mv = np.maximum(np.maximum(r_above * d_hi, -r_below * d_lo), 0.0)   # sup of v' (s - m)
            mv = mv + np.abs(mv) * 1e-12
            mv_low = np.maximum(np.maximum(-r_above * d_lo, r_below * d_hi), 0.0)   # sup of -v' (s - m)
            mv_low = mv_low + np.abs(mv_low) * 1e-12
            U_mv, L_mv = _up(vm_hi + mv), _down(vm_lo - mv_low)
            # Taylor form, for v and for -v
            U_t = _up(vm_hi + _upper_correction(dm_lo, dm_hi, e_hi, r_above, r_below))
            L_t = _down(vm_lo - _upper_correction(-dm_hi, -dm_lo, -e_lo, r_above, r_below))
            # monotone form: v' of one sign over the interval (its mean-value form where v' is continuous)
            de = r * np.maximum(e_hi, -e_lo)
            de = de + np.abs(de) * 1e-12
            dv_lo = np.where(smooth1 & (_down(dm_lo - de) > d_lo), _down(dm_lo - de), d_lo)
            dv_hi = np.where(smooth1 & (_up(dm_hi + de) < d_hi), _up(dm_hi + de), d_hi)
            rising, falling = smooth0 & (dv_lo >= 0), smooth0 & (dv_hi <= 0)
            a_lo, a_hi = at_lo[:, where_end[:n]], at_hi[:, where_end[:n]]   # v at lo
            b_lo, b_hi = at_lo[:, where_end[n:]], at_hi[:, where_end[n:]]   # v at hi
            U_m = np.where(rising, b_hi, np.where(falling, a_hi, np.inf))
            L_m = np.where(rising, a_lo, np.where(falling, b_lo, -np.inf))
        U = np.where(smooth0 & (U_mv < U), U_mv, U)
        L = np.where(smooth0 & (L_mv > L), L_mv, L)
        U = np.where(smooth1 & (U_t < U), U_t, U)
        L = np.where(smooth1 & (L_t > L), L_t, L)
        U = np.where(U_m < U, U_m, U)
        L = np.where(L_m > L, L_m, L)
        return L, U, vm_lo, vm_hi


def distinct_ends(lo, hi, cases=None):
    """(the distinct (case, value) pairs among the intervals' ends, ascending by case then value,
    each as its first end in the order lo then hi (an end equal in value to another, +0.0 and
    -0.0 included, is the same end: by s - s' != 0); each end's index among them, lo's then
    hi's; the case of each) of the intervals [lo, hi] of ``cases`` (None: one case; its cases
    None).  Where each case's intervals are consecutive and ascending, each ending where or
    before the next begins (a branch and bound's intervals, mostly), its ends are sorted
    already, taken in the order lo_0, hi_0, lo_1, hi_1, ...: found in one pass, the same
    arrays as the stable sort's (each group the same ends; its first in the order lo then hi,
    the smallest index), else (or with an infinite end) by that sort."""
    n = len(lo)
    if n > 1:
        s = np.empty(2 * n)   # (the ends in the order lo_0, hi_0, lo_1, hi_1, ...)
        s[0::2], s[1::2] = lo, hi
        c = None if cases is None else np.repeat(cases, 2)
        with np.errstate(invalid="ignore"):   # (NaN: not sorted; inf, whose copies the sort keeps apart: not taken)
            rising = (s[1:] >= s[:-1]) & (np.abs(s[1:]) < np.inf)
        new_case = None if c is None else c[1:] != c[:-1]
        if c is not None:
            rising |= new_case
        if np.logical_and.reduce(rising) and (c is None or np.logical_and.reduce(c[1:] >= c[:-1])):
            first = _first_of_each(s, new_case)
            group = first.cumsum() - 1
            where_end = np.empty(2 * n, int)
            where_end[:n], where_end[n:] = group[0::2], group[1::2]
            index = np.empty(2 * n, int)   # (each end's index in the order lo then hi)
            index[0::2], index[1::2] = np.arange(n), np.arange(n, 2 * n)
            head = np.minimum.reduceat(index, first.nonzero()[0])
            key_s = np.concatenate((lo, hi))
            return key_s[head], where_end, None if cases is None else np.concatenate((cases, cases))[head]
    key_s = np.concatenate((lo, hi))
    if cases is None:
        order = key_s.argsort(kind="stable")
    else:
        key_case = np.concatenate((cases, cases))
        order = np.lexsort((key_s, key_case))
    by_s = key_s[order]
    by_case = None if cases is None else key_case[order]
    first = _first_of_each(by_s, None if cases is None else by_case[1:] != by_case[:-1])
    where_end = np.empty(2 * n, int)
    where_end[order] = first.cumsum() - 1
    return by_s[first], where_end, None if cases is None else by_case[first]


def _first_of_each(s, new_case):
    """Of the ends ``s`` in order, those that differ from the one before (by s - s' != 0, so
    that +0.0 and -0.0 are one end) or begin a new case (``new_case[k]``: end k + 1 is another
    case's than end k; None: one case)."""
    first = np.empty(len(s), bool)
    first[:1] = True
    np.not_equal(s[1:] - s[:-1], 0, out=first[1:])
    if new_case is not None:
        first[1:] |= new_case
    return first


class Unavailable:
    """No enclosure, and why: :func:`~.peaks.certify` reports its quantities as not certified."""

    def __init__(self, reason: str):
        self.reason = reason

    def __repr__(self):
        return f"Unavailable({self.reason!r})"


class Enclosures:
    """The interval program of one Function (s, p) -> (v, dv/ds, d2v/ds2), built once; ``at(p)``
    gives its :class:`Enclosure` at parameters p, or :class:`Unavailable` with the reason.
    ``compile``: a function that returns the program's compiled twin (called as the program is:
    :func:`optdesign.model.intervals_compiled.compile_program`), or the program itself."""

    def __init__(self, func, compile=None):
        self.program, self.reason = interval_program(func)
        if compile is not None and self.program is not None:
            self.program = compile(self.program)

    def at(self, p):
        return Unavailable(self.reason) if self.program is None else Enclosure(self.program, p)


class Selected:
    """An enclosure of some rows of another, each times a sign (+1/-1): what a caller that
    certifies sign * v of a subset of a Function's rows passes on (an :class:`Unavailable`
    stays one).  ``case_sign``: of many cases (an Enclosure of many), each case's rows times its
    own sign as well."""

    def __init__(self, enclosure, rows, sign, case_sign=None):
        self.enclosure, self.rows = enclosure, np.asarray(rows, int)
        self.sign = np.asarray(sign, float)[:, None]
        self.case_sign = None if case_sign is None else np.asarray(case_sign, float)
        self.reason = getattr(enclosure, "reason", None)

    def bounds(self, lo, hi, rows=None, cases=None, centre=None):
        inner = None if rows is None else self.rows[np.asarray(rows, int)]
        L, U, m_lo, m_hi = (a[self.rows] for a in self.enclosure.bounds(lo, hi, inner, cases, centre))
        sign = self.sign if self.case_sign is None else self.sign * self.case_sign[np.asarray(cases, int)][None, :]
        up = sign > 0
        return (np.where(up, L, -U), np.where(up, U, -L), np.where(up, m_lo, -m_hi), np.where(up, m_hi, -m_lo))
