"""An independent numpy model of problems/press_servo_cycle.toml and its optimum (nothing of
optdesign is imported: the geometry, the virtual work, the profiles in time, the drive train and
the constraints are written here from the scene and docs/scenes.md).

The press: a slider-crank (crank r, rod l, ram line offset e) with its derivatives in closed
form, the torque at the crank by virtual work, T = sum m a_G . dG/dphi + I beta'' beta' + g sum
m dy_G/dphi - F dy_C/dphi, the efficiencies switched by the power flow (crank 0.95, gearbox
0.96), the motor torque T_m = T_g + J_r i phi''.  Each profile's motion in time from its jerk
(or acceleration) law, integrated exactly segment by segment.  The duty cycle: forming stroke
(s-curve, 400 kN drawing force), return (trapezoid, no force), 0.4 s dwell (motor idle).

Integrals over time: scipy.integrate.quad (:func:`case_integrals`) or Gauss-Legendre of 64 nodes
on each segment's pieces between the power flow's turns (:func:`cycle`, vectorised, for the
search): both split where T_S phi' changes sign.

The optimum (:func:`optimum`): a grid over (l, e, i), the best feasible points polished by SLSQP
on the Gauss-Legendre RMS with the constraints (rod angle to the ram line <= 10 deg over the
stroke, ram pin depth <= 0.46 m, motor peak torque <= 480 N m on 4,001 times per case, motor
speed i 6 rad/s <= 300, RMS <= 160)."""
from __future__ import annotations

import math

import numpy as np
from scipy.integrate import quad
from scipy.optimize import brentq, minimize

LOWER, UPPER = np.array([0.20, -0.08, 4.0]), np.array([0.60, 0.08, 60.0])   # l, e, i
STROKE = math.radians(120)
DWELL = 0.4


class Press:
    """The slider-crank of press_servo_cycle.toml at the parameters l, e, i (and F0)."""

    H, MR, G, J, ETA, ETA_G = 0.10, 400.0, 9.81, 0.04, 0.95, 0.96
    D0, W = 0.015, 0.008

    def __init__(self, l, e, i, F0):
        self.l, self.e, self.i, self.F0 = l, e, i, F0
        self.r = self.H / 2 * math.sqrt(1 - 4 * e**2 / (4 * l**2 - self.H**2))
        self.mL = 150 * l
        self.IL = self.mL * l**2 / 12
        self.yBDC = -math.sqrt((l + self.r) ** 2 - e**2)
        self.aBDC = -math.pi / 2 + math.asin(e / (l + self.r))

    def geometry(self, phi):
        """(xA, yA, h, yC): the crank pin, the rod's vertical extent and the ram pin at phi."""
        th = self.aBDC + np.asarray(phi, float)
        xA, yA = self.r * np.cos(th), self.r * np.sin(th)
        h = np.sqrt(self.l**2 - (self.e - xA) ** 2)
        return xA, yA, h, yA - h

    def torque(self, phi, pd, pdd):
        """(T_S at the crank, motor load torque T_g, motor torque T_g + J i phi'') at the crank
        angle phi from BDC, its rate and acceleration (arrays or numbers)."""
        r, l, e = self.r, self.l, self.e
        phi, pd, pdd = (np.asarray(v, float) for v in (phi, pd, pdd))
        th = self.aBDC + phi
        xA, yA = r * np.cos(th), r * np.sin(th)
        xA1, yA1, xA2, yA2 = -yA, xA, -xA, -yA
        D = l**2 - (e - xA) ** 2
        h = np.sqrt(D)
        D1 = 2 * (e - xA) * xA1
        D2 = 2 * ((e - xA) * xA2 - xA1**2)
        h1 = D1 / (2 * h)
        h2 = (D2 / 2 - h1**2) / h
        yC, yC1, yC2 = yA - h, yA1 - h1, yA2 - h2
        dx, dy, dx1, dy1, dx2, dy2 = e - xA, -h, -xA1, -h1, -xA2, -h2
        b1 = (dx * dy1 - dy * dx1) / l**2
        b2 = (dx * dy2 - dy * dx2) / l**2
        xG1, yG1, xG2, yG2 = xA1 / 2, (yA1 + yC1) / 2, xA2 / 2, (yA2 + yC2) / 2
        F = self.F0 * np.exp(-(((yC - self.yBDC - self.D0) / self.W) ** 2))
        ideal = (self.MR * (yC2 * pd**2 + yC1 * pdd) * yC1
                 + self.mL * ((xG2 * pd**2 + xG1 * pdd) * xG1 + (yG2 * pd**2 + yG1 * pdd) * yG1)
                 + self.IL * (b2 * pd**2 + b1 * pdd) * b1
                 + self.G * (self.MR * yC1 + self.mL * yG1) - F * yC1)
        drive = np.where(ideal * pd >= 0, ideal / self.ETA, ideal * self.ETA)
        load = np.where(drive * pd >= 0, drive / self.ETA_G, drive * self.ETA_G) / self.i
        return drive, load, load + self.J * self.i * pdd


def segments(kind, v, a, d, j, length):
    """A profile's motion from rest to rest over ``length`` as segments (duration, a0, jerk)."""
    if kind == "trapezoidal":
        up, down = [(v / a, a, 0.0)], [(v / d, -d, 0.0)]
    else:
        up = [(a / j, 0.0, j), (v / a - a / j, a, 0.0), (a / j, a, -j)]
        down = [(d / j, 0.0, -j), (v / d - d / j, -d, 0.0), (d / j, -d, j)]

    def distance(segs):
        s, vv = 0.0, 0.0
        for T, a0, jj in segs:
            s, vv = s + vv * T + a0 * T**2 / 2 + jj * T**3 / 6, vv + a0 * T + jj * T**2 / 2
        return s
    cruise = (length - distance(up) - (v * sum(T for T, _, _ in down) - distance([(T, -a0, -jj) for T, a0, jj in down]))) / v
    return up + [(cruise, 0.0, 0.0)] + down


# the cycle's two strokes: (force on, segments, phi at the start, direction)
FORMING = (True, segments("s-curve", 4.0, 40.0, 40.0, 1000.0, STROKE), -STROKE, +1)
RETURN = (False, segments("trapezoidal", 6.0, 60.0, 60.0, 0.0, STROKE), 0.0, -1)


def _states(segs, phi0, sign):
    """Per segment: (duration, state(tau) -> (phi, phi', phi''))."""
    out, s, v = [], 0.0, 0.0
    for T, a0, jj in segs:
        def state(tau, s=s, v=v, a0=a0, jj=jj):
            tau = np.asarray(tau, float)
            x = s + v * tau + a0 * tau**2 / 2 + jj * tau**3 / 6
            return phi0 + sign * x, sign * (v + a0 * tau + jj * tau**2 / 2), sign * (a0 + jj * tau)
        out.append((T, state))
        s, v = s + v * T + a0 * T**2 / 2 + jj * T**3 / 6, v + a0 * T + jj * T**2 / 2
    return out


def _pieces(press, T, state, n=401):
    """[0, T] cut where the power flow T_S phi' turns (the efficiencies switch there)."""
    def flow(t):
        phi, pd, pdd = state(t)
        return float(press.torque(phi, pd, pdd)[0] * pd)
    grid = np.linspace(0, T, n)
    phi, pd, pdd = state(grid)
    f = press.torque(phi, pd, pdd)[0] * pd
    cuts = [brentq(flow, grid[k], grid[k + 1], xtol=1e-15) for k in range(n - 1) if f[k] * f[k + 1] < 0]
    return [0.0] + cuts + [T]


def case_integrals(press, segs, phi0, sign):
    """int T_S^2 dt, int T_g^2 dt, int T_m^2 dt, int T_S phi' dt and the time, by quad in time."""
    out = np.zeros(5)
    for T, state in _states(segs, phi0, sign):
        def values(tau, state=state):
            phi, pd, pdd = state(tau)
            drive, load, motor = (float(v) for v in press.torque(phi, pd, pdd))
            return np.array([drive**2, load**2, motor**2, drive * float(pd)])
        edges = _pieces(press, T, state, 2001)
        for lo, hi in zip(edges[:-1], edges[1:]):
            for q in range(4):
                out[q] += quad(lambda t: values(t)[q], lo, hi, epsabs=0, epsrel=1e-13, limit=400)[0]
        out[4] += T
    return out


def quad_rms(l, e, i):
    """The RMS motor torque over the duty cycle by quad (the reference value)."""
    total, T = 0.0, DWELL
    for force, segs, phi0, sign in (FORMING, RETURN):
        out = case_integrals(Press(l, e, i, 400e3 if force else 0.0), segs, phi0, sign)
        total, T = total + out[2], T + out[4]
    return math.sqrt(total / T)


_X, _W = np.polynomial.legendre.leggauss(64)


def cycle(x, times=1001):
    """At design x = (l, e, i): the RMS motor torque over the cycle (Gauss-Legendre, 64 nodes on
    each piece between the power flow's turns), the motor's peak |torque| on ``times`` times per
    segment, the rod's largest angle to the ram line over the stroke, the ram pin's depth at BDC
    and the motor's peak speed.  None where the design does not assemble."""
    l, e, i = (float(v) for v in x)
    if 4 * l**2 - 0.01 <= 4 * e**2:
        return None
    total, T, peak = 0.0, DWELL, 0.0
    for force, segs, phi0, sign in (FORMING, RETURN):
        press = Press(l, e, i, 400e3 if force else 0.0)
        for dur, state in _states(segs, phi0, sign):
            if dur <= 0:
                continue
            edges = _pieces(press, dur, state, 101)
            for lo, hi in zip(edges[:-1], edges[1:]):
                t = 0.5 * (lo + hi) + 0.5 * (hi - lo) * _X
                total += 0.5 * (hi - lo) * float(np.dot(_W, press.torque(*state(t))[2] ** 2))
            peak = max(peak, float(np.max(np.abs(press.torque(*state(np.linspace(0, dur, times)))[2]))))
            T += dur
    press = Press(l, e, i, 0.0)
    xA, _, h, _ = press.geometry(np.linspace(-STROKE, 0.0, 4001))
    if not np.all(np.isfinite(h)):
        return None
    angle = float(np.max(np.arcsin(np.abs(e - xA) / l)))
    return {"rms": math.sqrt(total / T), "peak": peak, "angle": angle, "depth": -press.yBDC, "speed": 6.0 * i}


def peak_motor(x, times=4001):
    """The motor's peak |torque| over the cycle at design x: the largest of ``times`` times per
    segment, refined by a bounded scalar search between its neighbours."""
    from scipy.optimize import minimize_scalar

    l, e, i = (float(v) for v in x)
    best = 0.0
    for force, segs, phi0, sign in (FORMING, RETURN):
        press = Press(l, e, i, 400e3 if force else 0.0)
        for dur, state in _states(segs, phi0, sign):
            if dur <= 0:
                continue
            t = np.linspace(0, dur, times)
            k = int(np.argmax(np.abs(press.torque(*state(t))[2])))
            lo, hi = t[max(k - 1, 0)], t[min(k + 1, times - 1)]
            res = minimize_scalar(lambda u: -abs(float(press.torque(*state(u))[2])), bounds=(lo, hi),
                                  method="bounded", options={"xatol": 1e-14 * max(dur, 1.0)})
            best = max(best, -float(res.fun), float(np.abs(press.torque(*state(t[k]))[2])))
    return best


DEPTH = 0.46   # the ram pin depth's limit [m] (a test may relax it: l is then held by no constraint)


def constraints(c) -> np.ndarray:
    """Each constraint's margin (>= 0 where it holds), scaled to order one."""
    return np.array([(math.radians(10) - c["angle"]) / math.radians(10), (DEPTH - c["depth"]) / DEPTH,
                     (480 - c["peak"]) / 480, (300 - c["speed"]) / 300, (160 - c["rms"]) / 160])


def _screen_nodes(n=201):
    """Per stroke: (phi, phi', phi'', weights) on n times per segment (Simpson's rule in time),
    the same for every design: the grid's screening integrates on them."""
    out = []
    for force, segs, phi0, sign in (FORMING, RETURN):
        parts = []
        for dur, state in _states(segs, phi0, sign):
            if dur > 0:
                t = np.linspace(0, dur, n)
                w = np.full(n, 2.0)
                w[1::2], w[0], w[-1] = 4.0, 1.0, 1.0
                parts.append(np.vstack([*state(t), w * dur / (n - 1) / 3]))
        out.append((force, np.hstack(parts)))
    return out


def grid_search(n=(21, 9, 15)) -> list:
    """(rms, x) of the feasible points of a grid over the design box, best first (screened by
    Simpson's rule on 201 times per segment, the peak on them)."""
    nodes, found = _screen_nodes(), []
    for x in np.stack(np.meshgrid(*(np.linspace(lo, hi, k) for lo, hi, k in zip(LOWER, UPPER, n)),
                                  indexing="ij"), -1).reshape(-1, 3):
        l, e, i = x
        if 4 * l**2 - 0.01 <= 4 * e**2:
            continue
        total, peak = 0.0, 0.0
        for force, (phi, pd, pdd, w) in nodes:
            motor = Press(l, e, i, 400e3 if force else 0.0).torque(phi, pd, pdd)[2]
            total, peak = total + float(np.dot(w, motor**2)), max(peak, float(np.max(np.abs(motor))))
        press = Press(l, e, i, 0.0)
        xA, _, h, _ = press.geometry(np.linspace(-STROKE, 0.0, 401))
        if not np.all(np.isfinite(h)):
            continue
        T = DWELL + sum(float(np.sum(w)) for _, (_, _, _, w) in nodes)
        c = {"rms": math.sqrt(total / T), "peak": peak, "angle": float(np.max(np.arcsin(np.abs(e - xA) / l))),
             "depth": -press.yBDC, "speed": 6.0 * i}
        if np.all(constraints(c) >= 0):
            found.append((c["rms"], x))
    return sorted(found, key=lambda v: v[0])


def polish(x0):
    """SLSQP from x0 on the Gauss-Legendre RMS with the constraints (scaled design)."""
    span = UPPER - LOWER

    def at(z):
        return cycle(LOWER + span * np.asarray(z))

    def f(z):
        c = at(z)
        return c["rms"] / 100 if c else 1e3

    def g(z):
        c = at(z)
        return constraints(c) if c else -np.ones(5)
    res = minimize(f, (np.asarray(x0) - LOWER) / span, method="SLSQP", bounds=[(0, 1)] * 3,
                   constraints={"type": "ineq", "fun": g}, options={"ftol": 1e-15, "maxiter": 200})
    x = LOWER + span * np.clip(res.x, 0, 1)
    return at(res.x)["rms"], x


def optimum(n=(21, 9, 15), polished=3):
    """(rms, x): the best of the grid's ``polished`` best feasible points, each polished."""
    best = [polish(x) for _, x in grid_search(n)[:polished]]
    return min(best, key=lambda v: v[0])
