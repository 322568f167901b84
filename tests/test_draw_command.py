"""`optdesign draw` (issue 17, pieces 2 and 6): the preview of a scene with every point labelled
at the start and a few stroke positions, also where the stroke does not fully assemble (marked
in the figure and said on the console), an optimised design from its result.json, and the
geometry at chosen positions as DXF (read back with ezdxf, entities counted) and SVG."""
from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from optdesign.cli import main as cli

from figure_checks import check_png

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"
TRUCK = str(PROBLEMS / "truck_crane.toml")

# a bar with a rocker whose dyad assembles only for 0.7 <= 0.5 + t <= 1.3 (t in rad)
PARTLY = '''title = "a dyad that stops assembling"
[parameters]
L = 1.0
[sweep]
name = "t"
from = 0
to = "90 deg"
samples = 41
[points]
A = { fixed = [0, 0] }
B = { polar = ["A", "L", "t"] }
C = { dyad = ["B", 0.3, "A", "0.5 + t"], side = "left" }
[[bodies]]
name = "bar"
frame = ["A", "B"]
mass = 2
com = ["L/2", 0]
'''


def test_preview_of_a_shipped_scene(tmp_path, capsys):
    out = tmp_path / "p.png"
    assert cli.main(["draw", TRUCK, "--out", str(out)]) == 0
    check_png(out, min_size=(1000, 800), min_ink=0.03)
    assert "assembles over the whole stroke" in capsys.readouterr().out


def test_preview_where_the_stroke_stops_assembling(tmp_path, capsys):
    scene = tmp_path / "partly.toml"
    scene.write_text(PARTLY)
    out = tmp_path / "p.svg"
    assert cli.main(["draw", str(scene), "--out", str(out), "--positions", "0,0.5,1"]) == 0
    said = capsys.readouterr().out
    # 0.5 + t < 0.7 below t = 0.2 rad = 11.46 deg, > 1.3 above t = 0.8 rad = 45.84 deg: the samples
    # (every 0.45 deg) next inside are 11.7 and 45.45 deg
    assert "does not assemble at the start ([points] C (dyad))" in said
    assert "assembles again from t = 11.7 deg" in said
    assert "stops assembling after t = 45.45 deg ([points] C (dyad))" in said
    root = ET.parse(out).getroot()
    assert root.tag.endswith("svg")
    png = tmp_path / "p.png"
    assert cli.main(["draw", str(scene), "--out", str(png)]) == 0
    check_png(png)
    from PIL import Image

    rgb = np.asarray(Image.open(png).convert("RGB"), dtype=int)
    red = np.all(np.abs(rgb - [0xD9, 0x53, 0x4F]) < 8, axis=2).mean()
    green = np.all(np.abs(rgb - [0x5C, 0xB8, 0x5C]) < 8, axis=2).mean()
    assert red > 0.005 and green > 0.002  # the stroke bar: red where it does not assemble


def test_default_file_is_outside_the_project(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["draw", TRUCK]) == 0
    check_png(tmp_path / "optdesign-results" / "truck_crane-draw.png")


def test_design_from_a_result_file(tmp_path, capsys):
    result = tmp_path / "result.json"
    result.write_text(json.dumps({"design": {"xD": 0.2575, "yD": -1.8, "b": 1.031}}))
    out = tmp_path / "opt.png"
    assert cli.main(["draw", TRUCK, "--design", str(result), "--out", str(out)]) == 0
    check_png(out)
    result.write_text(json.dumps({"design": {"xd": 0.2}}))
    assert cli.main(["draw", TRUCK, "--design", str(result), "--out", str(out)]) == 2
    assert "the scene has no parameter 'xd'" in capsys.readouterr().err
    result.write_text("[1, 2]")
    assert cli.main(["draw", TRUCK, "--design", str(result), "--out", str(out)]) == 2
    assert "no 'design' table" in capsys.readouterr().err


@pytest.mark.parametrize("positions", ["0,1.5", "a,b", "-1"])
def test_bad_positions(tmp_path, capsys, positions):
    assert cli.main(["draw", TRUCK, "--out", str(tmp_path / "p.png"), "--positions", positions]) == 2
    assert "--positions" in capsys.readouterr().err


def test_dxf_and_svg_at_chosen_positions(tmp_path):
    import ezdxf

    dxf, svg = tmp_path / "out.dxf", tmp_path / "out.svg"
    assert cli.main(["draw", TRUCK, "--dxf", str(dxf), "--svg", str(svg), "--positions", "0,0.5,1"]) == 0
    assert not (tmp_path / "optdesign-results").exists()
    doc = ezdxf.readfile(dxf)
    assert doc.header["$INSUNITS"] == 4
    layers = {layer.dxf.name: layer.description for layer in doc.layers if layer.dxf.name.startswith("POS")}
    assert layers == {"POS1": "theta = -10 deg", "POS2": "theta = 30 deg", "POS3": "theta = 70 deg"}
    count = Counter((e.dxftype(), e.dxf.layer) for e in doc.modelspace())
    for layer in layers:
        # 3 bars (boom, bracket's two legs), 2 ground crosses of 2 lines, the cylinder's axis and
        # its barrel's 2 sides; 3 pins and 2 centres of mass; the position and 4 point names
        assert count["LINE", layer] == 3 + 4 + 1 + 2
        assert count["CIRCLE", layer] == 3 + 2
        assert count["POINT", layer] == 2
        assert count["TEXT", layer] == 1 + 4
    # the boom's tip T at theta = 30 deg, in mm
    texts = [e for e in doc.modelspace() if e.dxftype() == "TEXT" and e.dxf.layer == "POS2"]
    assert {t.dxf.text for t in texts} == {"theta = 30 deg", "A", "B", "D", "T"}
    lines = [e for e in doc.modelspace() if e.dxftype() == "LINE" and e.dxf.layer == "POS2"]
    tip = np.array([6000 * np.cos(np.radians(30)), 6000 * np.sin(np.radians(30))])
    assert any(np.allclose([e.dxf.end.x, e.dxf.end.y], tip) or np.allclose([e.dxf.start.x, e.dxf.start.y], tip)
               for e in lines)
    root = ET.parse(svg).getroot()
    groups = [g for g in root if g.tag.endswith("g")]
    assert [g.get("id") for g in groups] == ["POS1", "POS2", "POS3"]
    assert all(len([e for e in g if e.tag.endswith("line")]) == 10 for g in groups)
