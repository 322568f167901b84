"""Integrals to a stated tolerance: adaptive Gauss-Kronrod on pieces, with an error estimate.

A time integral over a cycle (RMS over time, energy, mean power) is a sum of integrals over
pieces of the sweep on which the integrand is smooth: between a profile's phase boundaries, and
from the stroke's ends, where the speed may vanish (a trapezoid's V = sqrt(2 a x), an s-curve's
V ~ x^(2/3), a law's square root).  :func:`integrate` takes such pieces and any vector of
integrands per unit of the sweep, and returns each integral with an estimate of its error:

* a piece is (anchor, other end, m): the sweep runs s = anchor + (other - anchor) u^m, u in
  [0, 1], so that an integrand that is singular like x^(1/m - 1) at the anchor (x its distance
  from it) becomes smooth in u (m = 2 for 1/sqrt(x), 3 for x^(-2/3)); m = 1 for a regular piece;
* on each interval of u, the 15-point Kronrod rule and its embedded 7-point Gauss rule; their
  difference |K15 - G7| is the interval's error estimate (conservative: K15's own error is far
  smaller wherever the integrand is smooth);
* every interval whose estimate exceeds its share of the tolerance (tol x the integral of
  |integrand| x its share of the sweep) is halved, all such intervals at once, until the
  estimates add up to within the tolerance (or ``max_rounds`` halvings, or MAX_INTERVALS at
  once); a jump (a power flow that switches the efficiency) or a kink is thus closed in by
  bisection, its interval's estimate halving each round.

The integrands are evaluated in batches (one call per round): ``f(s, d, piece)`` gets the
sweep values, each one's distance d from its piece's anchor (exact next to the anchor, where a
singular weight such as 1/V needs it: s itself rounds there) and its piece's index, and
returns an array (integrands x nodes) per unit of s, in the direction of increasing s.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Gauss-Kronrod 7-15 (QUADPACK's qk15): Kronrod nodes on [0, 1) of the half-interval, the
# Gauss nodes being every second of them
_XK = np.array([0.991455371120812639206854697526329, 0.949107912342758524526189684047851,
                0.864864423359769072789712788640926, 0.741531185599394439863864773280788,
                0.586087235467691130294144845693013, 0.405845151377397166906606412076961,
                0.207784955007898467600689403773245, 0.000000000000000000000000000000000])
_WK = np.array([0.022935322010529224963732008058970, 0.063092092629978553290700663189204,
                0.104790010322250183839876322541518, 0.140653259715525918745189590510238,
                0.169004726639267902826583426598550, 0.190350578064785409913256402421014,
                0.204432940075298892414161999234649, 0.209482141084727828012999174891714])
_WG = np.array([0.129484966168869693270611432679082, 0.279705391489276667901467771423780,
                0.381830050505118944950369775488975, 0.417959183673469387755102040816327])
NODES = np.r_[-_XK[:-1], _XK[::-1]]                       # 15 nodes on [-1, 1]
W_KRONROD = np.r_[_WK[:-1], _WK[::-1]]
W_GAUSS = np.zeros(15)
W_GAUSS[1:14:2] = np.r_[_WG[:-1], _WG[::-1]]


@dataclass(frozen=True)
class Integrals:
    """What :func:`integrate` gives: ``values`` and ``errors`` (one per integrand: the sum of
    the intervals' |K15 - G7|), ``scale`` (the integral of |integrand|, the tolerance's
    reference), ``converged`` (each error within tol x scale), ``intervals`` evaluated."""

    values: np.ndarray
    errors: np.ndarray
    scale: np.ndarray
    converged: np.ndarray
    intervals: int


MAX_INTERVALS = 40000   # intervals evaluated in one round at most (a load that is not integrable)


def integrate(f, pieces, starts=None, tol=1e-10, max_rounds=48) -> Integrals:
    """The integrals over ``pieces`` [(anchor, other, m)] of the integrands ``f`` (see the
    module's doc).  ``starts``: per piece, sweep values inside it at which to cut its first
    intervals (e.g. the samples: a piece starts as one interval per sample interval).  The one
    case of :func:`integrate_many`."""
    return integrate_many(lambda s, d, piece, case: f(s, d, piece), pieces, starts, tol, max_rounds, 1)[0]


def integrate_many(f, pieces, starts=None, tol=1e-10, max_rounds=48, cases=1) -> list:
    """:func:`integrate` of ``cases`` integrands over the same ``pieces`` at once: ``f(s, d,
    piece, case)`` gets each node's case too.  Every decision (an interval halved or kept, a
    case done) is the case's own, and its sums run over its own intervals in a fixed order, so
    a case's :class:`Integrals` are the same in any batch (bit for bit).  Returns one per case."""
    values, errors, scale, converged, count = integrate_arrays(f, pieces, starts, tol, max_rounds, cases)
    return [Integrals(values[:, c].copy(), errors[:, c].copy(), scale[:, c].copy(), converged[:, c].copy(),
                      int(count[c])) for c in range(cases)]


def integrate_arrays(f, pieces, starts=None, tol=1e-10, max_rounds=48, cases=1) -> tuple:
    """:func:`integrate_many`'s figures as arrays (integrands x cases): values, errors, scale,
    converged, and the intervals evaluated per case."""
    anchors = np.array([p[0] for p in pieces], float)
    lengths = np.array([p[1] - p[0] for p in pieces], float)
    powers = np.array([p[2] for p in pieces], float)
    total = float(np.sum(np.abs(lengths)))
    piece, lo, hi = [], [], []
    for j, (a, b, m) in enumerate(pieces):
        cuts = [0.0, 1.0]
        if starts is not None and len(starts[j]):
            x = np.clip((np.asarray(starts[j], float) - a) / (b - a), 0.0, 1.0)
            cuts = np.unique(np.r_[0.0, x ** (1.0 / m), 1.0])
        piece += [j] * (len(cuts) - 1)
        lo += list(cuts[:-1])
        hi += list(cuts[1:])
    if not piece:
        raise ValueError("integrate: no pieces")
    first = len(piece)   # each case's first intervals, case after case
    case = np.repeat(np.arange(cases), first)
    piece, lo, hi = np.tile(piece, cases), np.tile(lo, cases), np.tile(hi, cases)
    done_k = done_g = done_abs = done_err = None
    rounds, count = 0, np.zeros(cases, int)
    while len(piece):
        # the first round's intervals are each case's the same: their nodes made once (rounds > 0)
        k, absk, err = _rules(f, case, piece, lo, hi, anchors, lengths, powers, first if rounds == 0 else None)
        count += np.bincount(case, minlength=cases)
        if done_k is None:
            done_k, done_abs, done_err = (np.zeros((k.shape[0], cases)) for _ in range(3))
        by_abs, by_err = _by_case(absk, case, cases), _by_case(err, case, cases)
        scale = np.maximum(done_abs + by_abs, 1e-300)
        share = _share(piece, lo, hi, lengths, powers, total, first if rounds == 0 else None)
        fine = np.all(err <= tol * scale[:, case] * share[None, :], axis=0) | ~np.all(np.isfinite(err), axis=0)
        # within the tolerance as a whole (a jump's interval: halved until it is), or out of budget
        whole = (np.all(done_err + by_err <= tol * scale, axis=0) | (rounds >= max_rounds)
                 | (np.bincount(case, minlength=cases) > MAX_INTERVALS // 2))
        fine |= whole[case]
        fine |= hi - lo < 1e-15
        if fine.all():   # every interval kept (most quadratures after their first round): the sums made above
            done_k += _by_case(k, case, cases)
            done_abs += by_abs
            done_err += by_err
            break
        done_k += _by_case(k[:, fine], case[fine], cases)
        done_abs += _by_case(absk[:, fine], case[fine], cases)
        done_err += _by_case(err[:, fine], case[fine], cases)
        case, piece, lo, hi = case[~fine], piece[~fine], lo[~fine], hi[~fine]
        mid = 0.5 * (lo + hi)
        # halves: each case's first halves, then its second halves (a case's order whatever the others)
        order = np.argsort(np.r_[case, case], kind="stable")
        case, piece = np.r_[case, case][order], np.r_[piece, piece][order]
        lo, hi = np.r_[lo, mid][order], np.r_[mid, hi][order]
        rounds += 1
    converged = done_err <= tol * np.maximum(done_abs, 1e-300) * 1.0000001
    return done_k, done_err, done_abs, converged, count


def _by_case(x, case, cases):
    """Per case, the sum of each row of ``x`` (rows x intervals) over the case's intervals, in
    their order (rows x cases): the same numbers whatever other cases the intervals hold."""
    return np.array([np.bincount(case, weights=row, minlength=cases) for row in x]).reshape(len(x), cases)


def _map(u, m):
    return u ** m


def _share(piece, lo, hi, lengths, powers, total, tiled=None):
    """Each interval's share of the sweep (of ``total``); ``tiled``: the intervals are copies of
    their first ``tiled`` (:func:`_rules`), whose shares are made and repeated."""
    if tiled:
        return np.tile(_share(piece[:tiled], lo[:tiled], hi[:tiled], lengths, powers, total), len(piece) // tiled)
    return np.abs(lengths[piece]) * (_map(hi, powers[piece]) - _map(lo, powers[piece])) / total


def _rules(f, case, piece, lo, hi, anchors, lengths, powers, tiled=None):
    """Kronrod sums, Kronrod sums of |integrand| and |Kronrod - Gauss| on each interval
    (integrands x intervals), each a sum over the nodes in a fixed order (element by element,
    not a matrix product whose order may depend on an interval's place in the call).
    ``tiled``: the intervals are copies of their first ``tiled`` (each case's first intervals):
    the nodes of those are made and repeated (the same numbers: each is the same operation on
    the same operands)."""
    if tiled:
        reps = len(piece) // tiled
        s, d, jac = (np.tile(x, (reps, 1)) for x in _nodes(piece[:tiled], lo[:tiled], hi[:tiled], anchors,
                                                              lengths, powers))
        node_piece = np.tile(np.repeat(piece[:tiled], 15), reps)
        node_case = np.repeat(case[::tiled], 15 * tiled)
    else:
        s, d, jac = _nodes(piece, lo, hi, anchors, lengths, powers)
        node_piece, node_case = np.repeat(piece, 15), np.repeat(case, 15)
    values = np.asarray(f(s.ravel(), d.ravel(), node_piece, node_case), float)
    nodes = np.empty((15, values.shape[0], len(piece)))                   # 15 x integrands x intervals
    np.multiply(values.reshape(values.shape[0], len(piece), 15).transpose(2, 0, 1), jac.T[:, None, :], out=nodes)
    if not np.isfinite(np.sum(nodes)):   # (a sum of finite values that overflows: nothing to change)
        nodes[~np.isfinite(nodes)] = np.nan
    k, g, absk = (np.zeros(nodes.shape[1:]) for _ in range(3))
    for j in range(15):
        k = k + W_KRONROD[j] * nodes[j]
        absk = absk + W_KRONROD[j] * np.abs(nodes[j])
        if W_GAUSS[j]:
            g = g + W_GAUSS[j] * nodes[j]
    return k, absk, np.abs(k - g)


def _nodes(piece, lo, hi, anchors, lengths, powers) -> tuple:
    """The 15 Kronrod nodes of each interval (intervals x 15): sweep values s, their distances d
    from their piece's anchor, and ds/du x du per unit node (intervals x 15, or x 1 where it is
    the same at every node)."""
    half = 0.5 * (hi - lo)
    u = (0.5 * (lo + hi))[:, None] + half[:, None] * NODES[None, :]       # intervals x 15
    m = powers[piece][:, None]
    L = lengths[piece][:, None]
    regular = bool(np.all(powers == 1.0))   # u ** 1 is u and u ** 0 is 1, exactly: skipped
    d = np.abs(L) * (u if regular else u ** m)                           # distance from the anchor
    s = anchors[piece][:, None] + np.sign(L) * d
    jac = np.abs(L) * m * (1.0 if regular else u ** (m - 1)) * half[:, None]   # ds/du x du per unit node
    return s, d, jac


def end_power(speed, length, scale) -> float:
    """The substitution's m for an end where the sweep speed is ``speed(x)`` at distance x: 1
    when the speed there is not 0 (to round-off: it is below 1e-3 of its value 1e-8 of
    ``length`` away); else 1/(1 - alpha) for V ~ x^alpha (2 for a square root, 3
    for an s-curve's x^(2/3)), rounded to a whole number when it is within 0.05 of one, so that
    the integrand stays smooth in u (at most 20)."""
    x = np.array([0.0, 1e-8, 1e-10]) * length
    with np.errstate(all="ignore"):
        v0, v1, v2 = (float(v) for v in speed(x))
    # 0 at the end, to round-off (sqrt(sin(2 s)) at s = pi/2 is 1.7e-8, not 0)
    if not (v1 > v2 > 0 and (abs(v0) <= 1e-12 * max(scale, 1e-300) or abs(v0) <= 1e-3 * v1)):
        return 1.0
    alpha = float(np.log(v1 / v2) / np.log(100.0))
    if alpha <= 0.02:
        return 1.0
    m = 1.0 / max(1.0 - alpha, 0.05)
    return float(round(m)) if abs(m - round(m)) < 0.05 else min(m, 20.0)
