"""Where a run stops: the stroke end, located in time, or the rest where a self-locking drive
holds the mechanism (stall); else an integrator failure, reported with its time and state.

**Stroke ends.**  The run goes over the output grid (:mod:`.integrate`), and where the sweep
leaves the stroke the crossing time is located by re-integrating the last interval over a
variable length h (the time-scaled ODE) and solving s(h) = end (Illinois regula falsi, to 1e-12
of the interval: :func:`locate`).

**Self-locking (stall).**  Where a drive with eta < 1 brings the mechanism to rest at a position
whose drive load lies between eta and 1/eta times the static load, the switch holds it there
(moving on, the drive divided by eta is too small; moving back, the load times eta pushes it
forward again): the acceleration flips sign with ds/dt, and the integrators either give up or,
at looser tolerances, step on through the chatter (tiny steps: the run's cost, not its stop;
so a drive with eta < 1 is integrated in chunks of output intervals, each checked for a held
rest before the next).  Neither is used to find the stop: the approach to rest is smooth, so the
instant of rest is the root of ds/dt on the *one-sided* equation (:mod:`.equations`), which
continues smoothly through ds/dt = 0.  An output interval is examined where its end sample has
failed, reversed, or could have lost its speed in the interval (|ds/dt| <= |s''| dt); the root
is located like a stroke end, and the run stops 'stalled' there if the drive holds the mechanism
(either way out of rest decelerates back).

Every function takes the run (:class:`~.integrate.Integration`): its equations, parameter
values, integrator settings and counts.
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import SolverError
from ..kinematics.mechanism import _fmt_s
from .integrate import IntegratorFailed


def stop(run, grid, X, scene, ends):
    """Cut the run at the first rest where a self-locking drive holds the mechanism (up to
    the first failed or out-of-stroke sample), or where the sweep leaves the stroke
    (locating the crossing time), or report an integrator failure with its time and state.
    ``ends``: the sweep values of the stroke's ends {'from': ..., 'to': ...}.
    Returns (t, X, stop, stop_end) cut at the stop."""
    method, p = run.method, run.p
    bad = np.flatnonzero(~run.inside(X))
    if run.eq.uses_efficiency:
        stall = held_rest(run, grid, X, int(bad[0]) if bad.size else len(grid) - 1)
        if stall is not None:
            j, h, x = stall
            return np.append(grid[:j], grid[j - 1] + h), np.column_stack([X[:, :j], x]), "stalled", None
    if not bad.size:
        return grid, X, "t_end", None
    i = int(bad[0])
    x_prev, dt = X[:, i - 1], grid[i] - grid[i - 1]
    if np.isfinite(X[:, i]).all():
        target = run.hi if X[0, i] > run.hi else run.lo
    else:
        target = run.hi if x_prev[1] >= 0 else run.lo
    h, x_end = None, None
    sdd = run.eq.output("sdd", x_prev, p)
    reach = abs(x_prev[1]) * dt + 0.5 * abs(sdd) * dt**2  # how far s can plausibly get in dt
    if np.isfinite(X[:, i]).all() or abs(target - x_prev[0]) <= 4 * reach:
        h, x_end = locate(run, x_prev, dt, target, X[:, i])
    if x_end is None:
        name = scene.sweep.name
        qd = run.eq.output("qd", x_prev, p)
        what = ("its solution blew up (NaN or inf): the fixed step is beyond RK4's stability limit, the "
                "motion is stiff here" if method == "rk4" else
                "CVODES gave up (too many steps, or repeated error-test or convergence failures)")
        if run.eq.uses_efficiency and abs(x_prev[1]) < 1e-2 * np.nanmax(np.abs(X[1, :i])):
            raise SolverError(
                f"{scene.path}: the drive stalls near t = {grid[i - 1]:.6g} s, {name} = {_fmt_s(x_prev[0])}, "
                f"speed {qd:.3g}, but the instant the mechanism comes to rest could not be located: "
                "tighten the tolerance or use more samples.")
        hint = {"bdf": "tighten or loosen the tolerance, or check the law and the loads for a blow-up",
                "adams": "use the implicit integrator (integrator = \"bdf\"), which handles stiff cases",
                "rk4": "use more steps per sample or the implicit integrator (integrator = \"bdf\")"}[method]
        raise SolverError(
            f"{scene.path}: the {method} integrator failed between t = {grid[i - 1]:.6g} s and "
            f"{grid[i]:.6g} s, from {name} = {_fmt_s(x_prev[0])}, drive speed {qd:.6g}, "
            f"d{name}/dt = {x_prev[1]:.6g}: {what}; {hint}.")
    end = "to" if target == ends["to"] else "from"
    x_end[0] = target
    t = np.append(grid[:i], grid[i - 1] + h)
    return t, np.column_stack([X[:, :i], x_end]), "stroke end", end


def held_rest(run, grid, X, last, first=1):
    """The first output interval (up to sample ``last``) in which a self-locking drive brings
    the mechanism to rest and holds it: (j, h, state), the rest at t = grid[j-1] + h with
    ds/dt = 0 exactly, or None.  Past that instant the switch chatters: the integrator gives
    up, or (looser tolerances) steps on through it with |ds/dt| tiny; so examined are the
    intervals whose end sample has failed, reversed, or could have lost its speed within
    the interval (d sd_j <= |s''_j| dt, d the direction of motion at the interval's start);
    those from sample ``first`` on."""
    sdd = run.eq.output_row("sdd", X, run.p)
    for j in range(first, last + 1):
        x_prev, dt = X[:, j - 1], grid[j] - grid[j - 1]
        d = float(np.sign(x_prev[1]))
        if d == 0 or d * X[1, j] > abs(sdd[j]) * dt:  # (False for a failed sample: NaN)
            continue
        at_rest = rest(run, x_prev, dt, d)
        if at_rest is not None and held(run, at_rest[1], d, np.max(np.abs(X[1, :j]))):
            return (j, *at_rest)
    return None


def rest(run, x_prev, dt, d):
    """(h, state): the instant in (0, dt] where ds/dt reaches 0 on the one-sided equation from
    x_prev moving in direction d (smooth up to and through the rest), or None."""
    F = run.integrator([1.0], run.steps, one_sided=True)
    try:
        x_dt = run.call(F, x_prev, dt, d)[:, 0]
    except IntegratorFailed:
        x_dt = np.full_like(x_prev, np.nan)
    if np.isfinite(x_dt).all() and d * x_dt[1] > 0:
        return None
    h, x = locate(run, x_prev, dt, 0.0, x_dt, component=1, direction=d)
    if x is None:
        return None
    x = np.array(x, float)
    x[1] = 0.0
    return h, x


def held(run, x, d, speed_scale):
    """The drive holds the mechanism at rest in state x (ds/dt = 0), reached moving in
    direction d: either way out of rest decelerates back to it."""
    nudge = 1e-9 * speed_scale
    ahead, back = (run.eq.output("sdd", np.r_[x[0], e * nudge, x[2:]], run.p) for e in (d, -d))
    return d * ahead < 0 and d * back > 0


def locate(run, x_prev, dt, target, x_next, component=0, direction=None):
    """The time h in (0, dt] after which the state's ``component`` (0: s, 1: ds/dt) reaches
    ``target``, by re-integrating from x_prev (Illinois regula falsi where both ends are
    finite, bisection past a failure); with a ``direction`` on the one-sided equation.
    Returns (h, state), or (None, None)."""
    F = run.integrator([1.0], run.steps, one_sided=direction is not None)
    length = run.scale[component]  # the stroke length, or the reference rate

    def g(h):
        try:
            x = run.call(F, x_prev, h, direction)[:, 0]
        except IntegratorFailed:
            return None, None
        return (x[component] - target if np.isfinite(x).all() else None), x

    a, ga, xa = 0.0, x_prev[component] - target, x_prev
    b, gb = dt, (x_next[component] - target if np.isfinite(x_next).all() else None)
    xb = x_next
    side = 0
    for _ in range(200):
        if gb is not None and ga != gb:
            c = b - gb * (b - a) / (gb - ga)
            if not a < c < b:
                c = 0.5 * (a + b)
        else:
            c = 0.5 * (a + b)
        gc, xc = g(c)
        if gc is not None and abs(gc) <= 1e-13 * length:
            return c, xc
        if gc is not None and math.copysign(1, gc) == math.copysign(1, ga):
            a, ga, xa = c, gc, xc
            if side == -1 and gb is not None:
                gb *= 0.5
            side = -1
        else:
            b, gb, xb = c, gc, xc
            if side == 1:
                ga *= 0.5
            side = 1
        if b - a <= 1e-12 * dt:
            break
    if gb is not None and abs(gb) <= 1e-9 * length:
        return b, xb
    if abs(ga) <= 1e-9 * length:
        return a, xa
    return None, None
