"""The peaks in time of a run located between its output samples.

A run's samples (:mod:`.motion`) are its output grid and its events' instants; the drive's
torque or force, its speed, power and the load transmitted to the mechanism (``PEAKED`` of
:mod:`.equations`) peak in between.  Each sample interval runs on one branch of the equation of
motion, where these columns are smooth or have kinks only where the law has them (a
controller's saturation, a profile's phase changes).  Their rates along the motion (by AD,
:attr:`.equations.Equations.peaked`) at both ends of each interval say where one of them has an
extreme inside it: rising at the start and falling at the end (a maximum), or the reverse (a
minimum).  Where the Hermite cubic through the ends' values and rates puts such an extreme
within ``REACH`` of the run's range of that column from its largest (smallest) sample, the
instant is located by the Illinois regula falsi on the rate, each value integrated from the interval's
start on its branch (the integrator's own dense output, to the run's tolerance), and its
state inserted into the samples: the run's columns, and every figure taken from them (peak
torque, speed, power, where a limit binds), then hold the located peaks.  An extreme the rates
at the ends cannot see (a bump narrower than a sample interval whose ends both fall or both
rise) is not looked for: that is a sampled figure, not a certificate.
"""
from __future__ import annotations

import numpy as np
from .equations import PEAKED
from .integrate import IntegratorFailed

REACH = 0.1       # extremes within this share of a column's range of its sampled extreme are located
XTOL = 1e-10      # the tolerance on the instant, relative to the sample interval (a kink's value: to ~1e-10)


def locate_peaks(run, motion, kinks=()):
    """``motion`` (:class:`.motion.Motion`) with the located peaks of the ``PEAKED`` columns
    inserted as samples (their states on the branch of their interval), and the states at the
    law's ``kinks`` (instants in the motion's time where the law is not smooth: a tracked
    profile's phase changes, :func:`.phase_laws.profile_kinks`), where an extreme may sit
    with both its sides' rates of one sign."""
    if len(motion.t) < 2:
        return motion
    counts, run.counts = run.counts, run.peak_counts   # counted apart from the motion's own calls
    try:
        return _located(run, _with_kinks(run, motion, kinks))
    finally:
        run.peak_counts, run.counts = run.counts, counts


def _located(run, motion):
    """``motion`` with the extremes inside its intervals that may set a column's peak inserted."""
    t, X, c, held = motion.t, motion.X, motion.c, motion.held
    n = len(t)
    eq, p = run.eq, run.p
    # the columns and their rates at every sample, on its own branch and on the branch before
    # it (an interval's end: at an event's sample the branch after the event is recorded)
    values, rates = (np.asarray(a) for a in eq.mapped("peaked", n)(X, p, c[None, :]))
    c_before = np.r_[c[0], c[:-1]]
    end_values, end_rates = (np.asarray(a) for a in eq.mapped("peaked", n)(X, p, c_before[None, :]))
    dt = np.diff(t)
    moving = (dt > 0) & (held[:-1] == 0) & (held[1:] == 0)
    wanted = set()
    for row in range(len(PEAKED)):
        v_a, r_a = values[row, :-1], rates[row, :-1]
        v_b, r_b = end_values[row, 1:], end_rates[row, 1:]
        top, low = max(values[row].max(), end_values[row].max()), min(values[row].min(), end_values[row].min())
        reach = REACH * (top - low)
        for sign, extreme in ((1.0, top), (-1.0, low)):
            inside = moving & (sign * r_a > 0) & (sign * r_b < 0)
            for i in np.flatnonzero(inside):
                guess = sign * _cubic_extreme(sign * v_a[i], sign * r_a[i], sign * v_b[i], sign * r_b[i], dt[i])
                if sign * (guess - extreme) >= -reach:
                    wanted.add((int(i), row))
    extra = {}
    for i, row in sorted(wanted):
        found = _locate(run, t[i], X[:, i], c[i], dt[i], row)
        if found is not None:
            extra.setdefault(i, []).append(found)
    return _inserted(motion, extra)


def _with_kinks(run, motion, kinks):
    """``motion`` with the states at the ``kinks`` inside its moving intervals inserted."""
    t, held = motion.t, motion.held
    extra = {}
    for k in kinks:
        i = int(np.searchsorted(t, k)) - 1
        if 0 <= i < len(t) - 1 and t[i] < k < t[i + 1] and not held[i] and not held[i + 1]:
            n = run.subsamples if run.method == "rk4" else 1
            try:
                extra.setdefault(i, []).append((k - t[i], run.advance(motion.X[:, i], k - t[i], motion.c[i], n)[:, -1]))
            except IntegratorFailed:
                continue
    return _inserted(motion, extra)


def _inserted(motion, extra):
    """``motion`` with the states ``extra`` {sample i: [(tau, state) after it]} inserted."""
    if not extra:
        return motion
    t, X, c, held = motion.t, motion.X, motion.c, motion.held
    n = len(t)
    ts, xs, cs, hs = [], [], [], []
    for i in range(n):
        ts.append(t[i])
        xs.append(X[:, i])
        cs.append(c[i])
        hs.append(held[i])
        for tau, x in sorted(extra.get(i, []), key=lambda f: f[0]):
            if ts[-1] < t[i] + tau < t[i + 1]:
                ts.append(t[i] + tau)
                xs.append(x)
                cs.append(c[i])
                hs.append(0.0)
    return type(motion)(np.array(ts), np.column_stack(xs), np.array(cs), np.array(hs), motion.events, motion.stop,
                        motion.stop_end)


def _cubic_extreme(va, ra, vb, rb, h):
    """The largest value of the Hermite cubic through (0, va, ra) and (h, vb, rb) on [0, h]."""
    tau = np.linspace(0.0, 1.0, 33)
    h00, h10 = 2 * tau**3 - 3 * tau**2 + 1, tau**3 - 2 * tau**2 + tau
    h01, h11 = -2 * tau**3 + 3 * tau**2, tau**3 - tau**2
    return float(np.max(h00 * va + h10 * h * ra + h01 * vb + h11 * h * rb))


def _locate(run, t_a, x_a, c, h, row):
    """The instant tau in (0, h) after t_a where column ``row``'s rate changes sign (its rate
    at both ends of the interval differs in sign): (tau, state), or None where the integration
    fails."""
    eq, p = run.eq, run.p
    states = {0.0: x_a}
    n = run.subsamples if run.method == "rk4" else 1

    def state(tau):   # integrated from the latest state before tau
        x = states.get(tau)
        if x is None:
            start = max(u for u in states if u < tau)
            x = states[tau] = run.advance(states[start], tau - start, c, n)[:, -1]
        return x

    def rate(tau):
        return float(np.asarray(eq.peaked(state(tau), p, c)[1])[row, 0])

    try:
        tau = _root(rate, h)
        return tau, state(tau)
    except IntegratorFailed:
        return None


def _root(rate, h):
    """The instant in (0, h) where ``rate`` changes sign (it does between the ends): the Illinois
    regula falsi, to ``XTOL`` of h."""
    a, b, ra, rb = 0.0, h, rate(0.0), rate(h)
    side = 0
    for _ in range(100):
        if rb == 0.0 or b - a <= XTOL * h:
            break
        m = (a * rb - b * ra) / (rb - ra)
        if not a < m < b:
            m = 0.5 * (a + b)
        rm = rate(m)
        if rm == 0.0:
            return m
        if (rm > 0) == (ra > 0):
            a, ra = m, rm
            if side == -1:
                rb *= 0.5
            side = -1
        else:
            b, rb = m, rm
            if side == 1:
                ra *= 0.5
            side = 1
    return b
