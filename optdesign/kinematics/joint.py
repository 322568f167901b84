"""Several calls of the one certification (:func:`~.peaks.maxima`) of rows of one Function on
the same grid in one: one set of grid brackets, one Newton iteration and one branch and bound
for all of them (:func:`~.branch_bound.certify`), each call's numbers bit for bit what it gives
alone.

A certified analysis certifies its assembly margins (:mod:`.assembly`) and its peaks and
extremes (:mod:`optdesign.model.certified`) with two Functions and two calls; each call has a
fixed cost (its own evaluations of its own Function and interval program, each with its
overhead, and the numpy work of the branch and bound) whatever its size: on the slider crank
the assembly margins' call, one row, cost as much as half the extremes' four.  Here the rows of
both are one Function's (the same expressions, so the same numbers), and each call is a
*part*: its cases are numbered after the earlier parts' (:meth:`~.extrema.Tasks.joined`), so
that no interval, grid point or decision is shared between parts (a case's intervals are cut
about its own tasks' maxima only, as alone), and its rows after theirs.  A point is evaluated
once for all rows, an interval the parts have in common (the blocks away from every maximum)
once (:class:`Distinct`): each point's and interval's numbers are its own whatever else is
evaluated with it (:mod:`.extrema`).
"""
from __future__ import annotations

import numpy as np

from .branch_bound import certify
from .extrema import Found, Tasks, check_invariant, grid_brackets, newton


def maxima_together(s_grid, parts, evaluate, enclosure, s_tol=1e-13):
    """:func:`~.peaks.maxima` of every part (``parts``: (V, requests) each, as
    :func:`~.peaks.maxima`'s arguments: V cases x rows x samples, part q's rows those of the
    Function after the rows of the parts before it) on the ascending ``s_grid``, in one, with
    ``evaluate(s, cases)`` and ``enclosure`` of the Function's rows at one parameter vector
    (every case's).  Returns (found, top, bound, notes, first): :func:`~.peaks.maxima`'s
    results over the tasks of all parts, part q's tasks from ``first[q]`` on
    (:func:`~.peaks.extrema_lists`, :func:`~.peaks.maxima_arrays`)."""
    s_grid = np.asarray(s_grid, float)
    Vs = [np.asarray(V, float) for V, _ in parts]
    own = [Tasks.of(requests, V.shape[0]) for V, (_, requests) in zip(Vs, parts)]
    tasks = Tasks.joined([(t, V.shape[1]) for t, V in zip(own, Vs)])
    T = np.concatenate([V[t.case, t.row] for t, V in zip(own, Vs)])
    found = Found(len(tasks))
    bt, blo, bhi, bs0, bsign, bi, T, sampled = grid_brackets(tasks, s_grid, None, found, T)
    s_star, v_star = newton(evaluate, tasks.case[bt], tasks.row[bt], blo, bhi, bs0, bsign, s_tol)
    v_i = T[bt, bi]
    worse = bsign * v_star < bsign * v_i   # never less than the grid point itself
    found.add(bt, np.where(worse, s_grid[bi], s_star), np.where(worse, v_i, v_star))
    bound, notes = certify(enclosure, evaluate, tasks, s_grid, T, found, s_tol)
    top, best = found.best(tasks.code)
    check_invariant(tasks, T, found, top, best, sampled)
    first = np.concatenate(([0], np.cumsum([len(t) for t in own])))
    return found, top, bound, notes, first[:-1].tolist()


class Distinct:
    """An :class:`~.enclosure.Enclosure` of one case (its parameters one row) whose
    :meth:`bounds` evaluates each distinct (lo, hi, expansion point) once, whatever the case
    numbers (the parts of :func:`maxima_together`: the same parameters), every row asked on
    each."""

    reason = None

    def __init__(self, enclosure):
        self.enclosure = enclosure

    def bounds(self, lo, hi, rows=None, cases=None, centre=None):
        lo, hi = np.asarray(lo, float), np.asarray(hi, float)
        m = 0.5 * (lo + hi)   # (the expansion point as Enclosure.bounds takes it)
        if centre is not None:
            with np.errstate(invalid="ignore"):
                m = np.where((lo <= centre) & (centre <= hi), centre, m)
        a, b, c = lo.view(np.int64), hi.view(np.int64), m.view(np.int64)   # (by the bits)
        order = np.lexsort((c, b, a))
        a, b, c = a[order], b[order], c[order]
        new = np.empty(len(lo), bool)
        new[:1] = True
        new[1:] = (a[1:] != a[:-1]) | (b[1:] != b[:-1]) | (c[1:] != c[:-1])
        if np.count_nonzero(new) == len(lo):
            return self.enclosure.bounds(lo, hi, rows, np.zeros(len(lo), int), centre)
        first = order[new]
        inverse = np.empty(len(lo), int)
        inverse[order] = new.cumsum() - 1
        got = self.enclosure.bounds(lo[first], hi[first], rows, np.zeros(len(first), int), m[first])
        return tuple(x[:, inverse] for x in got)
