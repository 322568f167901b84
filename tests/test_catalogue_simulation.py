"""A motor catalogue through simulate (issue 29): a scene whose duty cycle in time names one
motor of its catalogue ([simulation] motor) is optimised with each motor in turn (optimise
exited 2 "unknown motor 'servo 1.5 kW'; did you mean 'servo 400 W'?" for every motor but the
named one), and `simulate --design RESULT_JSON` runs the motor the result chose, not the one
the file names."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

import optdesign
from optdesign.cli import main as cli
from optdesign.design.catalogue import with_motor

ARM = Path(__file__).resolve().parents[1] / "problems" / "transfer_arm.toml"


def test_each_motor_of_the_catalogue_makes_a_valid_scene_with_its_phases():
    scene = optdesign.load(ARM)
    assert scene.simulation.motor == "servo 1.5 kW" and len(scene.motors) == 3
    for motor in scene.motors:
        one = with_motor(scene, motor)   # validated as it is built (the old rule raised SceneError here)
        assert one.motors == (motor,) and one.simulation.motor == motor.name
        assert one.simulation.phases == scene.simulation.phases


def test_the_old_rule_fails_on_this_scene():
    """What optimise did before: the catalogue's other motors alone, [simulation] unchanged."""
    import dataclasses

    scene = optdesign.load(ARM)
    with pytest.raises(optdesign.SceneError, match="unknown motor 'servo 1.5 kW'"):
        dataclasses.replace(scene, motors=(scene.motors[0],))


def test_simulate_design_runs_the_chosen_motor(tmp_path, capsys):
    scene = optdesign.load(ARM)
    design = {p.name: scene.parameter_values()[p.name] for p in scene.parameters if p.is_design} | {"i": 28.0}
    result = tmp_path / "result.json"
    result.write_text(json.dumps({"design": design, "chosen_motor": "servo 750 W"}))
    assert cli.main(["simulate", str(ARM), "--design", str(result)]) == 0
    out = capsys.readouterr().out
    assert "duty cycle in time with motor 'servo 750 W'" in out
    # a chosen motor the scene does not have: an error naming it, status 2
    result.write_text(json.dumps({"design": design, "chosen_motor": "servo 3 kW"}))
    assert cli.main(["simulate", str(ARM), "--design", str(result)]) == 2
    assert "chosen motor 'servo 3 kW' is not in this scene's [[motors]]" in capsys.readouterr().err
