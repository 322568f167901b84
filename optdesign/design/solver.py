"""Solving the design problem from one start: the slots placed on the extrema of the start
design, IPOPT, then the continuous check (:mod:`.certify`); while some bound or the epigraph
is exceeded between the sample points, an exchange step moves the slots onto the located
extrema and solves again (warm).  Nothing passes from one start to the next.  (An active-set SQP
for these solves, IPOPT its fallback, is measured as an option: :mod:`.sqp`.)"""
from __future__ import annotations

import numpy as np

from ..errors import check_interrupt
from . import sqp
from .aggregates import sampled_extreme
from .certify import ContinuousCheck
from .cycle_certify import warm_cycle
from .problem import DesignProblem
from .results import Solution


STEP_START = 0.1   # the exchange's first design step limit, a tenth of each variable's range


class Solver:
    """Solves a :class:`DesignProblem` from one start by exchange of sample points."""

    def __init__(self, problem: DesignProblem):
        self.pb = problem
        # nothing passes from one start to the next (each start places its own slots), so a
        # start's result depends on its start point alone, whatever ran before it here.
        # The continuous check at a solution (with its own evaluation of the s-derivatives):
        self.checker = ContinuousCheck(problem)
        self._sqp = None   # this start's SQP (design/sqp.py), made on its first use

    def warm(self):
        """Build what an objective phase builds on its first use (the extrema's tracking, the
        exchange's warm solver, the continuous check's enclosure, the duty cycle's certifier and
        its recheck's time weights), so that the worker processes forked after this share them
        rather than each building its own (crane_luffing_drive's 7.5 kW motor: about 1.5 s of CPU
        per worker).  The same objects as built on first use."""
        pb = self.pb
        if pb.settings.slots:
            pb.quantity_tracking   # noqa: B018 - a property built on first use
        pb.warm_solver   # noqa: B018
        self.checker.enclosures   # noqa: B018
        warm_cycle(pb)

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
        self._sqp = None   # a fresh SQP for this start: nothing passes from the starts before
        s_pts = np.r_[pb.base_points, pb.initial_slots]
        x_ref, tracking, rows = np.clip(np.asarray(x0, float), pb.lower, pb.upper), np.zeros((pb.n_points, nd)), {}
        w = self._initial_w(x0, fixed, s_pts)
        if isinstance(w, str):
            return w
        if pb.settings.slots:
            # the slots start on the extrema of the start design (following them to first
            # order), where the optimum's extrema mostly are: a function of the start alone
            s_pts, x_ref, tracking, rows = self._start_slots(x_ref, fixed, w, s_pts)
            w = self._initial_w(x_ref, fixed, s_pts)
            if isinstance(w, str):
                return w
        iterations, res = 0, None
        # the design step limit of the exchange (a trust region, scaled design units): none for
        # the first solve; after an exchange step each solve stays within `step` of the last
        # design, halved while the worst excess between the samples does not fall, doubled
        # while a solve ends on the limit.  Tracking an extremum to first order holds only for
        # small design changes: without a limit a far step moves the extrema far from where the
        # slots follow them, and the solves can cycle between designs that each exploit a gap
        # between the samples (the toggle press's sharp forming-force peak).  A design is
        # accepted only with no excess and off the limit: a local optimum of the continuous problem.
        step, worst_before, cap = None, np.inf, 1.0
        for exchange in range(st.max_exchanges + 1):
            box = self._step_box(x_ref, step)
            res, stats, its = self._nlp(w, pb.nlp_parameters(fixed, s_pts, x_ref, tracking), pb.row_bounds(s_pts),
                                          res, box)
            iterations += its
            status = stats["return_status"]
            w = np.asarray(res["x"]).ravel()
            x = pb.to_x(w[:nd])
            s_now = np.clip(s_pts + tracking @ (x - x_ref), pb.s_grid[0], pb.s_grid[-1])  # the NLP's points at its solution
            if not stats["success"]:
                return self._solution(res, x, fixed, s_now, status, False, iterations, exchange, {}, {}, False)
            violations, certified, sampled = self.continuous_check(x, fixed, w, s_now)
            worst = max((v[0] for v in violations), default=0.0)
            on_limit = step is not None and self._on_step_limit(w[:nd], box)
            if worst <= 0 and not on_limit:
                # certified: the duty cycle's integrals too (design/cycle_certify.py), all rechecked
                # by another path before it may count (a start that fails its own check is a failed
                # start, with the reason, never an optimum)
                self.checker.add_cycle(x, fixed, certified)
                reason = self.checker.recheck(x, fixed, w, s_now, certified, sampled)
                if reason is not None:
                    return self._solution(res, x, fixed, s_now, f"{status} (recheck failed: {reason})", False,
                                          iterations, exchange, certified, sampled, False)
                return self._solution(res, x, fixed, s_now, status, True, iterations, exchange, certified, sampled, True)
            if step is None:
                step = STEP_START
            elif worst > 0 and worst >= worst_before:
                # a step that made the excess worse: halved, and never doubled back past it (else
                # halving and doubling alternate and the solves cycle through the same designs:
                # the knuckle press's blanking bump, four designs over and over until the 20th
                # exchange, 5 starts of 20 failed)
                step *= 0.5
                cap = step
            elif on_limit:
                step = min(2.0 * step, cap)
            worst_before = worst
            slots, rows = self._slots(violations, s_now, rows, np.asarray(res["lam_g"]).ravel())
            s_pts = np.r_[pb.base_points, slots]
            tracking = self._tracking(slots, rows, x, fixed)
            x_ref = x
        return self._solution(res, x, fixed, s_now, status + " (exchange did not converge)", False,
                              iterations, exchange, certified, sampled, False)

    def polish(self, sol: Solution, fixed=None) -> Solution:
        """One more exchange step from a certified solution: every slot onto a located extremum
        (followed to first order), solved warm from the solution's multipliers.  The active
        sample points then sit on the continuous extrema, so the multipliers (the constraint
        report's, the sensitivities) are the continuous problem's, not those of a point up to
        sqrt(peak_tol) of the stroke away (level-luffing cylinder: d peak / d payload mass off
        by 1.7e-4).  The polished solution if it is certified again, else ``sol``."""
        pb = self.pb
        fixed = self.fixed_values(fixed)
        nd = len(pb.design_names)
        if not sol.success or not pb.settings.slots:
            return sol
        self._sqp = None   # a fresh SQP, as for a start
        violations, _, _ = self.continuous_check(sol.x, fixed, sol.w, sol.s_points)
        slots, rows = self._slots(violations, sol.s_points, {}, np.zeros(len(sol.lam_g)))
        s_pts = np.r_[pb.base_points, slots]
        tracking = self._tracking(slots, rows, sol.x, fixed)
        res, stats, its = self._nlp(sol.w, pb.nlp_parameters(fixed, s_pts, sol.x, tracking), pb.row_bounds(s_pts),
                                      {"lam_x": sol.lam_x, "lam_g": sol.lam_g})
        if not stats["success"]:
            return sol
        w = np.asarray(res["x"]).ravel()
        x = pb.to_x(w[:nd])
        s_now = np.clip(s_pts + tracking @ (x - sol.x), pb.s_grid[0], pb.s_grid[-1])
        violations, certified, sampled = self.continuous_check(x, fixed, w, s_now)
        if any(v[0] > 0 for v in violations):
            return sol
        self.checker.add_cycle(x, fixed, certified)
        if self.checker.recheck(x, fixed, w, s_now, certified, sampled):
            return sol
        return self._solution(res, x, fixed, s_now, sol.status, True, sol.iterations + its, sol.exchanges + 1,
                              certified, sampled, True)

    def _start_slots(self, x, fixed, w, s_pts):
        """(sample points, x_ref, tracking, rows) with the slots on the located extrema of
        every block at design x (the continuous check's, near-active ones included)."""
        pb = self.pb
        violations, _, _ = self.continuous_check(x, fixed, w, s_pts)
        slots, rows = self._slots(violations, s_pts, {}, np.zeros(len(pb.lbg)))
        s_pts = np.r_[pb.base_points, slots]
        return s_pts, x, self._tracking(slots, rows, x, fixed), rows

    def _tracking(self, slots, rows, x, fixed):
        """d(sample point)/d(design) of every sample point: each slot that follows an extremum
        moves with it to first order in the design (IPOPT's points at x' are s + T (x' - x))."""
        pb = self.pb
        tracking = np.zeros((pb.n_points, len(pb.design_names)))
        for j, s_j in enumerate(slots):
            row = rows.get(round(s_j, 12))
            if row is not None:
                tracking[len(pb.base_points) + j] = pb.tracking_gradient(s_j, x, fixed, row)
        return tracking

    def _step_box(self, x_ref, step):
        """(lbw, ubw): the NLP's variable bounds, the design's within ``step`` of x_ref (scaled)."""
        pb = self.pb
        if step is None:
            return pb.lbw, pb.ubw
        nd = len(pb.design_names)
        z = pb.to_z(x_ref)
        lo, hi = pb.lbw.copy(), pb.ubw.copy()
        lo[:nd] = np.maximum(lo[:nd], z - step)
        hi[:nd] = np.minimum(hi[:nd], z + step)
        return lo, hi

    def _on_step_limit(self, z, box) -> bool:
        """Whether the design ``z`` lies on a side of the step limit that is not a design bound."""
        pb = self.pb
        nd = len(z)
        lo, hi = box[0][:nd], box[1][:nd]
        tight = 1e-7
        return bool(np.any((lo > pb.lbw[:nd]) & (z <= lo + tight)) or np.any((hi < pb.ubw[:nd]) & (z >= hi - tight)))

    def _nlp(self, w, p, row_bounds, last=None, box=None):
        """One solve of the NLP from ``w`` (warm from the last solution's multipliers after an
        exchange step), within the variable bounds ``box`` (default the NLP's): by IPOPT, or
        under an SQP rule of :mod:`.sqp` by sqpmethod first, IPOPT from the same point when the
        SQP's result is not accepted.
        Returns (result, stats, iterations: both solvers')."""
        pb = self.pb
        iterations = 0
        if sqp.use_sqp(first=last is None) and self._sqp is None:
            made = sqp.sqp_solver(pb)   # one per start (see sqp.sqp_solver); None: no library, IPOPT
            self._sqp = False if made is None else made
        if sqp.use_sqp(first=last is None) and self._sqp is not False:
            lbx, ubx = (pb.lbw, pb.ubw) if box is None else box
            bounds = {"lbx": lbx, "ubx": ubx, "lbg": row_bounds[0], "ubg": row_bounds[1]}
            solver = self._sqp
            warm = {} if last is None else {"lam_x0": last["lam_x"], "lam_g0": last["lam_g"]}
            res = solver(x0=w, p=p, **bounds, **warm)
            stats = solver.stats()
            check_interrupt()
            iterations += int(stats.get("iter_count", 0))
            if sqp.accepted(pb, res, stats, w, p, bounds):
                return res, stats, iterations
        res, stats, its = self._ipopt(w, p, row_bounds, last, box)
        return res, stats, iterations + its

    def _ipopt(self, w, p, row_bounds, last=None, box=None):
        """One IPOPT solve: warm from the last solution's multipliers after an exchange step
        (cold again if that fails), within the variable bounds ``box`` (default the NLP's).
        Returns (result, stats, iterations)."""
        pb = self.pb
        lbx, ubx = (pb.lbw, pb.ubw) if box is None else box
        bounds = {"lbx": lbx, "ubx": ubx, "lbg": row_bounds[0], "ubg": row_bounds[1]}
        iterations = 0
        if last is not None:
            res = pb.warm_solver(x0=w, p=p, lam_x0=last["lam_x"], lam_g0=last["lam_g"], **bounds)
            stats = pb.warm_solver.stats()
            check_interrupt()   # a Ctrl-C stops IPOPT as a failed solve: stop here (errors.py)
            iterations += int(stats.get("iter_count", 0))
            if stats["success"]:
                return res, stats, iterations
        res = pb.solver(x0=w, p=p, **bounds)
        stats = pb.solver.stats()
        check_interrupt()
        return res, stats, iterations + int(stats.get("iter_count", 0))

    def _solution(self, res, x, fixed, s_pts, status, success, iterations, exchanges, certified, sampled, converged):
        return Solution(
            x=x, w=np.asarray(res["x"]).ravel(), lam_g=np.asarray(res["lam_g"]).ravel(),
            lam_x=np.asarray(res["lam_x"]).ravel(), lam_p=np.asarray(res["lam_p"]).ravel(),
            g=np.asarray(res["g"]).ravel(), f=float(res["f"]), s_points=s_pts, status=status, success=success and converged,
            iterations=iterations, exchanges=exchanges, certified=certified, sampled=sampled,
            converged=converged, notes=dict(self.checker.notes) if success and converged else {},
        )

    def _initial_w(self, x0, fixed, s_pts):
        return initial_w(self.pb, x0, fixed, s_pts)

    def continuous_check(self, x, fixed, w, s_points):
        """Worst values of every block over the continuous stroke at design x: (violations,
        certified, sampled), see :class:`~optdesign.design.certify.ContinuousCheck`."""
        return self.checker(x, fixed, w, s_points)

    def _checks(self, x, fixed, w, s_points) -> list:
        """What the continuous check compares (:meth:`~optdesign.design.certify.ContinuousCheck.checks`)."""
        return self.checker.checks(x, fixed, w, s_points)

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


def initial_w(pb, x0, fixed, s_pts):
    """The NLP's point at design ``x0`` (clipped to its box) on the sample points ``s_pts``: the
    scaled design, the epigraph's sampled peak and each aggregate's sampled extreme; a reason
    (str) when the design does not assemble there."""
    x0 = np.clip(np.asarray(x0, float), pb.lower, pb.upper)
    q = pb.evaluate_grid(x0, fixed, s_pts)
    if not np.all(np.isfinite(q)):
        return "skipped: the start does not assemble and could not be repaired"
    t = []
    if pb.n_t:
        t = [float(np.max(np.abs(q[pb.objective_quantity]))) / pb.f_ref]
    a = [sampled_extreme(ag, q) for ag in pb.aggregates]
    return np.r_[pb.to_z(x0), t, np.asarray(a) / pb.a_scale]
