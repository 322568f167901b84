"""Independent numpy reference of problems/lib_dump_truck_hoist.toml (no optdesign).

The body turns about the hinge A by the sweep theta; every point of it is R(theta) p for its
body-frame coordinates p, so (' = d/dtheta) r' = J r and r'' = -r (J: a turn by +90 deg).
The rod eye B = R(theta) (b, hB), the base D fixed; the drive length |B - D| and its
derivatives from B' = J B, B'' = -B.  Bodies: the body and the payload, both turning with
theta (phi' = 1, phi'' = 0).  Constraint rows: the transmission angle at B between B->D and
B->A, the drive length (for the length ratio).
"""
from __future__ import annotations

import numpy as np

try:
    from . import refkit
except ImportError:  # run as a script
    import refkit

SCENE = refkit.ROOT / "problems" / "lib_dump_truck_hoist.toml"


def _turned(p, th):
    """R(theta) p and its first two theta-derivatives, for body-frame coordinates p."""
    c, s = np.cos(th), np.sin(th)
    r = refkit._stack(c * p[0] - s * p[1], s * p[0] + c * p[1])
    r1 = refkit.perp(r)
    return r, r1, -r


class DumpTruckHoist:
    per_sample = [("transmission angle", "angle")]
    ratios = [("cylinder length ratio", "L")]

    def __init__(self, scene):
        self.p = scene.params

    def state(self, x, th):
        p = self.p
        B, B1, B2 = _turned((x["b"], p["hB"]), th)
        D = refkit._stack(x["xD"] + 0 * th, x["yD"] + 0 * th)
        q, q1, q2 = refkit.length(B - D, B1, B2)
        one = np.ones_like(th)
        bodies = []
        for m, xc, yc, l, h in ((p["m_body"], p["xb"], p["yb"], p["l_body"], p["h_body"]),
                                (p["m_load"], p["xl"], p["yl"], p["l_load"], p["h_load"])):
            r, r1, r2 = _turned((xc, yc), th)
            bodies.append((m, m * (l ** 2 + h ** 2) / 12, r, r1, r2, one, 0 * one))
        rows = {"L": q, "angle": refkit.angle_between(D - B, -B)}
        return refkit.State(bodies, q, q1, q2, rows)


def scene_data():
    return refkit.SceneData(SCENE)


def problem():
    scene = scene_data()
    return refkit.Problem(DumpTruckHoist(scene), scene)


def global_optimum(level="small"):
    return refkit.global_optimum(problem(), level)


if __name__ == "__main__":
    import sys
    import time

    t0 = time.perf_counter()
    out = global_optimum(sys.argv[1] if len(sys.argv) > 1 else "small")
    print(f"{time.perf_counter() - t0:.1f} s", out["value"], out["design"], out["grid_best"])
    for cand in out["candidates"]:
        print("  ", cand)
    print(out["check"])
