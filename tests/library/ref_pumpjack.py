"""Independent reference for problems/lib_pumpjack.toml (conventional beam pumping unit).

The unit by hand, in numpy: saddle bearing B0 at the origin, crankshaft O = (I, -h), crank pin
Cp = O + R (cos a, sin a) with a = aB + phi; the equaliser E on the circle of radius C about B0
at distance P from Cp, to the left of B0 -> Cp, from the law of cosines in the triangle
B0-Cp-E.  The crank angle at the rod's bottom (aB) and the upstroke's length in crank angle
(phi_up) come from the two dead centres, where |O E| = P + R (bottom) and P - R (top), again by
the law of cosines in the triangle O-B0-E (written here, not read from the scene's
expressions).  The polished rod load is the rectangular card of the scene's comment, acting with
the constant moment arm A on the beam; the rods add the inertia m_rods A^2 about B0.  The
gearbox torque follows from Lagrange's equation for the crank angle (reflib_taylor.drive_load).

``global_optimum(level)``: a grid over the box (R, rcw, tau), every constraint on the stroke
samples, then SLSQP polishes (reflib_search).  Run this file to print it.
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

SCENE = HERE.parents[1] / "problems" / "lib_pumpjack.toml"
DESIGN = ["R", "rcw", "tau"]
LEVELS = {  # grid points per variable, grid stroke samples, polish's check samples, polished grid
    #          minima, final check samples
    "small": (9, 121, 2001, 2, 2001),
    "full": (25, 361, 4001, 6, 20001),
}


def data():
    return rs.read_scene(SCENE)


def logistic(x):
    return 1.0 / (1.0 + np.exp(-x))


def unit(p, X, s):
    """Points, bodies and quantities of the unit for designs X (name -> (n, 1)) at sweep s."""
    q = {**p, **X}
    A, C, I, h, P, R = (q[k] for k in ("A", "C", "I", "h", "P", "R"))
    d = np.sqrt(I**2 + h**2)
    gamma_bottom = np.arccos((d**2 + (P + R) ** 2 - C**2) / (2 * d * (P + R)))
    gamma_top = np.arccos((d**2 + (P - R) ** 2 - C**2) / (2 * d * (P - R)))
    aB = np.arctan2(h, -I) - gamma_bottom
    phi_up = math.pi - gamma_top + gamma_bottom
    phi = T2.variable(s)
    a = phi + aB
    O = (T2(I), T2(-h))
    Cp = (O[0] + R * cos(a), O[1] + R * sin(a))
    L = sqrt(Cp[0] * Cp[0] + Cp[1] * Cp[1])
    beta = acos((C**2 + L * L - P**2) / (2 * C * L))
    theta = atan2(Cp[1], Cp[0]) + beta            # beam angle B0 -> E (left of B0 -> Cp)
    E = (C * cos(theta), C * sin(theta))
    pick, ramp = q["pickup"], q["ramp"]
    W = q["W_rf"] + q["F_o"] * (logistic((s - pick) / ramp) - logistic((s - phi_up - pick) / ramp))
    pitman = atan2(E[1] - Cp[1], E[0] - Cp[0])
    a_cw = a + q["tau"]
    bodies = [
        {"mass": q["mb"], "com": (-q["db"] * cos(theta), -q["db"] * sin(theta)), "phi": theta,
         "inertia": q["mb"] * (A + C) ** 2 / 12},
        {"phi": theta, "inertia": q["m_rods"] * A**2, "torque": A * W},
        {"mass": q["mp"], "com": ((Cp[0] + E[0]) * 0.5, (Cp[1] + E[1]) * 0.5), "phi": pitman,
         "inertia": q["mp"] * P**2 / 12},
        {"mass": q["mc"], "com": (O[0] + 0.5 * cos(a), O[1] + 0.5 * sin(a)), "phi": a,
         "inertia": q["mc"] * 1.3**2 / 12},
        {"mass": q["mcw"], "com": (O[0] + q["rcw"] * cos(a_cw), O[1] + q["rcw"] * sin(a_cw)), "phi": a_cw,
         "inertia": q["mcw"] * 0.4**2 / 12},
    ]
    return {"phi": phi, "Cp": Cp, "E": E, "theta": theta, "W": W, "bodies": bodies, "phi_up": phi_up}


def rows(X, s, scene=None):
    """The drive torque and the constraints' per-sample quantities (n designs x m samples)."""
    sc = scene or data()
    p = sc["params"]
    with np.errstate(invalid="ignore"):
        u = unit(p, X, s)
        T, _ = drive_load(u["bodies"], u["phi"], sc["speed"], sc["acceleration"], sc["efficiency"], sc["gravity"])
        E, Cp = u["E"], u["Cp"]
        # transmission angle at E between E->Cp and E->B0
        v1 = (Cp[0].v - E[0].v, Cp[1].v - E[1].v)
        v2 = (-E[0].v, -E[1].v)
        trans = np.arctan2(np.abs(v1[0] * v2[1] - v1[1] * v2[0]), v1[0] * v2[0] + v1[1] * v2[1])
        beam = u["theta"].v + math.pi / 2  # angle(Z, B0, E): from straight down to B0 -> E
    shape = np.broadcast_shapes(T.shape, trans.shape)
    return {"drive": np.broadcast_to(T, shape), "transmission": np.broadcast_to(trans, shape),
            "beam": np.broadcast_to(beam, shape)}


def problem(scene=None):
    sc = scene or data()
    A = sc["params"]["A"]
    stroke_lo, stroke_hi = sc["bounds"]["polished rod stroke"]
    return rs.MinimaxProblem(
        names=DESIGN,
        lower=np.array([sc["box"][n][0] for n in DESIGN]),
        upper=np.array([sc["box"][n][1] for n in DESIGN]),
        sweep=sc["sweep"],
        rows=lambda X, s: rows(X, s, sc),
        per_sample={"transmission": sc["bounds"]["transmission angle at the equaliser"]},
        per_stroke={"stroke": (lambda e: A * (e[("beam", "max")] - e[("beam", "min")]), stroke_lo, stroke_hi,
                               [("beam", "max"), ("beam", "min")])},
    )


def drive(design, s):
    """Drive torque of one design (name -> value) at sweep values s."""
    sc = data()
    X = {n: np.array([[design[n]]]) for n in DESIGN}
    return rows(X, np.asarray(s, float), sc)["drive"][0]


def dense_peak(design, samples=20001):
    """Peak |drive| over the continuous stroke: ``samples`` samples, the extreme refined."""
    pb = problem()
    ext, _, _, _ = rs.stroke_extremes(pb, [design[n] for n in DESIGN], samples, [("drive", "abs")])
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
