"""The one certification of extrema (:mod:`.peaks`), over many cases at once.

A batch is N cases of the same rows, sampled on the same grid, that differ in their parameters
(a study's cases; one case is the batch of one).  Every request of every case is a *task*: the
sampled grid maxima of its target bracket continuous ones, which safeguarded Newton steps refine
(:func:`newton`, all brackets of all tasks in lockstep, as arrays); the enclosure then proves
them or finds better ones (:func:`~.branch_bound.certify`).  Every decision is taken per case
(a case's numbers never depend on the other cases of its batch or its place in it), and the
work is numpy over arrays of brackets and intervals, with one evaluation of the rows per step
for the whole batch: no Python work per case.

``evaluate(s, cases) -> (V, dV/ds, d2V/ds2)``, each rows x len(s): every row at s[j] with the
parameters of case cases[j].
"""
from __future__ import annotations

import numpy as np

MAX_STEPS = 200  # Newton/bisection steps per bracket (bisection alone gets to 1e-13 of it in ~45)
SENSES = ("abs", "max", "min")


def distinct(s, cases):
    """The distinct (case, s) pairs among ``s`` and ``cases``, in the order they first appear (s
    by its bits: +0.0 and -0.0 kept apart, so that each is evaluated at exactly the value asked
    for), and the index of each pair among them."""
    s, cases = np.asarray(s, float), np.asarray(cases, np.int64)
    bits = s.view(np.int64)
    order = np.lexsort((bits, cases))
    c, b = cases[order], bits[order]
    first = _starts((c[1:] != c[:-1]) | (b[1:] != b[:-1]), len(s))
    group = np.empty(len(s), int)
    group[order] = first.cumsum() - 1
    # the groups in the order of their first appearance (order[first] is each group's first
    # index, all distinct: sorted by their argsort)
    heads = order[first]
    by_place = heads.argsort(kind="stable")
    rank = np.empty(len(heads), int)
    rank[by_place] = np.arange(len(heads))
    firsts = heads[by_place]
    return s[firsts], cases[firsts], rank[group]


def newton(evaluate, cases, rows, lo, hi, s0, sign, s_tol=1e-13):
    """Maximise sign * v_row on each bracket [lo, hi] (arrays, one entry per bracket, of its
    case, row, ends, grid point s0 and sign) by Newton on dv/ds = 0, safeguarded by bisection.

    A bracket without a sign change of dv/ds (sign * dv/ds(lo) > 0 > sign * dv/ds(hi)) keeps its
    grid point.  Otherwise from s0: the bracket's end on the rising side moves to s; the Newton
    step is taken when dv''(s) < 0 and it stays in the closed bracket (one that lands on the end
    just moved to s is a step of about nothing: convergence), else the bisection; it stops when
    the step or the bracket is below s_tol (relative to max(1, |s|)) with the value at the new
    point, or after MAX_STEPS steps.  Returns (s, v(s)) arrays."""
    cases, rows = np.asarray(cases, int), np.asarray(rows, int)
    lo, hi, s0, sign = (np.asarray(a, float) for a in (lo, hi, s0, sign))   # (read only: s_out is s0's copy)
    n = len(s0)
    if not n:
        return np.zeros(0), np.zeros(0)
    points, point_case, index = distinct(np.concatenate((lo, hi, s0)), np.concatenate((cases, cases, cases)))
    V, D1, D2 = (np.asarray(a, float) for a in evaluate(points, point_case))
    at = rows * len(points) + index.reshape(3, n)   # (each bracket's row at its lo, hi and s0, flat: V[rows, i])
    s_out, v_out = s0.copy(), V.take(at[2])
    with np.errstate(invalid="ignore"):
        going = ~((sign * D1.take(at[0]) <= 0) | (sign * D1.take(at[1]) >= 0))
    k = going.nonzero()[0]
    sign, rows, cases = sign[k], rows[k], cases[k]   # (the unfinished brackets', filtered as k is)
    s, lo, hi, at = s0[k], lo[k], hi[k], at[2, k]
    d1, d2 = sign * D1.take(at), sign * D2.take(at)
    steps = 0
    with np.errstate(all="ignore"):
        while len(k):
            rising = d1 > 0
            lo, hi = np.where(rising, s, lo), np.where(rising, hi, s)
            step = s - d1 / d2
            s_new = np.where((d2 < 0) & (lo <= step) & (step <= hi), step, 0.5 * (lo + hi))
            small = s_tol * np.fmax(1.0, np.abs(s))
            done = (np.abs(s_new - s) <= small) | (hi - lo <= small)
            V, D1, D2 = (np.asarray(a, float) for a in evaluate(s_new, cases))
            at = rows * len(s_new) + np.arange(len(k))   # (each bracket's row at its own point, flat: V[rows, j])
            v_new = V.take(at)
            steps += 1
            if steps >= MAX_STEPS:   # the last point evaluated, converged or not
                done[:] = True
            s = s_new
            if np.count_nonzero(done):   # (no bracket done: none to drop)
                s_out[k[done]], v_out[k[done]] = s_new[done], v_new[done]
                keep = ~done
                k, s, lo, hi, sign, rows, cases, at = k[keep], s[keep], lo[keep], hi[keep], sign[keep], rows[keep], \
                    cases[keep], at[keep]
            d1, d2 = sign * D1.take(at), sign * D2.take(at)
    return s_out, v_out


def _starts(changes, n):
    """Where a run of equal sorted keys starts: True, then ``changes`` (n - 1 of them; n = 0: none)."""
    out = np.empty(n, bool)
    out[:1] = True
    out[1:] = changes
    return out


class Tasks:
    """The requests of N cases as flat arrays, one entry per (case, request): ``case``,
    ``request`` (its index), ``row``, ``code`` (the sense, an index into SENSES),
    ``only_above`` (-inf for none), ``ends``, ``tol`` (NaN: the default; a request's may be one
    per case).  Read only: :meth:`of` hands the same Tasks to every call with equal requests."""

    _made = {}   # (requests, cases) -> Tasks, for requests that hash (a tol per case does not)

    def __init__(self, requests, n_cases):
        k = len(requests)
        self.requests, self.n_cases = requests, n_cases
        self.case = np.arange(n_cases).repeat(k)
        self.request = np.arange(n_cases * k) % max(k, 1)
        self.row = np.array([r.row for r in requests], int)[self.request]
        self.code = np.array([SENSES.index(r.sense) for r in requests], int)[self.request]
        self.only_above = np.array([-np.inf if r.only_above is None else r.only_above for r in requests])[self.request]
        self.ends = np.array([bool(r.ends) for r in requests], bool)[self.request]
        tol = np.full((n_cases, k), np.nan)   # (a request's tol: one number, or one per case)
        for j, r in enumerate(requests):
            if r.tol is not None:
                tol[:, j] = r.tol
        self.tol = tol.ravel()
        # (what the calls ask of them again and again: whether any task is a max, a min, has a floor)
        self.is_max, self.is_min = self.code == 1, self.code == 2
        self.any_max, self.any_min = bool(self.is_max.any()), bool(self.is_min.any())
        self.any_above = bool((self.only_above > -np.inf).any())
        for a in (self.case, self.request, self.row, self.code, self.only_above, self.ends, self.tol, self.is_max,
                  self.is_min):
            a.flags.writeable = False

    @classmethod
    def of(cls, requests, n_cases):
        """The Tasks of ``requests`` for ``n_cases`` cases, made once per distinct requests (they
        are read only)."""
        try:
            key = (tuple(requests), n_cases)
            made = cls._made.get(key)
        except TypeError:   # (a tol given per case: an array)
            return cls(requests, n_cases)
        if made is None:
            if len(cls._made) > 256:
                cls._made.clear()
            made = cls._made[key] = cls(requests, n_cases)
        return made

    @classmethod
    def joined(cls, parts):
        """The Tasks of several calls' Tasks in one (:func:`~.joint.maxima_together`): part q's
        cases numbered after the earlier parts' (cases of different parts are never one case),
        its rows after theirs (``parts``: (tasks, rows) each, rows the number of its rows); each
        task's request an index into the requests of all parts, in order.  Read only: made once
        per parts (the key holds the Tasks themselves, so that their ids stay theirs)."""
        key = tuple(parts)
        made = cls._joined.get(key)
        if made is None:
            if len(cls._joined) > 256:
                cls._joined.clear()
            made = cls._joined[key] = cls._join(parts)
        return made

    _joined = {}

    @classmethod
    def _join(cls, parts):
        out = cls.__new__(cls)
        cases = rows = requests = 0
        pieces = []
        for tasks, n_rows in parts:
            pieces.append((tasks.case + cases, tasks.request + requests, tasks.row + rows))
            cases, rows, requests = cases + tasks.n_cases, rows + n_rows, requests + len(tasks.requests)
        out.requests = tuple(r for tasks, _ in parts for r in tasks.requests)
        out.n_cases = cases
        out.case, out.request, out.row = (np.concatenate(a) for a in zip(*pieces))
        for name in ("code", "only_above", "ends", "tol", "is_max", "is_min"):
            setattr(out, name, np.concatenate([getattr(tasks, name) for tasks, _ in parts]))
        out.any_max, out.any_min = bool(out.is_max.any()), bool(out.is_min.any())
        out.any_above = bool((out.only_above > -np.inf).any())
        for a in (out.case, out.request, out.row, out.code, out.only_above, out.ends, out.tol, out.is_max, out.is_min):
            a.flags.writeable = False
        return out

    def __len__(self):
        return len(self.case)

    def sign(self, values):
        """+1/-1 per value (tasks x anything) such that sign * v is the task's target."""
        sign = np.where(np.asarray(values) < 0, -1.0, 1.0)
        if self.any_max:   # (whole rows: a max's and a min's sign do not depend on v)
            sign[self.is_max] = 1.0
        if self.any_min:
            sign[self.is_min] = -1.0
        return sign


def target(values, code):
    """The target of values (sign * v) for senses ``code`` (same shape, or broadcast)."""
    return np.where(code == 1, values, np.where(code == 2, -values, np.abs(values)))


class Found:
    """The located extrema of every task, in the order they were found (flat arrays: task, s, v),
    the largest target per task first among equals (as a stable sort, descending, would put it)."""

    def __init__(self, n_tasks):
        self.n_tasks = n_tasks
        self.task, self.s, self.v = np.zeros(0, int), np.zeros(0), np.zeros(0)
        self._best = None   # (code, what best(code) gave) until the next add

    def add(self, task, s, v):
        self._best = None
        self.task = np.concatenate((self.task, np.asarray(task, int)))
        self.s, self.v = np.concatenate((self.s, np.asarray(s, float))), np.concatenate((self.v, np.asarray(v, float)))

    def best(self, code):
        """Per task: the index into the arrays of its largest target (the first among equals),
        and that target (-inf where a task has none)."""
        if self._best is not None and self._best[0] is code:
            return self._best[1]
        t = target(self.v, code[self.task])
        n, none = self.n_tasks, len(t)
        best = np.empty(n)
        best.fill(-np.inf)
        np.fmax.at(best, self.task, t)   # (NaN left out)
        top = np.empty(n, int)
        top.fill(none)
        hit = (t == best[self.task]).nonzero()[0]
        np.minimum.at(top, self.task[hit], hit)   # the first among equals
        if np.count_nonzero(top == none):   # a task with NaN targets only: its first; a task with none: -1
            first = np.full(n, none)
            np.minimum.at(first, self.task, np.arange(none))
            nan_only = (top == none) & (first < none)
            best[nan_only] = np.nan
            top = np.where(top < none, top, np.where(first < none, first, -1))
        top.flags.writeable, best.flags.writeable = False, False   # (shared by the calls until the next add)
        self._best = (code, (top, best))
        return top, best


def grid_brackets(tasks, s_grid, V, found, T=None):
    """Every task's candidates on the grid: the stroke's two ends (found), its flat row's largest
    sample (found), and brackets (arrays task, lo, hi, s0, sign, i: the grid point's index) of
    its interior grid maxima and, with ``ends``, of its end intervals refined from the end; then
    the samples of each task's row T (tasks x samples) and each task's largest sampled target.
    ``T``: those samples where the caller has them (``V`` is then not read)."""
    if T is None:
        T = V[tasks.case, tasks.row]   # tasks x samples
    S = T.shape[1]
    sign = tasks.sign(T)
    tgt = sign * T
    n = len(tasks)
    ends = np.empty((n, 2))
    ends[:, 0], ends[:, 1] = s_grid[0], s_grid[-1]
    found.add(np.arange(n).repeat(2), ends.ravel(), T[:, [0, -1]].ravel())
    with np.errstate(invalid="ignore"):
        high, low = np.maximum.reduce(T, axis=1), np.minimum.reduce(T, axis=1)   # (max |T|: the larger of theirs)
        flat = high - low <= 1e-14 * np.maximum(np.maximum(np.abs(high), np.abs(low)), 1e-300)   # (np.ptp's)
        inner = tgt[:, 1:-1]
        is_max = (inner >= tgt[:, :-2]) & (inner >= tgt[:, 2:])
        if tasks.any_above:
            is_max &= ~(inner < tasks.only_above[:, None])
    any_flat = np.count_nonzero(flat) > 0
    if any_flat:
        is_max &= ~flat[:, None]
        top = tgt[flat].argmax(axis=1)
        found.add(flat.nonzero()[0], s_grid[top], T[flat][np.arange(len(top)), top])
    t, i = is_max.nonzero()
    i = i + 1
    parts = [(t, np.minimum(s_grid[i - 1], s_grid[i + 1]), np.maximum(s_grid[i - 1], s_grid[i + 1]), s_grid[i], i)]
    if S >= 2:   # the end intervals, refined from their end sample, after the interior ones (per task)
        te = [(tasks.ends & np.isfinite(T[:, end])).nonzero()[0] for end in (0, S - 1)]
        which = [len(x) for x in te]   # (how many of each: the first sample's interval, then the last's)
        at, by = s_grid[[0, S - 1]].tolist(), s_grid[[1, S - 2]].tolist()   # (each end sample and its neighbour)
        low = [b if b < a else a for a, b in zip(at, by)]   # (min and max as Python's: by where by < at, else at)
        high = [b if b > a else a for a, b in zip(at, by)]
        parts.append((np.concatenate(te), np.repeat(low, which), np.repeat(high, which), np.repeat(at, which),
                      np.repeat([0, S - 1], which)))
    bt, blo, bhi, bs0, bi = (np.concatenate(a) for a in zip(*parts))
    order = bt.argsort(kind="stable")
    bt, blo, bhi, bs0, bi = bt[order], blo[order], bhi[order], bs0[order], bi[order]
    return bt, blo, bhi, bs0, sign[bt, bi], bi, T, np.maximum.reduce(tgt, axis=1)


def check_invariant(tasks, T, found, top, best, sampled=None):
    """The largest located target of a task is never below its largest sampled one (those above
    ``only_above``; rows with a NaN sample are not checked): a certification that fails this
    check is an error, never a result.  ``sampled``: each task's largest sampled target, where
    known (:func:`grid_brackets`')."""
    if not T.size:
        return
    if sampled is None:
        sampled = (tasks.sign(T) * T).max(axis=1)
    checked = np.logical_and.reduce(np.isfinite(T), axis=1) & ~(sampled < tasks.only_above)
    bad = (checked & ~(best >= sampled)).nonzero()[0]
    if len(bad):
        from ..errors import ResultError

        k = bad[0]
        r = tasks.requests[tasks.request[k]]
        raise ResultError(f"the certified extremum ({r.sense}) of row {r.row}, {found.v[top[k]]!r} at s = "
                          f"{found.s[top[k]]!r}, is below the largest sampled one ({sampled[k]!r}): the "
                          "certification failed its own check")
