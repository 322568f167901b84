"""Wrong answers presented as right: a NaN or inf anywhere in an analysis (model column,
per-sample or per-stroke constraint, peak) is an error naming the quantity, the first stroke
position and, where it is one, the point, body value or drive points that cause it (exit 2; a
study marks the case failed with that message); unphysical bodies are refused at load time."""
from __future__ import annotations

import json
import re

import numpy as np
import pytest

import optdesign
from optdesign.cli.main import main
from optdesign.errors import ResultError, SceneError
from optdesign.study import Study, values

from .util import JIB, JIB_DESIGN, PROBLEMS

TEXT = JIB.read_text()
CRANK = PROBLEMS / "seed1_slider_crank.toml"


def jib(old, new):
    assert old in TEXT
    return optdesign.loads(TEXT.replace(old, new), "jib.toml")


FIRST = "at theta = 0.0533310105 (sample 1 of 201)"


@pytest.mark.parametrize("old, new, message", [
    ('mass = "mC"', 'mass = "mC*sqrt(theta - 0.5)"',
     f"the reduced inertia (reduced_inertia) is NaN {FIRST}; the first of the scene's values that is not finite "
     "there: [[bodies]] load mass = NaN"),
    ('com = ["l", 0]', 'com = ["1/(theta - theta)", 0]',
     f"the reduced inertia (reduced_inertia) is +inf {FIRST}; the first of the scene's values that is not finite "
     "there: [[bodies]] load com (x) = +inf"),
    ('B = { polar = ["A", "b", "theta"] }', 'B = { polar = ["A", "b*sqrt(theta - 0.5)", "theta"] }',
     f"the drive coordinate q (q) is NaN {FIRST}; the first of the scene's values that is not finite there: "
     "point B (x) = NaN"),
    ('expr = "angle(D, B, A)"', 'expr = "acos(2) + angle(D, B, A)"',
     f"constraint 'transmission angle' is NaN {FIRST}: its expression is not defined there (acos or asin of a "
     "value outside [-1, 1]"),
    ('mass = "mC"', 'mass = "mC*(theta - 0.5)"',
     "the reduced inertia (reduced_inertia) is negative, {neg}, " + FIRST + ": a body's mass or inertia is "
     "negative there (they must be > 0)"),
])
def test_nan_inf_or_a_negative_inertia_in_an_analysis_is_an_error_naming_it(old, new, message):
    if "{neg}" in message:   # the reduced inertia is linear in the mass: the clean jib's times (theta - 0.5)/1
        clean = optdesign.analyse(optdesign.load(JIB))
        s0 = clean.columns["s"][0]
        message = message.format(neg=f"{clean.columns['reduced_inertia'][0] * (s0 - 0.5):.6g}")
    with pytest.raises(ResultError) as info:
        optdesign.analyse(jib(old, new))
    assert str(info.value).startswith(f"jib.toml: {message}"), str(info.value)


def test_nan_only_on_the_later_part_of_the_stroke_names_the_first_bad_sample():
    scene = jib('mass = "mC"', 'mass = "mC*sqrt(0.5 - theta)"')
    with pytest.raises(ResultError, match=r"is NaN at theta = 0\.50[0-9]+ \(sample (\d+) of 201\)") as info:
        optdesign.analyse(scene)
    i = int(re.search(r"sample (\d+) of", str(info.value)).group(1)) - 1
    s = np.linspace(0.053331010512329025, 0.776279030740378, 201)
    assert s[i] > 0.5 and s[i - 1] <= 0.5                   # the first sample past theta = 0.5


def test_a_crank_of_zero_length_names_the_drive_points():
    with pytest.raises(ResultError, match=r"the ratio k = dq/ds \(k\) is NaN at alpha = 0 \(sample 1 of 721\); the "
                                          r"drive's points S and A coincide there, so the drive's angle has no "
                                          r"derivative"):
        optdesign.analyse(optdesign.load(CRANK, {"r": 0}))


@pytest.mark.parametrize("flag", [[], ["--json"]])
def test_the_command_line_exits_2_and_prints_no_table(tmp_path, capsys, flag):
    path = tmp_path / "nan.toml"
    path.write_text(TEXT.replace('mass = "mC"', 'mass = "mC*sqrt(theta - 0.5)"'))
    assert main(["analyse", str(path), *flag]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert f"optdesign analyse: error: {path}: the reduced inertia (reduced_inertia) is NaN {FIRST}" in captured.err


def test_a_study_marks_the_case_failed_with_the_message(tmp_path):
    text = TEXT.replace("mC = 500.0", "mC = 500.0\nlim = 0.0").replace('mass = "mC"', 'mass = "mC*sqrt(theta - lim)"')
    scene = optdesign.loads(text, "jib.toml")
    result = Study(scene, [values("lim", [0.0, 0.5])], mode="analyse").run(out=tmp_path, workers=1, figures=False)
    ok, bad = result.rows
    assert ok["success"] and ok["peak:drive"] == pytest.approx(optdesign.analyse(scene).peaks["drive"], rel=1e-12)
    assert not bad["success"]
    assert bad["status"].startswith("error: jib.toml: the reduced inertia (reduced_inertia) is NaN at theta = ")
    assert "[[bodies]] load mass = NaN" in bad["status"]
    summary = (tmp_path / "summary.txt").read_text()
    assert "1 successful, 1 failed" in summary


def test_a_clean_scene_keeps_its_right_answer():
    """The checks change nothing that is finite: seed 1's jib, 13,706.3 N at the default samples
    (analyse(scene, 1) used to give 13,256.6 N; it is refused now)."""
    result = optdesign.analyse(optdesign.load(JIB))
    assert result.peaks["drive"] == pytest.approx(13706.3, abs=0.05)
    assert json.loads(json.dumps(result.peaks))["drive"] == result.peaks["drive"]


# --- physical validation at load time ---------------------------------------------------------------
@pytest.mark.parametrize("old, new, message", [
    ('mass = "mC"', 'mass = "-mC"', "line 29: [[bodies]] 'load', mass: expected a mass >= 0 [kg], found -500 "
                                   "(-mC at the parameters' values)"),
    ('mass = "mC"', 'mass = -1e-9', "mass: expected a mass >= 0 [kg], found -1e-09"),
    ('mass = "mC"', 'mass = "mC"\ninertia = -3', "line 30: [[bodies]] 'load', inertia: expected a moment of "
                                                "inertia >= 0 [kg m^2], found -3"),
    ('frame = ["A", "B"]', 'frame = ["A", "A"]', "line 28: [[bodies]] 'load', frame: ['A', 'A'] names one point "
                                                "twice: expected two distinct points"),
])
def test_unphysical_bodies_are_refused_at_load_time(old, new, message):
    with pytest.raises(SceneError) as info:
        jib(old, new)
    assert message in str(info.value), str(info.value)


def test_an_override_that_makes_a_mass_negative_is_refused(capsys):
    with pytest.raises(SceneError, match=r"\[\[bodies\]\] 'load', mass: expected a mass >= 0 \[kg\], found -5 "):
        optdesign.load(JIB, {"mC": -5})
    assert main(["analyse", str(JIB), "--set", "mC=-5"]) == 2
    assert "mass: expected a mass >= 0 [kg], found -5" in capsys.readouterr().err


def test_a_massless_body_is_allowed():
    """0 is a massless body (a study sweeping a mass from 0 needs it): its terms vanish."""
    result = optdesign.analyse(optdesign.load(JIB, {"mC": 0}))
    assert result.peaks["drive"] == 0.0
