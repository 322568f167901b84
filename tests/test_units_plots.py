"""Plots and checks in the user's units (issue 17, piece 4): the sweep in deg where the scene
wrote deg, loads in kN where large, angle constraints in deg where their bounds were; every
violated constraint named with how far and where (checked against the angle computed here from
the points); the CSV's headers carry units; the stroke figure draws bounds, shades the feasible
side and paints the violation red."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import optdesign
from optdesign.report.checks import csv_text, summary_lines, violation_text, violations
from optdesign.report.stroke_plots import stroke_figure
from optdesign.report.units import number, quantity, scaled, sweep_label, sweep_unit

from figure_checks import check_png

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"


def test_units_as_written():
    truck = optdesign.load(PROBLEMS / "truck_crane.toml")
    assert sweep_unit(truck) == "deg" and sweep_label(truck) == "theta [deg]"
    crank = optdesign.load(PROBLEMS / "seed1_slider_crank.toml")
    assert sweep_unit(crank) == "rad"                      # to = "2*pi"
    assert scaled([171492.2], "N") == (1e-3, "kN") and scaled([9999.0], "N") == (1.0, "N")
    assert scaled([2.5e7], "N m") == (1e-6, "MN m")
    assert quantity(171492.2, "N") == "171.5 kN" and quantity(14816.4, "N m", 5) == "14.816 kN m"
    assert number(6380.4, 3) == "6380" and number(1.2e-7) == "1.2e-07" and number(0.02541, 3) == "0.0254"


def _angle_DBA(scene):
    from optdesign.kinematics.mechanism import kinematics

    k = kinematics(scene)
    A, B, D = (np.stack([k.points[n]["x"], k.points[n]["y"]], axis=1) for n in "ABD")
    u, v = D - B, A - B
    return k.s, np.arccos(np.einsum("ij,ij->i", u, v) / np.hypot(*u.T) / np.hypot(*v.T))


def test_a_violated_constraint_is_named_with_how_far_and_where():
    scene = optdesign.load(PROBLEMS / "seed1_jib.toml")      # its start breaks its own 30 deg minimum
    result = optdesign.analyse(scene)
    found = violations(result)
    assert [(v["name"], v["bound"]) for v in found] == [("transmission angle", "min")]
    v = found[0]
    s, angle = _angle_DBA(scene)
    worst = int(np.argmin(angle))
    assert v["worst"] == pytest.approx(angle.min(), abs=1e-6)      # certified: no lower than the samples
    assert v["worst"] <= angle.min() + 1e-12
    assert v["by"] == pytest.approx(math.radians(30) - v["worst"], rel=1e-12)
    assert v["at"] == pytest.approx(s[worst], abs=(s[1] - s[0]))
    bad = s[angle < math.radians(30)]
    assert v["from"] == pytest.approx(bad.min()) and v["to"] == pytest.approx(bad.max())
    assert v["unit"] == "deg"
    text = violation_text(result, v)
    assert text.startswith("transmission angle: below its min 30 deg by 1.0")
    assert f"violated for theta = {number(bad.min())} .. {number(bad.max())}" in text
    lines = summary_lines(result)
    assert any(line.startswith("transmission angle: 28.9") and line.endswith("VIOLATED") for line in lines)
    assert any(line.startswith("cylinder length ratio: 1.45") and line.endswith(": ok") for line in lines)
    assert any(line.startswith("peak |drive| = 13.70") and " kN at theta = " in line for line in lines)
    # a design that keeps its constraints has none
    assert violations(optdesign.analyse(scene.with_parameters(e=3.0, b=4.0))) == []


def test_per_stroke_violation():
    scene = optdesign.load(PROBLEMS / "truck_crane.toml", {"b": 0.6, "xD": 0.0, "yD": -0.4})
    found = {(v["name"], v["bound"]): v for v in violations(optdesign.analyse(scene))}
    ratio = found.get(("cylinder length ratio", "max"))
    assert ratio is not None and ratio["at"] is None and ratio["by"] == pytest.approx(ratio["worst"] - 1.7)


def test_csv_headers_carry_units():
    result = optdesign.analyse(optdesign.load(PROBLEMS / "truck_crane.toml"))
    text = csv_text(result)
    head = text.splitlines()[0].split(",")
    assert head[0] == "theta [deg]" and "drive [N]" in head and "transmission angle [deg]" in head
    rows = np.array([[float(x) for x in line.split(",")] for line in text.splitlines()[1:]])
    assert rows.shape == (161, len(head))
    np.testing.assert_allclose(rows[[0, -1], 0], [-10.0, 70.0], rtol=1e-12)
    np.testing.assert_allclose(rows[:, head.index("drive [N]")], result.columns["drive"], rtol=1e-15)


def test_stroke_figure_shows_bounds_and_the_violation(tmp_path):
    from PIL import Image

    scene = optdesign.load(PROBLEMS / "seed1_jib.toml")
    runs = [("start", optdesign.analyse(scene)), ("optimum", optdesign.analyse(scene.with_parameters(e=3.0, b=4.0)))]
    path = stroke_figure(runs, tmp_path / "s.png", components=True)
    check_png(path, min_size=(800, 600))
    rgb = np.asarray(Image.open(path).convert("RGB"), dtype=int)
    red = np.all(np.abs(rgb - [0xD6, 0x27, 0x28]) < 40, axis=2).sum()
    shade = np.all(np.abs(rgb - [233, 243, 233]) < 6, axis=2).mean()    # the feasible band, light green
    assert red > 150 and shade > 0.05


def test_study_figure_draws_round_off_flat():
    """A quantity a study's axis does not change, equal to 1e-11 relative, is drawn flat (was
    plotted as a trend on an offset axis); a real change is drawn as it is."""
    import numpy as np

    from optdesign.report.study import flat

    noise = 171492.2 * (1 + 1e-11 * np.array([0.0, 3.0, -2.0, 5.0]))
    assert np.ptp(flat(noise)) == 0 and flat(noise)[0] == pytest.approx(171492.2, rel=1e-10)
    real = np.array([1.0, 1.0 + 1e-6, 1.0 + 2e-6])
    assert np.array_equal(flat(real), real)
    with_nan = np.array([2.0, np.nan, 2.0 * (1 + 1e-12)])
    out = flat(with_nan)
    assert np.isnan(out[1]) and out[0] == out[2]


def test_study_summary_has_a_compact_table_of_its_cases():
    """summary.txt of a study lists its cases (was counts alone): the axes' columns and the
    objective with the design, one line per case, the rest left to cases.csv."""
    from types import SimpleNamespace

    from optdesign.study.execute import case_table

    study = SimpleNamespace(mode="optimise", axes=[SimpleNamespace(columns=("mP",))])
    rows = [{"case": k, "mP": 1000.0 * k, "objective": 171492.2 + k, "design:xD": 0.5, "success": True}
            for k in range(40)]
    lines = case_table(study, rows, shown=30)
    assert lines[0] == "cases:" and lines[1].split() == ["case", "mP", "objective", "design:xD"]
    assert lines[2].split() == ["0", "0", "171492", "0.5"] and lines[3].split()[:3] == ["1", "1000", "171493"]
    assert len(lines) == 2 + 30 + 1 and lines[-1] == "  ... 10 more in cases.csv"


def test_a_one_axis_study_figure_draws_its_cases(tmp_path, monkeypatch):
    """A study of one axis draws one line of its cases in each panel (with the rows held column
    by column, no outer axis made no group: the figure came out empty)."""
    from types import SimpleNamespace

    import optdesign.report.study as study_figures
    from optdesign.study.rows import Rows

    drawn = {}

    def capture(fig, path, label=""):
        drawn.update({ax.get_ylabel(): [line.get_ydata().tolist() for line in ax.get_lines()] for ax in fig.axes})
        return path

    monkeypatch.setattr(study_figures, "save_figure", capture)
    scene = SimpleNamespace(title="a bar", drive=SimpleNamespace(kind="rotary"), objective=None)
    axis = SimpleNamespace(column="m", label="m", kind="values")
    study = SimpleNamespace(mode="analyse", axes=[axis], scene=scene)
    rows = Rows([{"case": k, "m": float(k), "peak:drive": 10.0 + k, "rms:drive": 5.0 + k, "success": True}
                 for k in range(3)])
    study_figures.figures(study, rows, tmp_path)
    assert drawn["peak drive torque [N m]"] == [[10.0, 11.0, 12.0]]
    assert drawn["rms:drive"] == [[5.0, 6.0, 7.0]]
