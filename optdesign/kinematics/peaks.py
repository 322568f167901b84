"""Extrema of a smooth quantity over the continuous stroke, not only at the samples.

A quantity v(s) is sampled on a grid; every grid point that is a local maximum of the target
(|v|, v or -v) brackets a continuous maximum, which is refined by safeguarded Newton steps on
dv/ds = 0 (exact derivatives from CasADi), falling back to bisection when a step leaves the
bracket.  The stroke's ends are candidates too.  The result is the peak of the continuous
stroke to the stated tolerance in s.

The Newton iteration is written once, as a coroutine that asks for (v, dv/ds, d2v/ds2) at the
sweep values it needs (:func:`_refinement`).  :func:`refine` and :func:`continuous_maxima` drive
it one bracket and one evaluation at a time; :func:`refine_all` and :func:`continuous_maxima_rows`
drive the brackets of many rows in lockstep, with one evaluation of every row at all the sweep
values the brackets need per step (a design's continuous check costs a few CasADi calls instead
of one per Newton step of every bracket).  Both drivers give the same numbers.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

SENSES = ("abs", "max", "min")
MAX_STEPS = 200  # Newton/bisection steps per bracket (bisection alone gets to 1e-13 of it in ~45)


@dataclass(frozen=True)
class Extremum:
    s: float
    value: float  # the quantity v at s (signed)


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


def continuous_maxima_rows(evaluate_many, s_grid, V, requests, s_tol=1e-13):
    """:func:`continuous_maxima` of several rows of ``V`` (rows x samples on ``s_grid``) at once.

    ``evaluate_many(s) -> (V, dV/ds, d2V/ds2)``, each rows x len(s): every row at every sweep
    value in ``s`` (the brackets of all ``requests`` are refined in lockstep, see
    :func:`refine_all`).  Returns one list of extrema per request, largest target first."""
    s_grid = np.asarray(s_grid, float)
    V = np.asarray(V, float)
    brackets, owners = [], []
    for k, req in enumerate(requests):
        indices, sign = grid_maxima(V[req.row], req.sense, req.only_above)
        for i in indices:
            brackets.append((req.row, s_grid[i - 1], s_grid[i + 1], s_grid[i], sign[i]))
            owners.append((k, i, sign[i]))
        if req.ends and len(s_grid) >= 2:
            for i, j in ((0, 1), (len(s_grid) - 1, len(s_grid) - 2)):
                if np.isfinite(V[req.row, i]):
                    lo, hi = sorted((s_grid[i], s_grid[j]))
                    brackets.append((req.row, lo, hi, s_grid[i], sign[i]))
                    owners.append((k, i, sign[i]))
    found = [[Extremum(float(s_grid[0]), float(V[r.row, 0])), Extremum(float(s_grid[-1]), float(V[r.row, -1]))]
             for r in requests]
    for (k, i, sign), (s_star, v_star) in zip(owners, refine_all(evaluate_many, brackets, s_tol)):
        v_i = V[requests[k].row, i]
        if sign * v_star < sign * v_i:  # never report less than the grid point itself
            s_star, v_star = float(s_grid[i]), float(v_i)
        found[k].append(Extremum(float(s_star), float(v_star)))
    return [sorted(ext, key=lambda e: _target(e.value, r.sense), reverse=True) for ext, r in zip(found, requests)]


def _target(value, sense):
    """The target (sign * v of :func:`target_sign`) of one value: the sort key of extrema."""
    if sense == "abs":
        return abs(value)
    return value if sense == "max" else -value


def refine(evaluate, lo, hi, s0, sign, s_tol=1e-13):
    """Maximise sign*v on [lo, hi] by Newton on dv/ds = 0, safeguarded by bisection.

    ``evaluate(s) -> (v, dv/ds, d2v/ds2)``.  Returns (s, v(s)).  Without a sign change of dv/ds
    on the bracket, the grid point s0 is returned (the bracket's maximum is then at s0 to
    within the grid)."""
    run = _refinement(lo, hi, s0, sign, s_tol)
    points = run.send(None)
    while True:
        try:
            points = run.send([evaluate(s) for s in points])
        except StopIteration as done:
            return done.value


def refine_all(evaluate_many, brackets, s_tol=1e-13):
    """:func:`refine` of many brackets in lockstep: each step evaluates every row at all the
    sweep values the unfinished brackets need, in one call, and each bracket stops on its own.

    ``brackets``: (row, lo, hi, s0, sign) each; ``evaluate_many(s) -> (V, dV/ds, d2V/ds2)``,
    each rows x len(s).  Returns (s, v(s)) per bracket, in order."""
    results = [None] * len(brackets)
    if not brackets:
        return results
    # the first step of every bracket at once: its ends and grid point in one call; a bracket
    # without a sign change of dv/ds ends here with its grid point (most of them: every sample
    # of a flat row is a grid maximum), and only the others run the Newton iteration
    distinct, column = _distinct(s for _, lo, hi, s0, _ in brackets for s in (lo, hi, s0))
    V, D1, D2 = (np.asarray(a, float) for a in evaluate_many(np.array(distinct, float)))
    column = np.asarray(column).reshape(len(brackets), 3)
    rows = np.array([b[0] for b in brackets])
    sign = np.array([float(b[4]) for b in brackets])
    with np.errstate(invalid="ignore"):
        ended = (sign * D1[rows, column[:, 0]] <= 0) | (sign * D1[rows, column[:, 1]] >= 0)
    runs, asks = {}, {}
    for k, (row, lo, hi, s0, sgn) in enumerate(brackets):
        if ended[k]:   # what _refinement returns without a sign change
            results[k] = (float(s0), float(V[row, column[k, 2]]))
            continue
        runs[k] = _refinement(lo, hi, s0, sgn, s_tol)
        runs[k].send(None)
        try:
            asks[k] = runs[k].send([(V[row, c], D1[row, c], D2[row, c]) for c in column[k]])
        except StopIteration as done:
            results[k] = done.value
    while asks:
        distinct, column = _distinct(s for ask in asks.values() for s in ask)
        V, D1, D2 = (np.asarray(a, float) for a in evaluate_many(np.array(distinct, float)))
        taken, next_asks = 0, {}
        for k, ask in asks.items():
            row, cols = brackets[k][0], column[taken:taken + len(ask)]
            taken += len(ask)
            try:
                next_asks[k] = runs[k].send([(V[row, c], D1[row, c], D2[row, c]) for c in cols])
            except StopIteration as done:
                results[k] = done.value
        asks = next_asks
    return results


def _distinct(points):
    """The distinct values among ``points`` and the index of each point among them.  Brackets
    share grid points (neighbouring maxima, rows with maxima at the same samples, every
    sample of a flat row): each is evaluated once.  +0.0 and -0.0 are kept apart, so every
    bracket is answered at exactly the value it asked for."""
    index, column = {}, []
    for s in points:
        column.append(index.setdefault((s, math.copysign(1.0, s)), len(index)))
    return [s for s, _ in index], column


def _refinement(lo, hi, s0, sign, s_tol):
    """The safeguarded Newton iteration behind :func:`refine`, as a coroutine.

    It yields a tuple of sweep values and is sent back [(v, dv/ds, d2v/ds2)] at them; it
    returns (s, v(s)).  First it asks for the bracket's ends and its grid point at once (dv/ds
    must change sign on [lo, hi], else the grid point is the answer), then for one value per
    step (its last step's value, or the point it converged to).  A Newton step is taken when
    it stays in the closed bracket: one that lands on the end just moved to s is a step of
    (about) nothing, i.e. convergence (rejecting it, as a strict test would, leaves some 45
    bisections of the whole bracket to find the same point again)."""
    (_, d_lo, _), (_, d_hi, _), at_s0 = yield (lo, hi, s0)
    if sign * float(d_lo) <= 0 or sign * float(d_hi) >= 0:
        return float(s0), float(at_s0[0])
    s, at_s = float(s0), at_s0
    for _ in range(MAX_STEPS):
        d1, d2 = sign * float(at_s[1]), sign * float(at_s[2])
        if d1 > 0:
            lo = s
        else:
            hi = s
        s_new = s - d1 / d2 if d2 < 0 and lo <= s - d1 / d2 <= hi else 0.5 * (lo + hi)
        if abs(s_new - s) <= s_tol * max(1.0, abs(s)) or hi - lo <= s_tol * max(1.0, abs(s)):
            (v_new, _, _), = yield (s_new,)
            return s_new, float(v_new)
        s = s_new
        at_s, = yield (s,)
    return s, float(at_s[0])


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
