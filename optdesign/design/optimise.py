"""Solving the design problem: exchange of sample points, peak certification, multistart,
multipliers and sensitivities.  Front door: :func:`optimise`."""
from __future__ import annotations

import math
import multiprocessing
import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from .problem import DesignProblem, SolverSettings
from ..model.mapped import MappedFunction
from ..model.peaks import Request, continuous_maxima_rows
from ..scene.elements import Scene


@dataclass(frozen=True)
class StartReport:
    """What one start did."""

    index: int
    start: dict
    status: str            # IPOPT's return status, or 'skipped: ...'
    success: bool          # IPOPT converged and the continuous check agreed
    objective: float | None
    repaired: bool
    iterations: int
    exchanges: int
    time_s: float


@dataclass(frozen=True)
class Solution:
    """One converged solve (internal, with what the reports need)."""

    x: np.ndarray
    w: np.ndarray
    lam_g: np.ndarray
    lam_x: np.ndarray
    lam_p: np.ndarray
    g: np.ndarray
    f: float
    s_points: np.ndarray
    status: str
    success: bool
    iterations: int
    exchanges: int
    certified: dict        # (block name, sense) -> worst continuous value (physical units)
    sampled: dict          # (block name, sense) -> worst value on the scene's samples
    converged: bool


@dataclass(frozen=True)
class OptimisationResult:
    """The result of :func:`optimise` (frozen; fixed fields)."""

    scene: Scene
    design: dict
    objective: float | None          # certified (continuous stroke) value of the objective
    objective_sampled: float | None  # the same on the scene's samples only
    objective_kind: str
    peak_certified: float | None     # continuous peak |drive| (or |objective quantity|)
    peak_sampled: float | None
    success: bool
    status: str
    message: str
    constraints: dict                # name -> {value, lower, upper, multiplier, active}
    sensitivities: dict              # fixed parameter -> d objective / d parameter
    starts_total: int
    starts_at_best: int
    starts: tuple
    timings: dict = field(default_factory=dict)
    settings: SolverSettings = field(default_factory=SolverSettings)


@dataclass(frozen=True)
class _Check:
    """One comparison of the continuous check: the extrema of quantity row ``row`` (|v|, max
    or min: ``sense``) against ``bound`` (an upper bound unless ``upper`` is False), in units
    of ``scale``, with tolerance ``tol``.  kind 'rms': the rms block's peak, certified only."""

    name: str
    row: int
    sense: str
    scale: float
    bound: float
    tol: float
    upper: bool = True
    kind: str = "bound"

    @property
    def request(self) -> Request:
        """Refine only the extrema within 10 % of the scale of the bound: the others cannot matter."""
        sign = 1.0 if self.upper else -1.0
        limit = sign * self.bound / self.scale - 0.1 if math.isfinite(self.bound) else None
        return Request(self.row, self.sense, None if limit is None else limit * self.scale)

    def amount(self, value) -> float:
        """By how much ``value`` exceeds the bound, in units of the scale (< 0: within it)."""
        if self.sense == "abs":
            return (abs(value) - self.bound) / self.scale
        sign = 1.0 if self.upper else -1.0
        return (sign * value - sign * self.bound) / self.scale


# --- one start -----------------------------------------------------------------------------
class Solver:
    """Solves a :class:`DesignProblem` from one start by exchange of sample points."""

    def __init__(self, problem: DesignProblem):
        self.pb = problem
        # the sample points (and their tracking) that certified the last optimum: the next
        # start begins with them, so that a start that reaches the same optimum needs no
        # exchange step
        self.learned = None
        # the per-sample quantities' s-derivatives at many sweep values (the continuous check)
        self.derivatives = MappedFunction(problem.quantity_derivatives)

    def fixed_values(self, fixed=None):
        pb = self.pb
        return pb.mech.parameter_values[pb.fixed_index] if fixed is None else np.asarray(fixed, float)

    def solve(self, x0, fixed=None) -> Solution | str:
        """Solve from design x0: IPOPT, then the continuous check; while some bound or the
        epigraph is exceeded between the sample points, move slots onto the located extrema
        (each following its extremum to first order in the design) and solve again."""
        pb, st = self.pb, self.pb.settings
        fixed = self.fixed_values(fixed)
        nd = len(pb.design_names)
        if self.learned is not None:  # the sample points that certified the last optimum
            s_pts, x_ref, tracking, rows = self.learned
        else:
            s_pts = np.r_[pb.base_points, pb.initial_slots]
            x_ref, tracking, rows = np.clip(np.asarray(x0, float), pb.lower, pb.upper), np.zeros((pb.n_points, nd)), {}
        w = self._initial_w(x0, fixed, s_pts)
        if isinstance(w, str):
            return w
        iterations, res = 0, None
        for exchange in range(st.max_exchanges + 1):
            res, stats, its = self._ipopt(w, pb.nlp_parameters(fixed, s_pts, x_ref, tracking), pb.row_bounds(s_pts), res)
            iterations += its
            status = stats["return_status"]
            w = np.asarray(res["x"]).ravel()
            x = pb.to_x(w[:nd])
            s_now = np.clip(s_pts + tracking @ (x - x_ref), pb.s_grid[0], pb.s_grid[-1])  # the NLP's points at its solution
            if not stats["success"]:
                return self._solution(res, x, fixed, s_now, status, False, iterations, exchange, {}, {}, False)
            violations, certified, sampled = self.continuous_check(x, fixed, w, s_now)
            if not any(v[0] > 0 for v in violations):
                self.learned = (s_pts, x_ref, tracking, rows)
                return self._solution(res, x, fixed, s_now, status, True, iterations, exchange, certified, sampled, True)
            slots, rows = self._slots(violations, s_now, rows, np.asarray(res["lam_g"]).ravel())
            s_pts = np.r_[pb.base_points, slots]
            tracking = np.zeros((pb.n_points, nd))
            for j, s_j in enumerate(slots):
                row = rows.get(round(s_j, 12))
                if row is not None:
                    tracking[len(pb.base_points) + j] = pb.tracking_gradient(s_j, x, fixed, row)
            x_ref = x
        return self._solution(res, x, fixed, s_now, status + " (exchange did not converge)", False,
                              iterations, exchange, certified, sampled, False)

    def _ipopt(self, w, p, row_bounds, last=None):
        """One IPOPT solve: warm from the last solution's multipliers after an exchange step
        (cold again if that fails).  Returns (result, stats, iterations)."""
        pb = self.pb
        bounds = {"lbx": pb.lbw, "ubx": pb.ubw, "lbg": row_bounds[0], "ubg": row_bounds[1]}
        iterations = 0
        if last is not None:
            res = pb.warm_solver(x0=w, p=p, lam_x0=last["lam_x"], lam_g0=last["lam_g"], **bounds)
            stats = pb.warm_solver.stats()
            iterations += int(stats.get("iter_count", 0))
            if stats["success"]:
                return res, stats, iterations
        res = pb.solver(x0=w, p=p, **bounds)
        stats = pb.solver.stats()
        return res, stats, iterations + int(stats.get("iter_count", 0))

    def _solution(self, res, x, fixed, s_pts, status, success, iterations, exchanges, certified, sampled, converged):
        return Solution(
            x=x, w=np.asarray(res["x"]).ravel(), lam_g=np.asarray(res["lam_g"]).ravel(),
            lam_x=np.asarray(res["lam_x"]).ravel(), lam_p=np.asarray(res["lam_p"]).ravel(),
            g=np.asarray(res["g"]).ravel(), f=float(res["f"]), s_points=s_pts, status=status, success=success and converged,
            iterations=iterations, exchanges=exchanges, certified=certified, sampled=sampled,
            converged=converged,
        )

    def _initial_w(self, x0, fixed, s_pts):
        pb = self.pb
        x0 = np.clip(np.asarray(x0, float), pb.lower, pb.upper)
        q = pb.evaluate_grid(x0, fixed, s_pts)
        if not np.all(np.isfinite(q)):
            return "skipped: the start does not assemble and could not be repaired"
        t = []
        if pb.n_t:
            t = [float(np.max(np.abs(q[pb.objective_quantity]))) / pb.f_ref]
        a = [float(np.max(q[ag.index]) if ag.func == "max" else np.min(q[ag.index])) for ag in pb.aggregates]
        return np.r_[pb.to_z(x0), t, np.asarray(a) / pb.a_scale]

    def continuous_check(self, x, fixed, w, s_points):
        """Worst values of every block over the continuous stroke at design x.

        Returns (violations, certified, sampled): violations is a list of (amount, s, row) with
        amount > 0 where a bound (or the epigraph) is exceeded by more than its tolerance,
        sorted largest first, near-active extrema included with amount <= 0.  The extrema of
        all blocks are refined together (:func:`~optdesign.model.peaks.continuous_maxima_rows`: one
        evaluation of every row per Newton step of all brackets)."""
        pb, st = self.pb, self.pb.settings
        p = pb.full_parameters(x, fixed)
        grid = pb.s_grid
        V = pb.evaluate_grid(x, fixed)
        checks = self._checks(x, fixed, w, s_points)
        extrema = continuous_maxima_rows(lambda s: self.derivatives(s, p), grid, V, [c.request for c in checks])
        out, certified, sampled = [], {}, {}
        for c, ext in zip(checks, extrema):
            vals = V[c.row]
            certified[(c.name, c.sense)] = ext[0].value
            sampled[(c.name, c.sense)] = float(np.max(np.abs(vals)) if c.sense == "abs" else (np.max(vals) if c.sense == "max" else np.min(vals)))
            if c.kind == "rms":
                # the quadrature of the NLP against one with twice the panels
                rms, finer = pb.rms(x, fixed), pb.rms(x, fixed, 2 * pb.rms_panels)
                certified[(c.name, "rms")], sampled[(c.name, "rms")] = finer, pb.rms_sampled(x, fixed)
                out.append((abs(rms - finer) / max(finer, 1e-300) - st.rms_tol, 0.5 * (grid[0] + grid[-1]), None))
            else:
                out += [(c.amount(e.value) - c.tol, e.s, c.row) for e in ext]
        out.sort(key=lambda v: v[0], reverse=True)
        return out, certified, sampled

    def _checks(self, x, fixed, w, s_points) -> list:
        """What the continuous check compares, in the order it reports: the epigraph of the
        peak (or the rms block's peak, bound-free), each constraint's upper then lower bound,
        each aggregate against its NLP value, and the dead-centre guard."""
        pb, st = self.pb, self.pb.settings
        nd = len(pb.design_names)
        t = float(w[nd]) if pb.n_t else None
        a = pb.aggregates_of(w)
        checks = []
        for b in pb.blocks:
            if b.kind == "peak":
                # the epigraph's own value: the largest |v| at the NLP's points (IPOPT may leave t
                # a hair below it, within its constraint tolerance)
                at_points = pb.evaluate_grid(x, fixed, s_points)
                reference = max(t * pb.f_ref, float(np.max(np.abs(at_points[b.index]))))
                checks.append(_Check(b.name, b.index, "abs", pb.f_ref, reference, st.peak_tol * reference / pb.f_ref))
            elif b.kind == "rms":
                checks.append(_Check(b.name, b.index, "abs", 1.0, math.inf, 0.0, kind="rms"))
            elif b.kind in ("constraint", "design constraint", "margin"):
                if math.isfinite(b.upper):
                    checks.append(_Check(b.name, b.index, "max", b.scale, b.upper, st.constraint_tol))
                if math.isfinite(b.lower):
                    checks.append(_Check(b.name, b.index, "min", b.scale, b.lower, st.constraint_tol, upper=False))
        for i, ag in enumerate(pb.aggregates):
            if ag.func == "max":
                checks.append(_Check(ag.name, ag.index, "max", ag.scale, float(a[i]), st.constraint_tol))
            else:
                checks.append(_Check(ag.name, ag.index, "min", ag.scale, float(a[i]), st.constraint_tol, upper=False))
        checks.append(_Check("dead centre", pb.k_row, "min" if pb.k_sign > 0 else "max", pb.k_ref,
                             pb.k_sign * st.dead_centre_margin * pb.k_ref, 0.0, upper=pb.k_sign < 0))
        return checks

    def _slots(self, violations, s_now, rows, lam_g):
        """Sample points for the slots, and the row whose extremum each one follows.

        Violated continuous extrema first, then slots whose constraints carry a multiplier at
        the last solution (dropping them lets the next solve cycle between designs), then the
        most nearly active extrema.  Returns (sorted points, {round(point, 12): row})."""
        pb = self.pb
        n_base, n_slots = len(pb.base_points), len(pb.initial_slots)
        weight = self._point_weights(lam_g, len(s_now))
        kept = sorted(((weight[j], s_now[j], rows.get(round(s_now[j], 12))) for j in range(n_base, len(s_now))
                       if weight[j] > 0), key=lambda k: k[0], reverse=True)
        new = [(s, row) for amount, s, row in violations if amount > 0]
        near = [(s, row) for amount, s, row in violations if amount <= 0]
        spare = np.linspace(pb.base_points[0], pb.base_points[-1], 4 * (n_base + n_slots))
        candidates = new + [(s, row) for _, s, row in kept] + near + [(s, None) for s in (*pb.initial_slots, *spare)]
        chosen = {}
        for s, row in candidates:
            if len(chosen) == n_slots:
                break
            base = int(np.argmin(np.abs(pb.base_points - s)))
            on_base = abs(pb.base_points[base] - s) <= 1e-9
            # no slot on a base point, where every block is imposed already, except for a row
            # imposed only at the ends and the slots (stroke aggregate, dead-centre guard)
            # between the ends: there the other blocks' repeated rows are freed (row_bounds)
            free = not on_base or (row in pb.sparse_rows and 0 < base < n_base - 1)
            if free and all(abs(s - c) > 1e-9 for c in chosen):
                chosen[s] = row
        points = np.array(sorted(chosen))
        return points, {round(s, 12): chosen[s] for s in points}

    def _point_weights(self, lam_g, n_points):
        """Sum of |multipliers| of all per-point constraint rows, per sample point."""
        w = np.zeros(n_points)
        for name, _, start, n in self.pb.g_blocks:
            points = self.pb.g_points.get(name)
            if points is not None:
                np.add.at(w, points, np.abs(lam_g[start:start + n]))
        return np.where(w > 1e-9 * max(float(np.max(w, initial=0.0)), 1e-300), w, 0.0)


# --- repair of starts that do not assemble ---------------------------------------------------
IPOPT_BOUND_PUSH = 0.01  # IPOPT's default bound_push and bound_frac, on the design scaled to [0, 1]


class Repair:
    """Projects a start onto designs whose constructions assemble at the sample points:
    min |z - z0|^2 subject to every dyad/slider margin >= 1e-3 of its start scale."""

    def __init__(self, problem: DesignProblem):
        pb = problem
        self.pb = pb
        margins = [b for b in pb.blocks if b.kind == "margin"]
        self.ok = bool(margins)
        if not self.ok:
            return
        sym = pb.mech.sym
        z = sym.sym("z", len(pb.design_names))
        z0 = sym.sym("z0", len(pb.design_names))
        fixed = sym.sym("fixed", len(pb.fixed_names))
        x = ca.DM(pb.z_offset) + ca.DM(pb.z_scale) * z
        p = pb.full_parameters(x, fixed)
        rows = ca.vertcat(*[pb.rows[b.index] / b.scale for b in margins])
        f = pb.mech.function("margins", {"m": rows})
        # the scene's samples and the NLP's own points: a repaired start must assemble wherever
        # the solve will evaluate it
        pts = np.unique(np.r_[pb.s_grid, pb.base_points, pb.initial_slots])
        g = ca.vec(f.map(len(pts))(ca.DM(pts).T, p))
        nlp = {"x": z, "p": ca.vertcat(z0, fixed), "f": ca.sumsqr(z - z0), "g": g}
        self.solver = ca.nlpsol("repair", "ipopt", nlp, {
            "ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes", "error_on_fail": False,
            "show_eval_warnings": False})
        self.n_g = int(g.numel())

    def __call__(self, x0, fixed):
        pb = self.pb
        if not self.ok:
            return None
        z0 = pb.to_z(np.clip(x0, pb.lower, pb.upper))
        # inside the box that IPOPT starts in: it moves a start closer than bound_push = 0.01
        # (of the scaled box) to a bound inward, where a repair made at the bound can fail to
        # assemble (level-luffing path scene: repaired onto xE's bound, moved 0.035 m inward,
        # NaN at iteration 0)
        lb = np.where(np.isfinite(pb.lower), IPOPT_BOUND_PUSH, -np.inf)
        ub = np.where(np.isfinite(pb.upper), 1.0 - IPOPT_BOUND_PUSH, np.inf)
        res = self.solver(x0=z0, p=np.r_[z0, fixed], lbx=lb, ubx=ub, lbg=1e-3, ubg=np.inf)
        if not self.solver.stats()["success"]:
            return None
        return pb.to_x(np.asarray(res["x"]).ravel())


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


def objective_value(pb: DesignProblem, sol: Solution, certified=True) -> float:
    """The objective in physical units: certified (continuous) or on the scene's samples."""
    values = sol.certified if certified else sol.sampled
    if pb.objective_kind == "peak":
        return abs(values[(pb.objective_text, "abs")])
    if pb.objective_kind == "rms":
        return values[(pb.objective_text, "rms")]
    return pb.stroke_value(pb.objective_expr, values)


def objective_gradient_factor(pb: DesignProblem, sol: Solution) -> float:
    """dJ/df: the physical objective J per unit of the NLP's objective f."""
    if pb.objective_kind == "peak":
        return pb.f_ref
    if pb.objective_kind == "rms":
        return pb.f_ref / (2 * math.sqrt(max(sol.f, 1e-300)))
    return pb.objective_scale


# --- the front door ------------------------------------------------------------------------
def draw_starts(problem: DesignProblem, starts: int, seed: int) -> np.ndarray:
    """The scene's own start, then uniform random points of the design box (reproducible)."""
    rng = np.random.default_rng(seed)
    lo = np.where(np.isfinite(problem.lower), problem.lower, problem.start - np.abs(problem.start) - 1)
    hi = np.where(np.isfinite(problem.upper), problem.upper, problem.start + np.abs(problem.start) + 1)
    rand = lo + (hi - lo) * rng.random((max(starts - 1, 0), len(lo)))
    return np.vstack([problem.start[None, :], rand])[:starts]


def optimise(scene: Scene, starts: int = 20, seed: int = 0, settings: SolverSettings | None = None,
             progress=None, x_starts=None, workers: int = 1) -> OptimisationResult:
    """Minimise the scene's objective over its design variables (front door).

    ``starts`` reproducible starts (the scene's start, then random points of the design box
    drawn with ``seed``) or explicit ``x_starts``; ``progress(done, total)`` is called after
    each start; ``workers`` > 1 solves the starts in that many forked processes (where the
    platform can fork; the result for a given number of workers does not depend on timing)."""
    t0 = time.perf_counter()
    problem = DesignProblem(scene, settings)
    solver, repair = Solver(problem), Repair(problem)
    t_build = time.perf_counter() - t0
    xs = draw_starts(problem, starts, seed) if x_starts is None else np.atleast_2d(np.asarray(x_starts, float))
    runs = solve_starts(solver, repair, xs, workers, progress)
    reports, solutions = [r for r, _ in runs], [s for _, s in runs]
    return summarise(problem, solver, reports, solutions, {"build_s": t_build, "total_s": time.perf_counter() - t0})


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


def summarise(problem, solver, reports, solutions, timings) -> OptimisationResult:
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
    # CasADi's lam_p is minus the gradient of the Lagrangian in p: dJ*/dp = -lam_p (scaled)
    sens = {name: float(-factor * sol.lam_p[j]) for j, name in enumerate(pb.fixed_names)}
    peak_key = (pb.objective_text, "abs")
    peak_c = abs(sol.certified[peak_key]) if peak_key in sol.certified else None
    peak_s = abs(sol.sampled[peak_key]) if peak_key in sol.sampled else None
    return OptimisationResult(
        scene=pb.scene, design=dict(zip(pb.design_names, map(float, np.clip(sol.x, pb.lower, pb.upper)))),
        objective=best_value, objective_sampled=objective_value(pb, sol, certified=False),
        objective_kind=pb.objective_kind, peak_certified=peak_c, peak_sampled=peak_s,
        success=True, status=sol.status, message="optimal: IPOPT converged and the continuous check agrees",
        constraints=constraint_report(pb, sol, factor), sensitivities=sens,
        starts_total=len(reports), starts_at_best=at_best, starts=tuple(reports), timings=timings,
        settings=pb.settings)


def constraint_report(pb: DesignProblem, sol: Solution, factor: float) -> dict:
    """Each named constraint: its extreme values over the continuous stroke, its bounds, and
    its multiplier as dJ*/d(active bound) in physical units (0 when inactive)."""
    out = {}
    for name, kind, start, n in pb.g_blocks:
        if kind in ("peak", "aggregate"):
            continue
        scale = pb.g_scale[name]
        lam = float(np.sum(_active(sol.lam_g[start:start + n], sol.g[start:start + n],
                                   pb.lbg[start:start + n], pb.ubg[start:start + n])))
        entry = {"kind": kind, "lower": _finite(pb.lbg[start] * scale), "upper": _finite(pb.ubg[start] * scale),
                 "multiplier": -lam * factor / scale + 0.0,
                 "active": None if lam == 0 else ("upper" if lam > 0 else "lower")}
        if kind == "stroke constraint":
            entry["value"] = pb.stroke_value(pb.stroke_outer[name], sol.certified)
        else:
            lo, hi = sol.certified.get((name, "min")), sol.certified.get((name, "max"))
            if kind == "dead centre":  # reported as sigma * k / k_ref, the guarded quantity
                lo, hi = [None if v is None else pb.k_sign * v / pb.k_ref for v in (lo, hi)]
                lo, hi = (hi, lo) if pb.k_sign < 0 else (lo, hi)
            entry.update({"min": lo, "max": hi})
            entry["value"] = hi if lo is None or (entry["active"] == "upper") else lo
        out[name] = entry
    for j, name in enumerate(pb.design_names):
        lam = float(_active(sol.lam_x[j:j + 1], sol.w[j:j + 1], pb.lbw[j:j + 1], pb.ubw[j:j + 1])[0])
        out[f"bounds of {name}"] = {
            "kind": "bound", "value": float(np.clip(sol.x[j], pb.lower[j], pb.upper[j])), "lower": _finite(pb.lower[j]), "upper": _finite(pb.upper[j]),
            "multiplier": float(-lam * factor / pb.z_scale[j]) + 0.0,
            "active": None if lam == 0 else ("upper" if lam > 0 else "lower")}
    return out


def _active(lam, value, lower, upper, tol=1e-6):
    """Multipliers of constraints at their bounds (within tol, scaled); 0 for the others,
    whose interior-point multipliers are of the order of IPOPT's barrier parameter."""
    at_bound = (np.abs(value - lower) <= tol) | (np.abs(value - upper) <= tol)
    return np.where(at_bound, lam, 0.0)


def _finite(v):
    return float(v) if math.isfinite(v) else None
