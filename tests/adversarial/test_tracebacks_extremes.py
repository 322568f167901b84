"""Tracebacks from extreme numbers (issue 32): every number of the drive-sizing tables ([profiles],
[duty], [gearbox], [[motors]], [cylinder]) is checked for the magnitudes where the computation
stays within a float (1e-50 .. 1e50, besides 0 where 0 is allowed), naming the field; inside that
band the analysis gives finite figures or a scene error, never a traceback.  A parameter override
that is not a number or an expression, and a point that is not defined over part of the stroke
in `kinematics`, are errors naming them."""
from __future__ import annotations

import json
import math
import re

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import optdesign
from optdesign.cli.main import main
from optdesign.errors import OptdesignError, ResultError, SceneError

from .util import JIB, ROOT

BARRIER = (ROOT / "tests" / "data" / "usertrial" / "barrier_gate_motor.toml").read_text()
RAMP = (ROOT / "tests" / "data" / "usertrial" / "loading_ramp_cylinder.toml").read_text()
BAND = "outside 1e-50 .. 1e+50 in magnitude, where the computation's products and powers stay within a float's range"

# (scene text, the text replaced, the new text with {} for the number, the field named)
FIELDS = {
    "jerk": (BARRIER, 'jerk = "1200 deg"', "jerk = {}", "[profiles] close, jerk: expected a jerk > 0"),
    "profile speed": (BARRIER, 'speed = "75 deg"', "speed = {}", "[profiles] close, speed: expected a speed > 0"),
    "gear ratio": (BARRIER, 'ratio = "i"', "ratio = {}", "[gearbox] ratio: expected a gear ratio i = motor speed / "
                                                         "drive speed > 0"),
    "rod": (RAMP, 'rod = "d_rod"', "rod = {}", "[cylinder] rod: expected a rod diameter in m > 0"),
    "bore": (RAMP, "bore = 0.08", "bore = {}", "[cylinder] bore: expected a bore diameter in m > 0"),
    "buckling safety": (RAMP, "buckling_safety = 3.5", "buckling_safety = {}",
                        "[cylinder] buckling_safety: expected buckling safety > 0"),
    "length factor": (RAMP, "length_factor = 1.0", "length_factor = {}",
                      "[cylinder] length_factor: expected length factor > 0"),
    "dwell": (RAMP, "{ dwell = 600 }", "{{ dwell = {} }}", "[duty] cycle[3]: expected a dwell duration in s > 0"),
    "hold": (RAMP, "hold = 60,", "hold = {},", "[duty] cycle[1]: expected a hold duration in s > 0"),
}


def scene_with(field, value):
    text, old, new, _ = FIELDS[field]
    assert old in text
    return optdesign.loads(text.replace(old, new.format(value)), "scene.toml")


def motor_field():
    """The first motor's rated torque of the barrier (a [[motors]] number)."""
    start = BARRIER.index("[[motors]]")
    line = next(line for line in BARRIER[start:].splitlines() if line.startswith("rated_torque"))
    return line


@pytest.mark.parametrize("field, value", [(f, v) for f in sorted(FIELDS) for v in ("1e-300", "1e300")
                                          if (f, v) != ("bore", "1e-300")])   # (a bore below the rod: rod < bore first)
def test_a_number_beyond_the_band_is_refused_naming_the_field(field, value):
    with pytest.raises(SceneError) as err:
        scene_with(field, value)
    assert FIELDS[field][3] in str(err.value) and f"found {float(value):g}, {BAND}" in str(err.value)


@pytest.mark.parametrize("value", ["1e-300", "1e300"])
def test_a_motor_number_beyond_the_band_is_refused(value):
    line = motor_field()
    text = BARRIER.replace(line, f"rated_torque = {value}", 1)
    with pytest.raises(SceneError, match=r"\[\[motors\]\] .*rated_torque: expected a value in N m, continuous "
                                         rf"\(thermal\) > 0, found {re.escape(f'{float(value):g}')}, outside"):
        optdesign.loads(text, "scene.toml")


def test_a_gear_ratio_as_a_design_variable_with_a_bound_beyond_the_band():
    text = BARRIER.replace("i   = { value = 60, min = 10, max = 200 }", "i   = { value = 60, min = 10, max = 1e300 }")
    with pytest.raises(SceneError, match=r"\[parameters\] i, max: the gear ratio's bound: found 1e\+300, outside"):
        optdesign.loads(text, "scene.toml")


@pytest.mark.parametrize("field, value", [("jerk", "1e-300"), ("gear ratio", "1e300"), ("gear ratio", "1e-300"),
                                          ("rod", "1e-300")])
def test_the_command_line_names_the_field_in_one_line(tmp_path, capsys, field, value):
    text, old, new, named = FIELDS[field]
    path = tmp_path / "scene.toml"
    path.write_text(text.replace(old, new.format(value)))
    assert main(["analyse", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"optdesign analyse: error: {path}, line ") and named in err and err.count("\n") == 1


def finite_everywhere(doc) -> bool:
    if isinstance(doc, dict):
        return all(finite_everywhere(v) for v in doc.values())
    if isinstance(doc, list):
        return all(finite_everywhere(v) for v in doc)
    return not isinstance(doc, float) or math.isfinite(doc)


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(field=st.sampled_from(sorted(FIELDS)), exponent=st.integers(-49, 49), mantissa=st.floats(1.0, 9.9))
def test_inside_the_band_the_answer_is_finite_or_an_error_naming_an_item(field, exponent, mantissa):
    value = f"{mantissa:.3f}e{exponent}"
    try:
        scene = scene_with(field, value)
        result = optdesign.analyse(scene, 21)
    except (SceneError, ResultError) as exc:          # e.g. a top speed the stroke cannot reach, a rod >= bore
        assert str(exc) and "Traceback" not in str(exc)
        return
    from optdesign.report.analysis import analysis_json
    from optdesign.report.output import to_json

    cases = result.cases
    assert finite_everywhere(json.loads(to_json(analysis_json(result))))
    assert all(finite_everywhere(r.integrals) for r in cases.cases.values())


# --- overrides that are not values ----------------------------------------------------------------

@pytest.mark.parametrize("value", [None, [1.0], True, {"a": 1}])
def test_an_override_that_is_not_a_number_or_an_expression(value):
    with pytest.raises(TypeError, match=r"^load: overrides: 'mC': expected a number or an expression string \(as "
                                        r"--set mC=VALUE\), found "):
        optdesign.load(JIB, {"mC": value})


def test_with_parameters_none_names_the_parameter():
    with pytest.raises(SceneError, match=r"\[parameters\] mC.*no value: expected"):
        optdesign.load(JIB).with_parameters(mC=None)


def test_numpy_numbers_are_overrides():
    import numpy as np

    a = optdesign.analyse(optdesign.load(JIB, {"mC": np.float64(600.0)}), 21)
    b = optdesign.analyse(optdesign.load(JIB, {"mC": 600}), 21)
    assert a.peaks == b.peaks


# --- kinematics of a point not defined over part of the stroke ----------------------------------------

NAN_B = JIB.read_text().replace('B = { polar = ["A", "b", "theta"] }', 'B = { polar = ["A", "b*sqrt(theta - 0.5)", "theta"] }')


def test_kinematics_of_a_point_not_defined_over_part_of_the_stroke(tmp_path, capsys):
    assert "sqrt(theta - 0.5)" in NAN_B
    path = tmp_path / "jib.toml"
    path.write_text(NAN_B)
    assert main(["kinematics", str(path)]) == 2
    err = capsys.readouterr().err
    # theta runs from 0.0533 over 201 samples: sqrt(theta - 0.5) is NaN below 0.5
    lo, hi = 0.053331010512329025, 0.776279030740378         # [sweep] from, to
    theta = [lo + k * (hi - lo) / 200 for k in range(201)]
    below = sum(t < 0.5 for t in theta)
    assert err.startswith("optdesign kinematics: error: [points] B: its position is not finite at theta = "
                          f"0.0533310105 (sample 1 of 201; {below} of the 201 samples)")
    with pytest.raises(ResultError, match=r"^\[points\] B: its position is not finite"):
        optdesign.kinematics(optdesign.load(path))


def test_kinematics_of_a_velocity_infinite_where_the_stroke_starts():
    # |AB| = b (1 + sqrt(theta - theta_start)): finite, but its rate is infinite at the start
    text = JIB.read_text().replace('B = { polar = ["A", "b", "theta"] }',
                                   'B = { polar = ["A", "b*(1 + sqrt(theta - 0.053331010512329025))", "theta"] }')
    with pytest.raises(ResultError, match=r"^\[points\] B: its velocity is not finite at theta = 0.0533310105 "
                                          r"\(sample 1 of 21; 1 of the 21 samples\)"):
        optdesign.kinematics(optdesign.loads(text, "jib.toml"), 21)


# --- every number of the drive's and the sizing's tables at the extremes ------------------------------

CRANE = (ROOT / "problems" / "crane_luffing_drive.toml").read_text()


def test_gravity_that_overflows_the_rms_names_the_case():
    with pytest.raises(ResultError, match=r"^case '[^']+': the time integral of the drive load squared \(its RMS over "
                                          r"time\) is (\+inf|NaN): the drive load of case '[^']+' reaches .* whose square "
                                          r"exceeds the largest number a float holds"):
        optdesign.analyse(optdesign.loads(re.sub(r"(?m)^g = .*$", "g = 1e300", CRANE), "crane.toml"), 21)


@pytest.mark.parametrize("table", ["drive", "gearbox"])
def test_an_efficiency_beyond_the_band_is_refused(table):
    text = CRANE.split(f"[{table}]", 1)
    head, tail = text[0], re.sub(r"(?m)^efficiency = .*$", "efficiency = 1e-300", text[1], count=1)
    with pytest.raises(SceneError, match=rf"\[{table}\] efficiency: expected 0 < eta <= 1, found 1e-300 \(outside "
                                         r"1e-50 .. 1e\+50 in magnitude"):
        optdesign.loads(head + f"[{table}]" + tail, "crane.toml")


def numbers_of_the_tables(text):
    """(line index, key) of every plain number in the scene's tables but [parameters], [sweep]."""
    table = ""
    for i, line in enumerate(text.split("\n")):
        head = re.match(r"\s*\[+([^\]]+)\]+", line)
        if head:
            table = head.group(1)
        elif table not in ("parameters", "sweep", "reference") and re.match(r"^\w+\s*=\s*-?[0-9.]+(e[-+]?\d+)?\s*(#.*)?$",
                                                                           line, re.I):
            yield i, line.split("=")[0].strip()


@pytest.mark.parametrize("name, text", [("loading_ramp_cylinder", RAMP), ("barrier_gate_motor", BARRIER)])
def test_every_number_of_the_tables_at_the_extremes_is_a_result_or_an_error(name, text):
    lines = text.split("\n")
    found = list(numbers_of_the_tables(text))
    assert len(found) >= 8
    for i, key in found:
        for value in ("1e-300", "1e300", "-1"):
            changed = "\n".join(lines[:i] + [f"{key} = {value}"] + lines[i + 1:])
            try:
                result = optdesign.analyse(optdesign.loads(changed, f"{name}.toml"), 21)
            except OptdesignError:
                continue
            from optdesign.report.analysis import analysis_json
            from optdesign.report.output import to_json

            assert finite_everywhere(json.loads(to_json(analysis_json(result)))), (key, value)


@pytest.mark.parametrize("jerk", ["5.75e10", "1e49"])
def test_a_jerk_whose_phases_are_below_the_time_laws_resolution_is_refused(jerk):
    # the barrier's 'close' reaches 75 deg/s at 180 deg/s^2 in 0.5 s; a jerk phase of a/j = 5e-11 s
    # made coincident sample times (a traceback), one of 3e-49 s an RMS of 4.6e25 N m
    text = BARRIER.replace('jerk = "1200 deg"', f"jerk = {jerk}")
    with pytest.raises(SceneError, match=rf"\[profiles\] close, jerk: the jerk {re.escape(f'{float(jerk):g}')} makes "
                                         r"its jerk phases .* s long, less than 1e-06 of the 0.5 s it takes to reach "
                                         r"the top speed"):
        optdesign.loads(text, "barrier.toml")
