"""Independent numpy reference of problems/lib_excavator_boom.toml (no optdesign).

The whole front (boom, stick, bucket with soil) turns rigidly about the foot pin A by the
sweep theta: a point with boom-frame coordinates p is at R(theta) p, so (' = d/dtheta)
r' = J r, r'' = -r, and every body's angle has phi' = 1, phi'' = 0.  In the boom frame
(x along the chord A-T): T = (Lb, 0); the stick's direction u = (cos psi, sin psi), its
normal n = (-sin psi, cos psi); the stick's centre of mass T + L_stick/2 u; the bucket's
T + (L_stick + a_bucket) u + c_bucket n.  The rod eye B = R(theta) (b, h), the base D fixed;
the drive length |B - D| and its derivatives.  Constraint rows: the transmission angle at B
between B->D and B->A, the drive length (for the length ratio).
"""
from __future__ import annotations

import math

import numpy as np

try:
    from . import refkit
except ImportError:  # run as a script
    import refkit

SCENE = refkit.ROOT / "problems" / "lib_excavator_boom.toml"


def _turned(p, th):
    c, s = np.cos(th), np.sin(th)
    r = refkit._stack(c * p[0] - s * p[1], s * p[0] + c * p[1])
    return r, refkit.perp(r), -r


class ExcavatorBoom:
    per_sample = [("transmission angle", "angle")]
    ratios = [("cylinder length ratio", "L")]

    def __init__(self, scene):
        self.p = scene.params

    def state(self, x, th):
        p = self.p
        B, B1, B2 = _turned((x["b"], p["h"]), th)
        D = refkit._stack(x["xD"] + 0 * th, x["yD"] + 0 * th)
        q, q1, q2 = refkit.length(B - D, B1, B2)
        one = np.ones_like(th)
        u = (math.cos(p["psi"]), math.sin(p["psi"]))
        n = (-u[1], u[0])
        stick_com = (p["Lb"] + 0.5 * p["L_stick"] * u[0], 0.5 * p["L_stick"] * u[1])
        ab, cb = p["L_stick"] + p["a_bucket"], p["c_bucket"]
        bucket_com = (p["Lb"] + ab * u[0] + cb * n[0], ab * u[1] + cb * n[1])
        m_bk = p["m_bucket"] + p["m_soil"]
        bodies = [
            (p["m_boom"], p["m_boom"] * p["L_boom"] ** 2 / 12) + _turned((p["a_boom"], p["c_boom"]), th),
            (p["m_stick"], p["m_stick"] * p["L_stick"] ** 2 / 12) + _turned(stick_com, th),
            (m_bk, m_bk * 1.2 ** 2 / 12) + _turned(bucket_com, th),
        ]
        bodies = [body + (one, 0 * one) for body in bodies]
        rows = {"L": q, "angle": refkit.angle_between(D - B, -B)}
        return refkit.State(bodies, q, q1, q2, rows)


def scene_data():
    return refkit.SceneData(SCENE)


def problem():
    scene = scene_data()
    return refkit.Problem(ExcavatorBoom(scene), scene)


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
