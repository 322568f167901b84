"""The SQP rules of the objective phase (optdesign/design/sqp.py): sqpmethod with qpOASES on the
exchange's re-solves (and on every solve), IPOPT the fallback.  They reach the jib design's
global optimum (an independent reference), a start's result does not depend on the starts
before it (qpOASES keeps a working set between calls: each start gets a fresh SQP), and an SQP
result is accepted only when it succeeded, keeps every bound and does not end worse than a
feasible start.  The SQP needs its compiled library: each test has its own cache folder."""
from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import numpy as np
import pytest

import optdesign
from optdesign.design import sqp
from optdesign.design.multistart import draw_plan, solve_start
from optdesign.design.problem import DesignProblem, SolverSettings
from optdesign.design.repair import Repair
from optdesign.design.solver import Solver
from optdesign.model import compiled

ROOT = Path(__file__).resolve().parents[1]
JIB = ROOT / "problems" / "seed1_jib_design.toml"
GLOBAL_JIB = 11294.3637   # tests/test_multistart.py: e = 3 (bound), b = 1.8927 (grid search)
# a coarse grid: the exchange takes steps, so that there are re-solves for the SQP
SETTINGS = SolverSettings(grid=5, slots=2)
pytestmark = pytest.mark.skipif(compiled.shutil.which(os.environ.get("CC", "gcc")) is None,
                                reason="no C compiler on this machine (the SQP runs from the compiled library)")


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.delenv("OPTDESIGN_NO_COMPILE", raising=False)
    monkeypatch.setenv("OPTDESIGN_COMPILE", "wait")
    monkeypatch.setenv("OPTDESIGN_CACHE_DIR", str(tmp_path / "cache"))
    compiled._compiler.clear()
    compiled._warned.clear()
    yield tmp_path / "cache"
    compiled._compiler.clear()
    compiled._warned.clear()


def counted(monkeypatch):
    """Count the SQP solves (and how many were accepted)."""
    calls = {"made": 0, "solves": 0, "accepted": 0}
    make, accept = sqp.sqp_solver, sqp.accepted

    def made(pb):
        out = make(pb)
        calls["made"] += out is not None
        return out

    def accepted(*args):
        ok = accept(*args)
        calls["solves"] += 1
        calls["accepted"] += ok
        return ok
    monkeypatch.setattr(sqp, "sqp_solver", made)
    monkeypatch.setattr(sqp, "accepted", accepted)
    return calls


def _same(a, b):
    da, db = dataclasses.asdict(a), dataclasses.asdict(b)
    for key in ("time_s", "optimum"):
        da.pop(key), db.pop(key)
    return da == db


@pytest.mark.parametrize("rule", ["sqpmethod on re-solves", "sqpmethod"])
def test_sqp_rules_reach_the_global_optimum(cache, monkeypatch, rule):
    monkeypatch.setattr(sqp, "SOLVER", rule)
    calls = counted(monkeypatch)
    result = optdesign.optimise(optdesign.load(JIB), 6, 0, settings=SETTINGS)
    assert calls["made"] >= 1 and calls["accepted"] >= 1, calls   # the SQP did solve
    assert result.success and result.objective == pytest.approx(GLOBAL_JIB, rel=1e-6)
    assert result.design["e"] == pytest.approx(3.0, abs=1e-6)


def test_a_start_under_the_sqp_does_not_depend_on_the_starts_before(cache, monkeypatch):
    monkeypatch.setattr(sqp, "SOLVER", "sqpmethod")
    scene = optdesign.load(JIB)
    serial = optdesign.optimise(scene, 4, 0, settings=SETTINGS)
    pb = DesignProblem(scene, SETTINGS)
    solver, repair = Solver(pb), Repair(pb)
    plan = draw_plan(pb, 4, 0)
    for i in reversed(range(4)):
        alone, _ = solve_start(solver, repair, i, plan.points[i], retry=lambda k, i=i: plan.retry(i, k))
        assert _same(alone, serial.starts[i]), i


def test_an_sqp_result_is_accepted_only_when_feasible_and_not_worse(monkeypatch):
    pb = DesignProblem(optdesign.load(JIB), SETTINGS)
    nd = len(pb.design_names)
    x = np.array([2.5, 2.0])
    s_pts = np.r_[pb.base_points, pb.initial_slots]
    fixed = pb.mech.parameter_values[pb.fixed_index]
    w0 = Solver(pb)._initial_w(x, fixed, s_pts)
    p = pb.nlp_parameters(fixed, s_pts, x)
    lbg, ubg = pb.row_bounds(s_pts)
    bounds = {"lbx": pb.lbw, "ubx": pb.ubw, "lbg": lbg, "ubg": ubg}
    f0, g0 = (np.asarray(v).ravel() for v in pb._nlp_function(w0, p))
    assert sqp.violation(w0, g0, bounds) <= 1e-9   # a feasible start (the epigraph at the peak)
    ok = {"success": True}

    def result(w):
        f, g = pb._nlp_function(w, p)
        return {"x": w, "f": f, "g": g}
    lower_t = w0.copy()
    lower_t[nd] *= 0.5   # t below the peak: the epigraph's rows are violated
    higher_t = w0.copy()
    higher_t[nd] *= 1.5   # feasible, but worse than the start
    assert sqp.accepted(pb, result(w0), ok, w0, p, bounds)
    assert not sqp.accepted(pb, result(w0), {"success": False}, w0, p, bounds)
    assert not sqp.accepted(pb, result(lower_t), ok, w0, p, bounds)
    assert not sqp.accepted(pb, result(higher_t), ok, w0, p, bounds)
    assert sqp.accepted(pb, result(higher_t), ok, lower_t, p, bounds)   # from an infeasible start: no comparison
    outside = w0.copy()
    outside[0] = 1.5   # the scaled design beyond its upper bound 1
    assert not sqp.accepted(pb, result(outside), ok, w0, p, bounds)
