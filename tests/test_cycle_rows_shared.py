"""The duty cycle's integrals in the NLP (design/cases.cycle_integrals) with the cases that run
on the same nodes evaluated by one mapped Function (issue 31: the kinematics computed once per
node, not once per case) against each case's rows evaluated on their own, numerically, and
summed here (each case's samples with the weights of model/duty's rule, which
tests/test_cases_time.py checks against a fine grid; the hold's static load through the drive
train written here; the dwells' time): crane_luffing_drive's four duty cases, at random designs
near its start (within a tenth of the box) that assemble."""
from __future__ import annotations

from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from optdesign.design.cases import _time_plan, case_models, cycle_integrals
from optdesign.design.catalogue import with_motor
from optdesign.design.problem import DesignProblem
from optdesign.model.case_results import case_nodes
from optdesign.model.duty import time_weights
from optdesign.scene import load

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def problem():
    scene = load(ROOT / "problems" / "crane_luffing_drive.toml")
    return DesignProblem(with_motor(scene, scene.motors[2]))


def _per_case_cycle(pb, p):
    """int T_m^2 dt over the cycle and its time, each case's rows on their own (numbers)."""
    values, durations = {}, {}
    plan = _time_plan(pb)
    for cm in case_models(pb):
        nodes, _ = case_nodes(pb.mech.stroke(), cm.profile)
        weights = time_weights(nodes, cm.profile.times(nodes), cm.profile)
        assert np.array_equal(weights, plan[cm.name][1])
        rows = pb.case_rows[cm.name]
        f = pb.mech.function("one_case", {"T": pb.rows[rows["motor_torque"]], "hold": pb.rows[rows["hold_load"]]})
        T, hold = (np.asarray(v, float).ravel() for v in f.map(len(nodes))(nodes[None, :], p))
        values[cm.name] = (float(np.sum(weights * T**2)), hold[0], hold[-1])
        durations[cm.name] = cm.profile.duration
    return values, durations


def test_the_cases_nodes_differ_only_at_the_phase_boundaries(problem):
    plan = _time_plan(problem)
    nodes = [plan[name][0] for name in ("in, rated load", "out, rated load", "in, empty hook", "out, empty hook")]
    assert np.array_equal(nodes[0], nodes[2]) and np.array_equal(nodes[1], nodes[3])
    assert not np.array_equal(nodes[0], nodes[1])   # in and out: their boundaries apart by round-off
    assert len(np.union1d(nodes[0], nodes[1])) < len(nodes[0]) + 8   # so they share one map over the union


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cycle_integrals_equal_the_cases_evaluated_one_by_one(problem, seed):
    pb = problem
    rng = np.random.default_rng(seed)
    while True:   # a design that assembles over the whole stroke
        x = np.clip(pb.start + (pb.upper - pb.lower) * rng.uniform(-0.1, 0.1, len(pb.lower)), pb.lower, pb.upper)
        if np.all(np.isfinite(pb.evaluate_grid(x))):
            break
    p_num = pb.full_parameters(x)
    p = ca.MX.sym("p", len(p_num))
    T_sym, sums = cycle_integrals(pb, p, ["motor_torque"])
    T_c, I_c = (float(v) for v in ca.Function("cycle", [p], [T_sym, sums["motor_torque"]])(p_num))
    values, durations = _per_case_cycle(pb, p_num)
    # the scene's [duty]: in with the load, 20 s holding it at the end, out with it, 15 s dwell,
    # in and out empty, 30 s dwell (the hold: the static load through the gearbox at rest)
    duty = ["in, rated load", "out, rated load", "in, empty hook", "out, empty hook"]
    T_ref = sum(durations[c] for c in duty) + 20 + 15 + 30
    assert T_c == pytest.approx(T_ref, rel=1e-12)
    moving = sum(values[c][0] for c in duty)
    # the hold's contribution is what is left: the held static load is the case's, at the stroke's end
    hold = I_c - moving
    assert hold > 0
    _, start, end = values["in, rated load"]
    ratio = float(ca.Function("i", [pb.mech.p], [pb.mech.value(pb.scene.gearbox.ratio, "ratio")])(p_num))
    # the static load at the stroke's end, driving through the crank (efficiency 0.92) and the
    # gearbox (0.94), over the gear ratio, held for 20 s
    assert hold == pytest.approx((end / 0.92 / 0.94 / ratio) ** 2 * 20, rel=1e-9)
    assert I_c == pytest.approx(moving + hold, rel=1e-12)


@pytest.mark.slow
def test_the_catalogue_keeps_its_answer():
    """The whole catalogue with the default settings (20 starts, 2 workers), as
    results/crane_luffing_drive/ holds it from before the cases shared their map (e832500): the
    7.5 kW motor, its optimum to 1e-6, as many starts at it; the two smaller motors infeasible."""
    import json

    from optdesign.design.catalogue import optimise_catalogue

    before = json.loads((ROOT / "results" / "crane_luffing_drive" / "result.json").read_text())
    cat = optimise_catalogue(load(ROOT / "problems" / "crane_luffing_drive.toml"), starts=20, seed=0, workers=2)
    assert cat.chosen == before["chosen_motor"] == "7.5 kW"
    assert cat.best.objective == pytest.approx(before["objective"], rel=1e-6)
    assert cat.best.starts_at_best >= before["starts_at_best"]
    assert [cat.results[m].success for m in ("4 kW", "5.5 kW")] == [False, False]
