"""[quantities]: named per-sample expressions, against the same expressions written out and an
independent numpy four-bar (closed-form dyad); their use in bodies' loads, constraints and the
objective; their columns in the CSV and the JSON; mistakes named at their line."""
import json

import numpy as np
import pytest

import optdesign
from optdesign.errors import ExpressionError, SceneError
from optdesign.report.analysis import analysis_json, analysis_table
from optdesign.report.checks import csv_text
from optdesign.report.output import to_json

SCENE = """
title = "crank-rocker with quantities"
[parameters]
a = 0.05
b = {{ value = 0.16, min = 0.12, max = 0.20 }}
c = 0.12
d = 0.15
kt = 20.0
[sweep]
name = "phi"
from = "0 deg"
to = "360 deg"
samples = 73
[points]
A = {{ fixed = [0, 0] }}
D = {{ fixed = ["d", 0] }}
B = {{ polar = ["A", "a", "phi"] }}
C = {{ dyad = ["B", "b", "D", "c"], side = "left" }}
{quantities}
[[bodies]]
name = "rocker"
frame = ["D", "C"]
inertia = 0.01
torque = "{torque}"
[drive]
type = "rotary"
crank = ["A", "B"]
speed = 10
acceleration = 0
[[constraints]]
name = "transmission"
expr = "{mu}"
min = "30 deg"
max = "150 deg"
[[constraints]]
name = "swing"
expr = "{swing}"
max = "80 deg"
[objective]
minimise = "{objective}"
"""
QUANTITIES = """[quantities]
rocker = { expr = "angle(C, D, A)", unit = "rad" }
mu = { expr = "angle(B, C, D)", unit = "rad" }
lift = { expr = "rocker - 90 deg", unit = "rad" }
"""
NAMED = dict(quantities=QUANTITIES, torque="-kt*lift", mu="mu", swing="max(rocker) - min(rocker)",
             objective="max(lift)")
WRITTEN = dict(quantities="", torque="-kt*(angle(C, D, A) - 90 deg)", mu="angle(B, C, D)",
               swing="max(angle(C, D, A)) - min(angle(C, D, A))", objective="max(angle(C, D, A) - 90 deg)")


def scene(**kw):
    return optdesign.loads(SCENE.format(**{**NAMED, **kw}), "fourbar.toml")


def fourbar(phi, a=0.05, b=0.16, c=0.12, d=0.15):
    """Independent numpy four-bar: B on the crank, C the circles' intersection on the left of B->D."""
    B = np.stack([a * np.cos(phi), a * np.sin(phi)])
    D = np.array([[d], [0.0]])
    e = D - B
    L = np.hypot(*e)
    along = (b**2 - c**2 + L**2) / (2 * L)
    h = np.sqrt(b**2 - along**2)
    u = e / L
    C = B + along * u + h * np.stack([-u[1], u[0]])
    rocker = np.arccos(np.clip(((C - D) * (-D)).sum(0) / (c * d), -1, 1))
    bc, dc = B - C, D - C
    mu = np.arccos((bc * dc).sum(0) / (b * c))
    return rocker, mu


def test_named_equals_written_and_the_independent_fourbar():
    named, written = optdesign.analyse(scene()), optdesign.analyse(optdesign.loads(SCENE.format(**WRITTEN)))
    rocker, mu = fourbar(named.columns["s"])
    assert np.max(np.abs(named.quantities["rocker"] - rocker)) < 1e-12
    assert np.max(np.abs(named.quantities["mu"] - mu)) < 1e-12
    assert np.max(np.abs(named.quantities["lift"] - (rocker - np.pi / 2))) < 1e-12
    for key in ("drive", "static_load"):   # the body's torque through the quantity
        assert np.array_equal(named.columns[key], written.columns[key])
    assert np.array_equal(named.constraints["transmission"], written.constraints["transmission"])
    assert named.constraints["swing"] == pytest.approx(written.constraints["swing"], abs=1e-14)
    # virtual work of the torque -kt*lift on the rocker, whose frame angle D->C is pi - rocker:
    # T_Su = -(-kt*lift) * d(pi - rocker)/dphi = -kt*lift*drocker/dphi (central differences of the numpy model)
    s = named.columns["s"]
    h = 1e-6
    dpsi = (fourbar(s + h)[0] - fourbar(s - h)[0]) / (2 * h)
    assert np.max(np.abs(named.columns["static_load"] + 20.0 * (rocker - np.pi / 2) * dpsi)) < 1e-8


def test_quantities_in_the_json_and_the_csv():
    result = optdesign.analyse(scene())
    doc = json.loads(to_json(analysis_json(result)))
    assert doc["quantity_units"] == {"rocker": "rad", "mu": "rad", "lift": "rad"}
    first = doc["samples"][0]["quantities"]
    assert first["rocker"] == pytest.approx(result.quantities["rocker"][0], abs=0)
    header = analysis_table(result).splitlines()[0].split()
    assert {"rocker", "mu", "lift"} <= set(header)
    rows = csv_text(result).splitlines()
    assert {"rocker [rad]", "mu [rad]", "lift [rad]"} <= set(rows[0].split(","))
    column = rows[0].split(",").index("rocker [rad]")
    assert [float(r.split(",")[column]) for r in rows[1:]] == list(result.quantities["rocker"])


def test_quantity_in_the_objective():
    from optdesign.design.problem import DesignProblem

    named, written = DesignProblem(scene()), DesignProblem(optdesign.loads(SCENE.format(**WRITTEN)))
    x = np.array([0.15])
    assert named.objective_kind == written.objective_kind == "expression"
    a, b = (np.asarray(pb.evaluate_grid(x)) for pb in (named, written))
    assert a.shape == b.shape and np.array_equal(a, b)


@pytest.mark.parametrize("quantities, error, words", [
    ('[quantities]\nrocker = "lift + 1"\nlift = "angle(C, D, A)"\n', ExpressionError,
     ["line 20", "[quantities] rocker", "'lift' is defined further down"]),
    ('[quantities]\nrocker = "rocker + 1"\n', ExpressionError, ["is defined further down (or is this quantity itself)"]),
    ('[quantities]\nkt = "angle(C, D, A)"\n', SceneError, ["the quantity 'kt' has the name of a parameter"]),
    ('[quantities]\nC = "x(B)"\n', SceneError, ["the quantity 'C' has the name of a point"]),
    ('[quantities]\nrocker = "max(x(C))"\n', ExpressionError, ["[quantities] rocker", "min() or max() with one argument"]),
    ('[quantities]\nrocker = { expr = "x(C)", units = "m" }\n', SceneError, ["unknown key 'units'"]),
    ('[quantities]\nrocker = { expr = "x(E)" }\n', ExpressionError, ["no point 'E' is constructed"]),
    ('[quantities]\nrocker = 3\nlift = "x(C)"\nmu = { expr = "x(C)", unit = 5 }\n', SceneError,
     ["[quantities] mu", "expected the unit as a string"]),
])
def test_mistakes_name_the_quantity(quantities, error, words):
    with pytest.raises(error) as info:
        scene(quantities=quantities)
    for w in words:
        assert w in str(info.value), str(info.value)


def test_quantities_figure(tmp_path):
    from optdesign.report.analysis import analysis_figures

    written = analysis_figures(optdesign.analyse(scene()), tmp_path / "figures")
    assert tmp_path / "figures" / "quantities.png" in [p for p in map(type(tmp_path), written)]
    assert (tmp_path / "figures" / "quantities.png").stat().st_size > 10_000
