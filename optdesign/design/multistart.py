"""The front door of the design problem: :func:`optimise` builds the problem once, draws
reproducible starts, solves each one (repairing it first if it does not assemble), in this
process or in a pool of forked workers, and summarises the best certified optimum."""
from __future__ import annotations

import multiprocessing
import time

import numpy as np

from ..scene import Scene
from ..scene.arguments import optimise_arguments, scene_argument
from .problem import DesignProblem, SolverSettings
from .repair import Repair
from .results import OptimisationResult, StartReport
from .sensitivities import constraint_report, objective_gradient_factor, objective_value, sensitivities
from .solver import Solver


def optimise(scene: Scene, starts: int = 20, seed: int = 0, settings: SolverSettings | None = None,
             progress=None, x_starts=None, workers: int = 1) -> OptimisationResult:
    """Minimise the scene's objective over its design variables (front door).

    ``starts`` reproducible starts (the scene's start, then random points of the design box
    drawn with ``seed``) or explicit ``x_starts``; ``progress(done, total)`` is called after
    each start; ``workers`` > 1 solves the starts in that many forked processes (where the
    platform can fork; the result for a given number of workers does not depend on timing)."""
    starts, seed, workers = optimise_arguments(scene_argument("optimise", scene), starts, seed, workers)
    t0 = time.perf_counter()
    problem = DesignProblem(scene, settings)
    solver, repair = Solver(problem), Repair(problem)
    t_build = time.perf_counter() - t0
    xs = draw_starts(problem, starts, seed) if x_starts is None else np.atleast_2d(np.asarray(x_starts, float))
    runs = solve_starts(solver, repair, xs, workers, progress)
    reports, solutions = [r for r, _ in runs], [s for _, s in runs]
    return summarise(problem, solver, reports, solutions, {"build_s": t_build, "total_s": time.perf_counter() - t0})


def draw_starts(problem: DesignProblem, starts: int, seed: int) -> np.ndarray:
    """The scene's own start, then uniform random points of the design box (reproducible)."""
    rng = np.random.default_rng(seed)
    lo = np.where(np.isfinite(problem.lower), problem.lower, problem.start - np.abs(problem.start) - 1)
    hi = np.where(np.isfinite(problem.upper), problem.upper, problem.start + np.abs(problem.start) + 1)
    rand = lo + (hi - lo) * rng.random((max(starts - 1, 0), len(lo)))
    return np.vstack([problem.start[None, :], rand])[:starts]


def solve_starts(solver: Solver, repair: Repair, xs, workers=1, progress=None) -> list:
    """(StartReport, Solution) of every start, in order: in this process, or shared among
    ``workers`` forked processes, worker w taking starts w, w + workers, ... in turn (each
    worker's solver carries what it learned from one start to its next, as the serial loop
    does, so a given number of workers always gives the same result)."""
    n = len(xs)
    workers = max(1, min(int(workers), n))
    if workers == 1 or "fork" not in multiprocessing.get_all_start_methods():
        runs = []
        for i, x0 in enumerate(xs):
            runs.append(solve_start(solver, repair, i, x0))
            if progress is not None:
                progress(i + 1, n)
        return runs
    global _FORKED
    ctx = multiprocessing.get_context("fork")
    done_queue = ctx.SimpleQueue()
    _FORKED = (solver, repair, xs, workers, done_queue)
    try:
        with ctx.Pool(workers) as pool:
            shares = pool.map_async(_solve_share, range(workers))
            done = 0
            while done < n:
                shares.wait(0.01)
                while not done_queue.empty():
                    done_queue.get()
                    done += 1
                    if progress is not None:
                        progress(done, n)
                if shares.ready() and done_queue.empty():
                    break
            results = shares.get()  # a worker's exception is raised here
    finally:
        _FORKED = None
    runs = dict(item for share in results for item in share)
    return [runs[i] for i in range(n)]


_FORKED = None  # what forked workers inherit: (solver, repair, starts, workers, done queue)


def _solve_share(w):
    solver, repair, xs, workers, done_queue = _FORKED
    out = []
    for i in range(w, len(xs), workers):
        out.append((i, solve_start(solver, repair, i, xs[i])))
        done_queue.put(i)
    return out


def solve_start(solver: Solver, repair: Repair, index, x0, fixed=None) -> tuple:
    """One start: solve, repairing it first if it does not assemble.  (StartReport, Solution)"""
    pb = solver.pb
    t0 = time.perf_counter()
    fixed_v = solver.fixed_values(fixed)
    repaired = False
    start = dict(zip(pb.design_names, map(float, x0)))
    q = pb.evaluate_grid(np.clip(x0, pb.lower, pb.upper), fixed_v, np.r_[pb.base_points, pb.initial_slots])
    if not np.all(np.isfinite(q)):
        fixed_x = repair(np.asarray(x0, float), fixed_v)
        if fixed_x is None:
            return StartReport(index, start, "skipped: does not assemble and could not be repaired", False,
                               None, False, 0, 0, time.perf_counter() - t0), None
        x0, repaired = fixed_x, True
    sol = solver.solve(x0, fixed_v)
    if isinstance(sol, str):
        if repaired:
            sol = "skipped: the repaired start still does not assemble at the sample points"
        return StartReport(index, start, sol, False, None, repaired, 0, 0, time.perf_counter() - t0), None
    objective = objective_value(pb, sol) if sol.success else None
    report = StartReport(index, start, sol.status, sol.success, objective, repaired, sol.iterations,
                         sol.exchanges, time.perf_counter() - t0)
    return report, sol


def summarise(problem, solver, reports, solutions, timings) -> OptimisationResult:
    """The result of the starts: the best certified optimum (and how many starts reached it
    within 1e-3), its constraints and sensitivities; or why none converged."""
    pb = problem
    good = [(r.objective, i) for i, r in enumerate(reports) if r.success and r.objective is not None]
    if not good:
        statuses = sorted({r.status for r in reports})
        return OptimisationResult(
            pb.scene, {}, None, None, pb.objective_kind, None, None, False, "; ".join(statuses),
            "No start converged to a feasible design. Try more starts (--starts), widen the bounds, "
            "relax the constraints, or check the start with `optdesign analyse`.",
            {}, {}, len(reports), 0, tuple(reports), timings, pb.settings)
    best_value, best = min(good)
    at_best = sum(1 for v, _ in good if abs(v - best_value) <= 1e-3 * max(abs(best_value), 1e-300))
    sol = solutions[best]
    factor = objective_gradient_factor(pb, sol)
    peak_key = (pb.objective_text, "abs")
    peak_c = abs(sol.certified[peak_key]) if peak_key in sol.certified else None
    peak_s = abs(sol.sampled[peak_key]) if peak_key in sol.sampled else None
    return OptimisationResult(
        scene=pb.scene, design=dict(zip(pb.design_names, map(float, np.clip(sol.x, pb.lower, pb.upper)))),
        objective=best_value, objective_sampled=objective_value(pb, sol, certified=False),
        objective_kind=pb.objective_kind, peak_certified=peak_c, peak_sampled=peak_s,
        success=True, status=sol.status, message="optimal: IPOPT converged and the continuous check agrees",
        constraints=constraint_report(pb, sol, factor), sensitivities=sensitivities(pb, sol, factor),
        starts_total=len(reports), starts_at_best=at_best, starts=tuple(reports), timings=timings,
        settings=pb.settings)
