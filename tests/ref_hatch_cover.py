"""An independent numpy model of problems/hatch_cover.toml and its global optimum (nothing of
optdesign is imported: the geometry, the virtual work, the trapezoid in time and the constraints
are written here from the scene's comments and docs/scenes.md).

The cover turns about its hinge A = (0, 0) by theta; u = (cos, sin) theta, n = (-sin, cos) theta.
The rod eye B = b u - h n (the attach point (b, -h) in the cover's frame), the cylinder base
D = (xD, yD), the drive coordinate q = |DB| with k = dq/dtheta = (B - D).B'/q, B' = b n + h u.
Every body turns with the cover about A, so the virtual work on theta is exact in closed form:
Q(theta) = I_A theta'' + (mc + msnow) g (Lc/2) cos theta, I_A = mc Lc^2/3 + msnow (Lc/2)^2
(no velocity term: I_A does not vary).  The ideal cylinder force is Q/k, divided by eta while
the cylinder delivers power (Q theta' > 0, the direction of motion's sign also at the rests at
the stroke's ends), times eta while the power flows back.

Each case runs the trapezoid (15 deg/s, 30 deg/s^2 both ways) over 0 .. 90 deg: speeding up
over the first 3.75 deg (theta'' = +-a), cruising, slowing down over the last 3.75 deg; the
phase boundaries are taken from both sides (the acceleration jumps there).

The global optimum: the stroke equality |DB|(90 deg) - |DB|(0) = 0.4 solved for yD on a dense
grid of (xD, b) (every root in the box), the peak and the angle at B evaluated on the cases'
samples, the best feasible grid points polished by SLSQP (epigraph on the peak, every
constraint at dense samples, extremes refined between samples by bounded scalar searches and
exchanged into the epigraph until the continuous peak equals it).  The rod's buckling (<= 1)
and the dead centre are left out of the search and checked at the optimum found (a relaxation
whose optimum satisfies the dropped constraints is the optimum)."""
from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
from scipy.optimize import minimize, minimize_scalar

SCENE = Path(__file__).resolve().parents[1] / "problems" / "hatch_cover.toml"
DEG = math.pi / 180
LC, MC, H, G, ETA = 2.4, 1200.0, 0.1, 9.81, 0.9
STROKE, MIN_ANGLE = 0.4, 15 * DEG
V, ACC = 15 * DEG, 30 * DEG           # the trapezoid's top speed and acceleration
L = 90 * DEG
CASES = (("open", +1, 0.0), ("close", -1, 0.0), ("open with snow", +1, 300.0))   # name, direction, msnow
BOX = {"xD": (-0.2, 0.8), "yD": (-1.2, -0.3), "b": (0.25, 1.2)}
ROD, MODULUS, SAFETY = 0.05, 210e9, 3.5


def scene_numbers():
    """The numbers above as the scene file writes them (so that an edit of the scene shows)."""
    data = tomllib.loads(SCENE.read_text())
    p = data["parameters"]
    return {"Lc": p["Lc"], "mc": p["mc"], "h": p["h"], "box": {n: (p[n]["min"], p[n]["max"]) for n in BOX},
            "eta": data["drive"]["efficiency"], "g": data["gravity"]["g"],
            "cases": [(c["name"], c["direction"], c.get("set", {}).get("msnow", 0.0)) for c in data["cases"]],
            "cylinder": (data["cylinder"]["rod"], data["cylinder"]["modulus"], data["cylinder"]["buckling_safety"])}


def rod_eye(b, theta):
    c, s = np.cos(theta), np.sin(theta)
    return b * c + H * s, b * s - H * c, -b * s + H * c, b * c + H * s     # B and dB/dtheta


def length(xD, yD, b, theta):
    Bx, By, _, _ = rod_eye(b, theta)
    return np.hypot(Bx - xD, By - yD)


def stroke(xD, yD, b):
    return length(xD, yD, b, L) - length(xD, yD, b, 0.0)


def angle_at_B(xD, yD, b, theta):
    """angle(D, B, A): at B between B -> D and B -> A, 0 .. pi."""
    Bx, By, _, _ = rod_eye(b, theta)
    ux, uy, vx, vy = xD - Bx, yD - By, -Bx, -By
    return np.arctan2(np.abs(ux * vy - uy * vx), ux * vx + uy * vy)


def phase_samples(n):
    """(x, signed acceleration along the motion) over the three phases, n samples each, the
    boundaries in both phases they close."""
    x1 = V * V / (2 * ACC)
    parts = [(np.linspace(0, x1, n), ACC), (np.linspace(x1, L - x1, n), 0.0), (np.linspace(L - x1, L, n), -ACC)]
    x = np.concatenate([p[0] for p in parts])
    a = np.concatenate([np.full(n, p[1]) for p in parts])
    return x, a


def force(xD, yD, b, x, a, direction, msnow):
    """The cylinder force F_S at the distances ``x`` (with their phase's acceleration ``a``) of
    a case; designs broadcast against samples."""
    theta = x if direction > 0 else L - x
    speed = np.minimum(np.minimum(np.sqrt(2 * ACC * np.maximum(x, 0)), V), np.sqrt(2 * ACC * np.maximum(L - x, 0)))
    thdd = direction * a
    Bx, By, Bpx, Bpy = rod_eye(b, theta)
    dx, dy = Bx - xD, By - yD
    k = (dx * Bpx + dy * Bpy) / np.hypot(dx, dy)
    inertia = MC * LC ** 2 / 3 + msnow * (LC / 2) ** 2
    Q = inertia * thdd + (MC + msnow) * G * (LC / 2) * np.cos(theta)
    F = Q / k
    return np.where(Q * direction > 0, F / ETA, F * ETA)   # the motion's direction (also at a rest)


def peak(x3, n=241):
    """The largest |F_S| over the cases on n samples per phase (and where: case, x)."""
    xD, yD, b = x3
    x, a = phase_samples(n)
    best = (-1.0, None, None)
    for name, d, m in CASES:
        f = np.abs(force(xD, yD, b, x, a, d, m))
        i = int(np.argmax(f))
        if f[i] > best[0]:
            best = (float(f[i]), name, (x[i], a[i]))
    return best


def refined_peak(x3, n=2001):
    """The largest |F_S| over the continuous stroke of every case: each phase's samples, every
    local maximum refined by a bounded scalar search between its neighbours."""
    xD, yD, b = x3
    x1 = V * V / (2 * ACC)
    phases = [(0, x1, ACC), (x1, L - x1, 0.0), (L - x1, L, -ACC)]
    best = (-1.0, None, None)
    for name, d, m in CASES:
        for lo, hi, a in phases:
            xs = np.linspace(lo, hi, n)
            f = np.abs(force(xD, yD, b, xs, a, d, m))
            cands = [i for i in range(n) if (i == 0 or f[i] >= f[i - 1]) and (i == n - 1 or f[i] >= f[i + 1])]
            for i in cands:
                val, at = f[i], xs[i]
                if 0 < i < n - 1:
                    r = minimize_scalar(lambda t: -abs(float(force(xD, yD, b, t, a, d, m))),
                                        bounds=(xs[i - 1], xs[i + 1]), method="bounded", options={"xatol": 1e-13})
                    if -r.fun > val:
                        val, at = -r.fun, r.x
                if val > best[0]:
                    best = (float(val), name, (float(at), a))
    return best


def min_angle(x3, n=4001):
    """The smallest angle at B over the continuous stroke (refined between samples)."""
    th = np.linspace(0, L, n)
    v = angle_at_B(*x3, th)
    i = int(np.argmin(v))
    if 0 < i < n - 1:
        r = minimize_scalar(lambda t: float(angle_at_B(*x3, t)), bounds=(th[i - 1], th[i + 1]), method="bounded",
                            options={"xatol": 1e-13})
        return float(min(v[i], r.fun)), float(r.x if r.fun < v[i] else th[i])
    return float(v[i]), float(th[i])


def buckling(x3):
    """F_push S / Euler's load at full extension (the longest |DB| over the stroke), the largest
    over the cases (docs/scenes.md, [cylinder])."""
    th = np.linspace(0, L, 20001)
    longest = float(np.max(length(*x3, th)))
    euler = math.pi ** 2 * MODULUS * (math.pi * ROD ** 4 / 64) / longest ** 2
    x, a = phase_samples(2001)
    push = max(float(np.max(force(*x3, x, a, d, m))) for _, d, m in CASES)
    return SAFETY * max(push, 0.0) / euler


def dk_min(x3):
    """The smallest dq/dtheta over the stroke (> 0: no dead centre)."""
    th = np.linspace(0, L, 20001)
    Bx, By, Bpx, Bpy = rod_eye(x3[2], th)
    dx, dy = Bx - x3[0], By - x3[1]
    return float(np.min((dx * Bpx + dy * Bpy) / np.hypot(dx, dy)))


def grid_candidates(n=161, ny=801):
    """Every (xD, yD, b) on the stroke equality from an n x n grid of (xD, b) (each root yD in
    its range, bisected to round-off), with its sampled peak and smallest angle."""
    xD = np.linspace(*BOX["xD"], n)[:, None, None]
    b = np.linspace(*BOX["b"], n)[None, :, None]
    y = np.linspace(*BOX["yD"], ny)[None, None, :]
    g = stroke(xD, y, b) - STROKE
    i, j, k = np.nonzero(np.sign(g[:, :, :-1]) * np.sign(g[:, :, 1:]) <= 0)
    X, B_ = xD[i, 0, 0], b[0, j, 0]
    lo, hi = y[0, 0, k], y[0, 0, k + 1]
    glo = stroke(X, lo, B_) - STROKE
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        gm = stroke(X, mid, B_) - STROKE
        left = np.sign(gm) == np.sign(glo)
        lo, glo, hi = np.where(left, mid, lo), np.where(left, gm, glo), np.where(left, hi, mid)
    Y = 0.5 * (lo + hi)
    x, a = phase_samples(41)
    f = np.max([np.max(np.abs(force(X[:, None], Y[:, None], B_[:, None], x, a, d, m)), axis=1) for _, d, m in CASES],
               axis=0)
    ang = np.min(angle_at_B(X[:, None], Y[:, None], B_[:, None], np.linspace(0, L, 181)), axis=1)
    return np.column_stack([X, Y, B_]), f, ang


def polish(x0, samples=241, rounds=8):
    """SLSQP from x0 on (xD, yD, b, t): min t, t >= |F_S| at every case's samples (plus each
    refined peak found so far), the angle at B >= 15 deg at dense samples (plus the refined
    minimum), the stroke equality; repeated until the refined peak is the epigraph's."""
    scale = 1e4
    x, a = phase_samples(samples)
    extra = []           # refined peak points: (case index, x, a)
    th = list(np.linspace(0, L, 721))

    def peaks(z):
        out = [np.abs(force(z[0], z[1], z[2], x, a, d, m)) for _, d, m in CASES]
        out += [np.abs(force(z[0], z[1], z[2], np.array([xe]), ae, CASES[c][1], CASES[c][2])) for c, xe, ae in extra]
        return np.concatenate(out) / scale

    z = np.array(list(x0) + [peak(x0)[0] / scale])
    for _ in range(rounds):
        cons = [{"type": "eq", "fun": lambda z: np.array([stroke(*z[:3]) - STROKE])},
                {"type": "ineq", "fun": lambda z: z[3] - peaks(z)},
                {"type": "ineq", "fun": lambda z: angle_at_B(*z[:3], np.array(th)) - MIN_ANGLE}]
        bounds = [BOX["xD"], BOX["yD"], BOX["b"], (0, None)]
        r = minimize(lambda z: z[3], z, method="SLSQP", constraints=cons, bounds=bounds,
                     options={"ftol": 1e-15, "maxiter": 500})
        z = r.x
        value, case, (xe, ae) = refined_peak(z[:3])
        amin, at = min_angle(z[:3])
        done = value <= z[3] * scale * (1 + 1e-10) and amin >= MIN_ANGLE - 1e-10
        extra.append(([c[0] for c in CASES].index(case), xe, ae))
        th.append(at)
        if done:
            break
    return z[:3], refined_peak(z[:3])[0]


def global_optimum(n=161, polished=6):
    """The best of SLSQP polishes from the best feasible grid points that lie apart (1/20 of
    the box): {"design", "peak", "grid_best", "angle", "stroke"}."""
    X, f, ang = grid_candidates(n)
    ok = ang >= MIN_ANGLE
    order = np.argsort(np.where(ok, f, np.inf))
    span = np.array([hi - lo for lo, hi in BOX.values()])
    picks = []
    for i in order:
        if not ok[i] or len(picks) >= polished:
            break
        if all(np.max(np.abs(X[i] - X[j]) / span) > 0.05 for j in picks):
            picks.append(i)
    best = None
    for i in picks:
        z, value = polish(X[i])
        feasible = abs(stroke(*z) - STROKE) <= 1e-10 and min_angle(z)[0] >= MIN_ANGLE - 1e-9
        if feasible and (best is None or value < best[1]):
            best = (z, value)
    z, value = best
    return {"design": dict(zip(BOX, map(float, z))), "peak": value, "grid_best": float(f[order[0]]),
            "angle": min_angle(z)[0], "stroke": float(stroke(*z))}
