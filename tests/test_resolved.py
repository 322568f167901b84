"""The resolved scene (optdesign.scene.ResolvedScene): the numbers and symbols the pipeline takes
from a scene, made once.  Its values are the scene's own (Scene.parameter_values, the stroke of
[sweep]) and its symbols evaluate to them."""
from __future__ import annotations

from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from optdesign import Mechanism
from optdesign.scene import ResolvedScene, load, loads, parse

ROOT = Path(__file__).resolve().parents[1]
SCENES = sorted(p for p in (ROOT / "problems").glob("*.toml"))

DERIVED = '''title = "a crank with derived parameters"
[parameters]
r = { value = 0.1, min = 0.05, max = 0.2 }
l = "4*r"
k = 2.0
m = "k*l + 1"
[sweep]
name = "alpha"
from = "10 deg"
to = "k*pi"
samples = 7
[points]
A = { fixed = [0, 0] }
B = { polar = ["A", "r", "alpha"] }
'''


@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.stem)
def test_values_and_symbols_are_the_scenes(path):
    scene = load(path)
    res = ResolvedScene(scene)
    values = scene.parameter_values()
    assert res.values == values
    leaves = [p.name for p in scene.parameters if not p.value.names()]
    assert res.leaf_names == tuple(leaves)
    assert np.array_equal(res.leaf_values, [values[n] for n in leaves])
    assert {k: float(v) for k, v in res.environment(res.leaf_values).items()} == values
    p, env = res.symbols(ca.SX)
    f = ca.Function("env", [p], [ca.vertcat(*env.values())] if env else [ca.DM(0, 1)])
    np.testing.assert_allclose(np.asarray(f(res.leaf_values)).ravel(), [values[n] for n in env], rtol=1e-14)
    start = res.constant(scene.sweep.start, "from")
    assert np.array_equal(res.stroke(), np.linspace(start, res.constant(scene.sweep.stop, "to"), scene.sweep.samples))
    mech = Mechanism(res)
    assert mech.resolved is res and mech.scene is scene
    assert mech.parameter_names == res.leaf_names and np.array_equal(mech.parameter_values, res.leaf_values)


def test_derived_parameters_design_dependence_and_fixed_values():
    res = ResolvedScene(loads(DERIVED))
    assert res.leaf_names == ("r", "k") and res.design_names == ("r",)
    assert res.values == {"r": 0.1, "l": 0.4, "k": 2.0, "m": 2 * 0.4 + 1}
    assert (res.start, res.stop, res.samples) == (np.pi / 18, 2 * np.pi, 7)
    assert res.depends_on(parse("m + 1"), {"r"}) and not res.depends_on(parse("k + 1"), {"r"})
    assert res.fixed_value(parse("k*pi")) == 2 * np.pi
    assert res.fixed_value(parse("m")) is None          # through l, on the design variable r
    assert res.fixed_value(parse("alpha")) is None      # the sweep
    assert res.fixed_value(parse("x(B)")) is None       # a point
    env = res.environment(np.array([0.2, 3.0]))
    assert env["l"] == pytest.approx(0.8) and env["m"] == pytest.approx(3.4)


def test_a_mechanism_of_a_scene_resolves_it_once():
    scene = loads(DERIVED)
    mech = Mechanism(scene)
    assert isinstance(mech.resolved, ResolvedScene) and mech.resolved.scene is scene
    assert np.array_equal(mech.stroke(), mech.resolved.stroke())
