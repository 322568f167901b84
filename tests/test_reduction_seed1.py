"""Seed 1's worked examples in closed form against the AD model (issue 3, "Done when" item 1).

Every closed form here is written from our own derivation (docs/seed-slips.md has them in
full) and checked first against an independent derivative of the geometry (complex-step
differentiation of the position formulas, exact to round-off), then against the shipped scenes
problems/seed1_slider_crank.toml and problems/seed1_jib.toml through analyse(): to 1e-10
relative at every sample of the stroke.  The slips of the printed formulas are shown by tests
that the printed forms FAIL the same independent checks.

Slider-crank (section 2.5), crank angle alpha measured from the dead centre where the crank
points away from the piston (the scene's convention, checked below), lambda = r/l,
u = l^2/r^2 - sin^2 alpha:
    y_C(alpha)  = -r cos alpha + sqrt(l^2 - r^2 sin^2 alpha)                 piston pin height
    R(alpha)    = dy_C/dalpha = r [sin alpha - 1/2 sin 2alpha / sqrt(u)]      eq. (18) corrected
    R'(alpha)   = r [cos alpha - (2 cos 2alpha u + 1/2 sin^2 2alpha) / (2 u^(3/2))]   (19) corrected
    R_z = |R| (eq. 1 defines R_z = v_C/omega_S >= 0), dR_z/dalpha = sign(R) R'
    I_zS = m_C R^2 / eta (20),  dI_zS/dalpha = 2 m_C R R' / eta (21, as printed)
Jib (section 3.5), x = |DB|, e = |AD|, b = |AB|, l = |AC|, cos beta = (x^2 + e^2 - b^2)/(2 e x):
    i_v = (e/l) sin beta (39); di_v/dx (40); m_zS = m_C / i_v^2 (41); dm_zS/dx (42), as printed.

Where R = 0 (alpha = 0, pi, 2 pi: sin alpha = 0 to round-off) R_z = |R| has a kink and no
derivative: there we check only that R_z, I_zS, dI_zS/dalpha vanish (to 1e-15 of their peak)
and skip dR_z/dalpha and the accelerations a_C, delta_a_C (the AD gives NaN at the exact zero
alpha = pi and a one-sided value at alpha = 0, 2 pi where R_z = 8.7e-18 by round-off).
Relative errors are pointwise, |AD - closed| <= 1e-10 max(|closed|, 1e-6 peak|closed|): the
floor of a millionth of the stroke's peak only matters where a quantity crosses zero
(dR_z/dalpha, the accelerations).
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from optdesign.model.analysis import analyse
from optdesign.scene.expressions import constant_value
from optdesign.kinematics.mechanism import kinematics
from optdesign.scene.file import load

PROBLEMS = Path(__file__).resolve().parent.parent / "problems"
RTOL = 1e-10
H = 1e-30  # complex-step size: d f(x) = Im f(x + iH) / H, exact to round-off for analytic f


def assert_rel(actual, expected, what, rtol=RTOL, mask=None):
    """Pointwise relative agreement, with a floor of 1e-6 of the peak |expected|."""
    actual, expected = np.asarray(actual, float), np.asarray(expected, float)
    if mask is not None:
        actual, expected = actual[mask], expected[mask]
    scale = np.maximum(np.abs(expected), 1e-6 * np.max(np.abs(expected)))
    err = np.abs(actual - expected) / scale
    worst = int(np.argmax(np.where(np.isnan(err), np.inf, err)))
    assert np.all(err <= rtol), f"{what}: relative error {err[worst]:.3g} at index {worst} " \
                                f"(AD {actual[worst]!r}, closed form {expected[worst]!r})"


def drive_motion(scene):
    """The drive speed and acceleration written in the scene (inputs, not results)."""
    values = scene.parameter_values()
    return (constant_value(scene.drive.speed, values, "speed"),
            constant_value(scene.drive.acceleration, values, "acceleration"))


def complex_step(f, x):
    """df/dx of an analytic numpy function, to round-off."""
    return np.imag(f(np.asarray(x, float) + 1j * H)) / H


# ---------------------------------------------------------------------------------------------
# Slider-crank, section 2.5
# ---------------------------------------------------------------------------------------------
SC_PATH = PROBLEMS / "seed1_slider_crank.toml"


@pytest.fixture(scope="module")
def slider_crank():
    scene = load(SC_PATH)
    return scene, analyse(scene), scene.parameter_values()


def piston_height(alpha, r, l):
    """y_C: crank pin at r (sin alpha, -cos alpha) (pointing away from the piston at alpha = 0),
    piston pin on the vertical through S at distance l from the crank pin, above it."""
    return -r * np.cos(alpha) + np.sqrt(l**2 - r**2 * np.sin(alpha) ** 2)


def R_corrected(alpha, r, l):
    """Eq. (18) with sqrt(l^2/r^2 - sin^2 alpha): the signed dy_C/dalpha."""
    u = l**2 / r**2 - np.sin(alpha) ** 2
    return r * (np.sin(alpha) - 0.5 * np.sin(2 * alpha) / np.sqrt(u))


def R_printed(alpha, r, l):
    """Eq. (18) as printed, sqrt(r^2/l^2 - sin^2 alpha)."""
    with np.errstate(invalid="ignore"):
        u = r**2 / l**2 - np.sin(alpha) ** 2
        return r * (np.sin(alpha) - 0.5 * np.sin(2 * alpha) / np.sqrt(u))


def dR_corrected(alpha, r, l):
    """Eq. (19) without the extra factor 1/2 (i.e. the bracket of eq. 21)."""
    u = l**2 / r**2 - np.sin(alpha) ** 2
    return r * (np.cos(alpha) - (2 * np.cos(2 * alpha) * u + 0.5 * np.sin(2 * alpha) ** 2) / (2 * u**1.5))


def dR_printed(alpha, r, l):
    """Eq. (19) as printed (its sqrt corrected as in (18)), with the doubled factor 1/2."""
    u = l**2 / r**2 - np.sin(alpha) ** 2
    return r * (np.cos(alpha) - 0.5 * (2 * np.cos(2 * alpha) * u + 0.5 * np.sin(2 * alpha) ** 2) / (2 * u**1.5))


def dIzS_printed(alpha, r, l, m, eta=1.0):
    """Eq. (21) as printed (sqrt corrected as in (18))."""
    u = l**2 / r**2 - np.sin(alpha) ** 2
    bracket1 = np.sin(alpha) - 0.5 * np.sin(2 * alpha) / np.sqrt(u)
    bracket2 = np.cos(alpha) - (2 * np.cos(2 * alpha) * u + 0.5 * np.sin(2 * alpha) ** 2) / (2 * u**1.5)
    return 2 * m * r**2 / eta * bracket1 * bracket2


GENERIC_ALPHA = np.linspace(0.05, 2 * np.pi - 0.05, 97)


def test_alpha_convention_of_the_scene(slider_crank):
    """The shipped scene measures alpha from the dead centre where the crank points away from
    the piston: crank pin at r (sin alpha, -cos alpha), piston pin at (0, y_C(alpha))."""
    scene, result, p = slider_crank
    kin = kinematics(scene)
    a, r, l = kin.s, p["r"], p["l"]
    np.testing.assert_allclose(kin.points["A"]["x"], r * np.sin(a), rtol=0, atol=1e-14)
    np.testing.assert_allclose(kin.points["A"]["y"], -r * np.cos(a), rtol=0, atol=1e-14)
    np.testing.assert_allclose(kin.points["C"]["x"], 0.0, rtol=0, atol=1e-14)
    np.testing.assert_allclose(kin.points["C"]["y"], piston_height(a, r, l), rtol=0, atol=1e-14)
    # and the piston's velocity is omega_S times the corrected eq. (18), with its sign
    omega = kin.sd * 1.0  # dq/dalpha = 1 for this crank
    np.testing.assert_allclose(kin.points["C"]["vy"], omega * R_corrected(a, r, l), rtol=0, atol=1e-12)


def test_eq18_corrected_is_the_velocity_ratio_and_printed_is_not(slider_crank):
    """Corrected (18) = dy_C/dalpha (complex step of the position); the printed square root
    sqrt(r^2/l^2 - sin^2 alpha) is imaginary for |sin alpha| > r/l and wrong below it."""
    _, _, p = slider_crank
    r, l, a = p["r"], p["l"], GENERIC_ALPHA
    exact = complex_step(lambda x: piston_height(x, r, l), a)
    assert_rel(R_corrected(a, r, l), exact, "corrected eq. (18) vs dy_C/dalpha", rtol=1e-13)
    printed = R_printed(a, r, l)
    assert np.mean(np.isnan(printed)) > 0.5, "printed (18) should be undefined on most of the stroke"
    ok = ~np.isnan(printed) & (np.abs(np.sin(a)) > 0.01)
    assert ok.any() and np.all(np.abs(printed[ok] - exact[ok]) > 0.1 * np.abs(exact[ok]))


def test_eq18_sign_convention():
    """With alpha from the other dead centre (crank pointing at the piston) the velocity ratio
    is -r[sin alpha + ...]: the printed minus sign in (18) fixes the convention of the scene."""
    r, l, a = 0.1, 0.35, GENERIC_ALPHA
    other = complex_step(lambda x: r * np.cos(x) + np.sqrt(l**2 - r**2 * np.sin(x) ** 2), a)
    assert_rel(other, -r * (np.sin(a) + 0.5 * np.sin(2 * a) / np.sqrt(l**2 / r**2 - np.sin(a) ** 2)),
               "the other convention", rtol=1e-13)
    assert np.max(np.abs(np.abs(other) - np.abs(R_corrected(a, r, l)))) > 0.1 * r


def test_eq19_has_a_doubled_half_and_eq21_is_right(slider_crank):
    """dR/dalpha (complex step of corrected 18) = corrected (19); printed (19) carries an extra
    factor 1/2 on its second term; printed (21) = d/dalpha of (20) is right."""
    _, _, p = slider_crank
    r, l, m, a = p["r"], p["l"], p["mC"], GENERIC_ALPHA
    exact = complex_step(lambda x: R_corrected(x, r, l), a)
    assert_rel(dR_corrected(a, r, l), exact, "corrected eq. (19)", rtol=1e-12)
    wrong = np.abs(dR_printed(a, r, l) - exact) > 1e-3 * np.max(np.abs(exact))
    assert np.mean(wrong) > 0.9, "printed (19) should differ from dR/dalpha on nearly the whole stroke"
    dI_exact = complex_step(lambda x: m * R_corrected(x, r, l) ** 2, a)
    assert_rel(dIzS_printed(a, r, l, m), dI_exact, "printed eq. (21)", rtol=1e-12)


def test_slider_crank_ratios_against_AD(slider_crank):
    """R_z = |(18)|, dR_z/dalpha = sign * (19), I_zS (20), dI_zS/dalpha (21), eqs. (3)."""
    scene, res, p = slider_crank
    r, l, m = p["r"], p["l"], p["mC"]
    a = res.columns["s"]
    np.testing.assert_allclose(np.diff(res.columns["q"]), np.diff(a), rtol=0, atol=1e-13)  # q = alpha - pi/2
    R, dR = R_corrected(a, r, l), dR_corrected(a, r, l)
    kink = np.abs(np.sin(a)) < 1e-12
    assert np.count_nonzero(kink) == 3, "alpha = 0, pi, 2 pi are the only exact zeros of R_z"
    piston = res.bodies["piston"]
    assert_rel(piston["R_z"], np.abs(R), "R_z", mask=~kink)
    assert np.all(np.abs(piston["R_z"][kink]) <= 1e-15 * np.max(np.abs(R)))
    assert_rel(piston["dR_z_dq"], np.sign(R) * dR, "dR_z/dalpha", mask=~kink)
    I = m * R**2
    assert_rel(res.columns["reduced_inertia"], I, "I_zS (20)", mask=~kink)
    assert np.all(res.columns["reduced_inertia"][kink] <= 1e-15 * I.max())
    dI = dIzS_printed(a, r, l, m)
    assert_rel(res.columns["reduced_inertia_dq"], dI, "dI_zS/dalpha (21)", mask=~kink)
    assert np.all(np.abs(res.columns["reduced_inertia_dq"][kink]) <= 1e-15 * np.abs(dI).max())
    # eq. (3): a_C0 = R_z eps_S, delta_a_C = omega_S^2 dR_z/dalpha (tangential, along v_C)
    omega, eps = drive_motion(scene)
    assert_rel(piston["a_C0"], np.abs(R) * eps, "a_C0 (3)", mask=~kink)
    assert_rel(piston["delta_a_C"], omega**2 * np.sign(R) * dR, "delta_a_C (3)", mask=~kink)
    assert_rel(piston["a_C"], np.abs(R) * eps + omega**2 * np.sign(R) * dR, "a_C (3)", mask=~kink)


def test_slider_crank_torque_against_eq16(slider_crank):
    """T_S = T_Su + I_zS eps_S - dT_S (16) from the geometry in plain numpy, eta = 1:
    the gas force F_C = 2000 N pushes the piston down, so the power needed against it is
    F_C v_Cy: F_C^v = F_C sign(R) (component of -F along v_C), T_Su = F_C^v R_z = F_C R (11);
    dT_S = -1/2 omega^2 dI_zS/dalpha (15).  Also the expanded last line of (10)."""
    scene, res, p = slider_crank
    r, l, m, FC = p["r"], p["l"], p["mC"], p["FC"]
    omega, eps = drive_motion(scene)
    a = res.columns["s"]
    R, dR = R_corrected(a, r, l), dR_corrected(a, r, l)
    kink = np.abs(np.sin(a)) < 1e-12
    T_Su = (FC * np.sign(R)) * np.abs(R)
    I_zS = m * R**2
    dT_S = -0.5 * omega**2 * 2 * m * R * dR
    T_S = T_Su + I_zS * eps - dT_S
    eq10 = FC * R + m * R**2 * eps + m * omega**2 * R * dR  # last line of (10), I_C = 0, eta = 1
    assert_rel(eq10, T_S, "(10) vs (16)", rtol=1e-13, mask=~kink)
    assert_rel(res.columns["static_load"], T_Su, "T_Su (11)", mask=~kink)
    assert_rel(res.columns["inertia_term"], I_zS * eps, "I_zS eps_S", mask=~kink)
    assert_rel(res.columns["velocity_term"], dT_S, "dT_S (15)", mask=~kink)
    assert_rel(res.columns["drive"], T_S, "T_S (16)", mask=~kink)
    scale = np.max(np.abs(T_S))
    for key in ("static_load", "inertia_term", "velocity_term", "drive"):
        assert np.all(np.abs(res.columns[key][kink]) <= 1e-14 * scale), key


# ---------------------------------------------------------------------------------------------
# Jib, section 3.5
# ---------------------------------------------------------------------------------------------
JIB_PATH = PROBLEMS / "seed1_jib.toml"


@pytest.fixture(scope="module")
def jib():
    scene = load(JIB_PATH)
    return scene, analyse(scene), scene.parameter_values()


def cos_beta(x, e, b):
    """The angle at the cylinder base D between D->A and D->B (law of cosines)."""
    return (x**2 + e**2 - b**2) / (2 * e * x)


def i_v_39(x, e, b, l):
    return e / l * np.sqrt(1 - cos_beta(x, e, b) ** 2)


def di_v_40(x, e, b, l):
    return -(e**2 / l**2) * (x**4 - (e**2 - b**2) ** 2) / (4 * e**2 * x**3 * e / l * np.sqrt(1 - cos_beta(x, e, b) ** 2))


def m_zS_41(x, e, b, l, m):
    return m * l**2 * 4 * x**2 / (4 * e**2 * x**2 - (x**2 + e**2 - b**2) ** 2)


def dm_zS_42(x, e, b, l, m):
    return 0.5 * m * l**2 / e**4 * (x**4 - (e**2 - b**2) ** 2) / (x**3 * (1 - cos_beta(x, e, b) ** 2) ** 2)


def jib_x(theta, e, b, psi):
    """x = |DB| with D = e (cos psi, sin psi), B = b (cos theta, sin theta)."""
    return np.sqrt((b * np.cos(theta) - e * np.cos(psi)) ** 2 + (b * np.sin(theta) - e * np.sin(psi)) ** 2)


def jib_theta(x, e, b, psi):
    """The jib angle for a cylinder length x: theta = psi + gamma, gamma = angle DAB."""
    return psi + np.arccos((e**2 + b**2 - x**2) / (2 * e * b))


def test_jib_stroke_is_the_seeds(jib):
    """x runs over 2.2 .. 3.2 m (the seed's Figs. 13-16), monotonically."""
    scene, res, p = jib
    x = res.columns["q"]
    assert abs(x[0] - 2.2) < 1e-12 and abs(x[-1] - 3.2) < 1e-12
    assert np.all(np.diff(x) > 0)
    np.testing.assert_allclose(x, jib_x(res.columns["s"], p["e"], p["b"], p["psi"]), rtol=1e-14)
    np.testing.assert_allclose(jib_theta(x, p["e"], p["b"], p["psi"]), res.columns["s"], rtol=0, atol=1e-12)


def test_eqs_39_to_42_by_independent_derivation(jib):
    """(39): i_v = v_S/v_C = (dx/dtheta)/l by complex step of x(theta); (40), (42): complex
    step of (39), (41); (41) = m_C / i_v^2."""
    _, _, p = jib
    e, b, l, m, psi = p["e"], p["b"], p["l"], p["mC"], p["psi"]
    theta = np.linspace(0.0, 0.9, 61)
    x = jib_x(theta, e, b, psi)
    i_v_geometry = complex_step(lambda t: jib_x(t, e, b, psi), theta) / l
    assert_rel(i_v_39(x, e, b, l), i_v_geometry, "(39) vs (dx/dtheta)/l", rtol=1e-13)
    xs = np.linspace(2.2, 3.2, 61)
    assert_rel(di_v_40(xs, e, b, l), complex_step(lambda y: i_v_39(y, e, b, l), xs), "(40)", rtol=1e-12)
    assert_rel(m_zS_41(xs, e, b, l, m), m / i_v_39(xs, e, b, l) ** 2, "(41)", rtol=1e-13)
    assert_rel(dm_zS_42(xs, e, b, l, m), complex_step(lambda y: m_zS_41(y, e, b, l, m), xs), "(42)", rtol=1e-12)


def test_eq24_needs_di_v_dx(jib):
    """a_C^v = a_S/i_v - v_S^2/i_v^2 di_v/dx equals the tangential acceleration l theta_dd of
    the tip; the printed di_v/dt (= di_v/dx v_S) in its place gives another number."""
    _, _, p = jib
    e, b, l, psi = p["e"], p["b"], p["l"], p["psi"]
    v_S, a_S = 0.1, 0.2
    theta = np.linspace(0.06, 0.77, 41)
    x = jib_x(theta, e, b, psi)
    x_t = complex_step(lambda t: jib_x(t, e, b, psi), theta)  # dx/dtheta
    x_tt = complex_step(lambda t: e * b * np.sin(t - psi) / jib_x(t, e, b, psi), theta)  # d2x/dtheta2
    assert_rel(x_t, e * b * np.sin(theta - psi) / x, "dx/dtheta", rtol=1e-13)
    theta_d = v_S / x_t
    theta_dd = (a_S - x_tt * theta_d**2) / x_t
    a_tip = l * theta_dd  # |v_C| = l theta_d > 0
    iv, div = i_v_39(x, e, b, l), di_v_40(x, e, b, l)
    assert_rel(a_S / iv - v_S**2 / iv**2 * div, a_tip, "corrected (24)", rtol=1e-12)
    printed = a_S / iv - v_S**2 / iv**2 * (div * v_S)
    assert np.all(np.abs(printed - a_tip) > 1e-3 * np.abs(a_tip))


def test_jib_ratios_against_AD(jib):
    """i_v (39), di_v/dx (40), m_zS (41), dm_zS/dx (42), a_C0, delta_a_C, a_C (24), eta = 1."""
    scene, res, p = jib
    e, b, l, m = p["e"], p["b"], p["l"], p["mC"]
    x = res.columns["q"]
    body = res.bodies["load"]
    assert_rel(body["i_v"], i_v_39(x, e, b, l), "i_v (39)")
    assert_rel(body["di_v_dq"], di_v_40(x, e, b, l), "di_v/dx (40)")
    assert_rel(res.columns["reduced_inertia"], m_zS_41(x, e, b, l, m), "m_zS (41)")
    assert_rel(res.columns["reduced_inertia_dq"], dm_zS_42(x, e, b, l, m), "dm_zS/dx (42)")
    v_S, a_S = drive_motion(scene)
    iv, div = i_v_39(x, e, b, l), di_v_40(x, e, b, l)
    assert_rel(body["a_C0"], a_S / iv, "a_C0 (24)")
    assert_rel(body["delta_a_C"], -v_S**2 / iv**2 * div, "delta_a_C (24) with di_v/dx")
    assert_rel(body["a_C"], a_S / iv - v_S**2 / iv**2 * div, "a_C (24)")


def test_jib_force_against_eq37(jib):
    """F_S = F_Su + m_zS a_S - dF_S (37), eta = 1, from the geometry in plain numpy: the weight
    m_C g resists the tip's upward motion, F_C^v = m_C g cos theta (the tip moves along
    (-sin theta, cos theta)), F_Su = F_C^v / i_v (32); dF_S = -1/2 v_S^2 dm_zS/dx (36).
    Also the expanded last line of (31) with di_v/dx."""
    scene, res, p = jib
    e, b, l, m, psi = p["e"], p["b"], p["l"], p["mC"], p["psi"]
    v_S, a_S = drive_motion(scene)
    g = constant_value(scene.gravity.g, p, "g")
    x = res.columns["q"]
    theta = jib_theta(x, e, b, psi)
    iv, div = i_v_39(x, e, b, l), di_v_40(x, e, b, l)
    F_Su = m * g * np.cos(theta) / iv
    m_zS, dm_zS = m_zS_41(x, e, b, l, m), dm_zS_42(x, e, b, l, m)
    dF_S = -0.5 * v_S**2 * dm_zS
    F_S = F_Su + m_zS * a_S - dF_S
    eq31 = F_Su + m / iv**2 * a_S - m * v_S**2 / iv**3 * div  # last line of (31), I_C = 0
    assert_rel(eq31, F_S, "(31) vs (37)", rtol=1e-13)
    assert_rel(res.columns["static_load"], F_Su, "F_Su (32)")
    assert_rel(res.columns["inertia_term"], m_zS * a_S, "m_zS a_S (33)")
    assert_rel(res.columns["velocity_term"], dF_S, "dF_S (36)")
    assert_rel(res.columns["drive"], F_S, "F_S (37)")
    assert_rel(res.columns["power"], F_S * v_S, "P_in = F_S v_S (28)")


# ---------------------------------------------------------------------------------------------
# a_C^v = d|v_C|/dt (eqs. 3, 24) whichever way the drive runs
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("path,body,point", [(SC_PATH, "piston", "C"), (JIB_PATH, "load", "C")])
@pytest.mark.parametrize("direction", [1.0, -1.0])
def test_a_C_is_the_tangential_acceleration(path, body, point, direction):
    """The seed's a_C^v is the rate of change of |v_C|: (v_C . a_C)/|v_C| from the point's
    velocity and acceleration (optdesign.kinematics), also with the drive running backwards
    (where the naive R_z eps_S + omega_S^2 dR_z/dalpha has the wrong sign).  Samples where
    v_C = 0 to round-off (the piston's dead centres) are skipped: |v_C| has a kink there."""
    scene = load(path)
    speed, acc = drive_motion(scene)
    scene = dataclasses.replace(scene, drive=dataclasses.replace(scene.drive, speed=direction * speed))
    res, kin = analyse(scene), kinematics(scene)
    C = kin.points[point]
    v = np.hypot(C["vx"], C["vy"])
    moving = v > 1e-12 * v.max()
    tangential = (C["vx"] * C["ax"] + C["vy"] * C["ay"])[moving] / v[moving]
    assert_rel(res.bodies[body]["a_C"][moving], tangential, f"a_C, drive speed {direction * speed}")
