"""A pre-filter of the one certification's first pass (:func:`~.branch_bound.certify`) for a
batch of cases that differ in parameters entering the rows affinely (a study of masses).

A row v(s, p) whose graph is affine in the parameters m (a subset of p: a study's axes) is, in
exact arithmetic, v = v_0(s) + sum_k m_k v_k(s), with v_0 the row at m = 0 and v_k = dv/dm_k,
neither depending on m.  Whether a row is affine is read from the graph's structure
(:func:`affine_rows`: the degree in m of every instruction, never by sampling); where it is not,
the row has no parts and is never pre-filtered.  The parts' enclosure over an interval of s
(:class:`~.enclosure.Enclosure`, the same forms as the rows') is computed once per distinct
interval of the batch (and distinct value of the other parameters: a batch of masses, once), and
a case's bounds of v over the interval are the linear combination of the parts' bounds with its
own m (each part's upper or lower bound by the sign of m_k), moved outward by a bound on the
combination's floating-point rounding (:meth:`Prefiltered.upper`).  So the pre-filter's upper
bound of a task's target over an interval holds for every s in it, as the per-case enclosure's
does, and is looser by what the forms gain on v itself rather than on its parts.

Used only to skip: an interval whose pre-filter bound is already <= its tasks' best located
value needs no per-case enclosure, closes, and its midpoint could not have located a better
extremum (its midpoint's value is below that bound); so the located extrema do not change.
"""
from __future__ import annotations

import itertools

import casadi as ca
import numpy as np

from .enclosure import Enclosures

SHARE = 0.2   # pre-filter a pass only where the distinct parts' intervals are at most this fraction
#               of the distinct (case, interval)s (else the parts cost about what they save)
ROUND = 2.0 ** -50   # per term of a combination: covers its 2K + 1 roundings (each <= 2^-53 of the terms' sum)
TINY = 1e-300

_AFFINE = {ca.OP_ADD: "max", ca.OP_SUB: "max", ca.OP_MUL: "sum", ca.OP_NEG: "same", ca.OP_ASSIGN: "same",
           ca.OP_TWICE: "same", ca.OP_DIV: "num", ca.OP_IF_ELSE_ZERO: "value"}
NONLINEAR = 2   # (a degree above 1: not affine)
COMPARISONS = {ca.OP_LT, ca.OP_LE, ca.OP_EQ, ca.OP_NE}
MAX_CONDITIONS = 2   # comparisons of values that depend on the parameters taken both ways at most


def affine_rows(func: ca.Function, params) -> np.ndarray:
    """Per row of ``func``'s first output (an SX Function of (s, p)), whether it is affine in
    the parameters ``params`` (indices into p) by the graph's structure (:func:`degrees`)."""
    return degrees(func, params)[0] <= 1


def degrees(func: ca.Function, params):
    """(per row of ``func``'s first output its degree in the parameters ``params``, the
    comparisons (instruction numbers) whose operands depend on them), by the graph's structure:
    each instruction's degree (0 free of them, 1 affine, 2 anything else): an input of them 1;
    +, - the larger of their operands'; * the sum; / the numerator's where the denominator's is
    0; if_else_zero(c, x) x's where c's is 0; -x and copies x's; any other operation 0 where all
    its operands are 0, else 2.  A row of degree <= 1 is a polynomial of degree 1 in them with
    coefficients free of them: affine, exactly (in exact arithmetic)."""
    chosen = {int(k) for k in params}
    comparisons = []

    def degree_of(k, op, i, degree):
        if op == ca.OP_INPUT:
            return 1 if (i[0] == 1 and i[1] in chosen) else 0
        if op == ca.OP_CONST:
            return 0
        ins = [degree[x] for x in i]   # (the operands: one or two)
        rule = _AFFINE.get(op)
        if rule == "max":
            d = max(ins)
        elif rule == "sum":
            d = ins[0] + ins[1]
        elif rule == "same":
            d = ins[0]
        elif rule == "num":
            d = ins[0] if ins[1] == 0 else NONLINEAR
        elif rule == "value":
            d = ins[1] if ins[0] == 0 else NONLINEAR
        else:
            d = 0 if max(ins, default=0) == 0 else NONLINEAR
            if d and op in COMPARISONS:
                comparisons.append(k)
        return min(d, NONLINEAR)
    out = _walk(func, np.zeros(func.sz_w(), int), degree_of)
    return np.array([0 if d is None else d for d in out], int), comparisons


def rebuilt(func: ca.Function, inputs, forced: dict) -> list:
    """The rows of ``func``'s first output as SX expressions of ``inputs`` (its instructions
    again), the instructions ``forced`` (number -> value) replaced by those constants."""
    def value(k, op, i, work):
        if k in forced:
            return ca.SX(forced[k])
        if op == ca.OP_INPUT:
            return inputs[i[0]][i[1]]
        if op == ca.OP_CONST:
            return ca.SX(float(func.instruction_constant(k)))
        if len(i) == 2:
            return ca.SX.binary(op, work[i[0]], work[i[1]])
        return ca.SX.unary(op, work[i[0]])
    out = _walk(func, [None] * func.sz_w(), value)
    return [ca.SX(0.0) if x is None else x for x in out]


def _walk(func: ca.Function, work, value) -> list:
    """``func``'s instructions in order, each one's result ``value(k, op, inputs, work)`` kept in
    ``work``; its first output's rows as read from ``work`` (None where a row is structurally zero)."""
    out = [None] * func.size1_out(0)
    rows = func.sparsity_out(0).row()
    for k in range(func.n_instructions()):
        op, i, o = func.instruction_id(k), func.instruction_input(k), func.instruction_output(k)
        if op == ca.OP_OUTPUT:
            if o[0] == 0:
                out[rows[o[1]]] = work[i[0]]
            continue
        work[o[0]] = value(k, op, i, work)
    return out


class LinearParts:
    """The parts v_0, v_1 .. v_K of the rows ``rows`` (SX expressions of (s, p) of ``mech``)
    affine in the parameters ``params`` (indices into p), as one Function (s, p) -> (v, dv/ds,
    d2v/ds2) of the stacked parts and its enclosures.  A row whose graph compares values that
    depend on them (a drive's efficiency, 1/eta or eta by the sign of the power) is taken as
    each of its branches (every outcome of those comparisons, at most 2^MAX_CONDITIONS): at
    every s and p the row equals one of them, so the largest of their bounds bounds it.
    ``index[r]`` is row r's first part (each branch's v_0 then its v_k, ``branches`` of them),
    -1 for a row without (not affine, or its derivative in them still reads them: a
    cross-check of :func:`degrees`).  ``any``: whether some row has parts."""

    def __init__(self, mech, rows, params, compile=None):
        self.params = np.asarray(params, int)
        self.index = np.full(len(rows), -1)
        self.enclosures, self.branches, self._any = None, 1, None
        self._making = (mech, rows, compile)

    @property
    def any(self) -> bool:
        if self._any is None:   # (built at the first use: a study's first batch of several cases)
            self._any = False
            self._build(*self._making)
        return self._any

    def _build(self, mech, rows, compile):
        K = len(self.params)
        if not K or not rows or mech.sym is not ca.SX:   # (an MX graph: a Newton-closed loop, no interval program)
            return
        func = mech.function("rows_affine", {"v": ca.vertcat(*rows)})
        _, conditions = degrees(func, self.params)
        if len(conditions) > MAX_CONDITIONS:
            return
        versions = [rebuilt(func, (mech.s, mech.p), dict(zip(conditions, bits)))
                    for bits in itertools.product((0.0, 1.0), repeat=len(conditions))]
        self.branches = len(versions)
        flags = np.logical_and.reduce([affine_rows(ca.Function("branch", [mech.s, mech.p], [ca.vertcat(*v)]),
                                                   self.params) for v in versions])
        m = ca.vertcat(*[mech.p[int(k)] for k in self.params])
        parts = []
        for r in range(len(rows)):
            if not flags[r]:
                continue
            J = [ca.jacobian(v[r], m) for v in versions]
            if any(ca.depends_on(j, m) for j in J):
                continue
            self.index[r] = len(parts)
            for v, j in zip(versions, J):
                parts += [ca.substitute(v[r], m, ca.DM.zeros(K))] + [j[k] for k in range(K)]
        if parts:
            v = ca.vertcat(*parts)
            dv = mech.ds(v)
            func = mech.function("prefilter_parts", {"v": v, "dv": dv, "d2v": mech.ds(dv)})
            self.enclosures = Enclosures(func, compile)
            if self.enclosures.reason is None:
                self._any = True
            else:
                self.index[:] = -1

    @classmethod
    def of_axes(cls, mech, rows, compile=None):
        """The parts of ``rows`` in the study's axes (none where an axis is not a leaf parameter)."""
        axes = mech.resolved.axes
        known = bool(axes) and all(a in mech.parameter_names for a in axes)
        return cls(mech, rows, [mech.parameter_names.index(a) for a in axes] if known else [], compile)

    def at(self, enclosure, P):
        """``enclosure`` (of the cases ``P``: cases x parameters) with this pre-filter
        (:class:`Prefiltered`), or itself where there is nothing to pre-filter or where the
        rows' program is compiled and the parts' not (yet: compiled in the background as the
        others are; its numpy would cost more than it saves)."""
        P = np.atleast_2d(np.asarray(P, float))
        if len(P) < 2 or getattr(enclosure, "reason", None) is not None or not self.any:
            return enclosure
        compiled = [getattr(e.program, "subsets_pay", False) for e in (enclosure, self.enclosures)]
        if compiled[0] and not compiled[1]:
            return enclosure
        return Prefiltered(enclosure, self, P)


class Prefiltered:
    """An :class:`~.enclosure.Enclosure` of many cases (its :meth:`bounds` the same) with
    :meth:`upper`, the pre-filter's bounds of the tasks' targets over the first pass's intervals."""

    reason = None

    def __init__(self, enclosure, parts: LinearParts, P):
        self.enclosure, self.parts = enclosure, parts
        M = P[:, parts.params]   # each case's m, as m+ + m- (m+ >= 0 >= m-; a column of one sign: one of them)
        self.plus, self.minus = np.maximum(M, 0.0), np.minimum(M, 0.0)
        self.signs = [(bool((M[:, k] > 0).any()), bool((M[:, k] < 0).any())) for k in range(M.shape[1])]
        self.size = np.abs(M)
        self.largest = self.size.max(axis=0)   # (the margin's: >= every case's |m_k|)
        Q = P.copy()
        Q[:, parts.params] = 0.0   # (the parts do not read m)
        _, first, inverse = np.unique(np.ascontiguousarray(Q).view(np.int64), axis=0, return_index=True,
                                      return_inverse=True)
        self.Q, self.group = Q[first], inverse.ravel()

    def bounds(self, lo, hi, rows=None, cases=None, centre=None):
        return self.enclosure.bounds(lo, hi, rows, cases, centre)

    def upper(self, lo, hi, cases, row, where, code, best):
        """Per entry (its task's ``row``, ``code`` (the sense), ``best`` (its best located
        target) and interval ``where``: an index into the distinct (case, interval)s ``lo``,
        ``hi``, ``cases``) an upper bound of its target over its interval (inf where its row has
        no parts or the interval is one case's alone), or None where the parts' distinct
        intervals would be too many to pay (SHARE).  First |v| <= S_0 + sum_k |m_k| S_k (S_k
        the largest |bound| of part k over the row's branches), one sum per entry; where that
        is above ``best``, the bound below (of v, per branch, the largest of them).

        Per branch of the row, with each part's enclosure [L_k, U_k] over the interval: v <=
        U_0 + sum_k (m+_k U_k + m-_k L_k) and v >= L_0 + sum_k (m+_k L_k + m-_k U_k), moved
        out by (K + 1) 2^-50 (|U_0| or |L_0| + sum_k max|m_k| max(|L_k|, |U_k|)) + (K + 1)
        1e-300: the 2K + 1 roundings of the sum and its products, each within 2^-53 of the
        terms' sum (and a subnormal's absolute error), four times over."""
        from .branch_bound import target_bound   # (branch_bound calls this)

        parts = self.parts
        index = np.full(len(row), -1)
        ok = row < len(parts.index)
        index[ok] = parts.index[row[ok]]
        e = (index >= 0).nonzero()[0]
        if not len(e) or not len(lo):
            return None
        g = self.group.take(cases)   # the distinct (group of the other parameters, interval)s
        bits_lo, bits_hi = lo.view(np.int64), hi.view(np.int64)
        order = np.lexsort((bits_hi, bits_lo, g))
        new = np.ones(len(order), bool)
        a, b, c = bits_lo[order], bits_hi[order], g[order]
        new[1:] = (c[1:] != c[:-1]) | (a[1:] != a[:-1]) | (b[1:] != b[:-1])
        d_of = np.empty(len(lo), int)
        d_of[order] = new.cumsum() - 1
        # only the intervals of several cases (one case's own, about its maximum, mostly needs its enclosure)
        shared = np.bincount(d_of)[d_of] > 1
        e = e[shared.take(where.take(e))]
        if not len(e):
            return None
        K, A = len(parts.params), parts.branches
        asked = np.bincount(index.take(e)).nonzero()[0]
        part_rows = (asked[:, None] + np.arange(A * (K + 1))[None, :]).ravel()
        many = len(self.Q) > 1
        used = np.zeros(np.count_nonzero(new), bool)
        used[d_of.take(where.take(e))] = True
        if np.count_nonzero(used) > SHARE * len(lo):
            return None
        pick = order[new][used]
        d_of = (used.cumsum() - 1)[d_of]
        enclosure = parts.enclosures.at(self.Q if many else self.Q[0])
        L, U, _, _ = enclosure.bounds(lo[pick], hi[pick], part_rows, g[pick] if many else None)
        n_d = L.shape[1]
        with np.errstate(all="ignore"):
            # each branch's margin, with the batch's largest |m_k|, added to its v_0's bounds
            size = np.maximum(np.abs(L), np.abs(U))
            blocks = size.reshape(-1, K + 1, n_d)[:, 0]
            for k in range(K):
                blocks = blocks + self.largest[k] * size.reshape(-1, K + 1, n_d)[:, k + 1]
            margin = (K + 1) * ROUND * blocks + (K + 1) * TINY
            U0, L0 = U.copy(), L.copy()
            U0.reshape(-1, K + 1, n_d)[:, 0] += margin
            L0.reshape(-1, K + 1, n_d)[:, 0] -= margin
            where_e = where.take(e)
            d, case = d_of.take(where_e), cases.take(where_e)
            # first |v| <= S_0 + sum_k |m_k| S_k (S_k: the largest |bound| of part k over the
            # branches), moved out as below: one sum per entry, where most entries close
            S = size.reshape(-1, A, K + 1, n_d).max(axis=1)   # (a row's branches' parts follow one another)
            outer = S[:, 0] + sum(self.largest[k] * S[:, k + 1] for k in range(K))
            S[:, 0] += (K + 1) * ROUND * outer + (K + 1) * TINY
            at = index.take(e) // (A * (K + 1)) * ((K + 1) * n_d) + d
            first = S.take(at)
            for k in range(K):
                first += self.size[:, k].take(case) * S.take(at + (k + 1) * n_d)
            ub = np.full(len(row), np.inf)
            ub[e] = first
            rest = ~(first <= best.take(e))
            e, d, case = e[rest], d[rest], case[rest]
            base, code = index.take(e), code.take(e)
            plus = [self.plus[:, k].take(case) if self.signs[k][0] else None for k in range(K)]
            minus = [self.minus[:, k].take(case) if self.signs[k][1] else None for k in range(K)]
            for branch in range(A):
                at = (base + branch * (K + 1)) * n_d + d
                high, low = U0.take(at), L0.take(at)
                for k in range(K):
                    at = at + n_d
                    lo_k, hi_k = L.take(at), U.take(at)
                    if plus[k] is not None:
                        high, low = high + plus[k] * hi_k, low + plus[k] * lo_k
                    if minus[k] is not None:
                        high, low = high + minus[k] * lo_k, low + minus[k] * hi_k
                got = target_bound(low, high, code, upper=True)
                ub[e] = got if branch == 0 else np.maximum(ub[e], got)   # (NaN stays: not skipped)
        return ub
