"""Independent numpy reference of problems/lib_scissor_lift.toml (no optdesign).

The scissor by hand, with the arm angle theta as the sweep (' = d/dtheta):
    e1 = (cos, sin), n1 = (-sin, cos) (the inner arms' axis and its normal), e1' = n1, n1' = -e1;
    the roller R runs on the ground line 0.5 L from the centre pin C = 0.5 L e1:
    R = (L cos, 0); the outer arms' axis e2 = (C - R) / |C - R| = (-cos, sin), its normal
    (the scene's attach frame: x axis turned by +90 deg) n2 = (-sin, -cos), e2' = -n2 ... written
    out below;  P2 = R + L e2 = (0, L sin): the platform rises without turning;
    B = c e1 + eB n1,  D = R + d e2 + eD n2,  the drive length |B - D| and its derivatives.
Bodies: the inner arms (centre of mass 0.5 L e1, angle theta), the outer arms (centre of mass
R + 0.5 L e2 = C, angle pi - theta), the platform with the payload (translating with P2).
"""
from __future__ import annotations

import numpy as np

try:
    from . import refkit
except ImportError:  # run as a script
    import refkit

SCENE = refkit.ROOT / "problems" / "lib_scissor_lift.toml"


class ScissorLift:
    per_sample = [("rod eye under the platform deck", "deck"), ("cylinder base above the floor", "floor")]
    ratios = [("cylinder length ratio", "L")]

    def __init__(self, scene):
        self.p = scene.params

    def state(self, x, th):
        p = self.p
        L = p["L"]
        c, eB, d, eD = x["c"], x["eB"], x["d"], x["eD"]
        cs, sn = np.cos(th), np.sin(th)
        zero = 0 * th
        e1, n1 = refkit._stack(cs, sn), refkit._stack(-sn, cs)
        e2, n2 = refkit._stack(-cs, sn), refkit._stack(-sn, -cs)
        e2_1 = refkit._stack(sn, cs)          # d e2 / d theta
        e2_2 = refkit._stack(cs, -sn)         # = -e2
        n2_1 = refkit._stack(-cs, sn)         # d n2 / d theta = e2
        n2_2 = refkit._stack(sn, cs)          # = e2'
        R = refkit._stack(L * cs, zero)
        R1 = refkit._stack(-L * sn, zero)
        R2 = refkit._stack(-L * cs, zero)
        # pins
        B = c * e1 + eB * n1
        B1 = c * n1 - eB * e1
        B2 = -c * e1 - eB * n1
        D = R + d * e2 + eD * n2
        D1 = R1 + d * e2_1 + eD * n2_1
        D2 = R2 + d * e2_2 + eD * n2_2
        q, q1, q2 = refkit.length(B - D, B1 - D1, B2 - D2)
        # bodies: (m, I, r, r', r'', phi', phi'')
        m_arm, I_arm = p["m_arm"], p["m_arm"] * L ** 2 / 12
        one = np.ones_like(th)
        inner = (m_arm, I_arm, 0.5 * L * e1, 0.5 * L * n1, -0.5 * L * e1, one, 0 * one)
        outer = (m_arm, I_arm, R + 0.5 * L * e2, R1 + 0.5 * L * e2_1, R2 + 0.5 * L * e2_2, -one, 0 * one)
        P2 = refkit._stack(zero, L * sn)
        platform = (p["m_plat"] + p["m_load"], 0.0, P2, refkit._stack(zero, L * cs),
                    refkit._stack(zero, -L * sn), 0 * one, 0 * one)
        rows = {"L": q, "deck": P2[1] - B[1], "floor": D[1]}
        return refkit.State([inner, outer, platform], q, q1, q2, rows)


def scene_data():
    return refkit.SceneData(SCENE)


def problem():
    scene = scene_data()
    return refkit.Problem(ScissorLift(scene), scene)


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
