"""Independent numpy reference of problems/lib_tailgate_strut.toml (no optdesign).

The gate turns about the hinge A by the sweep phi, which is also the drive's crank angle
(q = phi, k = 1).  A point with gate-frame coordinates p is at R(phi) p, so (' = d/dphi)
r' = J r, r'' = -r.  The gate's centre of mass G = R(phi) (a_gate, c_gate), the strut's gate
pin B = R(phi) (b, c_pin), its body pin D fixed.  The struts' force on the gate acts at B
along u = (B - D) / |B - D| with the catalogue law F(L) = F1 (1 + (p_prog - 1)(L_ext - L) /
(L_ext - L_comp)); its generalised force is F u . B'.  Then (refkit.drive_load) the hand
torque is  T = m g x_G' ... = dV/dphi - F u . B' + I_A eps  (M_s = m |G'|^2 + I constant, so no
velocity term).  Constraint rows: the strut length; the hold-open condition.  The scene states it as the static
torque at full opening, end(static_load) <= -T_hold (its struts a [[forces]] gas spring); this
reference keeps it per sample as a ramp, the static torque dV/dphi - F u . B' minus
K_RAMP (phi_open - phi), whose maximum over the stroke is its value at full opening
(tests/library/test_lib_tailgate_strut.py checks that), so that refkit's grid and polish see
it as a row like any other.  ``ends`` names it with the row the scene's end value is.
"""
from __future__ import annotations

import numpy as np

try:
    from . import refkit
except ImportError:  # run as a script
    import refkit

SCENE = refkit.ROOT / "problems" / "lib_tailgate_strut.toml"
K_RAMP = 1000.0  # [N m/rad]: steeper than the static torque can fall


def _turned(p, th):
    c, s = np.cos(th), np.sin(th)
    r = refkit._stack(c * p[0] - s * p[1], s * p[0] + c * p[1])
    return r, refkit.perp(r), -r


class TailgateStrut:
    per_sample = [("strut within its stroke", "L"), ("holds itself open", "hold")]
    ratios = []
    ends = {"holds itself open": "static"}  # the scene's end(static_load): this row at the stroke's end

    def __init__(self, scene):
        self.p = scene.params
        self.g = scene.g

    def state(self, x, phi):
        p = self.p
        G, G1, G2 = _turned((p["a_gate"], p["c_gate"]), phi)
        B, B1, _ = _turned((x["b"], p["c_pin"]), phi)
        D = refkit._stack(x["xD"] + 0 * phi, x["yD"] + 0 * phi)
        d = B - D
        L = np.sqrt(d[0] ** 2 + d[1] ** 2)
        u = d / L
        F = x["F1"] * (1 + (p["p_prog"] - 1) * (p["L_ext"] - L) / (p["L_ext"] - p["L_comp"]))
        force = F * u
        one = np.ones_like(phi)
        gate = (p["m_gate"], p["m_gate"] * p["L_gate"] ** 2 / 12, G, G1, G2, one, 0 * one)
        static = p["m_gate"] * self.g * G1[1] - (force[0] * B1[0] + force[1] * B1[1])
        rows = {"L": L, "hold": static - K_RAMP * (p["phi_open"] - phi), "static": static}
        return refkit.State([gate], phi, one + 0 * L, 0 * L, rows, forces=[(force, B1)])


def scene_data():
    return refkit.SceneData(SCENE)


def problem():
    scene = scene_data()
    return refkit.Problem(TailgateStrut(scene), scene)


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
