"""Independent reference for problems/lib_toggle_press.toml (knuckle-joint press).

The press by hand, in numpy: crown pin G at the origin, crank centre O = (xO, yO), crank pin
A = O + r (cos a, sin a) with a = aBDC + phi; the knuckle K on the circle of radius L1 about G at
distance lc from A, to the right of G -> A (law of cosines in the triangle G-A-K); the ram pin
C = (0, y(K) - sqrt(L2^2 - x(K)^2)) on the vertical line through G.  The crank angle at BDC and
the ram's BDC height come from the extended dead centre |O K| = lc + r (law of cosines in the
triangle G-O-K), written here, not read from the scene's expressions.  The crank torque follows
from Lagrange's equation for the crank angle (reflib_taylor.drive_load) with the sizing force
on the slide.

``global_optimum(level)``: a grid over the box (r, lc, yO), every constraint on the stroke
samples (the ram stroke max(y) - min(y) >= H from the sampled and refined extremes), then SLSQP
polishes (reflib_search).  Run this file to print it.
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import reflib_search as rs  # noqa: E402
from reflib_taylor import T2, acos, atan2, cos, drive_load, sin, sqrt  # noqa: E402

SCENE = HERE.parents[1] / "problems" / "lib_toggle_press.toml"
DESIGN = ["r", "lc", "yO"]
LEVELS = {  # grid points per variable, grid stroke samples, polish's check samples, polished grid
    #          minima, final check samples
    "small": (11, 181, 2001, 2, 2001),
    "full": (31, 361, 4001, 4, 20001),
}


def data():
    return rs.read_scene(SCENE)


def angle_between(u, v):
    return np.arctan2(np.abs(u[0] * v[1] - u[1] * v[0]), u[0] * v[0] + u[1] * v[1])


def press(p, X, s):
    q = {**p, **X}
    L1, L2, r, lc, xO, yO = (q[k] for k in ("L1", "L2", "r", "lc", "xO", "yO"))
    dO = np.sqrt(xO**2 + yO**2)
    aBDC = np.arctan2(-yO, -xO) + np.arccos((dO**2 + (lc + r) ** 2 - L1**2) / (2 * dO * (lc + r)))
    xKB, yKB = xO + (lc + r) * np.cos(aBDC), yO + (lc + r) * np.sin(aBDC)
    yBDC = yKB - np.sqrt(L2**2 - xKB**2)
    phi = T2.variable(s)
    a = phi + aBDC
    A = (T2(xO) + r * cos(a), T2(yO) + r * sin(a))
    D = sqrt(A[0] * A[0] + A[1] * A[1])
    theta = atan2(A[1], A[0]) - acos((L1**2 + D * D - lc**2) / (2 * L1 * D))  # right of G -> A
    K = (L1 * cos(theta), L1 * sin(theta))
    C = (T2(np.zeros_like(K[0].v)), K[1] - sqrt(L2**2 - K[0] * K[0]))
    force = q["Fc"] * np.exp(-(((C[1].v - yBDC - q["d0"]) / q["w"]) ** 2)) / (1 + np.exp(s / math.radians(2)))
    lower = atan2(C[1] - K[1], C[0] - K[0])
    rod = atan2(K[1] - A[1], K[0] - A[0])
    bodies = [
        {"mass": q["mR"], "com": C, "force": (0.0, force)},
        {"mass": q["m1"], "com": (0.5 * K[0], 0.5 * K[1]), "phi": theta, "inertia": q["m1"] * L1**2 / 12},
        {"mass": q["m2"], "com": (0.5 * (K[0] + C[0]), 0.5 * (K[1] + C[1])), "phi": lower,
         "inertia": q["m2"] * L2**2 / 12},
        {"mass": q["mc"], "com": (0.5 * (K[0] + A[0]), 0.5 * (K[1] + A[1])), "phi": rod, "inertia": q["mc"] * lc**2 / 12},
    ]
    return {"phi": phi, "A": A, "K": K, "C": C, "bodies": bodies, "yBDC": yBDC}


def rows(X, s, scene=None):
    sc = scene or data()
    with np.errstate(invalid="ignore"):
        m = press(sc["params"], X, s)
        T, _ = drive_load(m["bodies"], m["phi"], sc["speed"], sc["acceleration"], sc["efficiency"], sc["gravity"])
        A, K, C = m["A"], m["K"], m["C"]
        KG = (-K[0].v, -K[1].v)
        toggle = angle_between(KG, (C[0].v - K[0].v, C[1].v - K[1].v))
        transmission = angle_between((A[0].v - K[0].v, A[1].v - K[1].v), KG)
    shape = np.broadcast_shapes(T.shape, toggle.shape)
    return {"drive": np.broadcast_to(T, shape), "toggle": np.broadcast_to(toggle, shape),
            "transmission": np.broadcast_to(transmission, shape), "y": np.broadcast_to(C[1].v, shape)}


def problem(scene=None):
    sc = scene or data()
    b = sc["bounds"]
    return rs.MinimaxProblem(
        names=DESIGN,
        lower=np.array([sc["box"][n][0] for n in DESIGN]),
        upper=np.array([sc["box"][n][1] for n in DESIGN]),
        sweep=sc["sweep"],
        rows=lambda X, s: rows(X, s, sc),
        per_sample={"toggle": b["toggle short of stretched"], "transmission": b["transmission angle at the knuckle"]},
        per_stroke={"stroke": (lambda e: e[("y", "max")] - e[("y", "min")], *b["ram stroke"],
                               [("y", "max"), ("y", "min")])},
        scales={"toggle": math.pi, "transmission": math.pi, "stroke": 0.1},
    )


def drive(design, s):
    X = {n: np.array([[design[n]]]) for n in DESIGN}
    return rows(X, np.asarray(s, float))["drive"][0]


def dense_peak(design, samples=20001):
    ext, _, _, _ = rs.stroke_extremes(problem(), [design[n] for n in DESIGN], samples, [("drive", "abs")])
    return ext[("drive", "abs")]


def global_optimum(level="small"):
    per_dim, grid_samples, check, starts, final = LEVELS[level]
    return rs.global_minimax(problem(), per_dim, grid_samples, check, starts, final_samples=final)


if __name__ == "__main__":
    import time

    level = sys.argv[1] if len(sys.argv) > 1 else "small"
    t0 = time.perf_counter()
    res = global_optimum(level)
    print(level, f"{time.perf_counter() - t0:.1f} s", res["peak"], res["design"], "viol", res["violation"])
    print("grid best", res["grid_best"], res["grid_feasible"], "/", res["grid_total"])
    for peak, viol, x in res["polished"]:
        print("  polished", peak, viol, x)
    pb = problem()
    if res["design"]:
        _, viol, ext, at = rs.evaluate(pb, [res["design"][n] for n in DESIGN], 20001)
        print({k: (round(v, 6), round(at[k], 5)) for k, v in ext.items()})
