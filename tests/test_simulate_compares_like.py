"""simulate's summary compares like with like: the simulated cycle against analyse's duty cycle
only when the phases run that cycle's steps (the same cases in order, each dwell a brake's hold
of the same time), else phase by phase, each phase that follows a case's profile against that
case, saying that the cycles differ.

The transfer arm (problems/transfer_arm.toml) simulates the transfer and a 0.3 s dwell (1.05 s;
the crank turns once per stroke, so the return cannot follow in one run), while its [duty] cycle
is transfer, dwell, return empty, dwell (2.11 s): the summary used to print "differences" of
-50 % (cycle time) and +37 % (RMS torque) between the two cycles.  Here the transfer phase is
checked against the independent numpy model of tests/ref_transfer_arm.py (its s-curve's
duration, the RMS and peak of the motor torque over the transfer); the press
(problems/press_servo_cycle.toml) simulates its [duty] cycle, so the cycles compare."""
from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import pytest

import optdesign
from optdesign.dynamics.simulator import simulate
from optdesign.report.cycle import cycle_figures, cycle_lines, profile_figures

sys.path.insert(0, str(Path(__file__).resolve().parent))
import ref_transfer_arm as ref  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
PRESS = ROOT / "problems" / "press_servo_cycle.toml"
PRESS_SIZED = {"l": 0.4178431511311544, "e": -0.08, "i": 50.0}   # as tests/test_duty_simulation.py


@pytest.fixture(scope="module")
def arm():
    design = json.loads((ROOT / "results" / "transfer_arm" / "result.json").read_text())["design"]
    result = simulate(optdesign.load(ref.SCENE).with_parameters(**design), tolerance=1e-6)
    return design, result, cycle_figures(result), profile_figures(result)


def test_transfer_arm_compares_the_transfer_phase_with_its_case(arm):
    design, result, figures, profile = arm
    assert result.scene.simulation.motor == "servo 1.5 kW" and figures["motor"]["name"] == "servo 1.5 kW"
    assert profile["same_cycle"] is False
    assert profile["cycle"]["steps"] == ["transfer", "dwell 0.3 s", "return empty", "dwell 0.3 s"]
    assert profile["cycle"]["cycle_time"] == pytest.approx(ref.cycle_time(), rel=1e-12)
    assert [(p["phase"], p["case"]) for p in profile["phases"]] == [("transfer", "transfer")]
    theirs, ours = profile["phases"][0], figures["phases"][0]
    # the numpy s-curve's time, analyse's case and the simulated phase: one duration
    duration = sum(d for d, _ in ref.phases())
    assert theirs["duration"] == pytest.approx(duration, rel=1e-12)
    assert ours["duration"] == pytest.approx(duration, rel=1e-9)
    # analyse's figures for the case against the numpy model (motor 'servo 1.5 kW')
    x = [design[n] for n in ref.NAMES]
    J = ref.MOTORS["servo 1.5 kW"][0]
    masses = dict(ref.CASES)
    rms = math.sqrt(ref.squared_integral(x, masses["transfer"], J) / duration)
    peak = ref.peak_torque(x, J, cases=[("transfer", masses["transfer"])])[0]
    assert theirs["rms_motor_torque"] == pytest.approx(rms, rel=1e-7)
    assert theirs["peak_motor_torque"] == pytest.approx(peak, rel=1e-7)
    assert theirs["peak_motor_speed"] == pytest.approx(x[3] * ref.V, rel=1e-7)
    # the simulation tracks the profile (gain 10 N m per rad/s): within its tracking error
    for key, within in (("rms_motor_torque", 1e-3), ("peak_motor_torque", 3e-3), ("peak_motor_speed", 3e-4),
                        ("drive_energy", 1e-3)):
        assert ours[key] == pytest.approx(theirs[key], rel=within), key
    # the brake's dwell: no motor torque in it (its first sample is its own, not the transfer's end)
    assert figures["phases"][1]["peak_motor_torque"] == 0.0


def test_transfer_arm_summary_says_the_cycles_differ(arm):
    _, _, figures, profile = arm
    text = "\n".join(cycle_lines(figures, profile))
    assert "the simulated phases (transfer, dwell (hold 0.3 s): 1.05333 s) are not analyse's duty cycle" in text
    assert "(transfer, dwell 0.3 s, return empty, dwell 0.3 s: 2.10667 s): compared phase by phase" in text
    assert "phase 'transfer', case 'transfer'" in text
    assert "cycle time" not in text                 # no row of one cycle against the other


def _press(text=None):
    text = text or PRESS.read_text()
    scene = optdesign.loads(text, str(PRESS)).with_parameters(**PRESS_SIZED)
    result = simulate(scene, tolerance=1e-4)
    return result, cycle_figures(result), profile_figures(result)


@pytest.mark.slow   # (the press: ~2 s CPU each; the transfer arm's tests above are the fast siblings)
def test_press_runs_its_duty_cycle_so_the_cycles_compare():
    result, figures, profile = _press()
    assert profile["same_cycle"] is True
    assert profile["cycle"]["steps"] == ["forming stroke", "return stroke", "dwell 0.4 s"]
    assert figures["cycle_time"] == pytest.approx(profile["cycle"]["cycle_time"], rel=1e-12)
    text = "\n".join(cycle_lines(figures, profile))
    assert "the cycle" in text and "cycle time [s]" in text and "not analyse's duty cycle" not in text


@pytest.mark.slow
@pytest.mark.parametrize("change", ["a longer dwell", "no dwell"])
def test_press_with_other_phases_compares_phase_by_phase(change):
    text = PRESS.read_text()
    dwell = '[[simulation.phases]]\nname = "dwell"\nhold = "brake"\nuntil = { time = 0.4 }\n'
    assert dwell in text
    text = text.replace(dwell, dwell.replace("0.4", "0.5") if change == "a longer dwell" else "")
    result, figures, profile = _press(text)
    assert profile["same_cycle"] is False
    assert [p["phase"] for p in profile["phases"]] == ["forming stroke", "return stroke"]
    lines = cycle_lines(figures, profile)
    assert any("not analyse's duty cycle" in x for x in lines)
    assert not any("cycle time" in x for x in lines)


def test_transfer_arm_torque_speed_plot_gives_each_rms_its_cycle(arm, tmp_path, monkeypatch):
    """simulate's torque_speed.png draws the simulated RMS (transfer + dwell, 1.05 s) beside the
    [duty] cycle's (2.11 s): each label gives its cycle's time (they read as one cycle's two RMS)."""
    import optdesign.report.sized as sized
    from optdesign.report.simulation import _torque_speed

    _, result, figures, _ = arm
    labels = []
    monkeypatch.setattr(sized, "save_figure",
                        lambda fig, path, label="": labels.extend(t.get_text() for t in fig.axes[0].get_legend().get_texts()))
    _torque_speed(result, figures, tmp_path)
    simulated = next(x for x in labels if x.startswith("simulated RMS"))
    duty = next(x for x in labels if x.startswith("duty cycle RMS"))
    assert simulated.endswith("over its 1.053 s") and duty.endswith(f"over its {ref.cycle_time():.4g} s")
