"""A case model keeps its time weights per node set (model/duty.CaseTimes.of): an optimisation
checks every start's solution on the same dense grids, and the weights depend on the nodes,
their times, the sweep speed there and the case's profile alone, not on the design.  Kept or
not, the numbers are the ones computed afresh, and what a caller gets is its own copy."""
from __future__ import annotations

import numpy as np

from optdesign.design.cycle_certify import cycle_cases
from optdesign.design.problem import DesignProblem
from optdesign.model import duty
from optdesign.model.case_results import case_nodes

from test_cases_optimise import MOTOR, _only_ratio, scene


def test_kept_weights_are_the_fresh_ones_for_every_design():
    pb = DesignProblem(_only_ratio(scene("rms_time(motor_torque)", extra=MOTOR), 2.0, 200.0))
    a = cycle_cases(pb)
    grid = pb.mech.stroke()
    dense = np.linspace(grid[0], grid[-1], 4 * (len(grid) - 1) + 1)
    for ratio in (5.0, 40.0, 150.0):   # designs: the weights' inputs are the same
        p = pb.full_parameters(np.array([ratio]), None)
        for cm, (names, function) in zip(a.cases, a.functions):
            nodes, _ = case_nodes(dense, cm.profile)
            values, times = a._evaluate(cm, names, function, nodes, cm.case_parameters(p))
            t = np.asarray(values["t"], float)
            fresh = duty.time_weights(nodes, t, cm.profile)
            work = duty.work_weights(nodes, t, cm.profile, np.abs(values["sd"]))
            assert np.array_equal(times.weights, fresh) and np.array_equal(times.work_weights, work)
            times.weights[:] = np.nan   # a caller's copy: the kept weights stay as they were
            again = duty.CaseTimes.of(cm, nodes, values)
            assert np.array_equal(again.weights, fresh)
    assert all(len(cm._time_weights) == 1 for cm in a.cases)   # one node set per case, kept once
    other = np.linspace(grid[0], grid[-1], 3 * (len(grid) - 1) + 1)   # another grid: computed, not taken
    cm, (names, function) = a.cases[0], a.functions[0]
    nodes, _ = case_nodes(other, cm.profile)
    values, times = a._evaluate(cm, names, function, nodes, cm.case_parameters(p))
    assert np.array_equal(times.weights, duty.time_weights(nodes, np.asarray(values["t"], float), cm.profile))
    assert len(cm._time_weights) == 2
