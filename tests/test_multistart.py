"""The multistart (issue 14): space-filling screened starts, phase 1 before the objective, each
start independent of the others, distinct local optima, infeasibility only when phase 1 fails
everywhere, unbounded design variables refused, warm study cases falling back to a cold
multistart.  Small and fast: seed 1's jib design (two local optima 0.6 % apart) and the truck
crane."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import optdesign
from optdesign.design import multistart
from optdesign.design.clusters import few
from optdesign.design.multistart import draw_plan, solve_start
from optdesign.design.problem import DesignProblem
from optdesign.design.repair import Repair
from optdesign.design.solver import Solver
from optdesign.design.starts import plan_starts, space_filling
from optdesign.errors import SceneError
from optdesign.report.design import optimisation_json, summary

ROOT = Path(__file__).resolve().parents[1]
JIB = ROOT / "problems" / "seed1_jib_design.toml"
CRANE = ROOT / "problems" / "truck_crane.toml"
GLOBAL_JIB = 11294.3637   # e = 3 (bound), b = 1.8927; the local optimum: 11359.617 at e = 2.116, b = 2.397


def _same(a, b):
    """Two start reports agree in everything but their timing (and the optimum's index, which
    summarise gives)."""
    da, db = dataclasses.asdict(a), dataclasses.asdict(b)
    for key in ("time_s", "optimum"):
        da.pop(key), db.pop(key)
    return da == db


def test_plan_starts_with_the_scene_start_and_is_reproducible():
    pb = DesignProblem(optdesign.load(JIB))
    a, b, c = plan_starts(pb, 8, 0), plan_starts(pb, 8, 0), plan_starts(pb, 8, 1)
    np.testing.assert_array_equal(a.points[0], pb.start)
    np.testing.assert_array_equal(a.points, b.points)
    np.testing.assert_array_equal(a.reserve, b.reserve)
    assert not np.array_equal(a.points[1:], c.points[1:])
    assert a.screened >= 1024 and len(a.reserve) == a.screened - 7
    assert np.all((a.points >= pb.lower) & (a.points <= pb.upper))
    # the space-filling sample itself: scrambled Sobol points in the box, by the seed
    x = space_filling(pb, 64, 3)
    assert x.shape == (64, 2) and np.all((x >= pb.lower) & (x <= pb.upper))
    np.testing.assert_array_equal(x, space_filling(pb, 64, 3))


def test_each_start_is_independent_of_the_others():
    """A start gives the same report alone, in reverse order, or among forked workers."""
    scene = optdesign.load(JIB)
    serial = optdesign.optimise(scene, 6, 0)
    forked = optdesign.optimise(scene, 6, 0, workers=2)
    pb = DesignProblem(scene)
    solver, repair = Solver(pb), Repair(pb)
    plan = draw_plan(pb, 6, 0)
    for i in reversed(range(6)):
        alone, _ = solve_start(solver, repair, i, plan.points[i], retry=lambda k, i=i: plan.retry(i, k))
        assert _same(alone, serial.starts[i]), i
    assert all(_same(a, b) for a, b in zip(serial.starts, forked.starts))
    assert serial.objective == forked.objective and serial.design == forked.design


def test_starts_record_where_they_began_and_ended():
    result = optdesign.optimise(optdesign.load(JIB), 5, 0)
    data = optimisation_json(result)
    assert result.success and result.objective == pytest.approx(GLOBAL_JIB, rel=1e-6)
    assert data["start_plan"]["method"] == "sobol" and data["start_plan"]["screened"] >= 1024
    for s in data["starts"]:
        assert s["tried"] and s["tried"][0]["start"] == s["start"]
        assert s["feasible_start"] is not None and s["end"] is not None and s["optimum"] is not None
    assert data["optima"][0]["value"] == pytest.approx(result.objective, rel=1e-9)
    assert sum(o["count"] for o in data["optima"]) == 5


def test_distinct_local_optima_are_listed_and_few_starts_are_flagged():
    """Starts in both basins of the jib design: two optima, each with its starts."""
    x_starts = [[3.0, 1.9], [2.1, 2.4], [2.2, 2.3], [2.9, 1.95]]
    result = optdesign.optimise(optdesign.load(JIB), x_starts=x_starts)
    assert [len(o.starts) for o in result.optima] == [2, 2]
    assert result.optima[0].value == pytest.approx(GLOBAL_JIB, rel=1e-6)
    assert result.optima[1].value == pytest.approx(11359.617, rel=1e-6)
    assert result.optima[0].starts == (0, 3) and result.optima[1].starts == (1, 2)
    assert [s.optimum for s in result.starts] == [0, 1, 1, 0]
    text = summary(result)
    assert "2 distinct" in text and "best of 4 starts, reached by 2" in text
    assert few(2, 20) and few(1, 4) and not few(5, 20) and not few(1, 1)


def test_one_start_is_a_local_optimum_not_optimal():
    result = optdesign.optimise(optdesign.load(JIB), 1, 0)
    assert result.success
    line = summary(result).splitlines()[1]
    assert "local optimum (1 start" in line and "OPTIMAL" not in line


def test_phase1_makes_an_infeasible_start_feasible():
    """From a start that violates the stroke and the transmission angle, phase 1 ends on a
    design feasible at the sample points, and the objective phase starts from there."""
    pb = DesignProblem(optdesign.load(JIB))
    solver, repair = Solver(pb), Repair(pb)
    ph1, repaired = multistart.feasible_start(solver, repair, np.array([3.0, 4.0]), solver.fixed_values())
    assert not repaired and ph1.iterations > 0 and ph1.feasible and ph1.violation <= 1e-7
    report, sol = solve_start(solver, repair, 0, np.array([3.0, 4.0]))
    assert report.success and report.tried[0]["phase1"] == "Solve_Succeeded"


def test_infeasible_only_when_phase1_fails_everywhere(tmp_path):
    """A stroke of at most 1 cm cannot be met: phase 1 fails from every start and its
    retries, and the result says so with the least-violating design and what it violates."""
    text = JIB.read_text().replace('name = "cylinder stroke"\nexpr = "max(length(D, B)) - min(length(D, B))"\nmax = 1.2',
                                   'name = "cylinder stroke"\nexpr = "max(length(D, B)) - min(length(D, B))"\nmax = 0.01')
    assert "max = 0.01" in text
    scene = optdesign.loads(text, str(tmp_path / "short_stroke.toml"))
    result = optdesign.optimise(scene, 3, 0)
    assert not result.success and result.status == "infeasible"
    assert all(s.status.startswith("phase 1 failed") and len(s.tried) == 5 for s in result.starts)
    assert "cylinder stroke" in result.least_violating["violated"]
    assert result.least_violating["violated"]["cylinder stroke"] > 0.1  # metres over the 1 cm
    assert "cylinder stroke" in result.message
    assert summary(result).splitlines()[1].endswith("INFEASIBLE (no start could be made feasible)")


def test_a_design_variable_with_one_bound_is_refused():
    text = JIB.read_text().replace("e  = { value = 1.6, min = 0.5, max = 3.0 }", "e  = { value = 1.6, min = 0.5 }")
    with pytest.raises(SceneError, match="design variable 'e' has min but no max"):
        optdesign.loads(text, "one_bound.toml")


def test_a_warm_case_falls_back_to_a_cold_multistart(monkeypatch):
    """A study case whose warm start fails is solved by a cold multistart before it could be
    reported infeasible (the row says so)."""
    import pickle

    from optdesign.study import tasks

    scene = optdesign.load(CRANE)
    x_warm = (0.5, -0.5, 2.5)

    def failing_at_the_warm_point(solver, repair, index, x0, fixed=None, retry=None):
        if np.allclose(x0, x_warm):
            pb = solver.pb
            return optdesign.design.results.StartReport(
                index, dict(zip(pb.design_names, x0)), "Infeasible_Problem_Detected", False, None, False, 0, 0,
                0.0), None
        return solve_start(solver, repair, index, x0, fixed, retry)

    monkeypatch.setattr(multistart, "solve_start", failing_at_the_warm_point)
    blob = pickle.dumps(scene)
    task = tasks.Task(blob, tasks.scene_digest(scene), "optimise", (), (), 3, 0, 1, (), x_warm)
    row = tasks.run_task(task)["row"]
    assert row["success"] and row["warm"] and row["cold_fallback"] is True
    assert row["objective"] == pytest.approx(171492.175, rel=1e-6)
