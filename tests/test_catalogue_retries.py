"""The motor catalogue's rule on retries (design/catalogue.py, multistart.optimise's
``retry_if_fits``): a motor's starts first try their own points alone; the starts that failed
are retried from fresh points only once one start reached a design feasible at the sample
points.  A motor that fits then has the result it has without the rule (the retries depend on a
start's index alone), and a motor that cannot fit is decided from the starts' own points.

The scene is tests/test_cases_optimise.py's crank with a gearbox (the ratio i the one design
variable) and its catalogue; which motor fits is checked there against a numpy model on a
dense scan of the ratio, and here once more for the two motors used."""
from __future__ import annotations

import math
import types

import numpy as np
import pytest

from optdesign.design import multistart
from optdesign.design.catalogue import RULE, optimise_catalogue, with_motor
from optdesign.design.phase1 import Phase1Result

from test_cases_optimise import CATALOGUE, _only_ratio, motion, motor_model, scan, scene

LIMITS = {"tiny": (1e-4, 0.05, 0.15), "small": (4e-4, 0.6, 2.0)}   # J_r, rated, peak (CATALOGUE's)


def crank():
    return _only_ratio(scene("rms_time(motor_torque)", extra=CATALOGUE), 2.0, 200.0)


def fits_by_scan(name):
    """Whether some ratio on a dense geometric scan of [2, 200] meets the motor's peak, RMS and
    speed (500 rad/s) limits, from the numpy model of tests/test_cases_optimise.py."""
    paths = motion()
    model = motor_model(paths, gravity=9.81)
    top_speed = max(np.max(np.abs(thd)) for _, thd, _, _ in paths.values())
    J_r, rated, peak_limit = LIMITS[name]

    def penalised(i):
        rms, peak = model(i, J_r)
        return rms if rms <= rated and peak <= peak_limit and i * top_speed <= 500 else math.inf
    return not math.isinf(scan(penalised, 2.0, 200.0, n=201, geometric=True)[1])


def _motor(sc, name):
    return with_motor(sc, next(m for m in sc.motors if m.name == name))


def _infeasible_at_own_points(monkeypatch, plan_points, which):
    """Phase 1 made to fail at the own points of the starts ``which`` (a violation of 0.5 at
    the point, as a start that cannot reach the feasible designs); every call recorded."""
    calls = []
    original = multistart.feasible_start

    def fake(solver, repair, x0, fixed):
        calls.append(np.asarray(x0, float).copy())
        for k in which:
            if np.array_equal(x0, plan_points[k]):
                return Phase1Result(np.asarray(x0, float), 0.5, "Solve_Succeeded", 7), False
        return original(solver, repair, x0, fixed)
    monkeypatch.setattr(multistart, "feasible_start", fake)
    return calls


def _summary(result):
    return (result.success, result.objective, result.design, result.starts_at_best,
            [(r.index, r.status, r.objective, r.iterations, r.tried) for r in result.starts])


@pytest.mark.slow   # 15 s each on the virtual machine (the suite's default); the two tests below are fast
@pytest.mark.parametrize("workers", [1, 2])
def test_a_motor_that_fits_has_the_result_it_has_without_the_rule(monkeypatch, workers):
    """Start 0 (of two given ratios) cannot be made feasible from its own point (phase 1 faked
    to fail there): with the rule it is retried after the first pass, from the same reserve
    point, and the result is the one without the rule, start by start; its own point's phase
    1 is not run again.  (With workers=2, the pool's path; its calls are in the workers.)"""
    assert fits_by_scan("small")
    sc = _motor(crank(), "small")
    points = np.array([[60.0], [20.0]])
    calls = _infeasible_at_own_points(monkeypatch, points, (0,))
    plain = multistart.optimise(sc, x_starts=points, workers=workers)
    n_plain = len(calls)
    ruled = multistart.optimise(sc, x_starts=points, workers=workers, retry_if_fits=True)
    assert plain.success
    assert [len(r.tried) for r in plain.starts] == [2, 1]   # the faked start took one retry
    assert _summary(ruled) == _summary(plain)
    if workers == 1:   # the calls of forked workers are not seen here
        assert len(calls) - n_plain == n_plain   # each point's phase 1 once, the own points' not repeated


def test_a_motor_that_cannot_fit_is_decided_from_the_starts_own_points():
    """The tiny motor carries the load at no ratio (the numpy scan): with the rule, phase 1
    runs once per start (no retries) and the motor is infeasible, as without the rule, whose
    starts each try 1 + RETRIES points; the message says which rule decided."""
    assert not fits_by_scan("tiny")
    sc = _motor(crank(), "tiny")
    plain = multistart.optimise(sc, starts=2)
    ruled = multistart.optimise(sc, starts=2, retry_if_fits=True)
    assert plain.status == ruled.status == "infeasible"
    assert [len(r.tried) for r in plain.starts] == [1 + multistart.RETRIES] * 2
    assert [len(r.tried) for r in ruled.starts] == [1] * 2
    assert [r.tried[0] for r in ruled.starts] == [r.tried[0] for r in plain.starts]


def test_the_catalogue_states_its_rule(monkeypatch):
    """The catalogue's answer with the rule: tiny does not fit (decided from the starts' own
    points, said in its message), small does, as the numpy scan finds.  (The energy proof,
    which decides tiny before its starts, left out: design/energy_bound.py, its own tests.)"""
    from optdesign.design import catalogue

    monkeypatch.setattr(catalogue.Prover, "prove", lambda self, motor: None)
    cat = optimise_catalogue(crank(), starts=1)
    assert cat.chosen == "small" and not fits_by_scan("tiny") and fits_by_scan("small")
    assert RULE in cat.results["tiny"].message
    assert [len(r.tried) for r in cat.results["tiny"].starts] == [1]


def _catalogue_text(motors):
    text = '\n[gearbox]\nratio = "i"\n'
    for name, J_r, rated, peak, speed in motors:
        text += (f'[[motors]]\nname = "{name}"\ninertia = {float(J_r)!r}\nrated_torque = {float(rated)!r}\n'
                 f'peak_torque = {float(peak)!r}\nmax_speed = {float(speed)!r}\n')
    return text


def _utilisation(model, top_speed, J_r, rated, peak_limit, max_speed):
    """(least utilisation over the ratios, the least RMS among the ratios that fit or inf) of a
    motor: utilisation max(RMS / rated, peak / peak limit, speed / max speed), by a dense
    geometric scan of i in [2, 200] refined around its best point (numpy model)."""
    def u(i):
        rms, peak = model(i, J_r)
        return max(rms / rated, peak / peak_limit, i * top_speed / max_speed)

    def fitting_rms(i):
        rms, _ = model(i, J_r)
        return rms if u(i) <= 1 else math.inf
    return scan(u, 2.0, 200.0, geometric=True)[1], scan(fitting_rms, 2.0, 200.0, geometric=True)[1]


@pytest.mark.slow   # about 30 s on the virtual machine; test_the_catalogue_states_its_rule is the fast sibling
def test_generated_catalogues_choose_the_motor_the_numpy_model_chooses():
    """Catalogues of three motors drawn from a Sobol sample (rotor inertia, rated and peak
    torque, top speed; the speed limit binds for some, the inertia's torque J_r i theta'' for
    others): the chosen motor is the smallest by rated torque whose least utilisation on the
    numpy model's dense scan is <= 1, and its optimum is the least RMS among the ratios that
    fit.  Motors within 3 % of fitting or not are left out (the scan's own resolution)."""
    from scipy.stats import qmc

    paths = motion()
    model = motor_model(paths, gravity=9.81)
    top_speed = max(np.max(np.abs(thd)) for _, thd, _, _ in paths.values())
    draws = qmc.Sobol(4, scramble=True, seed=7).random(16)
    motors = []
    for J_u, rated_u, peak_u, speed_u in draws:
        J_r, rated = 1e-4 * 50 ** J_u, 0.08 + 0.3 * rated_u
        peak, speed = rated * (1.5 + 1.5 * peak_u), 80.0 + 420.0 * speed_u
        u, best = _utilisation(model, top_speed, J_r, rated, peak, speed)
        if abs(u - 1) >= 0.03 and (u > 1 or math.isfinite(best)):
            motors.append((J_r, rated, peak, speed, u, best))
    fit, unfit = [m for m in motors if m[4] <= 1], [m for m in motors if m[4] > 1]
    # one catalogue whose smallest motors cannot fit, one whose smallest can, one with none that fits
    catalogues = [(unfit[0], unfit[1], fit[0]), (fit[1], unfit[2], fit[2]), (unfit[3], unfit[1])]
    for n, group in enumerate(catalogues):
        named = [(f"m{n}{j}", *m[:4]) for j, m in enumerate(group)]
        sc = _only_ratio(scene("rms_time(motor_torque)", extra=_catalogue_text(named)), 2.0, 200.0)
        cat = optimise_catalogue(sc, starts=2)
        order = sorted(zip(named, group), key=lambda nm: (nm[0][2], nm[0][0]))
        expected = next(((nm[0], m) for nm, m in order if m[4] <= 1), None)
        assert cat.chosen == (expected[0] if expected else None), (n, group, cat.chosen)
        if expected is not None:
            assert cat.best.objective == pytest.approx(expected[1][5], rel=2e-4)


@pytest.mark.parametrize("workers", [1, 2])
def test_the_progress_reaches_its_total_only_when_the_retries_are_done(monkeypatch, workers):
    """With the rule, the starts that failed are retried after the first pass: the progress
    (done, total) must not say all done before them.  Four starts, of which 1 and 3 fail phase
    1 and start 2 fits (a stand-in for solve_start, which records each call): the total grows
    by the two failed starts once one start has fitted, ``done`` counts up by one per finished
    start or retried start, and done == total only at the last call, after every retry."""
    from optdesign.design.results import StartReport
    from optdesign.design.starts import StartPlan

    def fake(solver, repair, index, x0, fixed=None, retry=None, first=None):
        ok = index not in (1, 3) or retry is not None   # its own point fails; a retry succeeds
        status = "Solve_Succeeded" if ok else "phase 1 failed: infeasible"
        return StartReport(index, {}, status, ok, 1.0 if ok else None, False, 0, 0, 0.0,
                           tried=({"violation": None, "repaired": False},) * (2 if retry is not None else 1)), None

    monkeypatch.setattr(multistart, "solve_start", fake)
    calls = []
    solver = types.SimpleNamespace(pb=None)
    runs = multistart.solve_then_retry(solver, None, StartPlan(np.zeros((4, 1))), workers,
                                       progress=lambda done, total: calls.append((done, total)))
    assert [r.success for r, _ in runs] == [True] * 4
    assert [d for d, _ in calls] == list(range(1, 7))            # 4 first tries, then 2 retried starts
    assert calls[-1] == (6, 6) and all(d < t for d, t in calls[:-1])
    assert [t for _, t in calls] == sorted(t for _, t in calls)  # the total never shrinks
