"""Extrema of a smooth quantity over the continuous stroke, not only at the samples.

A quantity v(s) is sampled on a grid; every grid point that is a local maximum of the target
(|v|, v or -v) brackets a continuous maximum, which is refined by safeguarded Newton steps on
dv/ds = 0 (exact derivatives from CasADi), falling back to bisection when a step leaves the
bracket.  The stroke's ends are candidates too.  The result is the peak of the continuous
stroke to the stated tolerance in s.

The algorithm is written once, over many cases at once (:mod:`.extrema`: the brackets and the
Newton iteration of every row of every case in lockstep, as arrays; :mod:`.branch_bound`: the
proof with the enclosure); :func:`continuous_maxima_rows` (many rows of one case),
:func:`continuous_maxima` (one row), :func:`refine_all` and :func:`refine` are its one-case
forms; over a batch of cases :func:`extrema_of_cases` (every located extremum, as lists) and
:func:`maxima_of_cases` (the largest of each request, as arrays: no Python work per case).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .branch_bound import CERTIFY_TOL, certify
from .extrema import Found, Tasks, check_invariant, grid_brackets, newton


@dataclass(frozen=True)
class Extremum:
    """A located extremum: the quantity v at s.  The largest of a request's list carries, when
    it was certified by an enclosure, ``bound``: an upper bound of the target (|v|, v or -v)
    over the whole stroke, within the tolerance of the located value; ``note`` says why there
    is no such bound where one was asked for (the enclosure not available, or not closing)."""

    s: float
    value: float  # the quantity v at s (signed)
    bound: float | None = None
    note: str = ""


@dataclass(frozen=True)
class Request:
    """One target of :func:`continuous_maxima_rows`: row ``row`` of the sampled quantities,
    maximised as |v|, v or -v (``sense``), grid maxima below ``only_above`` left unrefined.
    ``ends``: also refine the first and the last interval of the grid from the stroke's end
    (a maximum between the end sample and its neighbour, where the sampled target rises from
    that end, is found as well; without it the end's own value is the candidate there)."""

    row: int
    sense: str = "abs"
    only_above: float | None = None
    ends: bool = False
    tol: float | None = None   # the certificate's tolerance (absolute, on the target); default
    #                            CERTIFY_TOL of the row's largest sampled |v|


def target_sign(values, sense):
    """+1/-1 per sample such that sign * v is the target to maximise."""
    values = np.asarray(values, float)
    if sense == "abs":
        sign = np.sign(values)
        sign[sign == 0] = 1.0
        return sign
    return np.full(values.shape, 1.0 if sense == "max" else -1.0)


def grid_maxima(values, sense="abs", only_above=None):
    """Interior grid points whose target is >= both neighbours' (and not below ``only_above``).

    Returns (indices, sign): the points' indices, increasing, and the target's sign at every
    sample.  A sample whose target, or a neighbour's, is NaN is not a maximum (a comparison
    with NaN is false)."""
    v = np.asarray(values, float)
    sign = target_sign(v, sense)
    target = sign * v
    inner = target[1:-1]
    is_max = (inner >= target[:-2]) & (inner >= target[2:])
    if only_above is not None:
        is_max &= ~(inner < only_above)
    return np.flatnonzero(is_max) + 1, sign


def continuous_maxima(evaluate, s_grid, values, sense="abs", s_tol=1e-13, only_above=None):
    """Continuous local maxima of the target of ``values`` (v sampled on ``s_grid``).

    ``evaluate(s) -> (v, dv/ds, d2v/ds2)`` at one s.  Interior grid maxima are refined; the
    stroke's ends are always candidates.  ``only_above``: skip refining grid maxima whose
    target is below it (they cannot matter).  Returns extrema, largest target first."""
    def evaluate_many(s):
        out = np.array([[float(c) for c in evaluate(s_k)] for s_k in s]).reshape(len(s), 3)
        return out[:, 0][None, :], out[:, 1][None, :], out[:, 2][None, :]

    v = np.asarray(values, float)[None, :]
    return continuous_maxima_rows(evaluate_many, s_grid, v, [Request(0, sense, only_above)], s_tol)[0]


def continuous_maxima_rows(evaluate_many, s_grid, V, requests, s_tol=1e-13, enclosure=None, tol=CERTIFY_TOL):
    """:func:`continuous_maxima` of several rows of ``V`` (rows x samples on ``s_grid``) at once.

    ``evaluate_many(s) -> (V, dV/ds, d2V/ds2)``, each rows x len(s): every row at every sweep
    value in ``s`` (the brackets of all ``requests`` are refined in lockstep, see
    :func:`refine_all`).  Returns one list of extrema per request, largest target first.

    ``enclosure``: an :class:`~.enclosure.Enclosure` of the same rows (or an
    :class:`~.enclosure.Unavailable` saying why there is none): the located maxima are then
    certified by branch and bound (:func:`~.branch_bound.certify`): the largest extremum of each
    request carries ``bound``, an upper bound of its target over the continuous stroke within
    ``tol`` (relative to the row's largest sampled |v|) of its value, and maxima between the
    samples that the grid does not bracket are found and located too.  Without it the extrema
    are the refined grid maxima (no proof).  Either way the largest reported target is never
    below the largest sampled one (a :class:`~optdesign.errors.ResultError` otherwise).  The
    one-case form of :func:`extrema_of_cases`."""
    return extrema_of_cases(lambda s, cases: evaluate_many(s), s_grid, np.asarray(V, float)[None], requests, s_tol,
                            enclosure, tol)[0]


def extrema_of_cases(evaluate, s_grid, V, requests, s_tol=1e-13, enclosure=None, tol=CERTIFY_TOL):
    """:func:`continuous_maxima_rows` of N cases at once (the arguments as
    :func:`maxima_of_cases`'): per case, one list of extrema per request, largest target first
    (the first with the enclosure's ``bound`` and ``note``)."""
    V = np.asarray(V, float)
    found, top, bound, notes = maxima(evaluate, s_grid, V, requests, s_tol, enclosure, tol)
    return extrema_lists(found, bound, notes, V.shape[0], requests, enclosure is not None)


def extrema_lists(found, bound, notes, n_cases, requests, certified, first=0):
    """:func:`extrema_of_cases`' lists of ``n_cases`` cases of ``requests`` from :func:`maxima`'s
    ``found`` (their tasks from ``first`` on among its: :func:`~.joint.maxima_together`'s
    parts), ``bound`` and ``notes`` (theirs, from their first task); ``certified``: with the
    enclosure's bounds."""
    k = len(requests)
    order = np.argsort(found.task, kind="stable")   # each task's extrema in the order found
    starts = np.searchsorted(found.task[order], np.arange(first, first + n_cases * k + 1))
    s, v = found.s[order].tolist(), found.v[order].tolist()
    out = []
    for c in range(n_cases):
        lists = []
        for j, r in enumerate(requests):
            t = c * k + j
            ext = sorted((Extremum(s[i], v[i]) for i in range(starts[t], starts[t + 1])),
                         key=lambda e: _target(e.value, r.sense), reverse=True)
            if certified:
                b = None if np.isnan(bound[t]) else float(bound[t])
                ext[0] = Extremum(ext[0].s, ext[0].value, b, notes[t])
            lists.append(ext)
        out.append(lists)
    return out


def maxima_of_cases(evaluate, s_grid, V, requests, s_tol=1e-13, enclosure=None, tol=CERTIFY_TOL):
    """The largest continuous extremum of every request of N cases at once: ``V`` (cases x rows
    x samples on ``s_grid``, the same for every case); ``evaluate(s, cases) -> (V, dV/ds,
    d2V/ds2)``, each rows x len(s), column j at s[j] with case cases[j]'s parameters;
    ``enclosure``: bounds(lo, hi, rows, cases) of the rows (each interval with its case's
    parameters), or an Unavailable; a request's ``tol`` may be one per case.  Returns (s, value,
    bound, notes): arrays cases x requests
    (bound NaN without an enclosure) and the notes as a list of lists.  Case i's numbers are
    those of :func:`continuous_maxima_rows` of case i alone (its first extremum per request)."""
    V = np.asarray(V, float)
    found, top, bound, notes = maxima(evaluate, s_grid, V, requests, s_tol, enclosure, tol)
    return maxima_arrays(found, top, bound, notes, V.shape[0], len(requests))


def maxima_arrays(found, top, bound, notes, n, k):
    """:func:`maxima_of_cases`' arrays from :func:`maxima`'s results (``top``, ``bound`` and
    ``notes``: the tasks of n cases x k requests)."""
    return (found.s[top].reshape(n, k), found.v[top].reshape(n, k), bound.reshape(n, k),
            [notes[i * k:(i + 1) * k] for i in range(n)])


def maxima(evaluate, s_grid, V, requests, s_tol=1e-13, enclosure=None, tol=None):
    """The largest continuous extremum of every request of every case (``V``: cases x rows x
    samples on the ascending ``s_grid``).  Returns (found, top, bound, notes): ``found`` every
    located extremum (:class:`Found`, tasks case-major: task = case * len(requests) + request),
    ``top`` per task the index of its largest, ``bound`` per task the enclosure's upper bound
    of the target over the stroke (NaN without an enclosure) and ``notes`` per task ("" when
    certified).  Raises :class:`~optdesign.errors.ResultError` where the largest located
    target is below the largest sampled one."""
    V = np.asarray(V, float)
    s_grid = np.asarray(s_grid, float)
    tasks = Tasks.of(requests, V.shape[0])
    found = Found(len(tasks))
    bt, blo, bhi, bs0, bsign, bi, T, sampled = grid_brackets(tasks, s_grid, V, found)
    s_star, v_star = newton(evaluate, tasks.case[bt], tasks.row[bt], blo, bhi, bs0, bsign, s_tol)
    v_i = T[bt, bi]
    worse = bsign * v_star < bsign * v_i   # never less than the grid point itself
    found.add(bt, np.where(worse, s_grid[bi], s_star), np.where(worse, v_i, v_star))
    bound = np.full(len(tasks), np.nan)
    notes = [""] * len(tasks)
    if enclosure is not None:
        bound, notes = certify(enclosure, evaluate, tasks, s_grid, T, found, s_tol, tol)
    top, best = found.best(tasks.code)
    check_invariant(tasks, T, found, top, best, sampled)
    return found, top, bound, notes


def _check_invariant(top, sampled, request):
    """The largest located target is never below the largest sampled one (those above
    ``only_above``): a certification that fails this check is an error, never a result
    (:func:`~.extrema.check_invariant`, for one request)."""
    T = np.asarray(sampled, float)[None, :]
    tasks = Tasks([request], 1)
    found = Found(1)
    found.add([0], [top.s], [top.value])
    check_invariant(tasks, T, found, np.array([0]), np.array([_target(top.value, request.sense)]))


def _target(value, sense):
    """The target (sign * v of :func:`target_sign`) of one value: the sort key of extrema."""
    if sense == "abs":
        return abs(value)
    return value if sense == "max" else -value


def refine(evaluate, lo, hi, s0, sign, s_tol=1e-13):
    """Maximise sign*v on [lo, hi] by Newton on dv/ds = 0, safeguarded by bisection.

    ``evaluate(s) -> (v, dv/ds, d2v/ds2)``.  Returns (s, v(s)).  Without a sign change of dv/ds
    on the bracket, the grid point s0 is returned (the bracket's maximum is then at s0 to
    within the grid).  One bracket of :func:`refine_all`."""
    def evaluate_many(s):
        out = np.array([[float(c) for c in evaluate(x)] for x in s]).reshape(len(s), 3)
        return out[:, 0][None, :], out[:, 1][None, :], out[:, 2][None, :]

    return refine_all(evaluate_many, [(0, lo, hi, s0, sign)], s_tol)[0]


def refine_all(evaluate_many, brackets, s_tol=1e-13):
    """:func:`refine` of many brackets in lockstep (:func:`~.extrema.newton`): each step
    evaluates every row at all the sweep values the unfinished brackets need, in one call, and
    each bracket stops on its own.

    ``brackets``: (row, lo, hi, s0, sign) each; ``evaluate_many(s) -> (V, dV/ds, d2V/ds2)``,
    each rows x len(s).  Returns (s, v(s)) per bracket, in order."""
    if not brackets:
        return []
    rows, lo, hi, s0, sign = (np.array(a) for a in zip(*brackets))
    s, v = newton(lambda x, cases: evaluate_many(x), np.zeros(len(rows), int), rows.astype(int), lo, hi, s0,
                  sign, s_tol)
    return [(float(a), float(b)) for a, b in zip(s, v)]


def narrow_minima(evaluate_many, extrema, spacing):
    """The minima among ``extrema`` (of a row that stays positive: an assembly margin, |dq/ds|)
    that are narrower than the sampling, as (s, width).  Near such a minimum v ~ v* + v''/2
    (s - s*)^2 and the quantities built on it (a velocity ~ 1/sqrt(v), a reduced inertia ~ 1/v)
    change over width = sqrt(2 v*/v'') in s; where that is below the sample spacing the samples
    do not resolve them, and :func:`resolving_points` adds sweep values that do.
    ``evaluate_many(s) -> (v, dv/ds, d2v/ds2)`` of that one row (arrays over s)."""
    candidates = [e for e in extrema if e.value > 0]
    if not candidates:
        return []
    s = np.array([e.s for e in candidates], float)
    v, d1, d2 = (np.asarray(a, float).ravel() for a in evaluate_many(s))
    out = []
    for k, e in enumerate(candidates):
        if d2[k] > 0 and abs(d1[k]) * math.sqrt(2 * v[k] / d2[k]) <= v[k]:  # a minimum, not a slope
            width = math.sqrt(2 * v[k] / d2[k])
            if width < spacing:
                out.append((float(e.s), width))
    return out


def resolving_points(narrow, lo, hi, spacing):
    """Sweep values that resolve narrow minima ((s*, width) each, :func:`narrow_minima`): s* and
    s* +- width t for t = 1/4, 1/2, 3/4, 1 and on by a factor 1.4 until width t passes two
    sample spacings (the quantities' scale grows with the distance from s*), inside [lo, hi]."""
    steps = [0.25, 0.5, 0.75, 1.0]
    out = []
    for centre, width in narrow:
        t = steps[-1]
        ts = list(steps)
        while width * t < 2 * spacing:
            t *= 1.4
            ts.append(t)
        out.append(centre)
        out += [centre + sign * width * t for t in ts for sign in (-1.0, 1.0)]
    a, b = min(lo, hi), max(lo, hi)
    return sorted({x for x in out if a < x < b})
