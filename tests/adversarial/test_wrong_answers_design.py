"""Wrong answers shown as results (issue 32): `--design result.json` that lacks a design variable,
is of another scene, did not succeed, or meets --set on a design variable; a cylinder's rod given
without its bore; a load case whose drive load squares beyond a float; a duty cycle of dwells;
an analyse study of a scene with load cases.  Each is an error or an explicit, printed rule,
never a silent figure."""
from __future__ import annotations

import csv
import json
import math

import pytest

import optdesign
from optdesign.cli.main import main
from optdesign.errors import ResultError, SceneError
from optdesign.model.train import cylinder_sizing
from optdesign.study import Study, values

from .util import JIB, PROBLEMS, ROOT

RESULT = json.loads((ROOT / "results" / "seed1_jib" / "result.json").read_text())   # e = 3, b = 4
RAMP = ROOT / "tests" / "data" / "usertrial" / "loading_ramp_cylinder.toml"
PRESS = PROBLEMS / "press_servo_cycle.toml"


def analysed(capsys, *args):
    code = main(["analyse", str(JIB), "--json", *args])
    out, err = capsys.readouterr()
    return code, (json.loads(out) if code == 0 else None), err


def result_file(tmp_path, **changes):
    path = tmp_path / "result.json"
    path.write_text(json.dumps({**RESULT, **changes}))
    return str(path)


def test_a_design_lacking_a_variable_is_an_error(tmp_path, capsys):
    code, _, err = analysed(capsys, "--design", result_file(tmp_path, design={"e": 3.0}))
    assert code == 2
    assert err == (f"optdesign analyse: error: --design {tmp_path}/result.json: gives no value for the design variable "
                   f"b of {JIB} (it holds e): it is the result of an older version of the scene or of another one; "
                   "optimise again, or give --set b=VALUE\n")


def test_set_gives_what_the_design_lacks(tmp_path, capsys):
    code, by_design, err = analysed(capsys, "--design", result_file(tmp_path, design={"e": 3.0}), "--set", "b=4")
    assert code == 0 and err == ""
    code, by_hand, _ = analysed(capsys, "--set", "e=3", "--set", "b=4")
    assert by_design["peaks"] == by_hand["peaks"]


def test_set_wins_over_the_design_and_says_so(tmp_path, capsys):
    path = result_file(tmp_path)
    code, both, err = analysed(capsys, "--design", path, "--set", "e=2.5")
    assert code == 0
    assert err == f"note: --set e=2.5 is used, not the design's e = 3 from {path}\n"
    _, by_hand, _ = analysed(capsys, "--set", "e=2.5", "--set", "b=4")
    _, design_alone, _ = analysed(capsys, "--design", path)
    assert both["peaks"] == by_hand["peaks"] != design_alone["peaks"]


@pytest.mark.parametrize("changes, says", [
    ({"success": False, "status": "Infeasible_Problem_Detected"},
     "the optimisation did not succeed (Infeasible_Problem_Detected): its design is used as it is, not as a "
     "proven optimum"),
    ({"success": False, "status": None}, "the optimisation did not succeed (success: false)"),
    ({"interrupted": True}, "the optimisation was interrupted (the best of its finished starts)"),
])
def test_an_unsuccessful_result_is_used_with_a_note(tmp_path, capsys, changes, says):
    path = result_file(tmp_path, **changes)
    code, got, err = analysed(capsys, "--design", path)
    assert code == 0 and err.startswith(f"note: --design {path}: {says}") and err.count("\n") == 1
    _, by_hand, _ = analysed(capsys, "--set", "e=3", "--set", "b=4")
    assert got["peaks"] == by_hand["peaks"]


def test_a_result_of_another_scene_with_the_same_variables_is_an_error(tmp_path, capsys):
    path = result_file(tmp_path, file="problems/other_jib.toml", title="Another jib")
    code, _, err = analysed(capsys, "--design", path)
    assert code == 2
    assert err.startswith(f"optdesign analyse: error: --design {path}: made from problems/other_jib.toml "
                          f"('Another jib'), not from {JIB} (")
    assert err.endswith(f"give the result.json of an optimisation of {JIB}\n")


def test_a_renamed_scene_file_or_a_new_title_keeps_its_results(tmp_path, capsys):
    for changes in ({"file": "problems/renamed.toml"}, {"title": "a new title"}):
        code, got, err = analysed(capsys, "--design", result_file(tmp_path, **changes))
        assert code == 0 and err == ""


# --- a cylinder's rod without its bore ------------------------------------------------------------

def test_a_rod_thicker_than_the_push_needs_and_no_pull_gives_no_bore(tmp_path):
    text = RAMP.read_text().replace('rod = "d_rod"\nbore = 0.08\n', "rod = 0.05\n")
    scene = optdesign.loads(text, str(tmp_path / "ramp.toml"))
    train = optdesign.analyse(scene).cases.train
    push, p = train["peak_push"], 16e6
    assert train["peak_pull"] == 0 and math.sqrt(4 * push / (math.pi * p)) < 0.05
    assert "bore" not in train and "pressure_pull" not in train and "pump_flow" not in train
    assert train["bore_undetermined"].startswith("any bore larger than the rod (0.05 m): nothing pulls, and the push "
                                                 f"alone needs {math.sqrt(4 * push / (math.pi * p)):.6g} m")


def test_the_command_prints_no_inf_for_a_rod_without_a_bore(tmp_path, capsys):
    scene = tmp_path / "ramp.toml"
    scene.write_text(RAMP.read_text().replace('rod = "d_rod"\nbore = 0.08\n', "rod = 0.05\n"))
    assert main(["analyse", str(scene)]) == 0
    out = capsys.readouterr().out
    assert "inf" not in out and "bore needed: any bore larger than the rod (0.05 m)" in out


@pytest.mark.parametrize("push, pull, rod", [(15772.0, 5000.0, 0.05), (1e5, 0.0, 0.02), (1e5, 2e5, 0.06)])
def test_a_cylinder_that_pulls_or_pushes_hard_has_finite_pressures(push, pull, rod):
    given = {"pressure": 16e6, "modulus": 210e9, "buckling_safety": 3.5, "length_factor": 1.0, "rod": rod,
             "bore": None}
    out = cylinder_sizing(given.get, push, pull, 2.0, 0.1, 0.1)
    p = 16e6
    bore = max(math.sqrt(4 * push / (math.pi * p)), math.sqrt(4 * pull / (math.pi * p) + rod**2))
    assert out["bore"] == pytest.approx(bore, rel=1e-12) and bore > rod
    annulus = math.pi * (bore**2 - rod**2) / 4
    assert out["pressure_pull"] == pytest.approx(pull / annulus if pull else 0.0, rel=1e-12, abs=1e-9)
    assert out["pressure_push"] <= p * (1 + 1e-12) and out["pressure_pull"] <= p * (1 + 1e-12)


# --- a load that overflows, a cycle of dwells --------------------------------------------------------

def press(old, new):
    text = PRESS.read_text()
    assert old in text
    return text.replace(old, new)


def test_a_case_whose_load_squares_beyond_a_float_is_an_error(tmp_path, capsys):
    path = tmp_path / "press.toml"
    path.write_text(press('name = "forming stroke"\ndirection = "forward"',
                          'name = "forming stroke"\ndirection = "forward"\nset = { F0 = 1e300 }'))
    assert main(["analyse", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("optdesign analyse: error: case 'forming stroke': the time integral of the drive load "
                          "squared (its RMS over time) is ")
    assert "the drive load of case 'forming stroke' reaches " in err and "(the case sets F0 = 1e+300)" in err
    assert "whose square exceeds the largest number a float holds (1.8e308)" in err and err.count("\n") == 1
    with pytest.raises(ResultError, match="case 'forming stroke'"):
        optdesign.analyse(optdesign.load(path))


@pytest.mark.parametrize("cycle", ["[{ dwell = 0.4 }]", "[{ dwell = 0.4 }, { dwell = 2 }]"])
def test_a_cycle_of_dwells_alone_is_an_error(tmp_path, cycle):
    text = press('cycle = ["forming stroke", "return stroke", { dwell = 0.4 }]', f"cycle = {cycle}")
    with pytest.raises(SceneError, match=r"\[duty\] cycle: the cycle holds only dwells, in which the drive neither "
                                         r"moves nor carries a load \(its RMS would be 0\): add the cases it runs, "
                                         r'e.g. cycle = \["forming stroke", \{ dwell = 10 \}\]'):
        optdesign.loads(text, "press.toml")


# --- unclear messages ---------------------------------------------------------------------------------

def test_a_duplicate_case_name_is_named_as_such_not_as_an_unknown_case_in_a_phase():
    text = PRESS.read_text()
    first = text.index("[[cases]]")
    second = text.index('name = "return stroke"', first)
    text = text[:second] + 'name = "forming stroke"' + text[second + len('name = "return stroke"'):]
    with pytest.raises(SceneError, match=r"\[\[cases\]\] 'forming stroke': the case name 'forming stroke' is used "
                                         r"twice; rename one of them"):
        optdesign.loads(text, "press.toml")


def test_a_cylinder_without_cases_is_an_error():
    text = RAMP.read_text()
    text = text[:text.index("[profiles.raise]")] + '[objective]\nminimise = "peak(drive)"\n'
    with pytest.raises(SceneError, match=r"\[cylinder\]: a cylinder is sized from the peak forces and speeds of the "
                                         r"load cases, and the scene has no \[\[cases\]\], so it would be ignored"):
        optdesign.loads(text, "ramp.toml")


def test_an_analyse_study_of_a_scene_with_cases_records_them(tmp_path):
    scene = optdesign.load(PRESS)
    result = Study(scene, [values("F0", [1e5, 2e5])], mode="analyse").run(out=tmp_path, workers=1, figures=False)
    rows = list(csv.DictReader(open(tmp_path / "cases.csv")))
    for row, f0 in zip(rows, (1e5, 2e5)):
        cases = optdesign.analyse(scene.with_parameters(F0=f0)).cases
        assert float(row["cycle_rms:drive"]) == pytest.approx(cases.duty["rms_time"]["drive"], rel=1e-12)
        assert float(row["case_peak:motor_torque"]) == pytest.approx(cases.governing["motor_torque"]["value"], rel=1e-12)
        assert row["case_peak_case:motor_torque"] == cases.governing["motor_torque"]["case"]
        assert row["smallest_motor"] == (cases.train["smallest_fitting"] or "none")
    assert float(rows[1]["cycle_rms:drive"]) > float(rows[0]["cycle_rms:drive"])
    assert "the load cases' are case_peak:* (with the governing case), cycle_rms:*" in (
        tmp_path / "summary.txt").read_text()
    assert result.complete
