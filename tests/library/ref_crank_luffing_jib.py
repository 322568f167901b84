"""Independent reference for problems/lib_crank_luffing_jib.toml (jib crane, crank luffing gear).

The crane by hand, in numpy: jib foot A at the origin, the jib's unit vector e = (cos theta,
sin theta) and its normal n (e turned counter-clockwise); the rod eye B = b e - f n; the crank
pin P on the circle of radius r about O = (xO, yO) at distance lc from B, to the right of
O -> B (law of cosines in the triangle O-B-P); the crank angle q = atan2(P - O) is the drive
coordinate, k = dq/dtheta.  Bodies: the jib (0.45 L along e, inertia mJ L^2/12), the balance
weight (lT behind A), the payload (at the head), the connecting rod (mid-length, slender).  The
crank torque from Lagrange's equation for the crank angle with the scene's speed, acceleration
and efficiency rule (reflib_taylor.drive_load).

``global_optimum(level)``: a grid over the box (xO, yO, r, lc), every constraint on the stroke
samples, then SLSQP polishes (reflib_search).  Run this file to print it.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import reflib_search as rs  # noqa: E402
from reflib_taylor import T2, acos, atan2, cos, drive_load, sin, sqrt  # noqa: E402

SCENE = HERE.parents[1] / "problems" / "lib_crank_luffing_jib.toml"
DESIGN = ["xO", "yO", "r", "lc"]
LEVELS = {  # grid points per variable, grid stroke samples, polish's check samples, polished grid
    #          minima, final check samples
    "small": (7, 91, 2001, 2, 2001),
    "full": (15, 221, 4001, 6, 20001),
}


def data():
    return rs.read_scene(SCENE)


def angle_between(u, v):
    return np.arctan2(np.abs(u[0] * v[1] - u[1] * v[0]), u[0] * v[0] + u[1] * v[1])


def crane(p, X, s):
    q = {**p, **X}
    L, b, f, xO, yO, r, lc = (q[k] for k in ("L", "b", "f", "xO", "yO", "r", "lc"))
    theta = T2.variable(s)
    e = (cos(theta), sin(theta))
    n = (-e[1], e[0])
    B = (b * e[0] - f * n[0], b * e[1] - f * n[1])
    dx, dy = B[0] - xO, B[1] - yO
    D = sqrt(dx * dx + dy * dy)
    crank = atan2(dy, dx) - acos((r**2 + D * D - lc**2) / (2 * r * D))  # P right of O -> B
    P = (xO + r * cos(crank), yO + r * sin(crank))
    m_rod = 130.0 * lc
    bodies = [
        {"mass": q["mJ"], "com": (0.45 * L * e[0], 0.45 * L * e[1]), "phi": theta, "inertia": q["mJ"] * L**2 / 12},
        {"mass": q["mT"], "com": (-q["lT"] * e[0], -q["lT"] * e[1])},
        {"mass": q["mP"], "com": (L * e[0], L * e[1])},
        {"mass": m_rod, "com": (0.5 * (P[0] + B[0]), 0.5 * (P[1] + B[1])), "phi": atan2(B[1] - P[1], B[0] - P[0]),
         "inertia": m_rod * lc**2 / 12},
    ]
    return {"q": crank, "P": P, "B": B, "bodies": bodies, "O": (xO, yO)}


def rows(X, s, scene=None):
    sc = scene or data()
    with np.errstate(invalid="ignore"):
        c = crane(sc["params"], X, s)
        T, parts = drive_load(c["bodies"], c["q"], sc["speed"], sc["acceleration"], sc["efficiency"], sc["gravity"])
        P, B, (xO, yO) = c["P"], c["B"], c["O"]
        PO = (xO - P[0].v, yO - P[1].v)
        PB = (B[0].v - P[0].v, B[1].v - P[1].v)
        crank_angle = angle_between(PO, PB)
        rod_jib = angle_between((-PB[0], -PB[1]), (-B[0].v, -B[1].v))
    shape = np.broadcast_shapes(T.shape, crank_angle.shape)
    return {"drive": np.broadcast_to(T, shape), "crank": np.broadcast_to(crank_angle, shape),
            "rod": np.broadcast_to(rod_jib, shape), "k": np.broadcast_to(parts["k"], shape)}


def problem(scene=None):
    sc = scene or data()
    b = sc["bounds"]
    return rs.MinimaxProblem(
        names=DESIGN,
        lower=np.array([sc["box"][n][0] for n in DESIGN]),
        upper=np.array([sc["box"][n][1] for n in DESIGN]),
        sweep=sc["sweep"],
        rows=lambda X, s: rows(X, s, sc),
        per_sample={"crank": b["crank transmission angle"], "rod": b["rod to jib angle"]},
        scales={"crank": np.pi, "rod": np.pi},
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
        print("k range", rows(X, np.linspace(*data()["sweep"], 2001))["k"].min())
