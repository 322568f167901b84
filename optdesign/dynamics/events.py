"""The non-smooth instants of a motion: watched on the dense output of each branch, located to
the integration tolerance, and decided (which branch follows, or a stop).

A run integrates one *branch* of the equation of motion at a time (:mod:`.equations`): a
direction of motion d and an efficiency factor c (c = 1/eta while power flows into the
mechanism, eta while it flows back; 1 without efficiency), on which the equation is smooth.  The
branch holds while its *indicators* keep their sign (each ``g >= 0`` as written here):

- ``from``, ``to``: the sweep inside the stroke (s - lo, hi - s);
- ``speed`` (eta < 1): d ds/dt, the motion keeps its direction;
- ``power`` (eta < 1): the power flow keeps its direction, +-d B with B the bracket of
  :mod:`.equations` (T_S qd has the sign of sd B); B within a round-off band of zero does not
  count (a drive without torque or inertia has B = 0 throughout).

:func:`first_exit` finds the first sub-interval of the dense output in which an indicator
leaves its sign (or, by the Hermite cubic through its values and rates at both ends, may have
dipped below zero and come back: then the dip's lowest point is integrated to and checked);
:func:`locate` finds the instant by Newton steps on the indicator's rate (its derivative along
the motion, by AD), each step integrated from the latest point still on the branch, safeguarded
by the bracket (Illinois regula falsi; bisection where the integration failed), to 1e-14 of
the indicator's scale or a time step at rounding level.

**Decisions.**  A stroke end stops the run.  At a power-flow switch c flips.  At a rest (speed
through zero) the one-sided accelerations decide (:func:`at_rest`): the mechanism moves off in a
direction whose acceleration, on the branch of that direction's own power flow, agrees with it
('reversal' if that is back the way it came, 'rest' if it goes on), or, when neither does, the
self-locking drive holds it ('stall': the run stops; the law depends on q and qd only, so it is
held for good).  The start is decided the same way when it is at rest with eta < 1.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .integrate import IntegratorFailed

EPS = np.finfo(float).eps


@dataclass(frozen=True)
class Branch:
    """A branch of the equation of motion: direction d (+1, -1; 0 when it does not matter),
    efficiency factor c, and ``held`` (a rest the drive holds: no motion)."""
    d: float
    c: float
    held: bool = False


@dataclass
class Event:
    """A located non-smooth instant: time ``t``, ``kind`` ('reversal', 'rest', 'stall', 'power
    flow', 'stroke end', 'phase end'), the state ``x`` there, the branches before and after (None at the
    start or at a stop), and the stroke ``end`` ('from'/'to') of a stroke end."""
    t: float
    kind: str
    x: np.ndarray
    before: Branch | None
    after: Branch | None
    end: str | None = None
    extra: dict = field(default_factory=dict)


def watch(run, branch, X, rates=True):
    """The indicators of ``branch`` at the states X (columns): names, values g (rows; the branch
    holds while g >= 0), their rates along the motion, and their round-off bands.  Without
    ``rates`` the speed's and the power's rates are NaN (the stroke's, ds/dt, are states): the
    values alone cost a fraction of the rates' AD graph."""
    s, sd = X[0], X[1]
    names, g, rate, band = ["from", "to"], [s - run.lo, run.hi - s], [sd, -sd], [0 * s, 0 * s]
    if run.uses_efficiency and branch.d != 0:
        if rates:
            _, _, sdd, B, B_rate, B_size = np.asarray(run.eq.mapped("indicators", X.shape[1])(X, run.p, branch.c))
        else:
            B, B_size = np.asarray(run.eq.mapped("power", X.shape[1])(X, run.p))
            sdd = B_rate = np.full_like(s, np.nan)
        d = branch.d
        e = d if branch.c > 1 else -d  # c = 1/eta: power into the mechanism, d B >= 0
        names += ["speed", "power"]
        g += [d * sd, e * B]
        rate += [d * sdd, e * B_rate]
        band += [0 * s, 1e-11 * B_size]
    if run.ends["from"] > run.ends["to"]:  # 'from' is the upper end of the stroke
        g[0], g[1], rate[0], rate[1] = g[1], g[0], rate[1], rate[0]
    end = getattr(run, "phase_end", None)  # a phase of a duty cycle (:mod:`.phases`): where it ends
    if end is not None and end[0] == "position":
        sigma, target = end[1], end[2]
        names.append("position")
        g.append(sigma * (target - s))
        rate.append(-sigma * sd)
        band.append(0 * s)
    elif end is not None and end[0] == "rest" and "speed" not in names:
        d = end[1]
        sdd = (np.asarray(run.eq.mapped("indicators", X.shape[1])(X, run.p, branch.c))[2] if rates
               else np.full_like(s, np.nan))
        names.append("rest")
        g.append(d * sd)
        rate.append(d * sdd)
        band.append(0 * s)
    return names, np.array(g), np.array(rate), np.array(band)


def first_exit(run, branch, t, X, blowup=None):
    """The first sub-interval (columns i-1, i of the dense output X at times t; column 0 is the
    start) in which an indicator of ``branch`` leaves its sign: ('exit', i, [names], t_b, x_b)
    with the end (t_b, x_b) past the exit (column i, or the lowest point of a confirmed dip), or
    ('failed', i) where column i is not finite (or blows up: ds/dt changes by more than
    ``blowup`` from one point to the next, RK4's instability) before any exit, or None."""
    finite = np.isfinite(X).all(axis=0)
    if blowup is not None:
        with np.errstate(invalid="ignore", over="ignore"):
            finite &= np.r_[0.0, np.abs(np.diff(X[1]))] <= blowup
    bad = np.flatnonzero(~finite)
    stop = int(bad[0]) if bad.size else X.shape[1]
    if stop <= 1:
        return ("failed", 1) if stop == 1 else None
    names, g, rate, band = watch(run, branch, X[:, :stop], rates=False)
    g[:, 0] = np.maximum(g[:, 0], 0.0)  # the start: an instant just located lies on the branch
    out = g < -band
    out[:, 0] = False
    first = np.flatnonzero(out.any(axis=0))
    last = int(first[0]) if first.size else stop  # dips are looked for before the first exit
    # the speed's and the power's rates where their values have a local minimum (a dip below
    # zero between two points leaves one next to it), small against the change around it
    lows = np.zeros(last, bool)
    if last > 2 and len(names) > 2:
        gv = g[2:, :last]
        low = (gv[:, 1:-1] <= gv[:, :-2]) & (gv[:, 1:-1] <= gv[:, 2:]) & (
            gv[:, 1:-1] < 2 * (np.abs(gv[:, :-2] - gv[:, 1:-1]) + np.abs(gv[:, 2:] - gv[:, 1:-1])))
        cols = np.flatnonzero(low.any(axis=0)) + 1
        near = np.unique(np.clip(np.r_[cols - 1, cols, cols + 1], 0, last - 1))
        if near.size:
            rate[:, near] = watch(run, branch, X[:, near])[2]
            lows[near] = True
    # a dip: the indicator falls at the start of a sub-interval and rises at its end
    with np.errstate(invalid="ignore"):
        dips = (rate[:, :last - 1] < 0) & (rate[:, 1:last] > 0) & (g[:, :last - 1] >= 0) & (g[:, 1:last] >= 0)
    for i in np.flatnonzero(dips.any(axis=0)) + 1:
        for k in np.flatnonzero(dips[:, i - 1]):
            dt = t[i] - t[i - 1]
            tau = _cubic_minimum(g[k, i - 1], g[k, i], dt * rate[k, i - 1], dt * rate[k, i])
            if tau is None:
                continue
            try:
                x_m = run.advance(X[:, i - 1], tau * dt, branch.c)[:, 0]
            except IntegratorFailed:
                continue
            _, g_m, _, band_m = watch(run, branch, x_m[:, None])
            dipped = [names[j] for j in range(len(names)) if g_m[j, 0] < -band_m[j, 0]]
            if dipped:
                return ("exit", int(i), dipped, t[i - 1] + tau * dt, x_m)
    if first.size:
        i = int(first[0])
        return ("exit", i, [names[k] for k in range(len(names)) if out[k, i]], t[i], X[:, i])
    if stop < X.shape[1]:
        return ("failed", stop)
    return None


def _cubic_minimum(g0, g1, m0, m1):
    """Where the Hermite cubic with values g0, g1 and slopes m0, m1 at tau = 0, 1 dips below
    zero: its lowest point in (0, 1) if negative, else None."""
    a, b, c = 6 * g0 + 3 * m0 - 6 * g1 + 3 * m1, -6 * g0 - 4 * m0 + 6 * g1 - 2 * m1, m0
    roots = []
    if abs(a) > 1e-300:
        disc = b * b - 4 * a * c
        if disc >= 0:
            r = math.sqrt(disc)
            roots = [(-b - r) / (2 * a), (-b + r) / (2 * a)]
    elif abs(b) > 1e-300:
        roots = [-c / b]
    best = None
    for tau in roots:
        if 0 < tau < 1:
            h00, h10 = 2 * tau**3 - 3 * tau**2 + 1, tau**3 - 2 * tau**2 + tau
            h01, h11 = -2 * tau**3 + 3 * tau**2, tau**3 - tau**2
            v = h00 * g0 + h10 * m0 + h01 * g1 + h11 * m1
            if v < 0 and (best is None or v < best[1]):
                best = (tau, v)
    return None if best is None else best[0]


def _cubic_root(g0, g1, m0, m1):
    """The root in (0, 1) of the Hermite cubic with values g0 >= 0 > g1 and slopes m0, m1 at
    tau = 0, 1 (bisection and Newton on the cubic)."""
    def p(t):
        return ((2 * t**3 - 3 * t**2 + 1) * g0 + (t**3 - 2 * t**2 + t) * m0 + (-2 * t**3 + 3 * t**2) * g1
                + (t**3 - t**2) * m1)

    def dp(t):
        return (6 * t**2 - 6 * t) * (g0 - g1) + (3 * t**2 - 4 * t + 1) * m0 + (3 * t**2 - 2 * t) * m1

    lo, hi, t = 0.0, 1.0, g0 / (g0 - g1)
    for _ in range(60):
        v = p(t)
        if v >= 0:
            lo = t
        else:
            hi = t
        d = dp(t)
        t_new = t - v / d if d != 0 else 0.5 * (lo + hi)
        if not lo < t_new < hi:
            t_new = 0.5 * (lo + hi)
        if abs(t_new - t) <= 1e-15:
            break
        t = t_new
    return t


def locate(run, branch, name, t_a, x_a, t_b, x_b):
    """The instant in (t_a, t_b] at which indicator ``name`` of ``branch`` reaches zero, from
    x_a (on the branch) towards x_b (past it; None where the integration failed): (t, state),
    or None if it cannot be bracketed."""
    def value(x):
        if x is None or not np.isfinite(x).all():
            return None, None, None
        names, g, rate, band = watch(run, branch, x[:, None])
        if name not in names:
            return None, None, None
        k = names.index(name)
        return float(g[k, 0]), float(rate[k, 0]), float(band[k, 0])

    ga, ra, band = value(x_a)
    if ga is None:
        return None
    # to 1e-2 of the tolerance of its scale (the stroke, the reference rate, the bracket's terms)
    gtol = 1e-2 * run.tol * {"from": run.scale[0], "to": run.scale[0], "speed": run.scale[1], "rest": run.scale[1],
                             "position": run.scale[0], "power": band / 1e-11}[name]
    a, xa, ga = 0.0, x_a, max(ga, 0.0)
    b, xb = t_b - t_a, x_b
    gb, rb, _ = value(x_b)
    htol = max(1e-13 * b, 8 * EPS * abs(t_b))
    wa = wb = 1.0  # Illinois weights of the regula falsi
    # first guess: the root of the Hermite cubic through both ends (values and rates)
    guess = _cubic_root(ga, gb, b * ra, b * rb) * b if gb is not None and gb < 0 and ra is not None else None
    for _ in range(100):
        # Newton from the end nearer the root, else the regula falsi; integrated from the latest
        # point on the branch (never back from past the root: that side may be no motion at all)
        c = None
        if guess is not None:
            c, guess = guess, None
        elif gb is not None and rb is not None and rb < 0 and -gb < ga:
            c = b + gb / -rb
        elif ra is not None and ra < 0:
            c = a + ga / -ra
        if c is None or not a < c < b:
            c = a + wa * ga * (b - a) / (wa * ga - wb * gb) if gb is not None else None
            if c is None or not a < c < b:
                c = 0.5 * (a + b)
        try:
            xc = run.advance(xa, c - a, branch.c)[:, 0]
        except IntegratorFailed:
            xc = None
        gc, rc, _ = value(xc)
        if gc is not None and gc >= 0:
            a, xa, ga, ra = c, xc, gc, rc
            wa, wb = 1.0, wb * 0.5
        else:
            b, xb, gb, rb = c, (xc if gc is not None else None), gc, rc
            wa, wb = wa * 0.5, 1.0
        if (gc is not None and abs(gc) <= gtol) or b - a <= htol:
            break
    if gb is not None and abs(gb) < ga:
        return t_a + b, np.array(xb, float)
    if b - a <= 1e3 * htol or ga <= 1e3 * gtol:
        return t_a + a, np.array(xa, float)
    return None


def start(run, x):
    """The branch at the start x, and the event there (None, or a rest decided at t = 0)."""
    d = float(np.sign(x[1]))
    if not run.uses_efficiency:
        return Branch(d, 1.0), None
    if d == 0:
        ev = at_rest(run, 0.0, x, None)
        return (ev.after if ev.after is not None else ev.before), ev
    return flow_branch(run, x, d), None


def flow_branch(run, x, d):
    """The branch of direction d at the moving state x: c from the sign of d B (from the sign of
    B's rate where B is within round-off of zero)."""
    ind = np.asarray(run.eq.indicators(x, run.p, 1.0)).ravel()
    B, B_rate, size = ind[3], ind[4], ind[5]
    flow = B if abs(B) > 1e-11 * size else B_rate
    return Branch(d, 1 / run.eta if d * flow >= 0 else run.eta)


def at_rest(run, t, x, before):
    """The decision at a rest (x with ds/dt = 0) reached on branch ``before`` (None at the
    start): an :class:`Event` 'reversal' or 'rest' with the branch it moves off on, or 'stall'
    (``after`` None, ``before`` the branch held)."""
    x = np.array(x, float)
    x[1] = 0.0
    sdd_p, c_p, sdd_m, c_m, size = np.asarray(run.eq.rest(x, run.p)).ravel()
    small = 1e-10 * size
    moves = [(abs(sdd_p), 1.0, c_p)] if sdd_p > small else []
    moves += [(abs(sdd_m), -1.0, c_m)] if sdd_m < -small else []
    accel = {"forward": float(sdd_p), "backward": float(sdd_m)}
    if not moves:
        held = Branch(before.d if before is not None else 0.0, before.c if before is not None else 1.0, True)
        return Event(t, "stall", x, held, None, extra={"one_sided_accelerations": accel})
    _, d, c = max(moves)
    kind = "rest" if before is None or before.d == d else "reversal"
    return Event(t, kind, x, before, Branch(d, float(c)), extra={"one_sided_accelerations": accel})
