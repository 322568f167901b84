"""What a start evaluates once instead of twice (issue 31, the catalogue's starts), each the same
numbers as the evaluation it replaces: the recheck's rule on the grid 8 times denser than the
scene's taken from the 16 times denser grid's evaluation (every second point, bit for bit); the
adaptive quadrature's columns from a function of the columns it reads alone; phase 1's rows by
the design solver's own (compiled) function of them."""
from __future__ import annotations

from pathlib import Path

import casadi as ca
import numpy as np

import optdesign
from optdesign.design import cycle_certify
from optdesign.design.phase1 import Phase1
from optdesign.design.problem import DesignProblem
from optdesign.design.solver import initial_w
from optdesign.model.case_results import case_nodes

SCENE = Path(__file__).resolve().parents[1] / "problems" / "press_servo_cycle.toml"


def _designs(pb, n=3):
    rng = np.random.default_rng(7)
    return [pb.start] + [pb.lower + rng.random(len(pb.lower)) * (pb.upper - pb.lower) for _ in range(n)]


def test_the_coarser_rule_from_the_denser_grid_is_the_rule_evaluated_apart():
    pb = DesignProblem(optdesign.load(SCENE))
    a = cycle_certify.cycle_cases(pb)
    calls = []
    for c, (names, function) in enumerate(list(a.functions)):
        def counted(s, p, function=function, c=c):
            calls.append(c)
            return function(s, p)
        a.functions[c] = (names, counted)
    for x in _designs(pb):
        apart = [cycle_certify.rule_rms(pb, x, None, factor) for factor in (16, 8)]
        calls.clear()
        shared = cycle_certify.rule_rms_grids(pb, x, None)
        assert repr(shared) == repr(apart)   # the same numbers, bit for bit (repr: NaN compares too)
        assert sorted(calls) == list(range(len(a.cases)))   # each case evaluated once for both grids
    # linspace's points 8 times denser are every second point 16 times denser, exactly
    grid = pb.mech.stroke()
    fine, coarse = (np.linspace(grid[0], grid[-1], f * (len(grid) - 1) + 1) for f in (16, 8))
    assert np.array_equal(fine[::2], coarse)


def test_the_quadratures_columns_are_the_cases_own():
    pb = DesignProblem(optdesign.load(SCENE))
    a = cycle_certify.cycle_cases(pb)
    grid = pb.mech.stroke()
    s = np.linspace(grid[0], grid[-1], 301)
    for x in _designs(pb):
        p = pb.full_parameters(np.clip(x, pb.lower, pb.upper), None)
        for c, (cm, (names, function)) in enumerate(zip(a.cases, a.functions)):
            nodes, _ = case_nodes(s, cm.profile)
            full = dict(zip(names, function(nodes, cm.case_parameters(p))))
            few, reduced = a.integrands(c)
            assert set(few) < set(names) and "drive" in few and "k" in few
            for name, v in zip(few, reduced(nodes, cm.case_parameters(p))):
                assert np.array_equal(np.asarray(v), np.asarray(full[name]), equal_nan=True)


def test_phase1_rows_are_the_nlps_rows():
    pb = DesignProblem(optdesign.load(SCENE))
    ph = Phase1(pb)
    nlp = pb._nlp_dict
    vm = ca.Function("rows", [nlp["x"], nlp["p"]], [nlp["g"]])   # the graph on CasADi's virtual machine
    fixed = pb.mech.parameter_values[pb.fixed_index]
    s_pts = np.r_[pb.base_points, pb.initial_slots]
    checked = 0
    for x in _designs(pb, 8):
        w = initial_w(pb, x, fixed, s_pts)
        if isinstance(w, str):
            continue
        p = pb.nlp_parameters(fixed, s_pts, x)
        assert np.array_equal(np.asarray(ph.g(w, p)).ravel(), np.asarray(vm(w, p)).ravel(), equal_nan=True)
        checked += 1
    assert checked >= 3
