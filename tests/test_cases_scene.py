"""The drive-sizing items of a scene file (issue 16, piece 1): [profiles], [[cases]], [duty],
[gearbox], [[motors]], [cylinder].  They load into the scene's objects, and bad input stops the
load with a message that names the item (file, line, table, key) and what to do.  The numbers
in the messages are checked against closed forms written here."""
import math

import pytest

from optdesign.errors import SceneError
from optdesign.scene import Case, Cylinder, Gearbox, Motor, Profile
from optdesign.scene.file import loads
from optdesign.scene.profiles import profile_shape

CRANE = '''title = "arm on a winch-less crank, three cases"

[parameters]
r = 0.5
m = 1000.0
mL = 500.0
half = "mL/2"
i = { value = 50, min = 5, max = 200 }

[sweep]
name = "theta"
from = "0 deg"
to = "60 deg"
samples = 11

[points]
O = { fixed = [0, 0] }
A = { polar = ["O", "r", "theta"] }

[[bodies]]
name = "arm"
frame = ["O", "A"]
mass = "m + mL"
com = [0.5, 0]

[gravity]
g = 9.81

[drive]
type = "rotary"
crank = ["O", "A"]
speed = 0.1
acceleration = 0
efficiency = 0.9

[profiles.luff]
kind = "trapezoidal"
speed = 0.1
acceleration = 0.05
deceleration = 0.04

[[cases]]
name = "raise rated"
direction = "forward"
set = { mL = 800 }
profile = "luff"

[[cases]]
name = "lower rated"
direction = "reverse"
set = { mL = 800 }
efficiency = "braking"
profile = { kind = "s-curve", speed = 0.1, acceleration = 0.05, deceleration = 0.05, jerk = 0.2 }

[[cases]]
name = "test load"
direction = "forward"
set = { mL = "1.25*800" }

[duty]
cycle = ["raise rated", { hold = 5, case = "raise rated" }, "lower rated", { dwell = 10 }, { case = "test load", repeat = 2 }]

[gearbox]
ratio = "i"
efficiency = 0.95

[[motors]]
name = "small"
inertia = 0.001
rated_torque = 5
peak_torque = 15
max_speed = 300

[[motors]]
name = "large"
inertia = 0.004
rated_torque = 20
peak_torque = 60
max_speed = 300
'''


def mutate(old, new, text=CRANE):
    assert text.count(old) == 1, old
    return text.replace(old, new)


def error(text):
    with pytest.raises(SceneError) as info:
        loads(text, "crane.toml")
    return str(info.value)


def line_of(text, fragment):
    return next(i for i, line in enumerate(text.splitlines(), 1) if fragment in line)


def test_the_items_load():
    scene = loads(CRANE, "crane.toml")
    assert [c.name for c in scene.cases] == ["raise rated", "lower rated", "test load"]
    raise_, lower, test = scene.cases
    assert raise_.profile == "luff" and raise_.sign == 1 and raise_.efficiency == "auto"
    assert lower.sign == -1 and lower.efficiency == "braking" and isinstance(lower.profile, Profile)
    assert lower.profile.kind == "s-curve" and test.profile is None
    assert test.overrides["mL"].source == "1.25*800"
    assert [s.kind for s in scene.duty.steps] == ["case", "hold", "case", "dwell", "case"]
    assert scene.duty.steps[4].repeat == 2 and scene.duty.steps[1].at == "end"
    assert isinstance(scene.gearbox, Gearbox) and [m.name for m in scene.motors] == ["small", "large"]
    assert all(isinstance(m, Motor) for m in scene.motors)


def test_a_scene_without_cases_has_none():
    text = CRANE[:CRANE.index("[profiles.luff]")]
    scene = loads(text)
    assert scene.cases == () and scene.profiles == () and scene.duty is None and scene.gearbox is None


def test_profile_numbers_against_closed_forms():
    L = math.radians(60)
    v, a, d = 0.1, 0.05, 0.04
    shape = profile_shape(Profile("p", "trapezoidal", speed=v, acceleration=a, deceleration=d), {}, L)
    assert shape.time == pytest.approx(v / a + v / d + (L - v**2 / (2 * a) - v**2 / (2 * d)) / v, rel=1e-14)
    # the same trapezoid given by its time: the top speed follows
    shape_t = profile_shape(Profile("p", "trapezoidal", time=shape.time, acceleration=a, deceleration=d), {}, L)
    assert shape_t.speed == pytest.approx(v, rel=1e-12)
    # s-curve: v = 0.1, a = 0.05, j = 0.2 reaches a (a^2/j = 0.0125 < v): phase time v/a + a/j
    sc = profile_shape(Profile("p", "s-curve", speed=v, acceleration=a, deceleration=a, jerk=0.2), {}, L)
    assert sc.accelerate.duration == pytest.approx(v / a + a / 0.2, rel=1e-14)
    assert sc.accelerate.distance == pytest.approx(v * (v / a + a / 0.2) / 2, rel=1e-14)
    # with jerk 0.01 the speed comes first: peak acceleration sqrt(v j) = 0.0316 < a
    low = profile_shape(Profile("p", "s-curve", speed=v, acceleration=a, deceleration=a, jerk=0.01), {}, L)
    assert low.accelerate.peak == pytest.approx(math.sqrt(v * 0.01), rel=1e-14)
    assert low.accelerate.duration == pytest.approx(2 * math.sqrt(v / 0.01), rel=1e-14)


# --- errors that name the item ---
def test_a_case_overriding_an_unknown_parameter_suggests_the_near_miss():
    text = mutate('set = { mL = "1.25*800" }', 'set = { mLL = "1.25*800" }')
    msg = error(text)
    assert f"crane.toml, line {line_of(text, 'mLL')}" in msg
    assert "[[cases]] 'test load', set.mLL: the case overrides an unknown parameter 'mLL'; did you mean 'mL'?" in msg


def test_a_case_overriding_a_design_variable_or_a_derived_parameter():
    assert "'i' is a design variable: the design is the same in every case" in error(
        mutate('set = { mL = "1.25*800" }', 'set = { i = 20 }'))
    assert "'half' is derived from other parameters ('mL/2'); override the parameters it is made of" in error(
        mutate('set = { mL = "1.25*800" }', 'set = { half = 20 }'))
    assert "the case overrides the sweep variable" in error(mutate('set = { mL = "1.25*800" }', 'set = { theta = 1 }'))


def test_a_case_naming_an_unknown_profile():
    msg = error(mutate('profile = "luff"', 'profile = "lufff"'))
    assert "[[cases]] 'raise rated', profile: no profile 'lufff' in [profiles]; did you mean 'luff'?" in msg


def test_a_profile_whose_top_speed_cannot_be_reached():
    text = mutate("speed = 0.1\nacceleration = 0.05\ndeceleration = 0.04", "speed = 0.3\nacceleration = 0.05\ndeceleration = 0.04")
    msg = error(text)
    L, a, d = math.radians(60), 0.05, 0.04
    reach = math.sqrt(2 * L * a * d / (a + d))      # v^2/(2a) + v^2/(2d) = L
    assert f"crane.toml, line {line_of(text, 'speed = 0.3')}: [profiles] luff, speed: the top speed 0.3 cannot be reached" in msg
    assert f"the largest top speed this stroke allows is {reach:.6g}" in msg


def test_an_inline_profile_names_its_case_and_a_stroke_that_is_too_quick():
    msg = error(mutate("jerk = 0.2 }", "jerk = 0.2, time = 3 }"))
    assert "[[cases]] 'lower rated', profile: a 's-curve' profile takes speed, acceleration, deceleration, jerk" in msg
    text = mutate("speed = 0.1\nacceleration = 0.05\ndeceleration = 0.04", "time = 5\nacceleration = 0.05\ndeceleration = 0.04")
    L, c = math.radians(60), 1 / (2 * 0.05) + 1 / (2 * 0.04)
    assert f"it takes at least {2 * math.sqrt(c * L):.6g} s" in error(text)


def test_a_gear_ratio_that_is_not_positive():
    text = mutate('ratio = "i"', "ratio = -2")
    assert (f"crane.toml, line {line_of(text, 'ratio = -2')}: [gearbox] ratio: expected a gear ratio i = motor "
            "speed / drive speed > 0, found -2") in error(text)
    text = mutate("i = { value = 50, min = 5, max = 200 }", "i = { value = 50, min = 0, max = 200 }")
    assert "[parameters] i, min: the gear ratio's lower bound must be > 0, found 0" in error(text)


def test_an_empty_catalogue():
    text = mutate('title = "arm on a winch-less crank, three cases"',
                  'title = "arm on a winch-less crank, three cases"\nmotors = []')
    text = text[:text.index("[[motors]]")]
    msg = error(text)
    assert "the motor catalogue is empty; give at least one [[motors]] entry" in msg
    assert f"line {line_of(text, 'motors = []')}" in msg


def test_motor_and_cylinder_values():
    assert "[[motors]] 'small', peak_torque: the peak torque 4 is below the rated torque 5" in error(
        mutate("peak_torque = 15", "peak_torque = 4"))
    assert "[[motors]] 'large', inertia: expected a value in kg m^2" in error(mutate("inertia = 0.004", "inertia = -1"))
    cylinder = "\n[cylinder]\npressure = 2e7\nmodulus = 2.1e11\nbuckling_safety = 3.5\nlength_factor = 1\n"
    assert "[cylinder]: a cylinder needs a linear [drive]" in error(CRANE + cylinder)
    linear = CRANE[:CRANE.index("[gearbox]")].replace('type = "rotary"\ncrank = ["O", "A"]',
                                                      'type = "linear"\nbetween = ["B", "A"]')
    linear = linear.replace('A = { polar = ["O", "r", "theta"] }', 'A = { polar = ["O", "r", "theta"] }\nB = { fixed = [0.3, -0.4] }')
    assert loads(linear + cylinder).cylinder.rod is None
    assert isinstance(loads(linear + cylinder).cylinder, Cylinder)
    assert "[cylinder] rod: the rod (0.1 m) must be thinner than the bore (0.08 m)" in error(
        linear + cylinder + "rod = 0.1\nbore = 0.08\n")
    assert "[gearbox]: a gearbox needs a rotary [drive]" in error(linear + '[gearbox]\nratio = 2\n')


def test_duty_steps():
    assert "[duty] cycle[2]: no case 'lower rate'; did you mean 'lower rated'?" in error(
        mutate('"lower rated", { dwell', '"lower rate", { dwell'))
    assert "[duty] cycle[3]: expected a dwell duration in s > 0, found -10" in error(mutate("{ dwell = 10 }", "{ dwell = -10 }"))
    assert "[duty] cycle[3]: unknown key 'case' in a dwell step" in error(mutate("{ dwell = 10 }", '{ dwell = 10, case = "x" }'))
    assert "[duty] cycle[4]: repeat: expected a whole number >= 1, found 0" in error(mutate("repeat = 2", "repeat = 0"))


def test_case_keys_and_names():
    assert "[[cases]] 'raise rated', direction: expected 'forward' (from -> to) or 'reverse', found 'up'" in error(
        mutate('direction = "forward"\nset = { mL = 800 }\nprofile = "luff"', 'direction = "up"\nset = { mL = 800 }\nprofile = "luff"'))
    assert "unknown key 'wieght'; did you mean 'weight'?" in error(mutate('set = { mL = "1.25*800" }', 'set = { mL = "1.25*800" }\nwieght = 0.5'))
    assert "the case name 'raise rated' is used twice" in error(mutate('name = "lower rated"', 'name = "raise rated"'))
    assert "[[cases]] 'raise rated', direction: missing key 'direction'" in error(
        mutate('direction = "forward"\nset = { mL = 800 }\nprofile = "luff"', 'set = { mL = 800 }\nprofile = "luff"'))
    msg = error(mutate('kind = "trapezoidal"', 'kind = "trapezoid"'))
    assert "[profiles] luff, kind: expected one of 'constant', 'trapezoidal', 's-curve', 'law', 'cycloidal', " in msg
    assert "'polynomial-4567', 'polynomial', 'segments', 'cycle', found 'trapezoid'; did you mean 'trapezoidal'?" in msg


def test_a_profile_may_not_depend_on_a_design_variable():
    msg = error(mutate("speed = 0.1\nacceleration = 0.05\ndeceleration = 0.04", 'speed = "i/1000"\nacceleration = 0.05\ndeceleration = 0.04'))
    assert "[profiles] luff, speed: 'i/1000' depends on the design variable 'i'" in msg


def test_python_objects_check_alone():
    with pytest.raises(SceneError, match="expected 'auto'"):
        Case("c", "forward", efficiency="sometimes")
    with pytest.raises(SceneError, match="a 'law' profile takes speed; found nothing"):
        Profile("p", "law")


def test_a_weight_beside_a_duty_cycle():
    msg = error(mutate('set = { mL = "1.25*800" }', 'set = { mL = "1.25*800" }\nweight = 0.5'))  # beside [duty]
    assert "[[cases]] 'test load', weight: a weight is the case's share of the cycle without [duty]" in msg
