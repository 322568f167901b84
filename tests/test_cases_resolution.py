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


def test_a_run_that_fails_at_the_lock_up_says_where():
    """Without its crank-rod angle constraint the lift table's objective pulls the design into
    the lock-up, where IPOPT meets numbers that are not finite: the error says which
    construction is at its limit and what to add (it said only 'Invalid_Number_Detected ... try
    more starts').  The end design's lock-up is checked with numpy: |C| at the top of the
    stroke equals r + Lr."""
    text = LIFT.read_text()
    cut = text.index('[[constraints]]\nname = "crank-rod angle"')
    text = text[:cut] + text[text.index("[objective]"):]
    result = optdesign.optimise(optdesign.loads(text, "lift_table.toml"), starts=1, workers=1)
    assert not result.success and "Invalid_Number_Detected" in result.status
    assert "assembly of A (margin" in result.message and "lock-up" in result.message
    end = result.starts[0].end
    assert abs(np.hypot(end["e"], 0.55) - (end["r"] + LR)) < 1e-6
