"""The screening of start candidates shared among forked processes (issue 31: the command's first
problem is screened while the other core is idle; design/screening.shared): every design's
objective and violation are those of one call over all designs, bit for bit, for any cut, and
the plan of starts (points, reserve, counts) is the one planned in one process.  These checks
run in a spawned process with no other thread (fixture ``fresh``).

The scene is tests/test_cases_optimise.py's crank with a gearbox and its catalogue (the
smallest motor, which cannot fit: its candidates are screened infeasible, their violations
ranked), and seed 1's jib luffed by a cylinder (problems/seed1_jib.toml, feasible candidates ranked by
objective)."""
from __future__ import annotations

import concurrent.futures as cf
import multiprocessing
import os
import tempfile
import threading
from pathlib import Path

import numpy as np
import pytest

import optdesign
from optdesign.design import screening
from optdesign.design.catalogue import with_motor
from optdesign.design.problem import DesignProblem
from optdesign.design.starts import Screen, plan_starts, space_filling

from test_catalogue_retries import crank

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"


NAMES = ["crank, tiny motor", "seed1_jib"]
_BUILT = {}


def _problem(name):
    """The design problem ``name`` (built once per process)."""
    if name not in _BUILT:
        if name == NAMES[0]:
            sc = crank()
            _BUILT[name] = DesignProblem(with_motor(sc, next(m for m in sc.motors if m.name == "tiny")))
        else:
            _BUILT[name] = DesignProblem(optdesign.load(PROBLEMS / "seed1_jib.toml"))
    return _BUILT[name]


@pytest.fixture(scope="module")
def fresh():
    """A spawned process with no thread but its main one, where the checks run: the screenings
    are shared only then (screening.shared), and this process may hold threads an earlier test
    left (a Dask cluster's, under xdist)."""
    with cf.ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
        yield lambda check, name: pool.submit(check, name).result(timeout=600)


def _equal(a, b):
    return all(np.array_equal(x, y, equal_nan=True) for x, y in zip(a, b, strict=True))


def _each_design_as_in_one_call(name):
    assert threading.active_count() == 1
    pb = _problem(name)
    screen = Screen(pb)
    fixed = pb.mech.parameter_values[pb.fixed_index]
    xs = space_filling(pb, 1000, 7)
    whole = screen(xs, fixed, pb.lbg, pb.ubg)
    share_min, screening.SHARE_MIN = screening.SHARE_MIN, 1
    try:
        with tempfile.TemporaryDirectory() as folder:
            pids = Path(folder) / "pids"

            def noted(xs, *args):   # which process screened how many designs
                with open(pids, "a") as f:
                    f.write(f"{os.getpid()} {len(xs)}\n")
                return screen(xs, *args)
            for processes in (2, 3):
                pids.unlink(missing_ok=True)
                assert _equal(screening.shared(noted, xs, processes, fixed, pb.lbg, pb.ubg), whole)
                seen = [line.split() for line in pids.read_text().splitlines()]
                assert len({pid for pid, _ in seen}) == processes and sum(int(n) for _, n in seen) == len(xs)
    finally:
        screening.SHARE_MIN = share_min
    # odd cuts, one design alone, as the parts of one call
    for cut in (1, 333, 999):
        assert _equal([np.r_[a, b] for a, b in zip(screen(xs[:cut], fixed, pb.lbg, pb.ubg),
                                                   screen(xs[cut:], fixed, pb.lbg, pb.ubg))], whole)


def _plan_as_in_one_process(name):
    assert threading.active_count() == 1   # (else the screenings are not shared: screening.shared)
    pb = _problem(name)
    one = plan_starts(pb, 20, 0)
    two = plan_starts(pb, 20, 0, processes=2)
    assert np.array_equal(one.points, two.points) and np.array_equal(one.reserve, two.reserve)
    assert (one.screened, one.fitting) == (two.screened, two.fitting)


def _failed_share_screened_here(name):
    assert threading.active_count() == 1
    pb = _problem(name)
    screen = Screen(pb)
    fixed = pb.mech.parameter_values[pb.fixed_index]
    xs = space_filling(pb, 600, 3)
    here, calls = os.getpid(), []

    def failing(xs, *args):   # fails in the forked process
        if os.getpid() != here:
            raise RuntimeError("share failed")
        calls.append(len(xs))
        return screen(xs, *args)
    share_min, screening.SHARE_MIN = screening.SHARE_MIN, 100
    try:
        assert _equal(screening.shared(failing, xs, 2, fixed, pb.lbg, pb.ubg), screen(xs, fixed, pb.lbg, pb.ubg))
    finally:
        screening.SHARE_MIN = share_min
    assert calls == [300, 300]   # this process's share, then the failed one's here


@pytest.mark.parametrize("name", NAMES)
def test_each_design_is_screened_as_in_one_call(fresh, name):
    fresh(_each_design_as_in_one_call, name)


@pytest.mark.parametrize("name", NAMES)
def test_the_plan_is_the_one_planned_in_one_process(fresh, name):
    fresh(_plan_as_in_one_process, name)


@pytest.mark.parametrize("name", NAMES)
def test_a_failed_share_is_screened_here(fresh, name):
    fresh(_failed_share_screened_here, name)


@pytest.fixture(scope="module", params=NAMES)
def problem(request):
    return _problem(request.param)


def test_one_process_when_another_thread_runs(problem, monkeypatch):
    pb = problem
    screen = Screen(pb)
    fixed = pb.mech.parameter_values[pb.fixed_index]
    xs = space_filling(pb, 600, 3)
    monkeypatch.setattr(screening, "SHARE_MIN", 1)
    monkeypatch.setattr(screening, "_share", lambda *a: pytest.fail("forked beside a thread"))
    stop = threading.Event()
    other = threading.Thread(target=stop.wait)
    other.start()
    try:
        assert _equal(screening.shared(screen, xs, 2, fixed, pb.lbg, pb.ubg), screen(xs, fixed, pb.lbg, pb.ubg))
    finally:
        stop.set()
        other.join()
