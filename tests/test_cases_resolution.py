"""Next to a lock-up: a load case's integrals over time are the stroke's, although its samples do not resolve
them (issue 27: adaptive quadrature, model/time_integrals.py; before, the rule on the samples was reported, and
said to be unresolved).

The lift table of tests/data/usertrial (a crank and rod lifting a platform along a stated
trapezoidal motion, swept by the platform's height y) next to its lock-up: crank and rod nearly
in line at the top of the stroke, where the crank turns ever faster for the same motion of the
platform.  There the energy of the raise on the scene's 101 samples came out as 50 J where the
stroke needs about 500 J, with nothing said.  The reference is an identity: with efficiency 1
and a motion from rest to rest, the energy at the drive over a stroke is the change of the
bodies' potential energy, computed here from the geometry with numpy."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import optdesign
from optdesign.report.cases import cases_table

LIFT = Path(__file__).resolve().parent / "data" / "usertrial" / "lift_table.toml"
G, LR, MASSES = 9.81, 0.45, {"platform": 210.0, "rod": 4.0, "crank": 3.0}


def scene(r, e):
    text = LIFT.read_text().replace("efficiency = 0.85", "efficiency = 1.0")
    assert "efficiency = 1.0" in text
    return optdesign.loads(text, "lift_table.toml").with_parameters(r=r, e=e)


def potential(r, e, y):
    """Sum of m g y_com of the platform (its centre 0.1 above C), the rod (mid A-C) and the
    crank (mid O-A), with A the crank pin: |A| = r, |A - C| = Lr, to the right of O -> C."""
    c = np.array([e, y])
    d = np.linalg.norm(c)
    a = (r**2 - LR**2 + d**2) / (2 * d)
    h = np.sqrt(r**2 - a**2)
    u = c / d
    right = np.array([u[1], -u[0]])           # u turned clockwise
    pin = a * u + h * right
    return G * (MASSES["platform"] * (y + 0.1) + MASSES["rod"] * (pin[1] + y) / 2 + MASSES["crank"] * pin[1] / 2)


def test_away_from_the_lock_up_the_energy_is_the_potential_energy_and_nothing_is_said():
    r, e = 0.14, 0.0
    result = optdesign.analyse(scene(r, e))
    cases = result.cases
    rise = potential(r, e, 0.55) - potential(r, e, 0.35)
    raise_, lower = cases.cases["raise"].integrals, cases.cases["lower"].integrals
    assert raise_["energy"] == pytest.approx(rise, rel=1e-3)
    assert lower["energy"] == pytest.approx(-rise, rel=1e-3)
    assert raise_["unresolved"] == {} and lower["unresolved"] == {}
    assert "not resolved" not in cases_table(result, samples=False)


def test_next_to_the_lock_up_the_energy_is_still_the_stroke_s():
    """Next to the lock-up the rule on the samples (the NLP's, kept as ``sampled``) was 124 % off
    (the energy came out -103 J for a rise of 423 J); the reported energy is the adaptive
    quadrature's (issue 27), the potential energy to round-off, with its error estimate, and
    nothing is said to be unresolved."""
    r, e = 0.105, 0.07433        # |C| at the top = r + Lr to 4e-7: crank and rod all but in line
    assert np.hypot(e, 0.55) - (r + LR) < 1e-6
    result = optdesign.analyse(scene(r, e))
    cases = result.cases
    rise = potential(r, e, 0.55) - potential(r, e, 0.35)
    raise_, lower = cases.cases["raise"].integrals, cases.cases["lower"].integrals
    assert abs(raise_["sampled"]["energy"] - rise) > 0.2 * rise          # the samples' value is not the stroke's
    assert raise_["energy"] == pytest.approx(rise, rel=1e-9)
    assert lower["energy"] == pytest.approx(-rise, rel=1e-9)
    assert 0 < raise_["errors"]["energy"] < 1e-9 * rise
    assert raise_["unresolved"] == {} and lower["unresolved"] == {}
    assert "not resolved" not in cases_table(result, samples=False)


def test_more_samples_resolve_it():
    r, e = 0.105, 0.0743         # a little further from the lock-up
    rise = potential(r, e, 0.55) - potential(r, e, 0.35)
    cases = optdesign.analyse(scene(r, e), 2001).cases
    raise_ = cases.cases["raise"].integrals
    assert raise_["unresolved"] == {}
    assert raise_["energy"] == pytest.approx(rise, rel=2e-3)


def test_an_optimum_next_to_the_lock_up_reports_the_stroke_s_energy():
    """optimise's summary and JSON at an optimum next to the lock-up (the result of a 1-start
    run with its design moved there, as the lift table without its crank-rod angle constraint
    reaches: a 20-start run takes half a minute): the duty cycle's energy is the quadrature's,
    the potential energy's change over the raise and the lower (0 to round-off)."""
    import dataclasses

    from optdesign.report.design import optimisation_json, summary

    result = optdesign.optimise(scene(0.14, 0.0), starts=1, workers=1)
    assert "not resolved" not in summary(result)
    assert optimisation_json(result)["cases"]["unresolved"] == {}
    near = dataclasses.replace(result, design={"r": 0.105, "e": 0.07433})
    assert "not resolved" not in summary(near)
    out = optimisation_json(near)["cases"]
    assert out["unresolved"] == {}
    rise = potential(0.105, 0.07433, 0.55) - potential(0.105, 0.07433, 0.35)
    assert abs(out["duty"]["energy"]) < 1e-9 * rise and out["duty"]["errors"]["energy"] < 1e-9 * rise


def lift_drive(t, r, e, lowering, eta=0.85):
    """Crank torque and speed of the lift table at times t of its stroke, written apart from
    optdesign: the crank angle th is the coordinate (y(th) stays smooth through the toggle, dy/dth
    is hand-derived), T = c (M th'' + M'(th) th'^2 / 2 + V'(th)), c = 1/eta when the drive gives
    power and eta when it takes it; th' = y'/y_th, th'' = (y'' - y_thth th'^2)/y_th."""
    ta, total = 0.4, 2.4                                      # 0.1 m/s at 0.25 m/s^2 over 0.2 m
    s = np.where(t < ta, 0.125 * t**2, np.where(t < total - ta, 0.1 * t - 0.02,
                                                0.2 - 0.125 * (total - t) ** 2))
    sd = np.where(t < ta, 0.25 * t, np.where(t < total - ta, 0.1, 0.25 * (total - t)))
    sdd = np.where(t < ta, 0.25, np.where(t < total - ta, 0.0, -0.25))
    y, yd, ydd = (0.55 - s, -sd, -sdd) if lowering else (0.35 + s, sd, sdd)
    d = np.hypot(e, y)                                        # A on the right of O -> C
    a = (r * r - LR * LR + d * d) / (2 * d)
    h = np.sqrt(r * r - a * a)
    th = np.arctan2((a * y - h * e) / d, (a * e + h * y) / d)
    c, sn = np.cos(th), np.sin(th)
    q, q1, q2 = e - r * c, r * sn, r * c                      # C - A = (q, s)
    s0 = np.sqrt(LR**2 - q * q)
    s1 = -q * q1 / s0
    s2 = -(q1 * q1 + q * q2 + s1 * s1) / s0
    y1, y2 = r * c + s1, -r * sn + s2
    p1, p2 = (q * s1 - s0 * q1) / LR**2, (q * s2 - s0 * q2) / LR**2     # the rod's angle
    mp, mr, mc = MASSES["platform"], MASSES["rod"], MASSES["crank"]
    M = mp * y1**2 + mr * ((r * sn) ** 2 + (r * c + y1) ** 2) / 4 + mr * LR**2 / 12 * p1**2 \
        + mc * r * r / 3
    dM = 2 * mp * y1 * y2 + mr * (r * r * sn * c + (r * c + y1) * (y2 - r * sn)) / 2 \
        + mr * LR**2 / 6 * p1 * p2
    dV = G * (mp * y1 + mr * (r * c + y1) / 2 + mc * r * c / 2)
    w = yd / y1
    ideal = M * (ydd - y2 * w * w) / y1 + dM * w * w / 2 + dV
    return np.where(ideal * w >= 0, 1 / eta, eta) * ideal, w


def lift_peaks(r, e):
    """The largest |crank torque| and |crank speed| of raise and lower, on a dense grid in time
    refined geometrically towards both ends (where the toggle is)."""
    ends = np.logspace(-11, -1, 400)
    t = np.unique(np.concatenate([np.linspace(0, 2.4, 60001), ends, 2.4 - ends, [2.0, 0.4]]))
    raise_, lower = lift_drive(t, r, e, False), lift_drive(t, r, e, True)
    return (max(np.abs(raise_[0]).max(), np.abs(lower[0]).max()),
            max(np.abs(raise_[1]).max(), np.abs(lower[1]).max()))


def test_without_its_angle_constraint_the_lift_table_optimises_into_the_lock_up():
    """Without its crank-rod angle constraint the lift table's optimum sits at the lock-up:
    r at its bound 0.105 and |C| at the top of the stroke = r + Lr to about 3e-8 (the toggle at
    the stroke's end).  That is a real optimum, not an artefact: at the toggle the crank speed
    y'/y_th stays finite as the platform decelerates to rest and the static torque goes to zero;
    the peak torque (mid-stroke, 261.73 N m) falls slowly as e grows, until the torque spike at
    the stroke's end (60 N m here, 336 N m at margin 1e-9) overtakes it.  Checked against the
    numpy model above: the certified peak and the crank speed's extremes to 1e-6, and no
    assembling design nearby is better by more than that.  (It used to end in
    Invalid_Number_Detected; the certified integrals and peaks now carry it through.)"""
    text = LIFT.read_text()
    cut = text.index('[[constraints]]\nname = "crank-rod angle"')
    text = text[:cut] + text[text.index("[objective]"):]
    result = optdesign.optimise(optdesign.loads(text, "lift_table.toml"), starts=1, workers=1)
    assert result.success, result.message
    r, e = result.design["r"], result.design["e"]
    assert abs(np.hypot(e, 0.55) - (r + LR)) < 1e-6            # at the lock-up
    peak, speed = lift_peaks(r, e)
    assert result.peak_certified == pytest.approx(peak, rel=1e-6)
    assert result.objective == result.peak_certified
    for name, limits in result.constraints.items():
        if name.startswith("crank speed"):
            assert max(abs(limits["min"]), abs(limits["max"])) <= 2.5
            assert max(abs(limits["min"]), abs(limits["max"])) == pytest.approx(speed, rel=1e-6)
    assert speed < 2.5
    e_top = np.sqrt((r + LR) ** 2 - 0.55**2)                 # the largest e that assembles
    for dr, de in [(0, -1e-6), (0, -1e-4), (0, -1e-3), (1e-4, 0), (1e-3, 0), (1e-3, -1e-3)]:
        rn = r + dr
        en = min(e + de, np.sqrt((rn + LR) ** 2 - 0.55**2) - 1e-7)
        assert lift_peaks(rn, en)[0] >= result.objective * (1 - 1e-6), (rn, en)
    assert e <= e_top
