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
CERTIFY_TOL = 1e-9   # the certificate's tolerance, relative to the row's scale (its largest |v|)
MAX_PASSES = 60      # subdivision passes of the branch and bound before it gives up
MAX_INTERVALS = 16384  # intervals alive at once, idem
PRESPLIT = 16        # cuts each side of a located maximum in the first pass (_first_intervals)


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
    certified by branch and bound (:func:`certify`): the largest extremum of each request
    carries ``bound``, an upper bound of its target over the continuous stroke within ``tol``
    (relative to the row's largest sampled |v|) of its value, and maxima between the samples
    that the grid does not bracket are found and located too.  Without it the extrema are the
    refined grid maxima (no proof).  Either way the largest reported target is never below the
    largest sampled one (a :class:`~optdesign.errors.ResultError` otherwise)."""
    s_grid = np.asarray(s_grid, float)
    V = np.asarray(V, float)
    brackets, owners, found_flat = [], [], {}
    for k, req in enumerate(requests):
        indices, sign = grid_maxima(V[req.row], req.sense, req.only_above)
        if _flat(V[req.row]):   # every sample a grid maximum, none telling: the largest stands for them
            target = sign * V[req.row]
            indices = indices[:0]
            top = int(np.argmax(target))
            found_flat[k] = Extremum(float(s_grid[top]), float(V[req.row, top]))
        for i in indices:   # (lo, hi) ascending, also on a sweep that runs down
            lo, hi = sorted((s_grid[i - 1], s_grid[i + 1]))
            brackets.append((req.row, lo, hi, s_grid[i], sign[i]))
            owners.append((k, i, sign[i]))
        if req.ends and len(s_grid) >= 2:
            for i, j in ((0, 1), (len(s_grid) - 1, len(s_grid) - 2)):
                if np.isfinite(V[req.row, i]):
                    lo, hi = sorted((s_grid[i], s_grid[j]))
                    brackets.append((req.row, lo, hi, s_grid[i], sign[i]))
                    owners.append((k, i, sign[i]))
    found = [[Extremum(float(s_grid[0]), float(V[r.row, 0])), Extremum(float(s_grid[-1]), float(V[r.row, -1]))]
             for r in requests]
    for k, e in found_flat.items():
        found[k].append(e)
    for (k, i, sign), (s_star, v_star) in zip(owners, refine_all(evaluate_many, brackets, s_tol)):
        v_i = V[requests[k].row, i]
        if sign * v_star < sign * v_i:  # never report less than the grid point itself
            s_star, v_star = float(s_grid[i]), float(v_i)
        found[k].append(Extremum(float(s_star), float(v_star)))
    bounds = notes = None
    if enclosure is not None:
        bounds, notes = certify(enclosure, evaluate_many, s_grid, V, requests, found, s_tol, tol)
    out = []
    for k, (ext, r) in enumerate(zip(found, requests)):
        ext = sorted(ext, key=lambda e: _target(e.value, r.sense), reverse=True)
        _check_invariant(ext[0], V[r.row], r)
        if bounds is not None:
            ext[0] = Extremum(ext[0].s, ext[0].value, bounds[k], notes[k])
        out.append(ext)
    return out


def _flat(values) -> bool:
    """A row equal at every sample to 1e-14 of its size (a constraint on the design alone)."""
    with np.errstate(invalid="ignore"):
        return bool(np.ptp(values) <= 1e-14 * max(float(np.max(np.abs(values))), 1e-300)) if len(values) else False


def _check_invariant(top, sampled, request):
    """The largest located target is never below the largest sampled one (those above
    ``only_above``): a certification that fails this check is an error, never a result."""
    values = np.asarray(sampled, float)
    if not values.size or not np.all(np.isfinite(values)):
        return
    best = float(np.max(target_sign(values, request.sense) * values))
    if request.only_above is not None and best < request.only_above:
        return
    if not _target(top.value, request.sense) >= best:
        from ..errors import ResultError

        raise ResultError(f"the certified extremum ({request.sense}) of row {request.row}, {top.value!r} at s = "
                          f"{top.s!r}, is below the largest sampled one ({best!r}): the certification failed "
                          "its own check")


def certify(enclosure, evaluate_many, s_grid, V, requests, found, s_tol=1e-13, tol=CERTIFY_TOL):
    """Branch and bound over the stroke: bound each request's target over every sample interval
    with ``enclosure.bounds``; an interval whose bound exceeds the best located target by more
    than the tolerance (and ``only_above``) is split and bounded again, until none is left.  A
    split interval whose midpoint beats the best located target has its maximum located by
    :func:`refine_all` (its Extremum joins ``found``, in place).  All intervals of all requests
    are bounded together, one enclosure evaluation per pass.

    Returns (bounds, notes) per request: the upper bound of the target over the stroke (the
    largest bound of the intervals left behind; None without one) and why it is missing or
    wider than the tolerance ("" when certified)."""
    n_req = len(requests)
    notes = [""] * n_req
    if getattr(enclosure, "reason", None) is not None:   # no enclosure for these rows
        return [None] * n_req, [f"not certified: {enclosure.reason}"] * n_req
    s_grid = np.asarray(s_grid, float)
    rows = np.array([r.row for r in requests], int)
    sense = np.array([SENSES.index(r.sense) for r in requests], int)
    best = np.array([max(_target(e.value, r.sense) for e in found[k]) for k, r in enumerate(requests)])
    with np.errstate(invalid="ignore"):
        scale = np.array([np.nanmax(np.abs(V[r.row]), initial=0.0) for r in requests])
    tol_abs = tol * np.maximum(np.abs(best), scale) + 1e-300
    tol_abs = np.array([t if r.tol is None else r.tol + 1e-300 for t, r in zip(tol_abs, requests)])
    floor = np.array([-np.inf if r.only_above is None else r.only_above for r in requests])
    bound = np.full(n_req, -np.inf)
    span = abs(float(s_grid[-1] - s_grid[0])) if len(s_grid) > 1 else 0.0
    limits = (float(s_grid.min()), float(s_grid.max())) if len(s_grid) else (0.0, 0.0)
    req, lo, hi = _first_intervals(s_grid, found, requests, best)
    left_ub = np.full(len(req), np.inf)   # bounds of the intervals still open (inf: not bounded yet)
    for _ in range(MAX_PASSES):
        if not len(req):
            break
        # the distinct intervals (rows share them), as complex numbers lo + i hi: np.unique of
        # a 1-D array (sorting rows with axis=0 cost ~5 % of a certified analysis)
        key = np.empty(len(lo), complex)
        key.real, key.imag = lo, hi
        pairs, where = np.unique(key, return_inverse=True)
        where = where.ravel()
        L, U, vm_lo, vm_hi = enclosure.bounds(pairs.real, pairs.imag, np.unique(rows[req]))
        r_of, code = rows[req], sense[req]
        ub = _target_bound(L[r_of, where], U[r_of, where], code, upper=True)
        vm_lo, vm_hi = vm_lo[r_of, where], vm_hi[r_of, where]
        at_mid = _target_bound(vm_lo, vm_hi, code, upper=False)
        _locate_better(evaluate_many, requests, found, best, req, lo, hi, at_mid, vm_lo + vm_hi, s_tol, limits)
        # the tolerance, or where rounding is larger, four times the width of the midpoint's own
        # enclosure (a row that cancels to ~0: its floating-point evaluation cannot say more)
        noise = 4.0 * np.where(np.isfinite(vm_hi - vm_lo), vm_hi - vm_lo, 0.0)
        threshold = np.maximum(best[req] + np.maximum(tol_abs[req], noise), floor[req])
        keep = ~(ub <= threshold)   # NaN: not bounded, split again
        if np.any(~keep):
            np.maximum.at(bound, req[~keep], ub[~keep])
        req, lo, hi, left_ub = req[keep], lo[keep], hi[keep], np.where(np.isnan(ub[keep]), np.inf, ub[keep])
        width = hi - lo
        if not len(req) or len(req) > MAX_INTERVALS or np.any(width <= max(span, 1e-300) * 1e-13):
            break
        pieces = int(max(2, min(64, 4096 // len(req))))   # an evaluation costs about the same up to thousands
        t = np.arange(pieces + 1) / pieces
        edges = lo[:, None] + width[:, None] * t[None, :]
        edges[:, -1] = hi
        req, left_ub = np.repeat(req, pieces), np.repeat(left_ub, pieces)
        lo, hi = edges[:, :-1].ravel(), edges[:, 1:].ravel()
    for k in np.unique(req):
        left = req == k
        bound[k] = max(bound[k], float(np.max(left_ub[left])))
        where_s = float(0.5 * (lo[left][0] + hi[left][0]))
        notes[k] = (f"not certified: the enclosure did not close within {tol_abs[k]:.3g} of the located value near "
                    f"s = {where_s:.9g} (bound {bound[k]:.9g} against {best[k]:.9g})")
    bound = np.maximum(bound, best)
    return [float(b) for b in bound], notes


def _first_intervals(s_grid, found, requests, best):
    """The first pass's intervals: every sample interval of every request (lo < hi); around each
    located maximum within 1e-3 of its request's best (where the bound must come within the
    tolerance of the located value), the sample intervals holding it and their neighbours cut at
    s* +- h 2^-k, k = 0 .. PRESPLIT - 1 (h the sample spacing): pieces that shrink towards s*,
    as the Taylor form needs them to (a pass of the branch and bound saved, each running the
    whole program whatever its number of intervals).  Returns (request, lo, hi) arrays."""
    n_req, n_int = len(requests), max(len(s_grid) - 1, 0)
    # each interval from its smaller end to its larger one, also on a sweep that runs down
    # (from > to): the interval operations take [lo, hi] with lo <= hi
    a, b = np.minimum(s_grid[:-1], s_grid[1:]), np.maximum(s_grid[:-1], s_grid[1:])
    req = np.repeat(np.arange(n_req), n_int)
    lo, hi = np.tile(a, n_req), np.tile(b, n_req)
    if not n_int or not PRESPLIT:
        return req, lo, hi
    h = float(np.max(b - a))
    steps = h * 2.0 ** -np.arange(PRESPLIT)
    cut = np.zeros(len(req), bool)
    ks, los, his = [], [], []   # the pieces: (request, lo, hi) arrays
    for k, r in enumerate(requests):
        for e in found[k]:
            if not _target(e.value, r.sense) >= best[k] - 1e-3 * abs(best[k]):
                continue
            near = (a <= e.s + h) & (e.s - h <= b) & ~cut[k * n_int:(k + 1) * n_int]
            if not np.any(near):
                continue
            cut[k * n_int:(k + 1) * n_int] |= near
            xs, ys = a[near], b[near]
            edges = np.unique(np.concatenate((xs, ys, e.s - steps, [e.s], e.s + steps)))   # sorted, distinct
            # each sample interval [x, y] cut at the edges strictly inside it
            for x, y, i0, i1 in zip(xs, ys, np.searchsorted(edges, xs, "right"), np.searchsorted(edges, ys, "left")):
                inside = np.concatenate(([x], edges[i0:i1], [y])) if x < y else np.array([x])
                ks.append(np.full(len(inside) - 1, k))
                los.append(inside[:-1])
                his.append(inside[1:])
    if not sum(map(len, ks)):
        return req, lo, hi
    return (np.concatenate([req[~cut], *ks]), np.concatenate([lo[~cut], *los]), np.concatenate([hi[~cut], *his]))


def _target_bound(L, U, code, upper):
    """Per interval, an upper (``upper``) or lower bound of its request's target from v's bounds
    [L, U]; ``code``: the request's sense, an index into SENSES (abs, max, min)."""
    if upper:
        return np.select([code == 1, code == 2], [U, -L], np.maximum(U, -L))
    return np.select([code == 1, code == 2], [L, -U], np.maximum(L, -U))


def _locate_better(evaluate_many, requests, found, best, req, lo, hi, at_mid, v_mid, s_tol, limits):
    """Where an interval's midpoint beats its request's best located target, locate the maximum
    near it (Newton on dv/ds = 0 in the interval widened by its width each side, from the
    midpoint) and add it to ``found``; ``best`` is updated in place."""
    better = np.flatnonzero(at_mid > best[req])
    if not len(better):
        return
    chosen = {}
    for i in better:   # the best midpoint of each request
        k = int(req[i])
        if k not in chosen or at_mid[i] > at_mid[chosen[k]]:
            chosen[k] = i
    brackets = []
    for k, i in chosen.items():
        r, w, m = requests[k], hi[i] - lo[i], 0.5 * (lo[i] + hi[i])
        sign = 1.0 if r.sense == "max" else -1.0 if r.sense == "min" else (1.0 if v_mid[i] >= 0 else -1.0)
        brackets.append((r.row, max(lo[i] - w, limits[0]), min(hi[i] + w, limits[1]), m, sign))
    for (k, _), (s_star, v_star) in zip(chosen.items(), refine_all(evaluate_many, brackets, s_tol)):
        value = _target(v_star, requests[k].sense)
        if value == value:
            found[k].append(Extremum(float(s_star), float(v_star)))
            best[k] = max(best[k], value)


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
