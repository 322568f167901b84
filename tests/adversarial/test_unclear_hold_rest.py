"""A hold's rest test is judged on the cycle's own motion (the kinetic energy left at the hold
against the cycle's peak before it), not on t_end or the tolerance: raising ``[simulation]
t_end`` made a valid cycle fail "the phases do not connect: a hold keeps the mechanism at rest,
but it is moving (dphi/dt = -6.3e-08)", because the test compared the speed with stroke / t_end.
A cycle that ends before t_end does not depend on t_end (its phases' times and integrals are
the same); a hold after a phase that leaves the mechanism moving is still refused."""
from __future__ import annotations

import json

import pytest

import optdesign
from optdesign.dynamics.simulator import simulate
from optdesign.errors import SceneError

from .util import PROBLEMS, ROOT

PRESS = PROBLEMS / "press_servo_cycle.toml"


def _press(t_end):
    design = json.loads((ROOT / "results" / "press_servo_cycle" / "result.json").read_text())["design"]
    text = PRESS.read_text()
    assert "\nt_end = 3.0\n" in text
    return optdesign.loads(text.replace("\nt_end = 3.0\n", f"\nt_end = {t_end}\n")).with_parameters(**design)


@pytest.fixture(scope="module")
def shipped():
    return simulate(_press(3.0))


@pytest.mark.parametrize("t_end", [80.0, 1e5])
def test_a_longer_t_end_leaves_the_cycle_as_it_was(shipped, t_end):
    result = simulate(_press(t_end))
    assert [p["name"] for p in result.phases] == ["forming stroke", "return stroke", "dwell"]
    for mine, ref in zip(result.phases, shipped.phases):
        assert mine["t_start"] == pytest.approx(ref["t_start"], rel=1e-6, abs=1e-9)
        assert mine["t_end"] == pytest.approx(ref["t_end"], rel=1e-6)
        for name, value in ref["integrals"].items():
            assert mine["integrals"][name] == pytest.approx(value, rel=1e-4, abs=1e-6 * abs(value) + 1e-9), name


def test_a_hold_after_a_phase_that_leaves_the_mechanism_moving_is_refused():
    text = PRESS.read_text()
    # the forming stroke cut short by time, in the middle of its motion, then the dwell
    phases = text[text.index("[[simulation.phases]]"):]
    cut = text[:text.index("[[simulation.phases]]")] + (
        '[[simulation.phases]]\nname = "forming stroke"\ncase = "forming stroke"\n'
        'controller = { gain = 2000, position_gain = 100 }\nuntil = { time = 0.3 }\n\n'
        '[[simulation.phases]]\nname = "dwell"\nhold = "brake"\nuntil = { time = 0.4 }\n')
    assert "dwell" in phases
    design = json.loads((ROOT / "results" / "press_servo_cycle" / "result.json").read_text())["design"]
    scene = optdesign.loads(cut).with_parameters(**design)
    with pytest.raises(SceneError, match=r"'dwell': the phases do not connect: a hold keeps the mechanism at rest, but "
                                         r"it is moving at t = 0.3 s \(phi = .*dphi/dt = .*; its kinetic energy is "
                                         r"[0-9.e-]+ of the cycle's peak before it\)"):
        simulate(scene)
