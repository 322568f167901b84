"""Independent reference for problems/lib_patient_lift.toml (mobile patient lift).

The lift by hand, in numpy: boom pivot A at the origin, the boom's unit vector
e = (cos theta, sin theta) and its normal n (e turned counter-clockwise), the hook H = Lb e, the
actuator eye B = b e - f n, its base D = (xD, yD); the actuator length x = |D B| is the drive
coordinate, k = dx/dtheta.  Bodies: the boom (mid-length, a slender beam's inertia) and the
patient with sling and spreader bar at H.  The actuator force from Lagrange's equation for x
with the scene's speed, acceleration and efficiency rule (reflib_taylor.drive_load).

``global_optimum(level)``: a grid over the box (xD, yD, b), every constraint on the stroke
samples (stroke and retracted length from the sampled and refined extremes of x), then SLSQP
polishes (reflib_search).  Run this file to print it.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import reflib_search as rs  # noqa: E402
from reflib_taylor import T2, cos, drive_load, sin, sqrt  # noqa: E402

SCENE = HERE.parents[1] / "problems" / "lib_patient_lift.toml"
DESIGN = ["xD", "yD", "b"]
LEVELS = {  # grid points per variable, grid stroke samples, polish's check samples, polished grid
    #          minima, final check samples
    "small": (11, 76, 2001, 2, 2001),
    "full": (31, 151, 4001, 6, 20001),
}


def data():
    return rs.read_scene(SCENE)


def angle_between(u, v):
    return np.arctan2(np.abs(u[0] * v[1] - u[1] * v[0]), u[0] * v[0] + u[1] * v[1])


def lift(p, X, s):
    q = {**p, **X}
    Lb, f, b, xD, yD = (q[k] for k in ("Lb", "f", "b", "xD", "yD"))
    theta = T2.variable(s)
    e = (cos(theta), sin(theta))
    n = (-e[1], e[0])
    B = (b * e[0] - f * n[0], b * e[1] - f * n[1])
    x = sqrt((B[0] - xD) * (B[0] - xD) + (B[1] - yD) * (B[1] - yD))
    bodies = [
        {"mass": q["mB"], "com": (0.5 * Lb * e[0], 0.5 * Lb * e[1]), "phi": theta, "inertia": q["mB"] * Lb**2 / 12},
        {"mass": q["mP"] + q["mS"], "com": (Lb * e[0], Lb * e[1])},
    ]
    return {"x": x, "B": B, "D": (xD, yD), "bodies": bodies}


def rows(X, s, scene=None):
    sc = scene or data()
    with np.errstate(invalid="ignore"):
        m = lift(sc["params"], X, s)
        F, parts = drive_load(m["bodies"], m["x"], sc["speed"], sc["acceleration"], sc["efficiency"], sc["gravity"])
        B, (xD, yD) = m["B"], m["D"]
        transmission = angle_between((xD - B[0].v, yD - B[1].v), (-B[0].v, -B[1].v))
    shape = np.broadcast_shapes(F.shape, transmission.shape)
    return {"drive": np.broadcast_to(F, shape), "transmission": np.broadcast_to(transmission, shape),
            "length": np.broadcast_to(m["x"].v, shape), "k": np.broadcast_to(parts["k"], shape)}


def problem(scene=None):
    sc = scene or data()
    b = sc["bounds"]
    L = [("length", "max"), ("length", "min")]
    return rs.MinimaxProblem(
        names=DESIGN,
        lower=np.array([sc["box"][n][0] for n in DESIGN]),
        upper=np.array([sc["box"][n][1] for n in DESIGN]),
        sweep=sc["sweep"],
        rows=lambda X, s: rows(X, s, sc),
        per_sample={"transmission": b["transmission angle"]},
        per_stroke={
            "stroke": (lambda e: e[("length", "max")] - e[("length", "min")], *b["actuator stroke"], L),
            "retracted": (lambda e: 2 * e[("length", "min")] - e[("length", "max")],
                          *b["retracted length for the stroke"], L),
        },
        scales={"transmission": np.pi, "stroke": 0.3, "retracted": 0.3},
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
    if res["design"]:
        _, viol, ext, at = rs.evaluate(problem(), [res["design"][n] for n in DESIGN], 20001)
        print({k: (round(float(v), 6), round(float(at[k]), 5)) for k, v in ext.items()})
        X = {n: np.array([[v]]) for n, v in res["design"].items()}
        print("k min", rows(X, np.linspace(*data()["sweep"], 2001))["k"].min())
    p = data()["params"]
    start = {n: p[n] for n in DESIGN}
    print("start", rs.evaluate(problem(), [start[n] for n in DESIGN], 20001)[:2])
