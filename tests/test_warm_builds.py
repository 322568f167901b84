"""What an objective phase builds on its first use (the extrema's tracking, the exchange's warm
solver, the duty cycle's certifier and its recheck's time weights) is built while the problem
is prepared when a planned start is screened feasible, so that the worker processes forked
after it share those objects (design/multistart.prepare, design/solver.Solver.warm): a start
solved on a warmed problem gives bit for bit what it gives on a cold one; a motor that no
planned start fits (a catalogue's motor too small) builds none of it."""
from __future__ import annotations

import numpy as np

from optdesign.design import multistart
from optdesign.design.catalogue import with_motor
from optdesign.design.problem import DesignProblem
from optdesign.design.repair import Repair
from optdesign.design.solver import Solver
from optdesign.errors import casadi_messages_hidden

from test_cases_optimise import CATALOGUE, _only_ratio, scene

WARMED = {"tracking", "warm solver", "cycle integrals"}


def crane(motor):
    sc = _only_ratio(scene("rms_time(motor_torque)", extra=CATALOGUE), 2.0, 200.0)
    return with_motor(sc, next(m for m in sc.motors if m.name == motor))


def test_a_warmed_problem_solves_every_start_as_a_cold_one():
    sc = crane("small")
    warm = multistart.prepare(sc, starts=2)
    assert warm.plan.fitting > 0 and WARMED <= set(warm.problem._built)
    cold_pb = DesignProblem(sc)
    cold, repair = Solver(cold_pb), Repair(cold_pb)
    assert not WARMED & set(cold_pb._built)
    with casadi_messages_hidden():
        for i, x0 in list(enumerate(warm.plan.points))[1:]:   # the screened start (the scene's own: the same code)
            a, sol_a = multistart.solve_start(warm.solver, warm.repair, i, x0)
            b, sol_b = multistart.solve_start(cold, repair, i, x0)
            assert a.success and (a.status, a.objective, a.iterations, a.exchanges) == (
                b.status, b.objective, b.iterations, b.exchanges)
            assert np.array_equal(sol_a.x, sol_b.x) and sol_a.certified == sol_b.certified
    assert {"tracking", "cycle integrals"} <= set(cold_pb._built)   # the cold one built them on its first start


def test_a_motor_no_start_fits_builds_none_of_it():
    tiny = multistart.prepare(crane("tiny"), starts=3)
    assert tiny.plan.fitting == 0
    assert not WARMED & set(tiny.problem._built)
    result = multistart.optimise(crane("tiny"), starts=3, prepared=tiny, retry_if_fits=True)
    assert result.status == "infeasible"
    assert not WARMED & set(tiny.problem._built)   # its phase 1 failed from every start
