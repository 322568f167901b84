"""Unclear messages made clear: an objective naming a column the scene does not have, a link of
length 0 or less, a drive law that is not finite at the start, a crank of zero length in a
simulation, the summary of an objective that is not the peak drive, and option values that
argparse would take for options (``--tolerance -1e-6``).  Each asserts the error class and the
message, or the right answer against an independent reference."""
from __future__ import annotations

import math

import numpy as np
import pytest

import optdesign
from optdesign.cli.main import main
from optdesign.errors import ExpressionError, ResultError, SceneError

from .util import JIB_DESIGN, PROBLEMS, SIM

FOURBAR = """title = "a crank-rocker"
[parameters]
a = 1.0
b = 2.5
c = 2.0
[sweep]
name = "phi"
from = 0
to = 1
samples = 11
[points]
O = { fixed = [0, 0] }
Q = { fixed = [3, 0] }
A = { polar = ["O", "a", "phi"] }
B = { dyad = ["A", "b", "Q", "c"], side = "left" }
[[bodies]]
name = "crank"
frame = ["O", "A"]
mass = 1.0
com = [0.5, 0]
[drive]
type = "rotary"
crank = ["O", "A"]
speed = 1.0
acceleration = 0.0
"""


def run(capsys, *argv):
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exc:
        code = exc.code
    return code, capsys.readouterr().err


def problem_of(text):
    from optdesign.design.problem import DesignProblem

    return DesignProblem(optdesign.loads(text))


# --- an objective naming a column the scene does not have ---------------------------------------------
DESIGN = JIB_DESIGN.read_text()


@pytest.mark.parametrize("objective, change, message", [
    ("peak(power)", ("speed = 0.1", "speed = 0"),
     "unknown name 'power': this scene's model has no 'power' column because the drive's speed is 0"),
    ("peak(static_load)", ("[gravity]\ng = 9.81", ""),
     "unknown name 'static_load': this scene's model has no 'static_load' column because no static load acts"),
    ("peak(velocity_term)", ("speed = 0.1", "speed = 0"),
     "unknown name 'velocity_term': this scene's model has no 'velocity_term' column because the drive's speed is 0"),
    ("peak(inertia_term)", ("acceleration = 0.2", "acceleration = 0"),
     "this scene's model has no 'inertia_term' column because the drive's acceleration is 0"),
    ("peak(efficiency_factor)", ("", ""),
     "no 'efficiency_factor' column because the drive has no efficiency below 1"),
    ("rms(drvie)", ("", ""), "unknown name 'drvie'; did you mean 'drive'?: it is no column of the model and no parameter"),
    ("peak(nonsense)", ("", ""), "unknown name 'nonsense': it is no column of the model and no parameter; the columns here: "),
])
def test_an_objective_naming_a_missing_column_says_why_and_what_exists(objective, change, message):
    text = DESIGN.replace('minimise = "peak(drive)"', f'minimise = "{objective}"').replace(*change)
    assert objective in text and (not change[0] or change[0] not in text or change[0] == change[1])
    with pytest.raises(ExpressionError) as caught:
        problem_of(text)
    assert message in str(caught.value), str(caught.value)
    assert f"[objective] minimise = '{objective}'" in str(caught.value)
    if "columns here" in message:
        assert "the columns here: drive, inertia_term, k, power, q, reduced_inertia" in str(caught.value)


def test_peak_of_a_parameter_expression_is_still_an_expression():
    # peak(e) names a parameter, not a column: a constant objective, minimised at e's lower bound
    result = optdesign.optimise(optdesign.loads(DESIGN.replace('minimise = "peak(drive)"', 'minimise = "peak(e)"')),
                                starts=1, workers=1)
    assert result.success and result.design["e"] == pytest.approx(0.5, abs=1e-6)


def test_the_summary_names_the_peak_it_certified(capsys, tmp_path):
    from optdesign.report.design import summary

    text = DESIGN.replace('minimise = "peak(drive)"', 'minimise = "peak(length(D, B) - 3)"')
    result = optdesign.optimise(optdesign.loads(text), starts=1, workers=1)
    lines = summary(result).splitlines()
    assert not any(line.startswith("peak |drive|") for line in lines)
    line = next(line for line in lines if line.startswith("peak |length(D, B) - 3| certified = "))
    # independent reference: |DB| - 3 over a fine grid of theta, from the design's e and b
    e, b, psi = result.design["e"], result.design["b"], math.radians(-60)
    theta = np.linspace(0.053331010512329025, 0.776279030740378, 200001)
    length = np.hypot(b * np.cos(theta) - e * math.cos(psi), b * np.sin(theta) - e * math.sin(psi))
    reference = float(np.max(np.abs(length - 3)))
    # to the certification's tolerance (the located extreme, not a grid of 200,001 points)
    assert result.peak_certified == pytest.approx(reference, rel=1e-8)
    assert line.split("= ")[1].split(",")[0] == f"{result.peak_certified:.9g}"


# --- lengths of a dyad and of a slider -----------------------------------------------------------------
def test_the_four_bar_with_positive_lengths_loads_and_assembles():
    # the reference of the cases below: B at distance b from A and c from Q (closed form)
    points = optdesign.kinematics(optdesign.loads(FOURBAR), 11).points
    A, B = (np.array([points[n]["x"], points[n]["y"]]) for n in "AB")
    Q = np.array([3.0, 0.0])[:, None]
    assert np.allclose(np.hypot(*(B - A)), 2.5, atol=1e-12) and np.allclose(np.hypot(*(B - Q)), 2.0, atol=1e-12)
    # the left of A -> Q: the cross product (Q - A) x (B - A) > 0
    assert np.all((Q[0] - A[0]) * (B[1] - A[1]) - (Q[1] - A[1]) * (B[0] - A[0]) > 0)


@pytest.mark.parametrize("path, old, new, message", [
    (None, "c = 2.0", "c = 0",
     "[points] B, dyad length from Q: expected a length > 0 [m], found 0 (c at the parameters' values)"),
    (None, "c = 2.0", "c = -2",
     "[points] B, dyad length from Q: expected a length > 0 [m], found -2 (c at the parameters' values)"),
    (None, "b = 2.5", "b = 0.0",
     "[points] B, dyad length from P: expected a length > 0 [m], found 0 (b at the parameters' values)"),
    (None, '"A", "b", "Q"', '"A", "b - 2.5", "Q"',
     "[points] B, dyad length from P: expected a length > 0 [m], found 0 (b - 2.5 at the parameters' values)"),
    (SIM, "l = 0.35 ", "l = 0 ", "[points] C, slider length: expected a length > 0 [m], found 0 (l at the parameters' values)"),
    (SIM, "l = 0.35 ", "l = -0.35 ", "[points] C, slider length: expected a length > 0 [m], found -0.35"),
    (SIM, "l = 0.35 ", "l = nan ", "l: expected a finite number"),
])
def test_a_link_of_length_zero_or_less_is_refused_at_load(path, old, new, message):
    text = FOURBAR if path is None else path.read_text()
    assert old in text
    with pytest.raises(SceneError) as caught:
        optdesign.loads(text.replace(old, new, 1))
    assert message in str(caught.value), str(caught.value)


# --- simulate: the drive law and the crank at the start --------------------------------------------
@pytest.mark.parametrize("law, what", [("1/qd", "infinite"), ("log(qd)", "infinite"), ("sqrt(qd - 1)", "NaN"),
                                       ("sqrt(-1 - qd)", "NaN")])
def test_a_drive_law_not_finite_at_the_start_is_a_scene_error(law, what):
    text = SIM.read_text().replace('law = "T0*(1 - qd/omega0)"', f'law = "{law}"')
    text = text.replace("speed = 100.0                # omega_S at t = 0", "speed = 0.0 # omega_S at t = 0")
    assert f'law = "{law}"' in text and "speed = 0.0 # omega_S" in text
    with pytest.raises(SceneError) as caught:
        optdesign.simulate(optdesign.loads(text))
    assert (f"[drive] law = '{law}' is {what} at the start (alpha = 0.5 (28.6479 deg), q = -1.0708, qd = 0): "
            "the law must be finite") in str(caught.value), str(caught.value)


def test_a_crank_of_zero_length_in_simulate_is_named_with_its_cause():
    text = SIM.read_text().replace("r = 0.1 ", "r = 0.0 ", 1)
    with pytest.raises(ResultError) as caught:
        optdesign.simulate(optdesign.loads(text))
    assert ("the reduced inertia (M_s + J_d k^2) is NaN at alpha = 0 (0 deg) (sample 1 of 2001 of the stroke); the "
            "drive's points S and A coincide there") in str(caught.value), str(caught.value)


# --- option values that begin with '-' -----------------------------------------------------------------
@pytest.mark.parametrize("argv, message", [
    (["simulate", SIM, "--tolerance", "-1e-6"], "argument --tolerance: expected a finite number > 0 and <= 0.1, found '-1e-6'"),
    (["simulate", SIM, "--tolerance", "-.5"], "argument --tolerance: expected a finite number > 0 and <= 0.1, found '-.5'"),
    (["simulate", SIM, "--t-end", "-inf"], "argument --t-end: expected a finite number > 0, found '-inf'"),
    (["simulate", SIM, "--t-end", "-1e9"], "argument --t-end: expected a finite number > 0, found '-1e9'"),
    (["simulate", SIM, "--t-end", "-nan"], "argument --t-end: expected a finite number > 0, found '-nan'"),
    (["simulate", SIM, "--steps", "-2e3"], "argument --steps: expected a whole number >= 2, found '-2e3'"),
    (["analyse", SIM, "--samples", "-1e3"], "argument --samples: expected a whole number >= 2, found '-1e3'"),
    (["optimise", JIB_DESIGN, "--seed", "-1e3"], "argument --seed: expected a whole number >= 0, found '-1e3'"),
    (["optimise", JIB_DESIGN, "--starts", "-5"], "argument --starts: expected a whole number >= 1, found '-5'"),
])
def test_a_negative_option_value_reaches_the_options_own_check(capsys, tmp_path, argv, message):
    code, err = run(capsys, *argv, *(["--out", tmp_path / "o"] if argv[0] == "optimise" else []))
    assert code == 2 and message in err, err
    assert "expected one argument" not in err and not (tmp_path / "o").exists()


def test_a_negative_number_after_a_flag_is_not_joined_to_it(capsys):
    # --table takes no value: '-1' after it stays a (bad) argument of its own
    code, err = run(capsys, "analyse", SIM, "--table", "-1")
    assert code == 2 and "unrecognized arguments: -1" in err, err


PENDULUM = """title = "a pendulum that swings for ever"
[parameters]
L = 1.0
[sweep]
name = "phi"
from = -3
to = 0
samples = 101
[points]
O = { fixed = [0, 0] }
A = { polar = ["O", "L", "phi"] }
[[bodies]]
name = "bar"
frame = ["O", "A"]
mass = 1.0
com = ["L", 0]
[gravity]
g = 9.81
[drive]
type = "rotary"
crank = ["O", "A"]
speed = 1.0
acceleration = 0.0
law = 0
inertia = 0.01
[simulation]
start = -1.0
speed = 0.0
t_end = 5.0
samples = 101
"""


def test_a_t_end_far_beyond_the_motion_is_named_as_the_cause():
    scene = optdesign.loads(PENDULUM)
    swing = optdesign.simulate(scene)   # 5 s: it swings between phi = -1 and its mirror image -(pi - 1)
    q, qd = swing.columns["q"], swing.columns["qd"]
    # energy conserved at every sample: (I + J) qd^2 / 2 + m g L sin(q), I = m L^2 = 1, J = 0.01
    energy = 0.5 * 1.01 * qd**2 + 9.81 * np.sin(q)
    assert swing.stop == "t_end" and max(abs(energy - 9.81 * math.sin(-1.0))) < 1e-5
    # it swings to the mirror image -(pi - 1) and back to -1 (simulate's located turning points
    # are samples too, each within the integration's error: 1.5e-7 measured)
    assert min(q) < -2.1 and abs(max(q) + 1.0) < 1e-6
    from optdesign.errors import SolverError

    with pytest.raises(SolverError) as caught:
        optdesign.simulate(scene, t_end=1e9)
    assert ("CVODES needed more than 20,000 steps for the 1.25e+06 s between two of its output points; if t_end is "
            "far longer than the motion you meant to follow (e.g. 1e9 s), shorten it") in str(caught.value)


def test_a_point_built_on_a_frame_of_zero_length_names_the_two_points(capsys):
    """The forestry crane of tests/data/usertrial with its boom length L = 0: the rod eye B is
    attached to the frame A -> K, and A and K coincide.  The error named 'point B (x) = NaN' and
    no cause; it now names A and K and what to check."""
    from pathlib import Path

    crane = Path(__file__).resolve().parents[1] / "data" / "usertrial" / "forestry_crane_boom.toml"
    assert main(["analyse", str(crane), "--set", "L=0"]) == 2
    err = capsys.readouterr().err
    assert "point B (x) = NaN, built from A and K, which coincide there" in err
    assert "e.g. a parameter set to 0" in err and "Traceback" not in err
