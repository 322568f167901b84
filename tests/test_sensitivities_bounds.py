"""Issue 27: sensitivities of every parameter that enters the problem.  A parameter named in a
constraint's bound enters the NLP only as a number in its row bounds, which IPOPT's multipliers
of the NLP parameters do not see: its share is the bound's multiplier times d bound / d
parameter (checked against a central difference of re-optimised optima).  A parameter that
load cases set has a note saying which cases its sensitivity holds (none: no sensitivity)."""
from __future__ import annotations

from pathlib import Path

import optdesign
from optdesign.design.problem import DesignProblem
from optdesign.design.sensitivities import sensitivity_notes

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "tests" / "data" / "issue27" / "crank_rocker_mu.toml"


def test_sensitivity_of_a_parameter_in_a_bound_is_the_finite_difference_of_optima():
    """A fixed parameter named in a constraint's bound (here the ground d, also in the
    geometry, and k0, only in the bound): d objective / d parameter = IPOPT's multiplier of the
    NLP parameter plus the bound's multiplier times d bound / d parameter, against a central
    difference of re-optimised optima.  Before, the bound's share was missing (k0 read 0)."""
    text = SCENE.read_text().replace('expr = "min(angle(A, B, B0) - mu)"\nmin = 0',
                                     'expr = "min(angle(A, B, B0) - mu)"\nmin = "k0*d"')
    text = text.replace("d  = 0.12\n", "d  = 0.12\nk0 = 0.5\n")
    assert "k0*d" in text
    scene = optdesign.loads(text, path="crank_rocker_bound.toml")
    result = optdesign.optimise(scene, starts=1)
    assert result.success and result.constraints["transmission angle above mu"]["active"] == "lower"
    for name, h in (("d", 1e-5), ("k0", 1e-4)):
        base = {"d": 0.12, "k0": 0.5}[name]
        ends = [optdesign.optimise(scene.with_parameters(**{name: base + sign * h}), starts=1).objective
                for sign in (1, -1)]
        difference = (ends[0] - ends[1]) / (2 * h)
        assert abs(result.sensitivities[name] - difference) <= 1e-5 * max(1.0, abs(difference)), name
    assert abs(result.sensitivities["k0"] - 0.12) < 1e-6   # d(-mu*)/dk0 = d: mu* = min angle - k0 d



def test_parameters_that_cases_set_carry_a_note():
    servo = ROOT / "problems" / "press_servo_cycle.toml"
    notes = sensitivity_notes(DesignProblem(optdesign.load(servo)))
    assert list(notes) == ["F0"] and "return stroke" in notes["F0"] and "only the cases" in notes["F0"]
    text = servo.read_text().replace('name = "forming stroke"\n', 'name = "forming stroke"\nset = { F0 = 9e4 }\n', 1)
    assert text.count("set = {") == 2
    notes = sensitivity_notes(DesignProblem(optdesign.loads(text, path="every_case.toml")))
    assert "no sensitivity to it exists" in notes["F0"]
