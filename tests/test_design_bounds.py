"""DesignProblem.with_bounds: other constraint bounds on the same built NLP (no rebuild).

References are independent of with_bounds: a fresh build of the scene whose constraints carry
the new bounds (written here with dataclasses.replace, optimised by the front door
optimise()), finite differences of the optimum in the bound for the multipliers' meaning
(dJ*/d bound), and the scene's own numbers.  Every solve here is certified over the continuous
stroke; IPOPT's tol is 1e-10 on the scaled problem, so two builds that differ only in a row's
scale agree to about 1e-10 relative in the objective (tests: 1e-7, as tests/test_study.py).
"""
from __future__ import annotations

import dataclasses
import math
import threading
from pathlib import Path

import numpy as np
import pytest

import optdesign
from optdesign.study import tasks as study_run
from optdesign.design.problem import DesignProblem
from optdesign.errors import SceneError
from optdesign.design.multistart import draw_starts, optimise, solve_start, summarise
from optdesign.design.repair import Repair
from optdesign.design.solver import Solver
from optdesign.study import Study, pareto

ROOT = Path(__file__).resolve().parents[1]
CRANE = ROOT / "problems" / "truck_crane.toml"
PRESS = ROOT / "problems" / "crank_press_peak.toml"
STARTS = 3
DEG = math.pi / 180


@pytest.fixture(scope="module")
def crane():
    scene = optdesign.load(CRANE)
    pb = DesignProblem(scene)
    return scene, pb, Repair(pb)


@pytest.fixture(scope="module")
def press():
    scene = optdesign.load(PRESS)
    pb = DesignProblem(scene)
    return scene, pb, Repair(pb)


def scene_with(scene, name, side, value):
    """The scene with one bound replaced, written independently of the code under test
    (``None`` opens the side)."""
    key = "lower" if side == "min" else "upper"
    text = None if value is None else repr(float(value))
    constraints = tuple(dataclasses.replace(c, **{key: text}) if c.name == name else c for c in scene.constraints)
    assert any(c.name == name for c in scene.constraints)
    return dataclasses.replace(scene, constraints=constraints)


def solve(pb, repair, starts=STARTS, xs=None):
    """optimise() on a given problem: the same starts, a fresh Solver (nothing learned)."""
    solver = Solver(pb)
    xs = draw_starts(pb, starts, 0) if xs is None else np.atleast_2d(xs)
    runs = [solve_start(solver, repair, i, x) for i, x in enumerate(xs)]
    return summarise(pb, solver, [r for r, _ in runs], [s for _, s in runs], {})


def assert_same_optimum(got, fresh, name):
    assert got.success and fresh.success
    assert got.objective == pytest.approx(fresh.objective, rel=1e-7)
    for k, v in fresh.design.items():
        assert got.design[k] == pytest.approx(v, abs=1e-6)
    mine, ref = got.constraints[name], fresh.constraints[name]
    for side in ("lower", "upper"):      # the reported bounds are the new ones (physical units)
        assert (mine[side] is None) == (ref[side] is None)
        if ref[side] is not None:
            assert mine[side] == pytest.approx(ref[side], rel=1e-14)
    # multipliers per unit of the physical bound: the same whatever the row's scale
    assert mine["multiplier"] == pytest.approx(ref["multiplier"], rel=1e-5, abs=1e-9 * abs(fresh.objective))


# --- equal to a fresh build -----------------------------------------------------------------------
CRANE_CASES = [
    # tighter than the scene's 25 deg: active, the optimum moves
    ("transmission angle", "min", 30 * DEG),
    # looser than the scene's 25 deg: the optimum goes below 25 deg, which the continuous check
    # (reading the blocks' bounds) must accept
    ("transmission angle", "min", 20 * DEG),
    # a stroke constraint (max(L)/min(L)), tighter: active
    ("cylinder length ratio", "max", 1.6),
    # below the scene's 155 deg, which set this row's scale: a fresh build scales it otherwise
    ("transmission angle", "max", 86 * DEG),
    # the side opened (a fresh build of a scene without that side)
    ("transmission angle", "max", None),
]


@pytest.mark.parametrize("name, side, value", CRANE_CASES)
def test_truck_crane_with_bounds_equals_a_fresh_build(crane, name, side, value):
    scene, pb, repair = crane
    target = scene_with(scene, name, side, value)
    derived = pb.with_bounds(((name, side, math.inf if value is None and side == "max" else value),))
    assert derived.solver is pb.solver and derived.mech is pb.mech      # shared, not rebuilt
    assert derived.scene.constraints == target.constraints
    got = solve(derived, repair)
    fresh = optimise(target, starts=STARTS)
    assert_same_optimum(got, fresh, name)
    if value == 20 * DEG:   # the relaxed bound is used, not the build's 25 deg
        assert got.constraints[name]["min"] < 24.5 * DEG


@pytest.mark.parametrize("name, side, value", [
    ("rod angle to the ram line", "max", 8 * DEG),     # per sample, tighter (active)
    ("rod angle to the ram line", "max", 12 * DEG),    # per sample, looser (scale from the build's 10 deg)
    ("ram pin depth", "max", 0.44),                    # max(-y(C)) over the stroke, tighter
])
def test_crank_press_with_bounds_equals_a_fresh_build(press, name, side, value):
    scene, pb, repair = press
    got = solve(pb.with_bounds(((name, side, value),)), repair)
    fresh = optimise(scene_with(scene, name, side, value), starts=STARTS)
    assert_same_optimum(got, fresh, name)
    assert got.constraints[name]["value"] == pytest.approx(value, abs=1e-7)  # active: on the new bound


def test_stroke_bounds_are_bit_for_bit_a_fresh_build(crane):
    """A stroke constraint's scale does not depend on its bounds: the derived problem passes
    IPOPT exactly what a fresh build passes (what keeps a Pareto study's numbers as before)."""
    scene, pb, repair = crane
    target = scene_with(scene, "cylinder length ratio", "max", 1.55)
    derived = pb.with_bounds((("cylinder length ratio", "max", 1.55),))
    fresh = DesignProblem(target)
    assert np.array_equal(derived.lbg, fresh.lbg) and np.array_equal(derived.ubg, fresh.ubg)
    assert derived.blocks == fresh.blocks
    a, b = solve(derived, repair), solve(fresh, Repair(fresh))
    assert a.objective == b.objective and a.design == b.design


def test_the_base_problem_is_left_as_it_was(crane):
    scene, pb, _ = crane
    lbg, ubg, blocks = pb.lbg.copy(), pb.ubg.copy(), list(pb.blocks)
    derived = pb.with_bounds((("transmission angle", "min", 35 * DEG), ("cylinder length ratio", "max", 1.5)))
    assert not np.array_equal(derived.lbg, lbg) and not np.array_equal(derived.ubg, ubg)
    assert np.array_equal(pb.lbg, lbg) and np.array_equal(pb.ubg, ubg) and pb.blocks == blocks
    assert pb.scene is scene and pb.constraint_bounds("cylinder length ratio") == (-math.inf, 1.7)
    assert derived.constraint_bounds("cylinder length ratio") == (-math.inf, 1.5)
    assert derived.constraint_bounds("transmission angle") == (35 * DEG, 155 * DEG)
    # what either builds on first use is built once for both
    assert derived.warm_solver is pb.warm_solver
    # expressions are evaluated with the scene's values: "35 deg" is 35 * pi / 180
    assert pb.with_bounds((("transmission angle", "min", "35 deg"),)).constraint_bounds("transmission angle")[0] \
        == pytest.approx(35 * DEG, rel=1e-15)


# --- the multipliers keep their meaning -----------------------------------------------------------
@pytest.mark.parametrize("problem, name, side, value", [
    ("crane", "transmission angle", "min", 30 * DEG),
    ("crane", "cylinder length ratio", "max", 1.6),
    ("press", "rod angle to the ram line", "max", 8 * DEG),
])
def test_multiplier_is_the_derivative_of_the_optimum_in_the_bound(request, problem, name, side, value):
    """multiplier = dJ*/d(bound) in physical units; central differences of two with_bounds
    solves, started at the optimum (h = 1e-4 of the bound: truncation ~h^2, IPOPT's 1e-10
    relative objective error over 2h ~1e-6 relative)."""
    _, pb, repair = request.getfixturevalue(problem)
    res = solve(pb.with_bounds(((name, side, value),)), repair)
    multiplier = res.constraints[name]["multiplier"]
    assert res.constraints[name]["active"] is not None and multiplier != 0
    x = [res.design[k] for k in pb.design_names]
    h = 1e-4 * abs(value)
    up, down = (solve(pb.with_bounds(((name, side, value + d),)), repair, xs=x) for d in (h, -h))
    derivative = (up.objective - down.objective) / (2 * h)
    assert multiplier == pytest.approx(derivative, rel=1e-4)


# --- a Pareto study builds once ------------------------------------------------------------------
def test_pareto_study_builds_one_problem_and_equals_fresh_optimisations(tmp_path, crane, monkeypatch):
    scene = crane[0]
    monkeypatch.setattr(study_run, "_LOCAL", threading.local())     # an empty per-process cache
    builds = []
    init = DesignProblem.__init__

    def counting(self, *args, **kwargs):
        builds.append(1)
        init(self, *args, **kwargs)

    monkeypatch.setattr(DesignProblem, "__init__", counting)
    bounds = [1.5, 1.6, 1.8]
    result = Study(scene, [pareto("cylinder length ratio", bounds)], starts=STARTS, warm=False).run(
        out=tmp_path, workers=1, figures=False)
    assert len(builds) == 1
    monkeypatch.setattr(DesignProblem, "__init__", init)
    for eps, row in zip(bounds, result.rows):
        fresh = optimise(scene_with(scene, "cylinder length ratio", "max", eps), starts=STARTS)
        # a stroke constraint: bit for bit (test_stroke_bounds_are_bit_for_bit_a_fresh_build)
        assert row["objective"] == fresh.objective
        assert [row[f"design:{k}"] for k in fresh.design] == list(fresh.design.values())


# --- what with_bounds refuses, clearly -----------------------------------------------------------
@pytest.mark.parametrize("bounds, message", [
    ((("transmision angle", "min", 0.5),), r"no constraint 'transmision angle'; did you mean 'transmission angle'"),
    ((("transmission angle", "lower", 0.5),), r"'transmission angle' lower: the side must be 'min' or 'max'"),
    ((("transmission angle", "min", 2.0), ("transmission angle", "max", 1.0)), r"min = 2 exceeds max = 1"),
    ((("transmission angle", "min", -math.inf), ("transmission angle", "max", math.inf)), r"both sides would be open"),
    ((("transmission angle", "min", math.nan),), r"expected a finite number"),
    ((("transmission angle", "min", 0.3), ("transmission angle", "min", 0.4)), r"given twice"),
    ((("transmission angle", "min", "30 dg"),), r"transmission angle"),
])
def test_unsupported_bounds_fail_with_a_clear_message(crane, bounds, message):
    with pytest.raises(SceneError, match=message):
        crane[1].with_bounds(bounds)


@pytest.mark.parametrize("value", [1.7, 1.6])
def test_a_side_that_needs_the_located_extremes_is_a_fresh_build(crane, value):
    """A lower bound on max(L)/min(L) asks a max to be large, which an epigraph cannot hold:
    the scene's own build has an upper bound only (an epigraph), so with_bounds gives a fresh
    build of the new scene, whose aggregates are held at their located extremes; its optimum is
    the fresh build's through the front door.  The ratio fixed (min = max) at the scene's 1.7
    (active at the scene's optimum: the same optimum) and at 1.6 (a shorter stroke: a worse
    optimum, the ratio on its value)."""
    scene, pb, repair = crane
    new = pb.with_bounds([("cylinder length ratio", "min", value), ("cylinder length ratio", "max", value)])
    assert new.solver is not pb.solver and new.located == [0, 1] and pb.located == []
    reference = scene_with(scene_with(scene, "cylinder length ratio", "min", value), "cylinder length ratio", "max", value)
    fresh = optimise(reference, starts=STARTS)
    got = solve(new, Repair(new))
    assert_same_optimum(got, fresh, "cylinder length ratio")
    assert got.constraints["cylinder length ratio"]["value"] == pytest.approx(value, rel=1e-8)
    free = optimise(scene, starts=STARTS).objective
    if value == 1.7:
        assert got.objective == pytest.approx(free, rel=1e-7)
    else:
        assert got.objective > free * (1 + 1e-3)