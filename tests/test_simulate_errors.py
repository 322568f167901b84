"""`optdesign simulate`: the scene keys for it, their errors, and the command line."""
import json
from pathlib import Path

import pytest

import optdesign
from optdesign.cli.main import main
from optdesign.errors import DeadCentreError, ExpressionError, SceneError
from optdesign.dynamics.simulator import simulate

PROBLEMS = Path(__file__).resolve().parent.parent / "problems"
BAR = (PROBLEMS / "sim_bar.toml").read_text()


def load_bar(old, new):
    assert old in BAR
    return optdesign.loads(BAR.replace(old, new), "bar.toml")


@pytest.mark.parametrize("old,new,message", [
    ('law = "T"', 'law = "T*(1 - qd/omega)"', r"bar.toml, line \d+: \[drive\] law: 'T\*\(1 - qd/omega\)': unknown name 'omega'"),
    ('law = "T"', 'law = "T + x(A)"', r"\[drive\] law: .*no point 'A'|\[drive\] law: .*point"),
    ('inertia = "J_rotor"', 'inertia = "-J_rotor"', r"\[drive\] inertia: expected a drive inertia >= 0 \(kg m\^2"),
    ("start = 0.3 ", "start = -1 ", r"line \d+: \[simulation\] start: the start -1 lies outside the stroke \[0, 125.66"),
    ("t_end = 5.0 ", "t_end = 0 ", r"\[simulation\] t_end: expected an end time > 0 s, found 0"),
    ("samples = 101", "samples = 1", r"\[simulation\] samples: expected a whole number >= 2"),
    ("samples = 101", 'integrator = "bfd"', r"\[simulation\] integrator: expected one of 'bdf', 'adams', 'rk4'.*did you mean 'bdf'"),
    ("samples = 101", "tolerance = 1", r"\[simulation\] tolerance: expected a relative tolerance in \(0, 0.1\]"),
    ("samples = 101", "t_ned = 3", r"\[simulation\] t_ned: unknown key 't_ned'; did you mean 't_end'"),
    ("start = 0.3 ", "", r"\[simulation\] start: missing key 'start'"),
    ('law = "T"', 'law = "T"\nlaww = 1', r"\[drive\] laww: unknown key 'laww'; did you mean 'law'"),
    ('law = "T"', "", r"\[simulation\]: a simulation needs the drive's law: add law"),
    ("T = 2.0 ", "T = 2.0\nqd = 1.0 ", r"\[drive\] law: the parameter 'qd' has the name the law uses"),
])
def test_scene_errors_name_the_place(old, new, message):
    with pytest.raises((SceneError, ExpressionError), match=message):
        load_bar(old, new)


def test_no_law_is_a_clear_error():
    scene = optdesign.load(PROBLEMS / "seed1_slider_crank.toml")
    with pytest.raises(SceneError, match=r"\[drive\] law: the scene gives no drive law"):
        simulate(scene)


def test_no_simulation_table_is_a_clear_error():
    scene = optdesign.loads(BAR[:BAR.index("[simulation]")], "bar.toml")
    with pytest.raises(SceneError, match=r"\[simulation\]: missing table"):
        simulate(scene)


def test_vanishing_reduced_inertia_is_a_dead_centre_error():
    """The slider-crank without a rotor: I_zS = m R_z^2 = 0 at alpha = pi (and 0, 2 pi ...)."""
    scene = optdesign.load(PROBLEMS / "sim_slider_crank.toml", {"J_rotor": 0.0})
    with pytest.raises(DeadCentreError, match=r"reduced inertia vanishes at alpha = (0 |3.14159|6.28319).*\[drive\] inertia"):
        simulate(scene)


def test_existing_scenes_load_unchanged():
    """The new keys are optional: a scene without them has no law, inertia or simulation."""
    scene = optdesign.load(PROBLEMS / "seed1_jib.toml")
    assert scene.drive.law is None and scene.drive.inertia is None and scene.simulation is None


def test_cli_table_json_and_figures(tmp_path, capsys):
    assert main(["simulate", str(PROBLEMS / "sim_bar.toml"), "--set", "T=1", "--plot", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "stopped at t = 5 s: t_end" in out
    assert {p.name for p in tmp_path.iterdir()} == {"q.png", "q_rate.png", "drive_load.png"}
    assert main(["simulate", str(PROBLEMS / "sim_jib.toml"), "--json", "--integrator", "adams"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["kind"] == "simulation" and data["drive"] == "linear" and data["integrator"] == "adams"
    assert data["stop"]["reason"] == "stroke end" and data["stop"]["end"] == "to"
    assert data["samples"][-1]["q"] == pytest.approx(3.2, rel=1e-9)
    assert set(data["samples"][0]) >= {"t", "s", "sd", "q", "qd", "qdd", "drive", "transmitted", "kinetic_energy", "power"}
    assert data["units"]["drive"] == "N" and data["stats"]["steps"] > 0


def test_cli_errors_exit_2(capsys):
    assert main(["simulate", str(PROBLEMS / "sim_slider_crank.toml"), "--integrator", "rk4", "--steps", "200"]) == 2
    assert "rk4 integrator failed" in capsys.readouterr().err
