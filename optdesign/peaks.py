"""Extrema of a smooth quantity over the continuous stroke, not only at the samples.

A quantity v(s) is sampled on a grid; every grid point that is a local maximum of the target
(|v|, v or -v) brackets a continuous maximum, which is refined by safeguarded Newton steps on
dv/ds = 0 (exact derivatives from CasADi), falling back to bisection when a step leaves the
bracket.  The stroke's ends are candidates too.  The result is the peak of the continuous
stroke to the stated tolerance in s.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SENSES = ("abs", "max", "min")


@dataclass(frozen=True)
class Extremum:
    s: float
    value: float  # the quantity v at s (signed)


def target_sign(values, sense):
    """+1/-1 per sample such that sign * v is the target to maximise."""
    values = np.asarray(values, float)
    if sense == "abs":
        sign = np.sign(values)
        sign[sign == 0] = 1.0
        return sign
    return np.full(values.shape, 1.0 if sense == "max" else -1.0)


def continuous_maxima(evaluate, s_grid, values, sense="abs", s_tol=1e-13, only_above=None):
    """Continuous local maxima of the target of ``values`` (v sampled on ``s_grid``).

    ``evaluate(s) -> (v, dv/ds, d2v/ds2)`` at one s.  Interior grid maxima are refined; the
    stroke's ends are always candidates.  ``only_above``: skip refining grid maxima whose
    target is below it (they cannot matter).  Returns extrema, largest target first."""
    s_grid = np.asarray(s_grid, float)
    v = np.asarray(values, float)
    sign = target_sign(v, sense)
    target = sign * v
    out = [Extremum(float(s_grid[0]), float(v[0])), Extremum(float(s_grid[-1]), float(v[-1]))]
    for i in range(1, len(s_grid) - 1):
        if not (target[i] >= target[i - 1] and target[i] >= target[i + 1]):
            continue
        if only_above is not None and target[i] < only_above:
            continue
        s_star, v_star = refine(evaluate, s_grid[i - 1], s_grid[i + 1], s_grid[i], sign[i], s_tol)
        if sign[i] * v_star < target[i]:  # never report less than the grid point itself
            s_star, v_star = float(s_grid[i]), float(v[i])
        out.append(Extremum(float(s_star), float(v_star)))
    return sorted(out, key=lambda e: float(target_sign([e.value], sense)[0] * e.value), reverse=True)


def refine(evaluate, lo, hi, s0, sign, s_tol=1e-13):
    """Maximise sign*v on [lo, hi] by Newton on dv/ds = 0, safeguarded by bisection.

    Returns (s, v(s)).  Without a sign change of dv/ds on the bracket, the grid point s0 is
    returned (the bracket's maximum is then at s0 to within the grid)."""
    def d(s):
        v, d1, d2 = evaluate(s)
        return float(v), sign * float(d1), sign * float(d2)

    if d(lo)[1] <= 0 or d(hi)[1] >= 0:
        return float(s0), d(s0)[0]
    s = float(s0)
    for _ in range(200):
        v, d1, d2 = d(s)
        if d1 > 0:
            lo = s
        else:
            hi = s
        s_new = s - d1 / d2 if d2 < 0 and lo < s - d1 / d2 < hi else 0.5 * (lo + hi)
        if abs(s_new - s) <= s_tol * max(1.0, abs(s)) or hi - lo <= s_tol * max(1.0, abs(s)):
            return s_new, d(s_new)[0]
        s = s_new
    return s, d(s)[0]
