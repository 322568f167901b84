"""Values per stroke held exactly by the optimiser (issue 14): a stroke written as an equality
max(y) - min(y) == H or as a lower bound max(y) - min(y) >= H (held at its located extremes,
not by an epigraph), and the values at the stroke's ends, start(e) and end(e), in constraints
and objectives.

* The crank press of problems/crank_press_rms.toml eliminates its crank radius r by hand (the
  closed form of the stroke of an offset slider-crank).  Written instead with r a design
  variable and the ram stroke as an equality (and, separately, as a lower bound) it must reach
  the same optimum; the stroke at that optimum is recomputed in numpy (the slider-crank by
  hand, 20,001 samples with each extreme refined by a bounded scalar search) and must be H.
* A bar turning about a movable pivot, whose optimum under start()/end() values and located
  extremes in the objective is known in closed form.
* The syntax: start()/end() take one argument, do not nest, and only stroke expressions may
  use them.
"""
from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

import optdesign
from optdesign import ExpressionError, SceneError
from optdesign.design import optimise
from optdesign.design.problem import DesignProblem

ROOT = Path(__file__).resolve().parents[1]
PRESS = ROOT / "problems" / "crank_press_rms.toml"
STARTS = 4


# --- the crank press with its stroke as a constraint ----------------------------------------
ELIMINATED = 'r    = "H/2*sqrt(1 - 4*e^2/(4*l^2 - H^2))"      # crank radius for the stroke H [m]'


def press_with_stroke(sides=("min", "max")) -> str:
    """crank_press_rms.toml with r a design variable and the ram stroke a constraint on the
    given sides (both: an equality)."""
    text = PRESS.read_text()
    assert ELIMINATED in text
    text = text.replace(ELIMINATED, 'r    = { value = 0.05, min = 0.03, max = 0.08 }  # crank radius [m]')
    bounds = "".join(f'{side} = "H"\n' for side in sides)
    return text + f'\n[[constraints]]\nname = "ram stroke"\nexpr = "max(y(C)) - min(y(C))"\n{bounds}'


@functools.cache
def press_optimum(sides):
    if sides is None:
        return optimise(optdesign.load(PRESS), starts=STARTS, seed=0)
    return optimise(optdesign.loads(press_with_stroke(sides), "press_stroke.toml"), starts=STARTS, seed=0)


def press_stroke(design, H=0.10, samples=20001):
    """The ram's stroke in numpy: crank pin A = r (cos a, sin a), a = aBDC + phi, with aBDC =
    -pi/2 + asin(e/(l + r)) as the scene has it; the ram pin C on the vertical line x = e below
    A at |AC| = l.  Largest minus smallest y(C) over phi in [-pi, pi] on ``samples`` samples,
    each extreme refined by a bounded scalar search between its neighbours."""
    l, e, r = design["l"], design["e"], design["r"]
    a0 = -math.pi / 2 + math.asin(e / (l + r))

    def y(phi):
        a = a0 + np.asarray(phi, float)
        return r * np.sin(a) - np.sqrt(l**2 - (e - r * np.cos(a)) ** 2)

    phi = np.linspace(-math.pi, math.pi, samples)
    v = y(phi)
    out = []
    for sense in (1.0, -1.0):
        i = int(np.argmax(sense * v))
        lo, hi = phi[max(i - 1, 0)], phi[min(i + 1, samples - 1)]
        res = minimize_scalar(lambda t: -sense * y(t), bounds=(lo, hi), method="bounded", options={"xatol": 1e-13})
        out.append(sense * max(sense * v[i], -res.fun))
    return out[0] - out[1]


@pytest.mark.parametrize("sides", [("min", "max"), ("min",)], ids=["equality", "minimum"])
def test_a_stroke_constraint_gives_the_optimum_of_the_eliminated_radius(sides):
    """The ram stroke as max(y(C)) - min(y(C)) == H (or >= H: a larger crank only costs torque)
    reaches crank_press_rms's optimum (3,007.509 N m, r eliminated by the closed form of the
    stroke): the same rms torque (1e-6 relative; measured 3e-10), the same rod and offset, the
    crank radius of the closed form; every start succeeds; the stroke is H in numpy."""
    eliminated, stated = press_optimum(None), press_optimum(sides)
    assert eliminated.success and stated.success, (eliminated.status, stated.status)
    assert eliminated.objective == pytest.approx(3007.5088841, rel=1e-9)
    assert stated.objective == pytest.approx(eliminated.objective, rel=1e-6)
    assert stated.starts_at_best == STARTS, [(s.status, s.objective) for s in stated.starts]
    for name in ("l", "e"):
        assert stated.design[name] == pytest.approx(eliminated.design[name], abs=1e-5)
    l, e, H = stated.design["l"], stated.design["e"], 0.10
    assert stated.design["r"] == pytest.approx(H / 2 * math.sqrt(1 - 4 * e**2 / (4 * l**2 - H**2)), rel=1e-7)
    stroke = press_stroke(stated.design)
    assert stroke == pytest.approx(H, abs=1e-8)
    report = stated.constraints["ram stroke"]
    assert report["value"] == pytest.approx(stroke, abs=1e-10)
    assert report["active"] == "lower" and report["multiplier"] > 0  # more stroke costs torque
    assert report["lower"] == H and report["upper"] == (H if "max" in sides else None)


def test_the_stroke_is_held_at_its_located_extremes():
    """The build: a stroke with a lower bound (or an equality) holds both aggregates at their
    located extremes, with rows at every sample point; an upper bound keeps the epigraph."""
    for sides, located in ((("min", "max"), [0, 1]), (("min",), [0, 1]), (("max",), [])):
        text = press_with_stroke(sides).replace('expr = "max(-y(C))"', 'expr = "-min(y(C))"')
        pb = DesignProblem(optdesign.loads(text, "press_stroke.toml"))
        stroke = [i for i, ag in enumerate(pb.aggregates) if "ram stroke" in ag.inner.source]
        assert [i for i in pb.located if i in stroke] == [stroke[j] for j in located], sides
        for i in stroke:
            ag = pb.aggregates[i]
            assert len(pb.g_points[ag.name]) == (pb.n_points if i in pb.located else 2 + pb.settings.slots)


# --- values at the stroke's ends, and located extremes in the objective ----------------------
BAR = """
title = "A bar turning about a movable pivot"
[parameters]
L = { value = 1.5, min = 1.0, max = 2.0 }
c = { value = 0.0, min = -0.5, max = 0.5 }
[sweep]
name = "th"
from = 0
to = "TO"
samples = 41
[points]
A = { fixed = ["c", 0] }
B = { polar = ["A", "L", "th"] }
[[bodies]]
name = "bar"
frame = ["A", "B"]
mass = 1.0
com = ["L/2", 0]
[drive]
type = "rotary"
crank = ["A", "B"]
speed = 1.0
acceleration = 0.0
[[constraints]]
name = "reach at the start"
expr = "start(x(B))"
max = 2.2
[objective]
minimise = "OBJECTIVE"
"""


def bar(objective, to=1.0):
    return optdesign.loads(BAR.replace("OBJECTIVE", objective).replace('"TO"', repr(to)), "bar.toml")


def test_end_values_in_the_objective_and_a_constraint():
    """Maximise the end point's x + y, c + L (cos 1 + sin 1), with the start's reach c + L <=
    2.2: L at its bound 2, c = 0.2 on the constraint, whose multiplier is -1 (a metre more of
    reach is a metre more of c); the reported values are the ends' own."""
    res = optimise(bar("-end(x(B)) - end(y(B))"), starts=STARTS)
    assert res.success, res.status
    assert res.design["L"] == pytest.approx(2.0, abs=1e-9)
    assert res.design["c"] == pytest.approx(0.2, abs=1e-8)
    assert res.objective == pytest.approx(-(0.2 + 2 * (math.cos(1) + math.sin(1))), rel=1e-9)
    reach = res.constraints["reach at the start"]
    assert reach["value"] == pytest.approx(2.2, abs=1e-8) and reach["active"] == "upper"
    assert reach["multiplier"] == pytest.approx(-1.0, rel=1e-6)


@pytest.mark.parametrize("to", [1.0, 2.0])
def test_located_extremes_in_the_objective(to):
    """Minimise min(x(B)) - max(y(B)): both aggregates push the wrong way for an epigraph (a
    small min, a large max), so both are held at their located extremes; the answer is
    c + L cos(to) - L sin(min(to, pi/2)) at c = -0.5, L = 2 (the highest point inside the
    stroke when it passes pi/2: a slot on it)."""
    res = optimise(bar("min(x(B)) - max(y(B))", to), starts=STARTS)
    assert res.success, res.status
    L, c = 2.0, -0.5
    assert res.objective == pytest.approx(c + L * math.cos(to) - L * math.sin(min(to, math.pi / 2)), rel=1e-9)
    assert res.design == pytest.approx({"L": L, "c": c}, abs=1e-8)


def test_end_values_in_analyse():
    """analyse reports a start()/end() constraint as the value at the first/last sample."""
    scene = bar("-end(x(B))").with_parameters(L=1.25, c=0.1)
    an = optdesign.analyse(scene)
    assert an.constraints["reach at the start"] == pytest.approx(0.1 + 1.25, rel=1e-12)


# --- the syntax ------------------------------------------------------------------------------
def _scene_with(expr, where="constraint"):
    text = BAR.replace("OBJECTIVE", "-end(x(B))").replace('"TO"', "1.0")
    if where == "constraint":
        text = text.replace('expr = "start(x(B))"', f'expr = "{expr}"')
    else:
        text = text.replace('com = ["L/2", 0]', f'com = ["{expr}", 0]')
    return optdesign.loads(text, "bar.toml")


@pytest.mark.parametrize("expr, error, message", [
    ("start(x(B), y(B))", ExpressionError, r"start\(\) takes 1 argument"),
    ("end()", ExpressionError, r"end\(\) needs an argument"),
    ("start(max(x(B)))", ExpressionError, "do not nest"),
    ("max(end(x(B)))", ExpressionError, "do not nest"),
    ("start(x(B)) - x(B)", ExpressionError, "mixes one value per stroke"),
    ("strat(x(B))", ExpressionError, "did you mean 'start'"),
])
def test_stroke_end_syntax_errors(expr, error, message):
    with pytest.raises(error, match=message):
        _scene_with(expr)


def test_stroke_ends_only_in_constraints():
    with pytest.raises(SceneError, match=r"start\(\) and end\(\) the value at its first and last sample"):
        _scene_with("start(L)", where="body")
