"""Joint forces of issue 27's knuckle-joint press (tests/data/issue27/knuckle_press.toml) against
Newton-Euler written here from the geometry (issue 30): no optdesign kinematics.

Positions in closed form from the scene's numbers (the crank S->A, the dyad K on the circles
|K - A| = l and |K - F| = a on the left of A->F, the ram C on the vertical line through F, b
below... from K), their first and second derivatives in the crank angle by central differences at 40 digits
(mpmath);
at the scene's constant crank speed w, v = r' w and a = r'' w^2.  Five moving parts: the
massless crank S-A, the connecting rod A-K, the upper link F-K, the lower link K-C (massive
links, centres at the middle, I = m L^2/12) and the ram (its mass at C, the blanking force, on a
vertical guide: a normal force and a moment).  The pin K joins three parties (the upper link,
the lower link, the rod).  Fifteen unknowns, fifteen equations per sample, solved by numpy.

Checked: every pin force's components (at K, the force on each of its three parties), the
guide's normal force and moment, and the drive
torque, to 1e-10 of the largest pin force (the torque to 1e-10 of its own peak), over the
stroke and around the blanking-force bump; with a spring anchored at the three-party pin K;
and in two load cases ([[cases]] with another blanking force and ram mass).
"""
from __future__ import annotations

from pathlib import Path

import casadi as ca
import mpmath as mp
import numpy as np
import pytest

import optdesign
from optdesign.kinematics.mechanism import Mechanism
from optdesign.model.joints import JointForces
from optdesign.model.reduction import ReducedModel
from optdesign.scene.resolved import ResolvedScene

SCENE = Path(__file__).parent / "data" / "issue27" / "knuckle_press.toml"
REL = 1e-10
NOMINAL = {"xS": 0.62, "yS": -0.45, "r": 0.05, "l": 0.55, "a": 0.30, "b": 0.30, "F0": 600e3, "d0": 0.012,
           "w": 0.003, "m_ram": 900.0, "m_link": 45.0, "m_rod": 70.0}
OMEGA, G = 5.235987755982989, 9.81
H = (0.35, 0.25)          # the spring's fixed anchor (the variant with a spring at K)


def _geometry(v):
    """The press's points at the crank angle phi (mpmath), from the scene's parameters ``v``."""
    xS, yS, r, l, a, b = (mp.mpf(v[k]) for k in ("xS", "yS", "r", "l", "a", "b"))
    dS = mp.sqrt(xS**2 + yS**2)
    gK = mp.atan2(yS, xS) - mp.acos((a**2 + dS**2 - (l + r)**2) / (2 * a * dS))
    xKB, yKB = a * mp.cos(gK), a * mp.sin(gK)
    aBDC = mp.atan2(yKB - yS, xKB - xS)
    yBDC = yKB - mp.sqrt(b**2 - xKB**2)

    def points(phi):
        th = aBDC + phi
        A = (xS + r * mp.cos(th), yS + r * mp.sin(th))
        d = mp.sqrt(A[0]**2 + A[1]**2)
        u = (-A[0] / d, -A[1] / d)                  # A -> F (F at the origin)
        along = (l**2 - a**2 + d**2) / (2 * d)
        h = mp.sqrt(l**2 - along**2)
        K = (A[0] + along * u[0] - h * u[1], A[1] + along * u[1] + h * u[0])
        C = (mp.mpf(0), K[1] - mp.sqrt(b**2 - K[0]**2))
        return {"A": A, "K": K, "C": C}

    return points, yBDC


def kinematics(v, phis):
    """{P: (position, velocity, acceleration)} as (3, 2, n) arrays, and the links' angles
    (angle, rate, acceleration) at the constant crank speed; yBDC.  The derivatives in phi by
    the five-point central differences at 40 digits with the step 1e-8 (truncation ~1e-32,
    rounding ~1e-24)."""
    mp.mp.dps = 40
    points, yBDC = _geometry(v)
    h = mp.mpf("1e-8")
    ends = {"upper link": ("F", "K"), "lower link": ("K", "C"), "connecting rod": ("A", "K")}
    out = {P: np.zeros((3, 2, len(phis))) for P in "AKC"}
    angles = {k: np.zeros((3, len(phis))) for k in ends}
    for i, phi in enumerate(phis):
        at = [points(mp.mpf(phi) + j * h) for j in (-2, -1, 0, 1, 2)]
        for pts in at:
            pts["F"] = (mp.mpf(0), mp.mpf(0))

        def derivatives(values):
            m2, m1, c, p1, p2 = values
            return [float(c), float((m2 - 8 * m1 + 8 * p1 - p2) / (12 * h)) * OMEGA,
                    float((-m2 + 16 * m1 - 30 * c + 16 * p1 - p2) / (12 * h**2)) * OMEGA**2]

        for P in "AKC":
            for j in range(2):
                out[P][:, j, i] = derivatives([pts[P][j] for pts in at])
        for name, (p, q) in ends.items():
            raw = [mp.atan2(pts[q][1] - pts[p][1], pts[q][0] - pts[p][0]) for pts in at]
            # unwrapped about the middle one (the stencil is 4e-8 wide)
            angles[name][:, i] = derivatives([raw[2] + mp.atan2(mp.sin(a - raw[2]), mp.cos(a - raw[2])) for a in raw])
    zero = np.zeros((3, 2, len(phis)))
    S = zero.copy()
    S[0] = np.array([v["xS"], v["yS"]])[:, None]
    return {"A": out["A"], "K": out["K"], "C": out["C"], "F": zero, "S": S}, angles, float(yBDC)


def _cross(a, b):
    return a[0] * b[1] - a[1] * b[0]


def newton_euler(v, phis, spring=None, ram_com=(0.0, 0.0)):
    """The press's joint forces by Newton-Euler: {name: (2, n) or (n,)}.  Unknowns
    x = [R_S, R_A, R_F, R_KU, R_KL, R_C, N, M, T]: the ground on the crank at S, the crank on
    the rod at A, the ground on the upper link at F, the pin K on the upper and on the lower
    link (on the rod: the spring's pull at K less these two), the lower link on the ram at C,
    the guide's normal force (along +x, the line's left normal) and moment on the ram, the
    crank torque.  ``spring``: (rate, free length) of a spring from H to K; ``ram_com``: the
    ram's centre of mass (a, b) in its frame C->U (x up, y towards -x), where its weight, its
    d'Alembert force and the blanking force act."""
    P, ang, yBDC = kinematics(v, phis)
    n = len(phis)
    pos = {k: P[k][0] for k in P}
    g = np.array([0.0, -G])
    load_K = np.zeros((2, n))
    if spring is not None:
        d = np.array(H)[:, None] - pos["K"]
        L = np.hypot(*d)
        load_K = spring[0] * (L - spring[1]) * d / L    # the tension pulls K towards H
    y_c = pos["C"][1]
    blank = v["F0"] * np.exp(-((y_c - yBDC - v["d0"]) / v["w"])**2) / (1 + np.exp(phis / np.radians(2.0)))
    # the known loads on each part (force at its centre, its moment about the part's origin):
    # weight, the blanking force, d'Alembert's forces
    masses = {"connecting rod": ("A", "K", v["m_rod"], v["l"]), "upper link": ("F", "K", v["m_link"], v["a"]),
              "lower link": ("K", "C", v["m_link"], v["b"])}
    known = {}
    for name, (p, q, m, length) in masses.items():
        aG = (P[p][2] + P[q][2]) / 2
        Gc = (pos[p] + pos[q]) / 2
        f = m * (g[:, None] - aG)
        known[name] = (f, _cross(Gc - pos[p], f) - m * length**2 / 12 * ang[name][2])
    f = v["m_ram"] * (g[:, None] - P["C"][2]) + np.array([np.zeros(n), blank])
    rho = np.array([-ram_com[1], ram_com[0]])[:, None] + 0 * f   # from C to the ram's centre (it does not turn)
    known["ram"] = (f, _cross(rho, f))
    known["crank"] = (np.zeros((2, n)), np.zeros(n))
    # the unknown forces on each part: (part, point, column, sign, extra known force at the point)
    on = {"crank": [("S", 0, 1), ("A", 2, -1)],
          "connecting rod": [("A", 2, 1), ("K", 6, -1), ("K", 8, -1)],
          "upper link": [("F", 4, 1), ("K", 6, 1)],
          "lower link": [("K", 8, 1), ("C", 10, -1)],
          "ram": [("C", 10, 1)]}
    origin = {"crank": "S", "connecting rod": "A", "upper link": "F", "lower link": "K", "ram": "C"}
    x = np.zeros((15, n))
    for i in range(n):
        M = np.zeros((15, 15))
        rhs = np.zeros(15)
        for k, part in enumerate(on):
            o = pos[origin[part]][:, i]
            for point, col, sign in on[part]:
                arm = pos[point][:, i] - o
                M[3 * k, col] += sign
                M[3 * k + 1, col + 1] += sign
                M[3 * k + 2, col] += -sign * arm[1]
                M[3 * k + 2, col + 1] += sign * arm[0]
            f, m = known[part][0][:, i].copy(), known[part][1][i]
            if part == "connecting rod":   # the spring's pull at K reaches the rod through the pin
                f += load_K[:, i]
                m += _cross(pos["K"][:, i] - o, load_K[:, i])
            if part == "ram":
                M[3 * k, 12] = 1.0          # the guide's normal force, along +x at C
                M[3 * k + 2, 13] = 1.0      # its moment
            if part == "crank":
                M[3 * k + 2, 14] = 1.0      # the drive torque
            rhs[3 * k: 3 * k + 2] = -f
            rhs[3 * k + 2] = -m
        x[:, i] = np.linalg.solve(M, rhs)
    R = {k: x[j: j + 2] for k, j in (("S", 0), ("A", 2), ("F", 4), ("KU", 6), ("KL", 8), ("C", 10))}
    return {"pin S": -R["S"], "pin A": R["A"], "pin F": -R["F"], "pin K": R["KU"], "pin C": R["C"],
            "K on upper link": R["KU"], "K on lower link": R["KL"], "K on connecting rod": load_K - R["KU"] - R["KL"],
            "normal C": x[12], "moment C": x[13], "drive": x[14]}


def _tool(scene, phis):
    """The tool's pin forces, the slider C's normal force and moment and the drive torque at ``phis``."""
    mech = Mechanism(ResolvedScene(scene))
    jf = JointForces(ReducedModel(mech))
    outs = {"drive": jf.drive}
    outs.update({f"pin {p}": f for p, f in jf.pins.items()})
    outs["slider C"] = ca.vertcat(*jf.sliders["C"][:2])
    outs.update({f"K on {name}": f for name, f in jf.parties["K"]})
    res = mech.function("jf", outs).map(len(phis))(s=phis[None, :], p=mech.parameter_values)
    return {k: np.asarray(val, float) for k, val in res.items()}


def _stroke():
    """One turn at 121 samples and 41 more across the blanking-force bump (phi near -14 deg)."""
    return np.sort(np.r_[np.linspace(-np.pi, np.pi, 121), np.radians(np.linspace(-20, -8, 41))])


def check_against_newton_euler(tool, ours):
    pins = {k for k in tool if k.startswith("pin ")}
    assert pins == {"pin S", "pin A", "pin F", "pin K", "pin C"}
    scale = max(np.max(np.hypot(*ours[k])) for k in pins)
    for k in sorted(pins):
        err = np.max(np.abs(tool[k] - ours[k])) / scale
        assert err <= REL, (k, err)
    # the three parties at K: the force on each (they sum to the spring's pull on the pin)
    assert {k for k in tool if k.startswith("K on ")} == {"K on upper link", "K on lower link", "K on connecting rod"}
    for k in ("K on upper link", "K on lower link", "K on connecting rod"):
        assert np.max(np.abs(tool[k] - ours[k])) <= REL * scale, k
    for j, k in enumerate(("normal C", "moment C")):
        assert np.max(np.abs(tool["slider C"][j] - ours[k])) <= REL * scale, k
    T = ours["drive"]
    assert np.max(np.abs(tool["drive"].ravel() - T)) <= REL * np.max(np.abs(T))
    return scale


def test_knuckle_press_pin_forces_against_newton_euler():
    """The nominal press: the blanking force (600 kN) reaches the ground through F and S; the
    largest pin force is hundreds of kN, and every component agrees to 1e-10 of it."""
    phis = _stroke()
    ours = newton_euler(NOMINAL, phis)
    scale = check_against_newton_euler(_tool(optdesign.load(SCENE), phis), ours)
    assert scale > 3e5          # the blanking force is carried (a sanity check of the reference)


SPRING = SCENE.read_text().replace("[gravity]", f"""[points.H]
fixed = [{H[0]}, {H[1]}]

[[forces]]
name = "knee spring"
kind = "spring"
between = ["H", "K"]
rate = 2.0e5
free_length = 0.15

[gravity]""")


def test_knuckle_press_with_a_spring_at_the_three_party_pin():
    """A spring from H to the knuckle K, where three parts meet: its pull acts on the pin."""
    phis = _stroke()
    check_against_newton_euler(_tool(optdesign.loads(SPRING), phis), newton_euler(NOMINAL, phis, spring=(2.0e5, 0.15)))


CASES = SPRING.replace("[objective]", """[[cases]]
name = "light"
direction = "forward"
set = { F0 = 350e3 }
[[cases]]
name = "heavy ram"
direction = "forward"
set = { F0 = 750e3, m_ram = 1400.0 }

[objective]""")


def test_knuckle_press_pin_forces_in_load_cases():
    """analyse(joints=True) of the press with the spring and two [[cases]]: each case's pin
    force components, its guide's normal force and its torque are Newton-Euler's at the case's
    parameters, and each pin's peak is the largest of Newton-Euler's on the case's samples."""
    an = optdesign.analyse(optdesign.loads(CASES), samples=73, joints=True, certify=False)
    for case, overrides in (("light", {"F0": 350e3}), ("heavy ram", {"F0": 750e3, "m_ram": 1400.0})):
        columns = an.cases.cases[case].columns
        phis = np.asarray(columns["s"], float)
        ours = newton_euler({**NOMINAL, **overrides}, phis, spring=(2.0e5, 0.15))
        scale = max(np.max(np.hypot(*ours[f"pin {p}"])) for p in "SAFKC")
        for p in "SAFKC":
            for j, c in enumerate("xy"):
                assert np.max(np.abs(columns[f"pin_force_{c}({p})"] - ours[f"pin {p}"][j])) <= REL * scale, (p, c)
            assert an.cases.cases[case].peaks[f"pin_force({p})"] == pytest.approx(
                np.max(np.hypot(*ours[f"pin {p}"])), rel=REL)
        assert np.max(np.abs(columns["slider_normal(C)"] - ours["normal C"])) <= REL * scale
        for party in ("upper link", "lower link", "connecting rod"):
            for j, c in enumerate("xy"):
                assert np.max(np.abs(columns[f"pin_force_{c}(K, {party})"] - ours[f"K on {party}"][j])) <= REL * scale
        assert np.max(np.abs(columns["drive"] - ours["drive"])) <= REL * np.max(np.abs(ours["drive"]))


PARTY_CONSTRAINTS = SPRING.replace("[objective]", """[[constraints]]
name = "lower link at K"
expr = "pin_force(K, C)"
max = 1e9

[[constraints]]
name = "rod at K, x"
expr = "pin_force_x(K, A)"
max = 1e9

[[constraints]]
name = "upper link at K, y"
expr = "pin_force_y(K, F)"
max = 1e9

[[constraints]]
name = "ground at F"
expr = "pin_force(F, S)"
max = 1e9

[objective]""")


def test_pin_force_on_a_party_in_constraints():
    """pin_force(P, Q): the force at pin P on the party that runs from P to Q (the lower link
    K-C, the rod K-A, the upper link K-F at the three-party pin K with the spring's pull; the
    ground at F, which carries S too), per sample against Newton-Euler; a point that no party at
    the pin reaches is an error naming the pin's parties."""
    an = optdesign.analyse(optdesign.loads(PARTY_CONSTRAINTS), samples=37, certify=False)
    phis = np.asarray(an.columns["s"], float)
    ours = newton_euler(NOMINAL, phis, spring=(2.0e5, 0.15))
    scale = max(np.max(np.hypot(*ours[f"pin {p}"])) for p in "SAFKC")
    expected = {"lower link at K": np.hypot(*ours["K on lower link"]), "rod at K, x": ours["K on connecting rod"][0],
                "upper link at K, y": ours["K on upper link"][1], "ground at F": np.hypot(*ours["pin F"])}
    for name, values in expected.items():
        assert np.max(np.abs(an.constraints[name] - values)) <= REL * scale, name
    bad = PARTY_CONSTRAINTS.replace('expr = "pin_force(K, C)"', 'expr = "pin_force(K, U)"')
    with pytest.raises(optdesign.errors.SceneError, match=r"no party at pin K reaches 'U' \(its parties: upper link, "
                                                          r"lower link, connecting rod\)"):
        optdesign.analyse(optdesign.loads(bad), samples=5, certify=False)


def test_knuckle_press_guide_moment_with_an_offset_ram():
    """The ram's centre of mass 40 mm beside and 50 mm above its pin C: its weight, inertia and
    the blanking force there turn it against the guide, which holds it with a moment (zero in
    the scene): the guide's normal force and moment, and every pin force, against Newton-Euler."""
    phis = _stroke()
    text = SCENE.read_text().replace("com = [0, 0]", "com = [0.05, 0.04]", 1)
    assert text != SCENE.read_text()
    ours = newton_euler(NOMINAL, phis, ram_com=(0.05, 0.04))
    scale = check_against_newton_euler(_tool(optdesign.loads(text), phis), ours)
    assert np.max(np.abs(ours["moment C"])) > 1e-3 * scale   # the moment is not zero
