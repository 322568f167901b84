"""The two shipped scenes that size a drive over load cases (issue 16, piece 6), end to end:
problems/crane_luffing_drive.toml (a luffing crane's motor and gearbox over raise, lower and
test-load cases on a trapezoid, a motor catalogue) and problems/press_servo_cycle.toml (a servo
press on its forming stroke, return and dwell, sized for the motor's RMS torque over time).

What is checked against what: the analysis's governing case against a loop over its cases;
the optimum's objective against the scene analysed again at the optimal design; optimality of
the gear ratio against a scan of it with the geometry held (the ratio sits at the motor's speed
limit: every smaller ratio is worse, a larger one too fast); the catalogue's choice against
each smaller motor's limits."""
import dataclasses
from pathlib import Path

import numpy as np
import pytest

from optdesign.design import optimise
from optdesign.model.analysis import analyse
from optdesign.scene.file import load

ROOT = Path(__file__).resolve().parents[1] / "problems"


def test_crane_cases_and_the_governing_test_load():
    scene = load(ROOT / "crane_luffing_drive.toml")
    cases = analyse(scene).cases
    assert list(cases.cases) == ["in, rated load", "out, rated load", "in, empty hook", "out, empty hook", "test load"]
    for key in ("drive", "motor_torque"):
        loop = max(cases.cases, key=lambda n: cases.cases[n].peaks[key])
        assert cases.governing[key]["case"] == loop == "test load"
    duty = cases.duty
    assert duty["cycle_time"] == pytest.approx(4 * 59.0 + 20 + 15 + 30, rel=1e-12)   # 59 s per stroke
    assert [s["kind"] for s in duty["steps"]] == ["case", "hold", "case", "dwell", "case", "case", "dwell"]
    # luffing out with the load, power flows back: negative energy, the efficiency multiplies
    assert cases.cases["out, rated load"].integrals["energy"] < 0 < cases.cases["in, rated load"].integrals["energy"]


def test_crane_optimum_with_the_motor_that_fits():
    """The design optimised for the 7.5 kW motor (the one `optdesign optimise` chooses from the
    catalogue: results/crane_luffing_drive/): its least peak motor torque over the cases is
    above the smaller motors' peak torques (95 and 70 N m), by more than their rotor torques
    could change it, so they cannot fit; the ratio stands at the motor's speed limit."""
    scene = load(ROOT / "crane_luffing_drive.toml")
    scene = dataclasses.replace(scene, sweep=dataclasses.replace(scene.sweep, samples=61))  # quicker
    motor = next(m for m in scene.motors if m.name == "7.5 kW")
    result = optimise(dataclasses.replace(scene, motors=(motor,)), starts=1)
    assert result.success, result.status
    at = analyse(scene.with_parameters(**result.design)).cases
    entry = at.train["motors"]["7.5 kW"]
    assert entry["fits"] and at.train["smallest_fitting"] == "7.5 kW"
    assert entry["peak"] == pytest.approx(result.objective, rel=1e-5)
    assert at.governing["motor_torque"]["case"] == "test load"
    assert max(c.peaks["motor_speed"] for c in at.cases.values()) == pytest.approx(157.0, rel=1e-6)
    # a rotor's share of the motor torque J_r i theta'' over the cases, at most:
    rotor = max(float(np.max(np.abs(c.columns["motor_acceleration"]))) for c in at.cases.values()) * 0.028
    assert result.objective - rotor > 95.0
    for name in ("4 kW", "5.5 kW"):
        assert not at.train["motors"][name]["fits"]


@pytest.fixture(scope="module")
def press():
    scene = load(ROOT / "press_servo_cycle.toml")
    return scene, optimise(scene, starts=3)


def test_press_cycle(press):
    scene, _ = press
    cases = analyse(scene).cases
    assert [s["kind"] for s in cases.duty["steps"]] == ["case", "case", "dwell"]
    forming = cases.cases["forming stroke"]
    assert forming.profile == "forming" and cases.cases["return stroke"].overrides == {"F0": 0.0}
    assert cases.governing["drive"]["case"] == "forming stroke"


def test_press_thermal_optimum(press):
    scene, result = press
    assert result.success and result.objective_kind == "rms_time"
    assert result.starts_at_best == 3
    at = analyse(scene.with_parameters(**result.design)).cases
    # the optimiser's power-flow switches are smoothed (SolverSettings.efficiency_smoothing),
    # analyse's exact: they agree to about 1e-6 here
    assert at.duty["rms_time"]["motor_torque"] == pytest.approx(result.objective, rel=1e-5)
    assert result.constraints["motor rated torque"]["value"] == pytest.approx(result.objective, rel=1e-9)
    # the gear ratio at the motor's speed limit in the return stroke; with the geometry held,
    # every smaller ratio gives a larger RMS torque
    i = result.design["i"]
    top = max(c.peaks["motor_speed"] for c in at.cases.values())
    assert top == pytest.approx(300.0, rel=1e-6)
    rms = [analyse(scene.with_parameters(**dict(result.design, i=float(x)))).cases.duty["rms_time"]["motor_torque"]
           for x in np.linspace(0.8 * i, i, 5)]
    assert all(a > b for a, b in zip(rms, rms[1:])), rms
    # an inactive two-sided constraint is reported at its extreme nearer a bound: the forming
    # stroke's motor speed in [-300, 300] runs from rest to the s-curve's top crank speed, 4 rad/s
    # times the ratio (the scene's [profiles.forming]), not at the rest's 0
    forming = result.constraints["motor speed in case 'forming stroke'"]
    assert forming["active"] is None and forming["value"] == pytest.approx(4.0 * i, rel=1e-6)
