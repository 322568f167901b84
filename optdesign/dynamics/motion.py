"""One run over the output grid, branch by branch: integrate, watch, locate, decide, restart.

The run goes in stretches of whole output intervals, each one integrator call on the current
branch with its dense output (:mod:`.integrate`): one interval after a restart, then twice as
many each time none ends the branch (a CVODES restart costs a few steps; a stretch integrated
past an event on the wrong branch is thrown away, so it should not be much longer than the
motion since the last event).  In each stretch :func:`.events.first_exit` finds where the
branch ends, :func:`.events.locate` the instant, and the decision there (:mod:`.events`) the
branch that follows or the stop; the run restarts from the located state.  A stretch that fails
is tried again one output interval at a time, and a failing interval point by point: a
stroke end within reach is then located with the failure counted as past it, anything else is a
:class:`~optdesign.errors.SolverError` naming the time, the state and a fix.

The samples are the output grid's up to the stop, with every event's state inserted at its time
(the branch after it; a held rest with no acceleration).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import SolverError
from ..kinematics.mechanism import _fmt_s
from .events import Event, at_rest, first_exit, flow_branch, locate, start
from .integrate import LONGEST, MAX_STEPS, IntegratorFailed

MAX_EVENTS = 100000   # events in one run
SAME_INSTANT = 50     # events in a row at one instant (to 1e-12 of an output interval)


@dataclass
class Motion:
    """The samples of a run (times ``t``, states ``X`` in columns, per sample the branch's c
    and whether the drive holds the mechanism at rest), its ``events`` and its stop ('t_end',
    'stroke end' with ``stop_end`` 'from'/'to', 'stalled'; 'phase end' where a phase of
    :mod:`.phases` ends)."""
    t: np.ndarray
    X: np.ndarray
    c: np.ndarray
    held: np.ndarray
    events: list
    stop: str
    stop_end: str | None


class _Samples:
    def __init__(self):
        self.t, self.x, self.c, self.held = [], [], [], []

    def add(self, t, x, branch):
        self.t.append(float(t))
        self.x.append(np.array(x, float))
        self.c.append(branch.c)
        self.held.append(1.0 if branch.held else 0.0)


def run_motion(run, grid, where):
    """The motion of ``run`` (:class:`~.integrate.Integration`) over the output ``grid`` (equally
    spaced from 0); ``where`` = (scene path, sweep name, scene) for messages."""
    n, m = len(grid) - 1, run.subsamples
    dt = grid[1] - grid[0]
    out, events = _Samples(), []
    x = np.array(run.x0, float)
    branch, ev = start(run, x)
    if ev is not None:
        events.append(ev)
    out.add(0.0, x, branch)
    if branch.held:
        return _finish(out, events, "stalled", None)
    t, j, K, same = 0.0, 1, 1, 0
    peak = abs(x[1]) + run.scale[1]
    while j <= n:
        if abs(t - grid[j - 1]) <= 1e-12 * dt:  # on the grid: a stretch of whole intervals
            t = grid[j - 1]
            k = 1 << (min(K, n - j + 1, LONGEST).bit_length() - 1)
        else:  # after an event: to the next grid time
            k = 1
        H = grid[j - 1 + k] - t
        steps0 = run.counts.steps
        try:
            Xs = run.advance(x, H, branch.c, k * m)
            failure = None
        except IntegratorFailed:
            if k > 1:
                K = 1
                continue
            Xs, failure = _pointwise(run, x, H, branch.c, m)
        # CVODES gives more points than watched: about one per step it took, where that is more
        taken = run.counts.steps - steps0
        npts = k * m
        while npts < min(taken, Xs.shape[1]):
            npts *= 2
        stride, per = Xs.shape[1] // npts, npts // k
        Xs = Xs[:, stride - 1::stride]
        ts = t + H * np.arange(1, npts + 1) / npts
        on_grid = np.arange(per - 1, npts, per)
        ts[on_grid] = grid[j:j + k]
        T, X = np.r_[t, ts], np.column_stack([x, Xs])
        # RK4 (no error control): a step that changes the speed by more than its largest value
        # so far is its instability (each step multiplies the error), not the motion
        blowup = peak if run.method == "rk4" else None
        hit = first_exit(run, branch, T, X, blowup)
        if hit is None:
            for i in on_grid + 1:
                out.add(T[i], X[:, i], branch)
            peak = max(peak, float(np.max(np.abs(X[1]))))
            t, x, j, K = T[-1], X[:, -1], j + k, min(2 * K, LONGEST)
            continue
        i = hit[1]
        for col in on_grid + 1:  # the grid samples before the sub-interval of the event
            if col <= i - 1:
                out.add(T[col], X[:, col], branch)
        j += int(np.sum(on_grid + 1 <= i - 1))
        event = _event(run, branch, hit, T, X, failure, where)
        same = same + 1 if events and event.t - events[-1].t <= 1e-12 * dt else 0
        events.append(event)
        if len(events) > MAX_EVENTS or same >= SAME_INSTANT:
            raise SolverError(f"{where[0]}: {len(events)} events (reversals, power-flow switches) by t = "
                              f"{event.t:.9g} s, {same + 1} of them at that instant: the motion chatters there "
                              f"({where[1]} = {_fmt_s(event.x[0], where[2])}, d{where[1]}/dt = {event.x[1]:.6g}); check the "
                              "law and the efficiency")
        if j <= n and grid[j] - event.t <= 1e-12 * dt:  # the event falls on a grid time: it replaces it
            j += 1
        after = event.after if event.after is not None else event.before
        out.add(event.t, event.x, after)
        peak = max(peak, float(np.max(np.abs(X[1, :i]))))
        if event.kind == "stroke end":
            return _finish(out, events, "stroke end", event.end)
        if event.kind == "stall":
            return _finish(out, events, "stalled", None)
        if event.kind == "phase end":
            return _finish(out, events, "phase end", None)
        t, x, branch, K = event.t, event.x, event.after, 1
    return _finish(out, events, "t_end", None)


def _event(run, branch, hit, T, X, failure, where):
    """The first event in sub-interval i of the stretch (T, X), located and decided."""
    i = hit[1]
    t_a, x_a = T[i - 1], X[:, i - 1]
    if hit[0] == "exit":
        _, _, names, t_b, x_b = hit
        found = [(r[0], name, r[1]) for name in names
                 for r in [locate(run, branch, name, t_a, x_a, t_b, x_b)] if r is not None]
        if not found:
            raise SolverError(f"{where[0]}: an event ({', '.join(names)}) between t = {t_a:.9g} s and {t_b:.9g} s "
                              "could not be located; tighten the tolerance")
        order = {"position": -1, "from": 0, "to": 0, "speed": 1, "rest": 1, "power": 2}
        t_e, name, x_e = min(found, key=lambda f: (f[0], order[f[1]]))
        return _decide(run, branch, name, t_e, x_e)
    # the integration failed (or blew up) in the sub-interval: a stroke end within reach?
    d = np.sign(x_a[1])
    name = ("to" if (run.ends["to"] > run.ends["from"]) == (d > 0) else "from") if d != 0 else None
    target = run.ends[name] if name else None
    sdd = run.eq.output("sdd", x_a, run.p, branch.c)
    dt = T[i] - T[i - 1]
    reach = abs(x_a[1]) * dt + 0.5 * abs(sdd) * dt**2
    if name and abs(target - x_a[0]) <= 4 * reach:
        r = locate(run, branch, name, t_a, x_a, T[i], None)
        if r is not None:
            return _decide(run, branch, name, *r)
    raise _failure(run, branch, t_a, T[i], x_a, failure, where)


def _decide(run, branch, name, t, x):
    x = np.array(x, float)
    if name in ("from", "to"):
        x[0] = run.ends[name]
        return Event(t, "stroke end", x, branch, None, end=name)
    end = getattr(run, "phase_end", None)
    if name == "position" or name == "rest" or (name == "speed" and end is not None and end[0] == "rest"):
        if name == "position":
            x[0] = end[2]  # located to the tolerance: on it
        else:
            x[1] = 0.0
        return Event(t, "phase end", x, branch, None)
    if name == "speed":
        return at_rest(run, t, x, branch)
    after = flow_branch(run, x, branch.d)
    if after.c == branch.c:  # B left the band only by rounding: flip anyway, it was seen past zero
        after = type(branch)(branch.d, run.eta if branch.c > 1 else 1 / run.eta)
    return Event(t, "power flow", x, branch, after)


def _pointwise(run, x, H, c, m):
    """A failing interval point by point: the states up to the failure, NaN after; and the
    failure's message."""
    cols, failure = [], None
    for _ in range(m):
        if failure is None:
            try:
                x = run.advance(x, H / m, c)[:, 0]
            except IntegratorFailed as exc:
                failure = str(exc)
        cols.append(x if failure is None else np.full_like(x, np.nan))
    return np.column_stack(cols), failure or "no finite solution"


def _failure(run, branch, t_a, t_b, x_a, failure, where):
    path, name = where[:2]
    qd = run.eq.output("qd", x_a, run.p, branch.c)
    method = run.method
    what = ("its solution blew up (NaN or inf): the fixed step is beyond RK4's stability limit, the "
            "motion is stiff here" if method == "rk4" else
            "CVODES gave up (too many steps, or repeated error-test or convergence failures)")
    hint = {"bdf": "tighten or loosen the tolerance, or check the law and the loads for a blow-up",
            "adams": "use the implicit integrator (integrator = \"bdf\"), which handles stiff cases",
            "rk4": "use more steps per sample or the implicit integrator (integrator = \"bdf\")"}[method]
    if method != "rk4" and failure and "CV_TOO_MUCH_WORK" in failure:   # the input, not the solver, is the cause
        what = (f"CVODES needed more than {MAX_STEPS:,} steps for the {t_b - t_a:.3g} s between two of its "
                "output points")
        hint = ("if t_end is far longer than the motion you meant to follow (e.g. 1e9 s), shorten it "
                "(--t-end, [simulation] t_end) or ask for more samples; else " + hint)
    exc = SolverError(
        f"{path}: the {method} integrator failed between t = {t_a:.6g} s and {t_b:.6g} s, from "
        f"{name} = {_fmt_s(x_a[0], where[2])}, drive speed {qd:.6g}, d{name}/dt = {x_a[1]:.6g}: {what}; {hint}.")
    exc.state, exc.span, exc.branch = np.array(x_a, float), float(t_b - t_a), branch  # for :mod:`.phases`
    return exc


def _finish(out, events, stop, end):
    return Motion(np.array(out.t), np.column_stack(out.x), np.array(out.c), np.array(out.held), events, stop, end)
