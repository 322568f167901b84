"""The front door of the design problem: :func:`optimise` builds the problem once, plans
reproducible space-filling starts (:mod:`.starts`), makes each one feasible (:mod:`.phase1`,
retrying from a fresh point when it cannot be), minimises the objective from there, in this
process or in a pool of forked workers, and summarises the best certified optimum with the
distinct local optima the starts found (:mod:`.clusters`).

Every start is independent of the others: it begins from its own point with the NLP's initial
sample points, and its retries come from its own share of the reserve, so the result is the
same whatever the order of the starts or the number of workers."""
from __future__ import annotations

import concurrent.futures as cf
import contextlib
import multiprocessing
import os
import time
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, replace

import numpy as np

from ..errors import OptimisationInterrupted, SolverError, casadi_messages_hidden, interruptible, resume_after_interrupt, worker_process
from ..scene import Scene
from ..scene.arguments import optimise_arguments, scene_argument
from .clusters import local_optima
from .phase1 import Phase1
from .problem import DesignProblem, SolverSettings
from .repair import Repair
from .results import OptimisationResult, StartReport
from .cycle_certify import certify_cycle, uncertified
from .sensitivities import (constraint_report, objective_gradient_factor, objective_value, sensitivities,
                            sensitivity_notes)
from .solver import Solver, initial_w
from .starts import RETRIES, StartPlan, plan_starts


def optimise(scene: Scene, starts: int = 20, seed: int = 0, settings: SolverSettings | None = None,
             progress=None, x_starts=None, workers: int = 1, prepared=None, finished=None,
             retry_if_fits: bool = False, planned=None, polished=None) -> OptimisationResult:
    """Minimise the scene's objective over its design variables (front door).

    ``starts`` local solves from reproducible starts (the scene's start, then the best of a
    screened scrambled Sobol sample of the design box drawn with ``seed``) or from explicit
    ``x_starts`` (retried from the seeded reserve if one cannot be made feasible);
    ``progress(done, total)`` is called once the starts are planned (done = 0) and after each
    start; ``workers`` > 1 solves the starts in that many forked processes (where the platform
    can fork; the result does not depend on the number of workers).  ``prepared``: the
    :class:`Prepared` problem and plan of these arguments, made beforehand (the motor
    catalogue makes the next motor's while this one's starts run); ``planned(prepared)`` before
    the starts, ``finished(report)`` as each one finishes (its :class:`StartReport`) and
    ``polished(design)`` once the best start is polished (:func:`summarise`) are called.

    ``retry_if_fits`` (the motor catalogue's rule, :mod:`.catalogue`): each start first tries
    its own point alone; only when one of them found a design feasible at the sample points are
    the others retried from the reserve, as without the rule (the same result: a start's
    retries depend on its index alone).  When phase 1 failed from every start's own point, the
    problem is reported infeasible without the retries (a catalogue motor that cannot fit:
    crane_luffing_drive's 4 and 5.5 kW motors, whose every retry ended at the same least
    violation as its start)."""
    starts, seed, workers = optimise_arguments(scene_argument("optimise", scene), starts, seed, workers)
    t0 = time.perf_counter()
    with interruptible():   # Ctrl-C: stop at once, keep the finished starts
        if prepared is None:
            prepared = prepare(scene, starts, seed, settings, x_starts)
        if planned is not None:
            planned(prepared)
        problem, solver, repair, plan = prepared.problem, prepared.solver, prepared.repair, prepared.plan
        timings = dict(prepared.timings)

        def spent():
            return dict(timings, total_s=time.perf_counter() - t0 + prepared.ahead_s)
        runs = []
        with casadi_messages_hidden():
            try:
                if progress is not None:
                    progress(0, len(plan.points))  # the starts are planned (a caller may stop here: Ctrl-C)
                if retry_if_fits:
                    runs = solve_then_retry(solver, repair, plan, workers, progress, finished)
                else:
                    runs = solve_starts(solver, repair, plan, workers, progress, finished)
                reports, solutions = [r for r, _ in runs], [s for _, s in runs]
                return summarise(problem, solver, reports, solutions, spent(), plan, polished=polished)
            except KeyboardInterrupt as exc:   # during the starts, or while all of them are summarised
                raise interrupted(problem, solver, plan, getattr(exc, "finished", runs), len(plan.points),
                                  spent()) from None


@dataclass
class Prepared:
    """What :func:`optimise` makes before its starts: the problem, its solver and repair, the
    planned starts; ``timings`` (build_s, screen_s) and ``ahead_s``, the time spent making it
    when that was not in the call of :func:`optimise` that uses it (else 0)."""

    problem: DesignProblem
    solver: Solver
    repair: Repair
    plan: StartPlan
    timings: dict
    ahead_s: float = 0.0


def prepare(scene: Scene, starts: int = 20, seed: int = 0, settings: SolverSettings | None = None,
            x_starts=None, ahead: bool = False) -> Prepared:
    """The problem of ``scene`` built and its starts planned, as :func:`optimise` would with
    these arguments (``ahead``: made beforehand, in another thread than the one that will
    optimise: CasADi's messages are then left alone, the starts' optimise hides them)."""
    t0 = time.perf_counter()
    problem = DesignProblem(scene, settings)
    solver, repair = Solver(problem), Repair(problem)
    t_build = time.perf_counter() - t0
    with contextlib.nullcontext() if ahead else casadi_messages_hidden():
        plan = draw_plan(problem, starts, seed, x_starts=x_starts)
    if plan.fitting:   # an objective phase will run: what it builds on first use, built once (before workers fork)
        solver.warm()
    t_all = time.perf_counter() - t0
    return Prepared(problem, solver, repair, plan, {"build_s": t_build, "screen_s": t_all - t_build},
                    t_all if ahead else 0.0)


def interrupted(problem, solver, plan, runs, total, timings) -> OptimisationInterrupted:
    """Ctrl-C after ``runs`` of ``total`` starts finished: the best design of those, marked
    interrupted (a second Ctrl-C while it is summarised stops at once)."""
    if not any(s is not None for _, s in runs):
        return OptimisationInterrupted(None, len(runs), total)
    resume_after_interrupt()
    result = summarise(problem, solver, [r for r, _ in runs], [s for _, s in runs], timings, plan)
    note = (f"INTERRUPTED by Ctrl-C after {len(runs)} of {total} starts: the best design of those "
            f"{len(runs)} starts, not a search of all {total}. " if len(runs) < total else
            f"INTERRUPTED by Ctrl-C after {total} of {total} starts, once all had finished: the best design "
            f"of all {total}. ")
    return OptimisationInterrupted(replace(result, interrupted=True, message=note + result.message),
                                   len(runs), total)


def draw_plan(problem: DesignProblem, starts: int, seed: int, fixed=None, x_starts=None) -> StartPlan:
    """The starts (and their reserve for retries): planned from the seed, or the given ones
    (then the reserve is screened only if a start needs a retry).  A single start is the
    scene's own, with the reserve screened on demand too."""
    if x_starts is None and starts > 1:
        return plan_starts(problem, starts, seed, fixed)
    points = problem.start[None, :] if x_starts is None else np.atleast_2d(np.asarray(x_starts, float))
    return StartPlan(points, method="sobol" if x_starts is None else "given",
                     plan_reserve=lambda: plan_starts(problem, len(points), seed, fixed))


def draw_starts(problem: DesignProblem, starts: int, seed: int, fixed=None) -> np.ndarray:
    """The planned start points (the scene's own start first): :func:`~.starts.plan_starts`."""
    return plan_starts(problem, starts, seed, fixed).points


def solve_then_retry(solver: Solver, repair: Repair, plan, workers=1, progress=None, finished=None) -> list:
    """:func:`solve_starts` with ``retry_if_fits`` (:func:`optimise`): every start from its own
    point alone; then, if any start reached phase 1's feasibility (its objective phase ran),
    the starts that failed retried as :func:`solve_starts` would (phase 1 from their own point
    not repeated: its result is the first pass's), giving the same (report, solution) per start.
    ``finished`` sees the first pass; ``progress(done, total)`` every start and retried start,
    the total grown by the failed ones once a start fits: done == total after the last retry."""
    n, tally = len(plan.points), [0, 0, False]   # starts done, failed, whether one fitted

    def first(report):
        tally[:] = [tally[0] + 1, tally[1] + (not report.success), tally[2] or _fits(report)]
        if finished is not None:
            finished(report)
        if progress is not None:
            progress(tally[0], n + tally[1] * tally[2])
    firsts = solve_starts(solver, repair, plan, workers, finished=first, retries=False)
    again = [i for i, (report, _) in enumerate(firsts) if not report.success]
    if not again or not tally[2]:   # all succeeded, or no start fitted: no retries
        return firsts
    earlier = {i: _first_try(solver.pb, firsts[i][0]) for i in again}
    step = None if progress is None else (lambda done, total: progress(n + done, n + total))
    try:
        retried = solve_starts(solver, repair, plan, workers, step, indices=again, earlier=earlier)
    except KeyboardInterrupt as exc:   # keep the first pass's successes and the retried starts finished
        done = dict(zip(getattr(exc, "finished_at", []), getattr(exc, "finished", [])))
        exc.finished = [done.get(i, run) for i, run in enumerate(firsts) if i in done or run[0].success]
        raise
    retried = dict(zip(again, retried))
    return [retried.get(i, run) for i, run in enumerate(firsts)]


def _fits(report) -> bool:
    """Whether a start's phase 1 reached a design feasible at the sample points."""
    return report.success or not report.status.startswith("phase 1 failed")


def _first_try(pb, report):
    """(Phase1Result or None, repaired) of a start's own point, from its report of a pass
    without retries: what :func:`feasible_start` returned there; None when the objective phase
    ran from it (the start is then solved again whole)."""
    from .phase1 import Phase1Result

    if _fits(report) or len(report.tried) != 1:
        return None
    entry = report.tried[0]
    if entry["violation"] is None:   # did not assemble and could not be repaired
        return (None, entry["repaired"])
    x = np.array([report.feasible_start[n] for n in pb.design_names])
    return (Phase1Result(x, entry["violation"], entry["phase1"], entry["phase1_iterations"]), entry["repaired"])


def solve_starts(solver: Solver, repair: Repair, plan, workers=1, progress=None, finished=None, retries=True,
                 indices=None, earlier=None) -> list:
    """(StartReport, Solution) of every start of ``plan`` (a :class:`StartPlan` or an array of
    start points), in order: in this process, or shared among ``workers`` forked processes
    (``finished(report)`` called here as each one finishes).
    Each start is solved on its own (nothing passes between starts), so the result is the
    same for any number of workers.  ``retries`` False: each start from its own point alone;
    ``indices``: only these starts (in this order; all by default), ``earlier``: index ->
    (Phase1Result or None, repaired) of that start's own point, already found
    (:func:`solve_then_retry`)."""
    if not isinstance(plan, StartPlan):
        plan = StartPlan(plan, np.zeros((0, len(solver.pb.design_names))), 0, "given")
    indices = list(range(len(plan.points))) if indices is None else list(indices)
    earlier = earlier or {}
    n = len(indices)
    workers = max(1, min(int(workers), n))
    if workers == 1 or "fork" not in multiprocessing.get_all_start_methods():
        runs = []
        try:
            for i in indices:
                runs.append(_solve_one(i, (solver, repair, plan, retries, earlier))[1])
                if finished is not None:
                    finished(runs[-1][0])
                if progress is not None:
                    progress(len(runs), n)
        except KeyboardInterrupt as exc:   # Ctrl-C: the caller keeps the starts that finished
            exc.finished, exc.finished_at = runs, indices[:len(runs)]
            raise
        return runs
    global _FORKED
    ctx = multiprocessing.get_context("fork")
    _FORKED = (solver, repair, plan, retries, earlier)
    runs = {}
    # a pool that says when one of its processes died (a multiprocessing.Pool replaces it and
    # waits for ever for the start it was solving)
    pool = cf.ProcessPoolExecutor(workers, mp_context=ctx, initializer=worker_process, initargs=(os.getpid(),))
    try:
        for f in cf.as_completed([pool.submit(_solve_one, i) for i in indices]):
            i, run = f.result()   # a worker's exception is raised here
            runs[i] = run
            if finished is not None:
                finished(run[0])
            if progress is not None:
                progress(len(runs), n)
    except KeyboardInterrupt as exc:   # Ctrl-C: the caller keeps the starts that finished
        exc.finished_at = [i for i in indices if i in runs]
        exc.finished = [runs[i] for i in exc.finished_at]
        raise
    except BrokenProcessPool:
        raise SolverError(f"a worker process of --workers {workers} died while solving the starts (killed, out of "
                          f"memory or crashed) after {len(runs)} of {n} starts had finished; run again, with fewer "
                          "--workers if memory is short") from None
    finally:
        _FORKED = None
        _end_pool(pool, wait=len(runs) == n)
    return [runs[i] for i in indices]


def _end_pool(pool, wait):
    """Shut the pool down; when it is left early (Ctrl-C, a dead process) its workers are
    stopped at once rather than left to finish the start they are solving."""
    processes = list((getattr(pool, "_processes", None) or {}).values())   # no public way before 3.14
    pool.shutdown(wait=wait, cancel_futures=True)
    if not wait:
        for process in processes:
            process.terminate()


_FORKED = None  # what forked workers inherit: (solver, repair, plan, retries, earlier)


def _solve_one(i, given=None):
    solver, repair, plan, retries, earlier = given or _FORKED
    return i, solve_start(solver, repair, i, plan.points[i], retry=(lambda k: plan.retry(i, k)) if retries else None,
                          first=earlier.get(i))


def feasible_start(solver: Solver, repair: Repair, x0, fixed):
    """Phase 1 from x0: (Phase1Result or None, repaired).  A start that does not assemble at
    the NLP's sample points is first projected onto designs that do; None when that fails."""
    pb = solver.pb
    repaired = False
    x0 = np.clip(np.asarray(x0, float), pb.lower, pb.upper)
    s_pts = np.r_[pb.base_points, pb.initial_slots]
    q = pb.evaluate_grid(x0, fixed, s_pts)
    if not np.all(np.isfinite(q)):
        fixed_x = repair(x0, fixed)
        if fixed_x is None:
            return None, False
        x0, repaired = fixed_x, True
    w0 = solver._initial_w(x0, fixed, s_pts)
    if isinstance(w0, str):
        return None, repaired
    phase1 = pb._once("phase 1", lambda: Phase1(pb))
    p = pb.nlp_parameters(fixed, s_pts, x0)
    lbg, ubg = pb.row_bounds(s_pts)
    return phase1(w0, p, lbg, ubg), repaired


def solve_start(solver: Solver, repair: Repair, index, x0, fixed=None, retry=None, first=None) -> tuple:
    """One start: phase 1 (a design feasible at the sample points, repairing the point first if
    it does not assemble), then the objective phase from the feasible design.  While phase 1
    cannot make the point feasible, or the objective phase fails, the start is retried from
    ``retry(k)`` (k = 0, 1, ...: fresh points; None when spent).  ``first``: what
    :func:`feasible_start` returned from ``x0``, found before (then not found again).
    (StartReport, Solution)"""
    pb = solver.pb
    t0 = time.perf_counter()
    fixed_v = solver.fixed_values(fixed)
    names = pb.design_names
    start = dict(zip(names, map(float, x0)))
    tried, least, failed, point = [], None, None, np.asarray(x0, float)
    for k in range(RETRIES + 1):
        if k:
            point = None if retry is None else retry(k - 1)
            if point is None:
                break
        ph1, repaired = first if k == 0 and first is not None else feasible_start(solver, repair, point, fixed_v)
        entry = {"start": dict(zip(names, map(float, point))), "repaired": repaired}
        tried.append(entry)
        if ph1 is None:
            entry.update({"phase1": "does not assemble and could not be repaired", "violation": None})
            continue
        entry.update({"phase1": ph1.status, "violation": ph1.violation, "phase1_iterations": ph1.iterations})
        if least is None or ph1.violation < least.violation:
            least = ph1
        if not ph1.feasible:
            continue
        sol = solver.solve(ph1.x, fixed_v)
        entry["status"] = sol if isinstance(sol, str) else sol.status
        if not isinstance(sol, str) and sol.success:
            report = StartReport(index, start, sol.status, True, objective_value(pb, sol), repaired, sol.iterations,
                                 sol.exchanges, time.perf_counter() - t0, tuple(tried), dict(zip(names, map(float, ph1.x))),
                                 dict(zip(names, map(float, np.clip(sol.x, pb.lower, pb.upper)))),
                                 _phase1_iterations(tried), 0.0)
            return report, sol
        failed = (sol, ph1, repaired)
    repaired_any = any(e["repaired"] for e in tried)
    if failed is not None:  # phase 1 succeeded somewhere, the objective phase failed from there
        sol, ph1, _ = failed
        status = sol if isinstance(sol, str) else sol.status
        its, exchanges, end = (0, 0, None) if isinstance(sol, str) else (
            sol.iterations, sol.exchanges, dict(zip(names, map(float, np.clip(sol.x, pb.lower, pb.upper)))))
        return StartReport(index, start, status, False, None, repaired_any, its, exchanges, time.perf_counter() - t0,
                           tuple(tried), dict(zip(names, map(float, ph1.x))), end, _phase1_iterations(tried), 0.0), None
    status = ("phase 1 failed: no point assembles" if least is None else
              f"phase 1 failed: least violation {least.violation:.3g} (scaled) after {len(tried)} points")
    return StartReport(index, start, status, False, None, repaired_any, 0, 0, time.perf_counter() - t0, tuple(tried),
                       None if least is None else dict(zip(names, map(float, least.x))), None,
                       _phase1_iterations(tried), None if least is None else least.violation), None


def _phase1_iterations(tried) -> int:
    return sum(e.get("phase1_iterations", 0) for e in tried)


def summarise(problem, solver, reports, solutions, timings, plan=None, fixed=None,
              polished=None) -> OptimisationResult:
    """The result of the starts: the best certified optimum (and how many starts reached it
    within 1e-3; ``polished(design)`` is told its design first), the distinct local optima, its
    constraints and sensitivities; or why none converged (with the least-violating design when
    phase 1 failed from every start)."""
    pb = problem
    optima = local_optima(pb, reports, solutions)
    index_of = {s: j for j, o in enumerate(optima) for s in o.starts}
    reports = [replace(r, optimum=index_of.get(r.index)) for r in reports]
    starts_info = plan.as_dict() if plan is not None else {"method": "given", "screened": 0, "reserve": None}
    good = [(r.objective, i) for i, r in enumerate(reports) if r.success and r.objective is not None]
    if not good:
        return _no_optimum(pb, reports, timings, starts_info)
    best_value, best = min(good)
    at_best = sum(1 for v, _ in good if abs(v - best_value) <= 1e-3 * max(abs(best_value), 1e-300))
    # the best start's solution with its sample points on the continuous extrema (its
    # multipliers are then the continuous problem's); the same optimum to the tolerances
    sol = solver.polish(solutions[best], fixed)
    if polished is not None:   # (the result's design, as below)
        polished(dict(zip(pb.design_names, map(float, np.clip(sol.x, pb.lower, pb.upper)))))
    best_value, refused, cycle = certify_cycle(pb, sol, objective_value(pb, sol),
                                              objective_value(pb, sol, certified=False), fixed)
    factor = objective_gradient_factor(pb, sol)
    peak_key = (pb.objective_text, "abs")
    peak_c = abs(sol.certified[peak_key]) if peak_key in sol.certified else None
    peak_s = abs(sol.sampled[peak_key]) if peak_key in sol.sampled else None
    n = len(reports)
    if peak_c is None and pb.objective_kind == "peak":   # load cases: the largest of the cases' peaks
        peak_c, peak_s = objective_value(pb, sol), objective_value(pb, sol, certified=False)
    constraints = _certified_cycle(constraint_report(pb, sol, factor), cycle)
    message = ("local optimum: IPOPT converged and the continuous check agrees (1 start: "
               "a local optimum, run more starts to search for a better one)" if n == 1 else
               "optimal: the best of the starts' local optima; IPOPT converged and the continuous check agrees")
    if sol.notes:   # what the enclosure could not prove (kinematics/enclosure.py): said, never pretended
        message += "; " + "; ".join(f"{name} {sense}: {note}" for (name, sense), note in sorted(sol.notes.items()))
    if uncertified(pb.scene):   # the NLP's rule on the samples stands for these terms: said, never pretended
        message += (f"; not certified: the RMS over time of {', '.join(uncertified(pb.scene))} is the NLP's rule on the "
                    "cases' samples (the cycle's quadrature covers drive, motor_load_torque, motor_torque and "
                    "[quantities] names)")
    if refused:
        message = f"refused: {refused}"
    return OptimisationResult(
        scene=pb.scene, design=dict(zip(pb.design_names, map(float, np.clip(sol.x, pb.lower, pb.upper)))),
        objective=best_value, objective_sampled=objective_value(pb, sol, certified=False),
        objective_kind=pb.objective_kind, peak_certified=peak_c, peak_sampled=peak_s,
        success=not refused, status="samples do not resolve the cycle" if refused else sol.status, message=message,
        constraints=constraints, sensitivities=sensitivities(pb, sol, factor, constraints),
        starts_total=n, starts_at_best=at_best, starts=tuple(reports), timings=timings,
        settings=pb.settings, optima=optima, start_plan=starts_info, sensitivity_notes=sensitivity_notes(pb))


def _certified_cycle(constraints, cycle):
    """The constraint report with each cycle constraint's value certified (the NLP's kept as
    ``value_sampled``) and its quadrature error."""
    for name, c in cycle.items():
        if name in constraints:
            constraints[name] = dict(constraints[name], value=c["value"], value_error=c["error"],
                                     value_sampled=constraints[name].get("value"))
    return constraints


def _no_optimum(pb, reports, timings, starts_info) -> OptimisationResult:
    """No start converged: 'infeasible' (with the least-violating design and what it violates)
    when phase 1 failed from every start, else the statuses of the failed objective phases."""
    phase1_failed = all(r.status.startswith("phase 1 failed") for r in reports)
    statuses = sorted({r.status for r in reports})
    if phase1_failed:
        least = min((r for r in reports if r.violation is not None), key=lambda r: r.violation, default=None)
        violated = {} if least is None else violated_constraints(pb, least.feasible_start)
        where = ("no start point assembled" if least is None else
                 f"the least-violating design {least.feasible_start} violates "
                 + "; ".join(f"{k} by {v:.4g}" for k, v in violated.items()))
        return OptimisationResult(
            pb.scene, {}, None, None, pb.objective_kind, None, None, False, "infeasible",
            f"Phase 1 (minimise the constraint violation) failed from every start and its retries: {where}. "
            "Relax those constraints or widen the bounds, or try more starts (--starts).",
            {}, {}, len(reports), 0, tuple(reports), timings, pb.settings,
            least_violating=None if least is None else {"design": least.feasible_start, "violated": violated},
            start_plan=starts_info)
    limits = {}
    for r in reports:
        if r.end is not None and "Invalid_Number" in r.status:
            limits.update(at_limit_positions(pb, r.end))
    lockup = ("" if not limits else
              " The starts that ended on a number that is not finite (Invalid_Number_Detected) ended where "
              + ", ".join(f"{k} (margin {v:.3g})" for k, v in limits.items())
              + " is at its limit position: a lock-up, where the drive would move infinitely fast for the "
              "output's motion. The objective pulls the design there: add a constraint that keeps the links "
              "out of line (a transmission angle, or the angle between the two links of that construction).")
    return OptimisationResult(
        pb.scene, {}, None, None, pb.objective_kind, None, None, False, "; ".join(statuses),
        "No start converged to a feasible design. Try more starts (--starts), widen the bounds, "
        "relax the constraints, or check the start with `optdesign analyse`." + lockup,
        {}, {}, len(reports), 0, tuple(reports), timings, pb.settings, start_plan=starts_info)


def rows_at(pb, design: dict):
    """(g, s_pts): the NLP's rows at ``design`` on its initial sample points, or None when the
    design does not assemble there."""
    x = np.array([design[n] for n in pb.design_names])
    fixed = pb.mech.parameter_values[pb.fixed_index]
    s_pts = np.r_[pb.base_points, pb.initial_slots]
    phase1 = pb._once("phase 1", lambda: Phase1(pb))
    w = initial_w(pb, x, fixed, s_pts)   # (a Solver would build its continuous check for nothing)
    if isinstance(w, str):
        return None
    return np.asarray(phase1.g(w, pb.nlp_parameters(fixed, s_pts, x))).ravel(), s_pts


def at_limit_positions(pb, design: dict, near=1e-4) -> dict:
    """The constructions that ``design`` takes to (or past) a limit position on the NLP's initial
    sample points: assembly block name -> its least margin in physical units, for each margin
    whose least value over the stroke is within ``near`` of its largest (a dyad's two links in
    line: a lock-up, where the drive moves infinitely fast for the output's motion and the
    model's derivatives are not finite)."""
    rows = rows_at(pb, design)
    out = {}
    for name, kind, start, n in pb.g_blocks if rows is not None else ():
        values = rows[0][start:start + n]
        if kind == "margin" and n and np.all(np.isfinite(values)) and values.min() <= near * np.abs(values).max():
            out[name] = float(values.min()) * pb.g_scale.get(name, 1.0)
    return out


def violated_constraints(pb, design: dict) -> dict:
    """Each block violated at ``design`` on the NLP's initial sample points: its worst
    violation in physical units (a margin: how far the construction is from assembling)."""
    rows = rows_at(pb, design)
    if rows is None:
        return {"assembly": float("inf")}
    g, s_pts = rows
    lbg, ubg = pb.row_bounds(s_pts)
    out = {}
    for name, kind, start, n in pb.g_blocks:
        if kind == "peak":
            continue
        sl = slice(start, start + n)
        v = float(np.max(np.maximum(np.maximum(lbg[sl] - g[sl], g[sl] - ubg[sl]), 0.0), initial=0.0))
        if v > 1e-7:
            label = {"aggregate": "stroke extreme", "dead centre": "dead centre (the drive stops moving)"}.get(kind, name)
            out[label] = v * pb.g_scale.get(name, 1.0)
    return out
