"""Engineering drawings (issue 17, piece 1): what the drawing infers from a scene (ground pivots,
joints, sliders, bars, helpers, the drive), the optional [drawing] table, the dimensions of the
design variables (found from the geometry's derivatives), and the figure files themselves
(PNG and SVG with content)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import optdesign
from optdesign.errors import SceneError
from optdesign.report.dimensions import dimensions
from optdesign.report.geometry import Geometry
from optdesign.report.mechanism import mechanism_figure, view
from optdesign.report.topology import topology

from figure_checks import check_png, check_svg

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"


def scene(name, **overrides):
    return optdesign.load(PROBLEMS / f"{name}.toml", overrides or None)


def bars(top):
    return {frozenset(b) for b in top.bars}


def test_truck_crane_roles():
    top = topology(scene("truck_crane"))
    assert sorted(top.ground) == ["A", "D"]
    assert top.joints == ["B"]
    assert top.tips == ["T"]
    assert top.helpers == set()
    assert top.drive == ("linear", ("D", "B"))
    # the boom and the rod eye's bracket (A to its foot on the boom, the foot to B); the
    # cylinder D-B is drawn as a cylinder, not a bar
    assert bars(top) == {frozenset(("A", "T")), frozenset(("A", "foot:B")), frozenset(("foot:B", "B"))}


def test_helpers_are_inferred():
    """A point above a piston or along a level platform only gives a frame's direction."""
    crank = topology(scene("seed1_slider_crank"))
    assert crank.helpers == {"U"}
    assert crank.sliders == [("C", "C", True)]           # on a ground guide
    assert frozenset(("C", "U")) not in bars(crank)
    assert frozenset(("S", "A")) in bars(crank) and crank.drive[0] == "rotary"
    lift = topology(scene("lib_scissor_lift"))
    assert lift.helpers == {"U"}
    assert lift.sliders == [("R", "R", True)]
    press = topology(scene("crank_press_peak"))
    assert press.guides == ["E"]                         # E only anchors the ram's guide
    assert "E" not in press.ground + press.joints


def test_loops_are_drawn_as_chains():
    top = topology(scene("seed2_fourbar"))
    assert {frozenset(("A", "B")), frozenset(("B", "C")), frozenset(("C", "D3"))} <= bars(top)
    assert "D" in top.ground and "A" in top.ground


DRAWN = '''title = "bar with a helper"
[parameters]
L = { value = 1.0, min = 0.5, max = 2.0 }
[sweep]
name = "t"
from = 0
to = "90 deg"
samples = 5
[points]
A = { fixed = [0, 0] }
B = { polar = ["A", "L", "t"] }
K = { polar = ["A", "L/2", "t"] }
[[bodies]]
name = "bar"
frame = ["A", "K"]
mass = 1
com = ["L/2", 0]
'''


def test_drawing_table_names_helpers():
    plain = topology(optdesign.loads(DRAWN))
    assert "K" not in plain.helpers and frozenset(("A", "K")) in bars(plain)
    marked = topology(optdesign.loads(DRAWN + '[drawing]\nhelpers = ["K"]\n'))
    assert marked.helpers == {"K"}
    assert frozenset(("A", "K")) not in bars(marked)


@pytest.mark.parametrize("table, message", [
    ('[drawing]\nhelpers = ["Kk"]\n', "line 19: [drawing] helpers: unknown point 'Kk'; did you mean 'K'?"),
    ('[drawing]\nhelpers = "K"\n', "[drawing] helpers: expected a list of point names"),
    ('[drawing]\nhelper = ["K"]\n', "unknown key 'helper'; did you mean 'helpers'?"),
])
def test_drawing_table_errors(table, message):
    with pytest.raises(SceneError) as err:
        optdesign.loads(DRAWN + table, "bar.toml")
    assert message in str(err.value)


def test_dimensions_of_the_design_variables():
    sc = scene("truck_crane")
    g = Geometry(sc)
    frame = g.frames(g.stroke(3)).at(0)
    dims = {d.name: d for d in dimensions(g, frame)}
    assert set(dims) == {"xD", "yD", "b"} and all(d.kind == "linear" for d in dims.values())
    D = frame.points["D"][0]
    np.testing.assert_allclose(dims["xD"].a, [0.0, -1.6], atol=1e-12)   # from the y axis to D
    np.testing.assert_allclose(dims["xD"].b, D)
    np.testing.assert_allclose(dims["yD"].a, [0.2, 0.0], atol=1e-12)    # from the x axis
    b = dims["b"]                                                       # along the boom
    assert math.isclose(np.hypot(*(b.b - b.a)), 0.8, rel_tol=1e-12)
    assert dims["xD"].text == "xD = 0.2 m" and dims["b"].text == "b = 0.8 m"
    # seed 1's jib: D = e (cos psi, sin psi), a length from the origin
    jib = Geometry(scene("seed1_jib"))
    frame = jib.frames(jib.stroke(2)).at(0)
    e = {d.name: d for d in dimensions(jib, frame)}["e"]
    np.testing.assert_allclose(e.a, [0, 0], atol=1e-12)
    assert math.isclose(np.hypot(*(e.b - e.a)), 1.6, rel_tol=1e-12)


def test_angle_dimension_in_the_scene_units():
    text = DRAWN.replace('B = { polar = ["A", "L", "t"] }',
                         'B = { polar = ["A", "L", "t + phi"] }').replace(
        'L = { value = 1.0, min = 0.5, max = 2.0 }',
        'L = { value = 1.0, min = 0.5, max = 2.0 }\nphi = { value = "20 deg", min = 0, max = "40 deg" }')
    g = Geometry(optdesign.loads(text))
    frame = g.frames([0.3]).at(0)
    phi = {d.name: d for d in dimensions(g, frame)}["phi"]
    assert phi.kind == "angular" and phi.text == "phi = 20 deg"
    np.testing.assert_allclose(phi.a, [0, 0], atol=1e-12)
    assert math.isclose(phi.angles[1] - phi.angles[0], math.radians(20), rel_tol=1e-12)


def test_a_stroke_that_does_not_assemble_is_drawn_where_it_does():
    g = Geometry(scene("seed2_fourbar"))
    assert g.frames(g.stroke()).assembled.all()
    g = Geometry(optdesign.loads(DRAWN.replace('K = { polar = ["A", "L/2", "t"] }',
                                               'K = { polar = ["A", "L/2", "t"] }\n'
                                               'C = { dyad = ["B", 0.3, "A", "0.5 + t"], side = "left" }')))
    frames = g.frames(np.linspace(0, math.pi / 2, 11))
    # |AB| = 1, |BC| = 0.3: C assembles while 0.7 <= 0.5 + t <= 1.3
    ok = frames.assembled
    np.testing.assert_array_equal(ok, (0.5 + frames.s >= 0.7) & (0.5 + frames.s <= 1.3))
    assert set(frames.failed[~ok]) == {"C (dyad)"}
    assert np.isnan(frames.points["C"][~ok]).all() and np.isfinite(frames.points["B"]).all()
    # a loop that Newton cannot close is named too (the four-bar driven past its range)
    g = Geometry(scene("seed2_fourbar"))
    frames = g.frames(np.linspace(0, 2 * math.pi, 73))
    assert not frames.assembled.all() and set(frames.failed[~frames.assembled]) == {"chain (loop)"}


def test_mechanism_figure_files(tmp_path):
    sc = scene("truck_crane")
    other = sc.with_parameters(xD=0.2575, yD=-1.8, b=1.031)
    png, svg = mechanism_figure([("start", sc), ("optimum", other)], [tmp_path / "m.png", tmp_path / "m.svg"],
                                suptitle=sc.title)
    check_png(png, min_size=(900, 400), min_ink=0.03)
    root = check_svg(svg, min_paths=60)
    text = " ".join(t.text or "" for t in root.iter() if t.tag.endswith("text"))
    del text  # matplotlib draws SVG text as paths by default; the PNG carries it
    one = mechanism_figure([("start", scene("lib_scissor_lift"))], [tmp_path / "s.png"])[0]
    check_png(one, min_size=(400, 300))


def test_view_marks_no_failure_on_shipped_scenes():
    for name in ("level_luffing_crane", "lib_pumpjack", "lib_toggle_press", "seed2_open_chain"):
        v = view(scene(name), samples=9)
        assert v.frames.assembled.all(), name
        assert v.ctx.extent > 0 and v.ctx.w > 0
