"""problems/transfer_arm.toml against its independent numpy model (tests/ref_transfer_arm.py:
four-bar, virtual work, the s-curve in time, the drive train and the constraints written there,
nothing of optdesign).

Fast (default suite): the numpy motor torque equals optdesign's analyse in every case (at the
scene's start and at the shipped optimum, results/transfer_arm/result.json, each motor of the
catalogue), the time law and the duty cycle's RMS agree, the closed-form swing and transmission
angle agree with analyse's certified ones, and the shipped objective is the numpy model's
continuous peak with every constraint held.
Slow: the numpy model's search for the smallest motor (a grid over (r, xQ) on the swing equality
times a grid of i, SLSQP polishes, then trust-box SLSQP steps on the tracked peaks) reaches the
shipped optimum to 1e-6, and the shipped run's starts are counted against it (14 of 20).  The
optimum lies in a flat valley (the peak moves 2e-8 of itself over 3.5e-4 of the box along it).
"""
from __future__ import annotations

import functools
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

import optdesign
from optdesign.design.catalogue import with_motor

sys.path.insert(0, str(Path(__file__).resolve().parent))
import ref_transfer_arm as ref  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = ROOT / "results" / "transfer_arm" / "result.json"
START = {"r": 0.12, "c": 0.45, "xQ": 0.45, "i": 20.0}
AT_GLOBAL = 1e-6


def shipped():
    return json.loads(SHIPPED.read_text())


def single_motor_scene(name, design):
    scene = optdesign.load(ref.SCENE)
    motor = next(m for m in scene.motors if m.name == name)
    return with_motor(scene, motor).with_parameters(**design)


def test_reference_reads_the_scene_it_models():
    n = ref.scene_numbers()
    assert n["fixed"] == (ref.YQ, ref.R, ref.LA, ref.MA, ref.G)
    assert n["eta"] == (ref.ETA_M, ref.ETA_G)
    assert n["profile"] == ("s-curve", "600 deg", "5000 deg", "5000 deg", "150000 deg")
    assert n["box"] == ref.BOX and n["motors"] == ref.MOTORS and n["cases"] == list(ref.CASES)
    assert n["duty"] == ["transfer", {"dwell": 0.3}, "return empty", {"dwell": 0.3}]


@pytest.mark.parametrize("which, motor", [("scene start", "servo 400 W"), ("scene start", "servo 1.5 kW"),
                                          ("shipped optimum", "servo 400 W")])
def test_numpy_motor_torque_is_analyses(which, motor):
    design = START if which == "scene start" else shipped()["design"]
    x = [design[n] for n in ref.NAMES]
    J = ref.MOTORS[motor][0]
    res = optdesign.analyse(single_motor_scene(motor, design))
    starts = ref.phase_starts()
    for name, m in ref.CASES:
        cols = res.cases.cases[name].columns
        t = np.asarray(cols["t"], float)
        # the numpy time law at optdesign's times gives optdesign's crank angles
        k = np.clip(np.searchsorted([p[0] for p in starts], t, side="right") - 1, 0, 6)
        phi = np.array([ref.state(starts[j], tj - starts[j][0])[0] for j, tj in zip(k, t)])
        assert np.max(np.abs(phi - np.asarray(cols["s"], float))) <= 1e-9, name
        s, sd, sdd = (np.asarray(cols[c], float) for c in ("s", "sd", "sdd"))
        base, part = ref.ideal_torque(x[0], x[1], x[2], s, sd, sdd)
        theirs = ref.motor_torque(base + m * part, sd, sdd, x[3], J)
        ours = np.asarray(cols["motor_torque"], float)
        assert np.max(np.abs(ours - theirs)) <= 1e-6 * np.max(np.abs(theirs)), name
    assert res.cases.duty["rms_time"]["motor_torque"] == pytest.approx(ref.rms(x, J), rel=1e-8)


@pytest.mark.parametrize("which", ["scene start", "shipped optimum"])
def test_closed_form_swing_and_transmission_are_analyses(which):
    design = START if which == "scene start" else shipped()["design"]
    res = optdesign.analyse(optdesign.load(ref.SCENE).with_parameters(**design))
    x = [design[n] for n in ref.NAMES]
    assert res.constraints["rocker swing"] == pytest.approx(ref.swing(*x[:3]), abs=1e-9)
    mu = res.constraint_extremes["transmission angle"]
    lo, hi = ref.transmission(*x[:3])
    assert (mu["min"], mu["max"]) == pytest.approx((lo, hi), abs=1e-9)


def test_shipped_optimum_is_the_numpy_peak_and_holds_every_constraint():
    data = shipped()
    assert data["chosen_motor"] == "servo 400 W"            # the smallest motor, and it fits
    x = [data["design"][n] for n in ref.NAMES]
    J = ref.MOTORS["servo 400 W"][0]
    value, case, _ = ref.peak_torque(x, J)
    assert data["objective"] == pytest.approx(value, rel=1e-8) and case == "heavy part"
    assert ref.swing(*x[:3]) == pytest.approx(ref.SWING, abs=1e-8)
    v = ref.violation(x, "servo 400 W")
    assert min(v.values()) >= -1e-9, v
    assert v["speed"] == pytest.approx(0, abs=1e-6)          # the motor's speed limit is active


def test_an_equality_met_to_tolerance_is_ok_and_a_miss_shows_its_digits():
    """The swing equality at the shipped optimum reads ok and states the tolerance it was judged
    in; a design 0.0008 deg off it reads VIOLATED with the value in the digits that show the
    miss (it read '60 deg ... VIOLATED' before)."""
    from optdesign.report.checks import summary_lines

    design = shipped()["design"]
    at = summary_lines(optdesign.analyse(optdesign.load(ref.SCENE).with_parameters(**design)))
    line = next(x for x in at if x.startswith("rocker swing:"))
    assert line.startswith("rocker swing: 60 deg (min 60 deg and max 60 deg): ok (an equality: met within 6e-05 deg")
    off = dict(design, c=design["c"] + 1.2e-5)
    miss = math.degrees(ref.swing(off["r"], off["c"], off["xQ"])) - 60
    assert 5e-4 < abs(miss) < 1e-3
    lines = summary_lines(optdesign.analyse(optdesign.load(ref.SCENE).with_parameters(**off)))
    line = next(x for x in lines if x.startswith("rocker swing:"))
    shown = float(line.split(":")[1].split("deg")[0])
    assert "VIOLATED" in line and shown != 60 and shown == pytest.approx(60 + miss, abs=1e-3)
    assert any(x.startswith("  violated: rocker swing: ") and f"({line.split(': ')[1].split(' (')[0]} over" in x
               for x in lines)


def test_numpy_torque_is_smooth_in_the_design():
    """The model's motor torque is smooth in the design to round-off (its derivatives d/dphi in
    closed form): second differences over steps of 1e-9 in r, c and xQ are below 1e-13 N m.  With
    the positions differentiated by eighth-order differences (step 1e-3 rad) they were ~1e-8 N
    m: SLSQP's finite-difference gradients were noise there, and the search stalled 2.5e-5
    above the optimum."""
    x = np.array([shipped()["design"][n] for n in ref.NAMES])
    J = ref.MOTORS["servo 400 W"][0]
    p = ref.phase_starts()[3]
    tau = np.linspace(0.0, p[4], 7)
    for k in range(3):
        step = np.zeros(4)
        step[k] = 1e-9
        f = [ref._tm(x + j * step, p, tau, 12.0, J) for j in (-1, 0, 1)]
        assert np.max(np.abs(f[0] - 2 * f[1] + f[2])) < 1e-13, ref.NAMES[k]


@functools.cache
def reference():
    return ref.global_optimum("servo 400 W", polished=2)


@pytest.mark.slow
def test_numpy_search_confirms_the_shipped_optimum():
    """The numpy search (a grid over (r, xQ) on the swing equality times a grid of i, SLSQP
    polishes from the 2 best grid designs apart, then trust-box SLSQP steps on the tracked
    peaks) reaches the shipped optimum from above and below to 1e-6 (measured 01:35 UTC
    2026-11-28: 2.3889192099 N m against the shipped 2.3889192101, ~2 min); its one run before the
    closed-form derivatives stopped at 2.388979225.  Of the shipped run's 20 starts (the default
    command `optdesign optimise problems/transfer_arm.toml`, motor servo 400 W), 14 reach it; 5
    stop at a local optimum 0.9 % higher (2.41068543, xQ at its upper bound) and 1 ends without
    a design (its peak exchange did not converge)."""
    glob, data = reference(), shipped()
    print(f"\ntransfer_arm: numpy search best {glob['peak']:.10g} N m at {glob['design']}; "
          f"shipped {data['objective']:.10g}")
    assert glob["violation"] >= -1e-9 and glob["peak"] <= glob["grid_best"]
    assert data["objective"] == pytest.approx(glob["peak"], rel=AT_GLOBAL)
    span = {n: hi - lo for n, (lo, hi) in ref.BOX.items()}
    assert all(abs(data["design"][n] - glob["design"][n]) <= 1e-4 * span[n] for n in ref.NAMES)
    reached = [s["index"] for s in data["starts"]
               if s["objective"] is not None and s["objective"] <= glob["peak"] * (1 + AT_GLOBAL)]
    assert len(reached) == data["starts_at_best"] == 14
    assert all(s["objective"] is None or s["objective"] >= glob["peak"] * (1 - AT_GLOBAL) for s in data["starts"])
