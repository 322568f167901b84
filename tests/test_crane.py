"""The harbour level-luffing crane (problems/level_luffing_crane.toml, seed 1 Fig. 10): the
cylinder force F_S of the reduced model against an independent Lagrange / virtual-work
calculation in plain numpy (issue 3, "Done when" item 4), and the sanity of the scene itself.

The independent calculation (:class:`Crane`) shares nothing with optdesign but the scene's
input numbers, read here with ``tomllib``:

- kinematics of its own: the four-bar A-B-D-E closed by the law of cosines in triangle B-D-E
  (D = B + L_BD * (u_BE turned clockwise by the angle at B), not the code's chord/height
  formula); every centre of mass and body axis written out from the bodies' descriptions below;
- derivatives by complex step in the jib angle theta (exact to round-off: every formula here is
  analytic, no abs, no atan2): dr/dtheta of every centre of mass, d(axis)/dtheta, dx/dtheta of
  the cylinder length x = |FS| and dV/dtheta of the potential energy V = g sum m y;
- referred to x by the chain rule: F_Su = dV/dx = V'/x',  m_zS(x) = 2 E_kin / v_S^2 = (sum m
  |r'|^2 + I omega'^2) / x'^2 (omega' = axis x d(axis)/dtheta), and dm_zS/dx by a fourth-order
  central difference of m_zS(theta) with step h = 1e-4 rad (its truncation error falls as h^4:
  measured 6.7e-7 relative at h = 2e-3, 1.6e-10 at 2.5e-4; round-off ~ 1e-16 m_zS / h, about
  3e-11 relative at h = 1e-4, grows below that);
- Lagrange's equation for the one coordinate x:  F = F_Su + m_zS a_S + 1/2 dm_zS/dx v_S^2, and
  the seed's efficiency rule: F_S = F / eta while the cylinder delivers power (F v_S > 0),
  F_S = eta F while power flows back into it.

Tolerance: 1e-6 relative at every sample (the issue's figure; the agreement found is better
than 1e-10 for every output).
F_S stays far from zero over the stroke (checked), so a per-sample relative error is meaningful.
"""
from __future__ import annotations

import math
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

from optdesign.model.analysis import analyse
from optdesign.scene.file import load, loads

SCENE_PATH = Path(__file__).resolve().parent.parent / "problems" / "level_luffing_crane.toml"
RTOL = 1e-6
G = 9.81


def _number(value):
    """A scene number: a float, {value = ...}, or a string 'N deg'."""
    if isinstance(value, dict):
        value = value["value"]
    if isinstance(value, str):
        m = re.fullmatch(r"\s*([-+0-9.eE]+)\s*deg\s*", value)
        assert m, f"unexpected scene value {value!r}"
        return math.radians(float(m.group(1)))
    return float(value)


def scene_data(text):
    """The crane's inputs from the TOML text (parameters, stroke, drive), without optdesign."""
    data = tomllib.loads(text)
    p = {k: _number(v) for k, v in data["parameters"].items()}
    sweep = data["sweep"]
    drive = data["drive"]
    return p, (_number(sweep["from"]), _number(sweep["to"]), int(sweep["samples"])), {
        "v": float(drive["speed"]), "a": float(drive["acceleration"]), "eta": float(drive["efficiency"])}


def _perp(v):
    return np.array([-v[1], v[0]])


def _unit(v):
    return v / np.sqrt(v[0] ** 2 + v[1] ** 2)  # complex-step safe (no abs)


class Crane:
    """The crane's geometry and bodies, written out independently, as functions of the jib angle
    theta (scalar or complex array).  Bodies (as the scene describes them in words):
    jib (A->B, centre of mass 0.45 L_AB along it, I = m L_AB^2/12), beak (frame origin B, x axis
    towards D, centre of mass at (-2.5, -0.5), I = m (L_BD - aT)^2/12), connector (E->D, centre
    of mass at mid-length, I = m L_ED^2/12), barrel (F->S, centre of mass 0.48 L_barrel from F,
    I = m L_barrel^2/12), rod (S->F, centre of mass L_rod/2 from S, I = m L_rod^2/12), payload
    (point mass at the tip T = B + aT e_BD + bT perp(e_BD))."""

    def __init__(self, p):
        self.p = p

    def points(self, th):
        p = self.p
        A = np.array([p["xA"], p["yA"]])[:, None]
        E = np.array([p["xE"], p["yE"]])[:, None]
        F = np.array([p["xF"], p["yF"]])[:, None]
        B = A + p["L_AB"] * np.array([np.cos(th), np.sin(th)])
        BE = E - B
        d = np.sqrt(BE[0] ** 2 + BE[1] ** 2)
        u = BE / d
        # angle at B in triangle B-D-E (law of cosines); D lies to the right of B->E
        gamma = np.arccos((p["L_BD"] ** 2 + d**2 - p["L_ED"] ** 2) / (2 * p["L_BD"] * d))
        D = B + p["L_BD"] * (np.cos(gamma) * u - np.sin(gamma) * _perp(u))
        e_jib = _unit(B - A)
        S = A + p["aS"] * e_jib + p["bS"] * _perp(e_jib)
        return {"A": A, "B": B, "D": D, "E": E, "F": F, "S": S, "e_jib": e_jib}

    def bodies(self, th):
        """name -> (mass, centre of mass 2 x n, unit body axis 2 x n or None, inertia)."""
        p, P = self.p, self.points(th)
        e_beak = (P["D"] - P["B"]) / p["L_BD"]
        e_conn = (P["D"] - P["E"]) / p["L_ED"]
        e_cyl = _unit(P["S"] - P["F"])
        tip = P["B"] + p["aT"] * e_beak + p["bT"] * _perp(e_beak)
        return {
            "jib": (p["m2"], P["A"] + 0.45 * p["L_AB"] * P["e_jib"], P["e_jib"], p["m2"] * p["L_AB"] ** 2 / 12),
            "beak": (p["m3"], P["B"] - 2.5 * e_beak - 0.5 * _perp(e_beak), e_beak,
                     p["m3"] * (p["L_BD"] - p["aT"]) ** 2 / 12),
            "connector": (p["m4"], P["E"] + 0.5 * p["L_ED"] * e_conn, e_conn, p["m4"] * p["L_ED"] ** 2 / 12),
            "barrel": (p["m_barrel"], P["F"] + 0.48 * p["L_barrel"] * e_cyl, e_cyl,
                       p["m_barrel"] * p["L_barrel"] ** 2 / 12),
            "rod": (p["m_rod"], P["S"] - 0.5 * p["L_rod"] * e_cyl, e_cyl, p["m_rod"] * p["L_rod"] ** 2 / 12),
            "payload": (p["m_L"], tip, None, 0.0),
        }

    def tip(self, th):
        return self.bodies(th)["payload"][1]

    def cylinder_length(self, th):
        P = self.points(th)
        FS = P["S"] - P["F"]
        return np.sqrt(FS[0] ** 2 + FS[1] ** 2)

    def potential(self, th):
        return sum(G * m * com[1] for m, com, _, _ in self.bodies(th).values())


def complex_step(f, th, h=1e-30):
    """df/dtheta, exact to round-off for analytic f."""
    return np.imag(f(np.asarray(th, dtype=complex) + 1j * h)) / h


class Lagrange:
    """F_Su, m_zS, dm_zS/dx and F_S of the crane from energies, referred to x = |FS|."""

    def __init__(self, crane, motion):
        self.crane, self.motion = crane, motion

    def x_theta(self, th):
        return complex_step(self.crane.cylinder_length, th)

    def static_load(self, th):  # F_Su = dV/dx (before efficiency)
        return complex_step(self.crane.potential, th) / self.x_theta(th)

    def reduced_mass(self, th):  # m_zS: E_kin = 1/2 m_zS v_S^2 (before efficiency)
        th_c = np.asarray(th, dtype=complex) + 1e-30j
        twice_kinetic = 0.0
        for m, com, axis, inertia in self.crane.bodies(th_c).values():
            r_th = np.imag(com) / 1e-30
            twice_kinetic = twice_kinetic + m * (r_th[0] ** 2 + r_th[1] ** 2)
            if axis is not None and inertia:
                e, e_th = np.real(axis), np.imag(axis) / 1e-30
                omega_th = e[0] * e_th[1] - e[1] * e_th[0]
                twice_kinetic = twice_kinetic + inertia * omega_th**2
        return twice_kinetic / self.x_theta(th) ** 2

    def reduced_mass_dx(self, th, h=1e-4):
        f = self.reduced_mass
        d_th = (-f(th + 2 * h) + 8 * f(th + h) - 8 * f(th - h) + f(th - 2 * h)) / (12 * h)
        return d_th / self.x_theta(th)

    def drive(self, th):
        """F_S and its parts with the seed's efficiency rule."""
        v, a, eta = self.motion["v"], self.motion["a"], self.motion["eta"]
        F_Su, m_zS, dm_zS = self.static_load(th), self.reduced_mass(th), self.reduced_mass_dx(th)
        ideal = F_Su + m_zS * a + 0.5 * dm_zS * v**2
        c = np.where(ideal * v > 0, 1 / eta, eta)
        return {"static_load": c * F_Su, "reduced_inertia": c * m_zS, "reduced_inertia_dq": c * dm_zS,
                "velocity_term": -0.5 * v**2 * c * dm_zS, "drive": c * ideal, "c": c}


def _assert_close(name, ours, ref, rtol, scale=None):
    scale = np.abs(ref) if scale is None else scale
    err = np.abs(ours - ref) / scale
    worst = int(np.argmax(err))
    assert err[worst] <= rtol, (
        f"{name}: relative error {err[worst]:.3g} > {rtol:g} at sample {worst} (ours {ours[worst]!r}, "
        f"independent {ref[worst]!r})")


TEXT = SCENE_PATH.read_text()

# The shipped crane, then variants: luffing out while braking (negative speed, positive
# acceleration: power flows back into the cylinder, eta multiplies), moved cylinder pins, and
# luffing in while braking hard, where F_S changes sign near minimum outreach (the efficiency
# switch inside the stroke).
VARIANTS = {
    "shipped": (TEXT, {}),
    "luffing out": (TEXT.replace("speed = 0.05", "speed = -0.05"), {}),
    "moved pins": (TEXT, {"xF": 7.2, "yF": 8.4, "aS": 5.0, "bS": -1.6}),
    "braking": (TEXT.replace("acceleration = 0.05", "acceleration = -0.08"), {}),
}


@pytest.mark.parametrize("variant", list(VARIANTS))
def test_drive_force_agrees_with_lagrange(variant):
    """Every output of the reduced model against the Lagrange calculation, sample by sample.
    Where F_S keeps its sign, relative to its value at each sample; in the braking variant,
    where F_S passes through zero, relative to the stroke's peak |F_S| (a relative error at a
    sample where F_S is nearly zero says nothing), and the efficiency factor must switch there."""
    text, overrides = VARIANTS[variant]
    assert text != TEXT or variant in ("shipped", "moved pins"), "the variant's replacement did not apply"
    p, (s0, s1, n), drive = scene_data(text)
    p.update(overrides)
    scene = loads(text, f"{variant}.toml")
    if overrides:
        scene = scene.with_parameters(**overrides)
    result = analyse(scene)
    th = result.columns["s"]
    np.testing.assert_allclose(th, np.linspace(s0, s1, n), rtol=0, atol=1e-15)

    ref = Lagrange(Crane(p), drive).drive(th)
    crosses_zero = variant == "braking"
    peak = np.max(np.abs(ref["drive"]))
    if crosses_zero:
        assert ref["drive"].min() < 0 < ref["drive"].max(), "the braking variant must change sign"
        scale = {k: np.full(n, np.max(np.abs(ref[k]))) for k in ref}
    else:
        assert np.min(np.abs(ref["drive"])) > 0.05 * peak
        scale = {k: np.abs(ref[k]) for k in ref}
    _assert_close("F_S", result.columns["drive"], ref["drive"], RTOL, scale["drive"])
    _assert_close("F_Su", result.columns["static_load"], ref["static_load"], RTOL, scale["static_load"])
    _assert_close("m_zS", result.columns["reduced_inertia"], ref["reduced_inertia"], RTOL,
                  scale["reduced_inertia"])
    _assert_close("dm_zS/dx", result.columns["reduced_inertia_dq"], ref["reduced_inertia_dq"], RTOL,
                  scale["reduced_inertia_dq"])
    # dF_S is small next to F_S; hold it to the same relative accuracy of its own size
    _assert_close("dF_S", result.columns["velocity_term"], ref["velocity_term"], RTOL, scale["velocity_term"])
    np.testing.assert_array_equal(result.columns["efficiency_factor"], ref["c"])
    if variant == "luffing out":
        assert np.all(ref["c"] == drive["eta"]), "lowering: power flows back, eta multiplies"
    elif crosses_zero:
        assert set(ref["c"]) == {drive["eta"], 1 / drive["eta"]}
    else:
        assert np.all(ref["c"] == 1 / drive["eta"]), "raising: the cylinder delivers power, eta divides"


def test_payload_path_is_level_over_the_luffing_range():
    """The point of level luffing: over the sweep the tip's outreach runs from 30 m to 9 m while
    its height varies by less than 0.5 m (2.4 % of the 21 m travel; the fitted design gives
    0.44 m), checked on 4001 samples of the independent kinematics."""
    p, (s0, s1, _), _ = scene_data(TEXT)
    crane = Crane(p)
    th = np.linspace(s0, s1, 4001)
    tip = crane.tip(th)
    assert tip[0, 0] == pytest.approx(30.0, abs=0.05) and tip[0, -1] == pytest.approx(9.0, abs=0.05)
    assert np.all(np.diff(tip[0]) < 0), "the outreach must fall monotonically as the jib rises"
    height_variation = tip[1].max() - tip[1].min()
    assert height_variation < 0.5
    # the jib head itself rises by 6.5 m over the same sweep: the beak takes out 93 % of it
    head = crane.points(th)["B"]
    assert head[1].max() - head[1].min() > 10 * height_variation


def test_mechanism_assembles_without_dead_centre():
    """Triangle B-D-E stays a proper triangle over the whole sweep (D at least 1 m off the line
    B-E, so the dyad assembles with margin and never flips branch), the
    cylinder length grows strictly with theta (dx/dtheta bounded away from zero: no dead centre),
    and the cylinder's transmission angle stays within its constraint."""
    p, (s0, s1, _), _ = scene_data(TEXT)
    crane = Crane(p)
    th = np.linspace(s0, s1, 4001)
    P = crane.points(th)
    BE, BD = P["E"] - P["B"], P["D"] - P["B"]
    height = (BE[0] * BD[1] - BE[1] * BD[0]) / np.hypot(*BE)  # signed distance of D from B->E
    assert height.max() < -1.0  # right of B->E (the scene's side) by more than 1 m throughout
    x_th = Lagrange(crane, None).x_theta(th)
    assert x_th.min() > 3.0  # m/rad; |dx/dtheta| ~ the lever arm of the cylinder about A
    FS, AS = P["F"] - P["S"], P["A"] - P["S"]
    mu = np.degrees(np.arccos(np.sum(FS * AS, 0) / np.hypot(*FS) / np.hypot(*AS)))
    assert 40 < mu.min() and mu.max() < 140


def test_reported_constraints_agree_with_independent_geometry():
    """The scene's constraints as the analysis reports them (per sample and per stroke) against
    the same quantities from the independent kinematics, at the same samples, to 1e-9."""
    p, (s0, s1, n), _ = scene_data(TEXT)
    crane = Crane(p)
    result = analyse(load(SCENE_PATH))
    th = result.columns["s"]
    P = crane.points(th)
    FS, AS = P["F"] - P["S"], P["A"] - P["S"]
    mu = np.arccos(np.sum(FS * AS, 0) / np.hypot(*FS) / np.hypot(*AS))
    np.testing.assert_allclose(result.constraints["cylinder transmission angle"], mu, rtol=0, atol=1e-9)
    tip_y = crane.tip(th)[1]
    assert result.constraints["payload height variation"] == pytest.approx(tip_y.max() - tip_y.min(), abs=1e-9)
