"""Next to a lock-up: a load case's integrals over time that its samples do not resolve are said, not reported as
the stroke's (model/cases.py ``_unresolved``).

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


def test_next_to_the_lock_up_the_unresolved_energy_is_said():
    r, e = 0.105, 0.07433        # |C| at the top = r + Lr to 4e-7: crank and rod all but in line
    assert np.hypot(e, 0.55) - (r + LR) < 1e-6
    result = optdesign.analyse(scene(r, e))
    cases = result.cases
    rise = potential(r, e, 0.55) - potential(r, e, 0.35)
    raise_ = cases.cases["raise"].integrals
    assert abs(raise_["energy"] - rise) > 0.2 * rise          # the samples' value is not the stroke's ...
    told = raise_["unresolved"]["energy"]                     # ... and it is said, with both values
    assert told["samples"] == 101 and told["half_samples"] == 51 and told["value"] == raise_["energy"]
    assert abs(told["value"] - told["half_value"]) > 0.01 * rise
    text = cases_table(result, samples=False)
    assert text.count("WARNING: not resolved by the samples") == 2   # raise and lower
    assert "use more samples" in text


def test_more_samples_resolve_it():
    r, e = 0.105, 0.0743         # a little further from the lock-up
    rise = potential(r, e, 0.55) - potential(r, e, 0.35)
    cases = optdesign.analyse(scene(r, e), 2001).cases
    raise_ = cases.cases["raise"].integrals
    assert raise_["unresolved"] == {}
    assert raise_["energy"] == pytest.approx(rise, rel=2e-3)


def test_an_optimum_next_to_the_lock_up_says_it_too():
    """optimise's summary and JSON at an optimum whose cases the samples do not resolve (the
    result of a 1-start run with its design moved next to the lock-up, as the lift table
    without its crank-rod angle constraint reaches: a 20-start run takes half a minute)."""
    import dataclasses

    from optdesign.report.design import optimisation_json, summary

    result = optdesign.optimise(scene(0.14, 0.0), starts=1, workers=1)
    assert "not resolved" not in summary(result)
    assert optimisation_json(result)["cases"]["unresolved"] == {}
    near = dataclasses.replace(result, design={"r": 0.105, "e": 0.07433})
    lines = [line for line in summary(near).splitlines() if "not resolved by the samples" in line]
    assert [line.split(":")[0] for line in lines] == ["  case 'raise'", "  case 'lower'"]
    assert set(optimisation_json(near)["cases"]["unresolved"]) == {"raise", "lower"}


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
