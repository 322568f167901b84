"""Independent numpy reference of problems/lib_wheel_loader_arm.toml (no optdesign).

The arm turns about the pivot A by the sweep theta: a point with arm-frame coordinates p is at
R(theta) p, so (' = d/dtheta) r' = J r, r'' = -r (J: a turn by +90 deg).  The hinge pin
T = R(theta) (L, 0); bucket and load translate with T (parallel lift: their centres of mass
move as T does, they do not turn).  The rod eye B = R(theta) (b, -f), the base D fixed; the
drive length |B - D| and its derivatives from B' = J B, B'' = -B.  Constraint rows: the
transmission angle at B between B->D and B->A, the drive length (for the length ratio).
"""
from __future__ import annotations

import numpy as np

try:
    from . import refkit
except ImportError:  # run as a script
    import refkit

SCENE = refkit.ROOT / "problems" / "lib_wheel_loader_arm.toml"


def _turned(p, th):
    c, s = np.cos(th), np.sin(th)
    r = refkit._stack(c * p[0] - s * p[1], s * p[0] + c * p[1])
    return r, refkit.perp(r), -r


class WheelLoaderArm:
    per_sample = [("transmission angle", "angle")]
    ratios = [("cylinder length ratio", "L")]

    def __init__(self, scene):
        self.p = scene.params

    def state(self, x, th):
        p = self.p
        B, B1, B2 = _turned((x["b"], -p["f"]), th)
        D = refkit._stack(x["xD"] + 0 * th, x["yD"] + 0 * th)
        q, q1, q2 = refkit.length(B - D, B1, B2)
        one = np.ones_like(th)
        arm = (p["m_arm"], p["m_arm"] * p["L"] ** 2 / 12) + _turned((p["a_arm"], p["c_arm"]), th) + (one, 0 * one)
        T, T1, T2 = _turned((p["L"], 0.0), th)
        # bucket and load: centres of mass T + constant offsets; no rotation
        bucket = (p["m_bucket"] + p["m_load"], 0.0, T, T1, T2, 0 * one, 0 * one)
        rows = {"L": q, "angle": refkit.angle_between(D - B, -B)}
        return refkit.State([arm, bucket], q, q1, q2, rows)


def scene_data():
    return refkit.SceneData(SCENE)


def problem():
    scene = scene_data()
    return refkit.Problem(WheelLoaderArm(scene), scene)


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
