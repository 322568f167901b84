"""Independent reference for problems/lib_landing_gear.toml (main gear retraction actuator).

The gear by hand, in numpy: trunnion A at the origin, x forward, y up; the leg's unit vector
e = (sin psi, -cos psi) (straight down at psi = 0, swinging forward); the axle W = Lg e, the
actuator's lug B = -a e (on the leg's axis above the trunnion), the structure pin
D = (xD, yD); the actuator length x = |D B| is the drive coordinate, k = dx/dpsi.  Bodies: the
leg (0.45 Lg down, a slender bar's inertia), the wheels at W, and the air drag
D0 cos^2 psi acting aft at 0.8 Lg.  The actuator force from Lagrange's equation for x with the
scene's speed, acceleration and efficiency rule (reflib_taylor.drive_load).

``global_optimum(level)``: a grid over the box (xD, yD, a), every constraint on the stroke
samples (length ratio and envelope from the sampled and refined extremes of x), then SLSQP
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

SCENE = HERE.parents[1] / "problems" / "lib_landing_gear.toml"
DESIGN = ["xD", "yD", "a"]
LEVELS = {  # grid points per variable, grid stroke samples, polish's check samples, polished grid
    #          minima, final check samples
    "small": (11, 89, 2001, 2, 2001),
    "full": (31, 177, 4001, 6, 20001),
}


def data():
    return rs.read_scene(SCENE)


def angle_between(u, v):
    return np.arctan2(np.abs(u[0] * v[1] - u[1] * v[0]), u[0] * v[0] + u[1] * v[1])


def gear(p, X, s):
    q = {**p, **X}
    Lg, xD, yD, a = (q[k] for k in ("Lg", "xD", "yD", "a"))
    psi = T2.variable(s)
    e = (sin(psi), -cos(psi))
    B = (-a * e[0], -a * e[1])
    x = sqrt((B[0] - xD) * (B[0] - xD) + (B[1] - yD) * (B[1] - yD))
    leg_angle = psi - np.pi / 2
    drag = -q["D0"] * np.cos(s) ** 2
    bodies = [
        {"mass": q["mL"], "com": (0.45 * Lg * e[0], 0.45 * Lg * e[1]), "phi": leg_angle, "inertia": q["mL"] * Lg**2 / 12},
        {"mass": q["mW"], "com": (Lg * e[0], Lg * e[1])},
        {"com": (0.8 * Lg * e[0], 0.8 * Lg * e[1]), "force": (drag, 0.0)},
    ]
    return {"x": x, "B": B, "D": (xD, yD), "bodies": bodies}


def rows(X, s, scene=None):
    sc = scene or data()
    with np.errstate(invalid="ignore"):
        m = gear(sc["params"], X, s)
        F, parts = drive_load(m["bodies"], m["x"], sc["speed"], sc["acceleration"], sc["efficiency"], sc["gravity"])
        B, (xD, yD) = m["B"], m["D"]
        transmission = angle_between((xD - B[0].v, yD - B[1].v), (-B[0].v, -B[1].v))
    shape = np.broadcast_shapes(F.shape, transmission.shape)
    return {"drive": np.broadcast_to(F, shape), "transmission": np.broadcast_to(transmission, shape),
            "length": np.broadcast_to(m["x"].v, shape), "k": np.broadcast_to(parts["k"], shape)}


def problem(scene=None):
    sc = scene or data()
    b = sc["bounds"]
    return rs.MinimaxProblem(
        names=DESIGN,
        lower=np.array([sc["box"][n][0] for n in DESIGN]),
        upper=np.array([sc["box"][n][1] for n in DESIGN]),
        sweep=sc["sweep"],
        rows=lambda X, s: rows(X, s, sc),
        per_sample={"transmission": b["transmission angle"]},
        per_stroke={
            "ratio": (lambda e: e[("length", "max")] / e[("length", "min")], *b["actuator length ratio"],
                      [("length", "max"), ("length", "min")]),
            "envelope": (lambda e: e[("length", "max")], *b["actuator length in the bay"], [("length", "max")]),
        },
        scales={"transmission": np.pi, "ratio": 1.65, "envelope": 1.3},
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
