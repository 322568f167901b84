"""Phase 1: from a start, a design that satisfies every constraint at the NLP's sample points,
before the objective is minimised from it.

An elastic NLP on the design NLP's own rows (the same CasADi graph, so the same exact first
and second derivatives): every row except the epigraph of the peak gets two nonnegative
elastic variables, ``lbg <= g(w) + e_lo - e_hi <= ubg``, and IPOPT minimises

    sum(e_lo + e_hi) + rho |z - z0|^2

over the design z (its box kept), the stroke aggregates and the elastics (and, if that ends
with a violation, once more from there on the rows' own bounds with rho = 0: the pure L1
violation).  The problem is
feasible from any design that assembles (the elastics absorb every violation), so IPOPT does
not end in its restoration phase or declare the problem infeasible; the L1 penalty is exact
(the small proximal term keeps the result near the start, so that space-filling starts stay
spread, and its multipliers stay far below 1), so a start from which a feasible design is
reachable ends with zero elastics.  Assembly margins, the transmission angle, stroke
constraints and the dead-centre guard are all rows, and all are included.  The rows' bounds
are tightened by ``INTERIOR`` (scaled) where the row's range allows it, so that the objective
phase starts strictly inside rather than on a boundary where a line search step can leave
the designs that assemble.

A start that does not assemble at the sample points (NaN rows) is first projected onto designs
that do (:class:`~optdesign.design.repair.Repair`).  A start from which phase 1 ends with
nonzero elastics is a local minimum of the violation: the multistart retries it from a fresh
point (:mod:`.starts`), and reports the problem infeasible only when every start failed.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..errors import check_interrupt
from ..model import compiled

RHO = 1e-2          # proximal weight on the scaled design (|z| <= 1 per variable)
INTERIOR = 1e-2     # rows' bounds tightened by this (scaled) in phase 1
# the monotone barrier strategy from IPOPT's default mu_init: from the library's starts it
# makes 100 % of the wheel loader's starts feasible where the adaptive one (the objective
# phase's) leaves a third at a local minimum of the violation (benchmarks/bench_library.py)
OPTIONS = {"ipopt.mu_strategy": "monotone", "ipopt.mu_init": 0.1}
FEASIBLE = 1e-7     # a phase-1 design is feasible when no scaled row is violated by more


@dataclass(frozen=True)
class Phase1Result:
    """What phase 1 did from one start: the design (physical units), its worst scaled
    violation at the sample points, IPOPT's status and iterations (0 when the start was
    feasible already and no solve was needed)."""

    x: np.ndarray
    violation: float
    status: str
    iterations: int

    @property
    def feasible(self) -> bool:
        return self.violation <= FEASIBLE


class Phase1:
    """The elastic feasibility NLP of one design problem (built once, solved per start)."""

    def __init__(self, pb):
        self.pb = pb
        nlp = pb._nlp_dict
        sym = ca.MX if isinstance(nlp["x"], ca.MX) else ca.SX
        nd, na = len(pb.design_names), len(pb.aggregates)
        kinds = np.empty(len(pb.lbg), object)
        for name, kind, start, n in pb.g_blocks:
            kinds[start:start + n] = kind
        self.rows = np.flatnonzero(kinds != "peak")
        self.kinds = kinds
        m = len(self.rows)
        z, a = sym.sym("z", nd), sym.sym("a", na)
        e_lo, e_hi = sym.sym("e_lo", m), sym.sym("e_hi", m)
        p, z0, rho = sym.sym("p", nlp["p"].numel()), sym.sym("z0", nd), sym.sym("rho")
        g_all = ca.Function("phase1_rows", [nlp["x"], nlp["p"]], [nlp["g"]])
        w = ca.vertcat(z, ca.DM.zeros(pb.n_t), a)
        g = g_all(w, p)[self.rows.tolist()] + e_lo - e_hi
        f = ca.sum1(e_lo) + ca.sum1(e_hi) + rho * ca.sumsqr(z - z0)
        opts = {k: v for k, v in pb.solver_options.items() if k != "ipopt.expect_infeasible_problem"}
        opts.update({"ipopt.tol": 1e-9, "ipopt.constr_viol_tol": 1e-9, "ipopt.max_iter": 500})
        opts.update(OPTIONS)
        if sym is ca.MX:
            # an NLP that holds a cycle's integrals (mapped over every node of every case, MX:
            # design/cases.needs_mx) has an exact Hessian that costs more than the iterations
            # it saves; phase 1 only looks for a feasible design, whose quality the objective
            # phase (exact Hessian) does not depend on (crane_luffing_drive, 4 starts per motor:
            # the infeasible 4 kW motor 151 -> 60 s of CPU on the virtual machine, compiled 39 ->
            # 19.5 s; the 7.5 kW motor 47 -> 47 s, the same optimum 103.0558)
            opts["ipopt.hessian_approximation"] = "limited-memory"
        # its functions compiled from the disk cache like the design NLP's (crane_luffing_drive's
        # infeasible 4 kW motor, 4 starts: 1.22 -> 0.31 s per phase-1 solve, 60 -> 19.5 s of CPU)
        nlp1 = ca.Function("nlp", [ca.vertcat(z, a, e_lo, e_hi), ca.vertcat(p, z0, rho)], [f, g], ["x", "p"], ["f", "g"])
        self.solver = compiled.solver("phase1", "ipopt", nlp1, opts)
        # the design NLP's rows at a point: its solver's own function of them, compiled with it
        # from the disk cache when it is there (the same numbers as the graph on CasADi's virtual
        # machine, 3x faster: crane_luffing_drive's infeasible 5.5 kW motor spent 2 % of a start here)
        self.g = pb.solver.get_function("nlp_g")
        self.nd, self.na, self.m = nd, na, m

    def violation(self, w, p, lbg, ubg) -> float:
        """Worst scaled violation of the checked rows at the NLP point w (inf if not finite)."""
        return self._violation(self._checked(w, p), lbg, ubg)

    def _checked(self, w, p) -> np.ndarray:
        """The checked rows' values at the NLP point w."""
        return np.asarray(self.g(w, p)).ravel()[self.rows]

    def _violation(self, g, lbg, ubg) -> float:
        """Worst scaled violation of the checked rows' values ``g`` (inf if not finite)."""
        with np.errstate(invalid="ignore"):
            v = np.max(np.maximum(np.maximum(lbg[self.rows] - g, g - ubg[self.rows]), 0.0), initial=0.0)
        return float(v) if np.all(np.isfinite(g)) else np.inf

    def __call__(self, w0, p, lbg, ubg) -> Phase1Result:
        """Phase 1 from the NLP point ``w0`` (design, t, aggregates) with NLP parameters ``p``
        and row bounds (lbg, ubg)."""
        pb, nd, na = self.pb, self.nd, self.na
        z0 = np.asarray(w0[:nd], float)
        g0 = self._checked(w0, p)
        start_violation = self._violation(g0, lbg, ubg)
        if start_violation <= FEASIBLE:
            return Phase1Result(pb.to_x(z0), start_violation, "feasible at the start", 0)
        lo, hi = lbg[self.rows].copy(), ubg[self.rows].copy()
        room = hi - lo > 4 * INTERIOR
        lo = np.where(room & np.isfinite(lo), lo + INTERIOR, lo)
        hi = np.where(room & np.isfinite(hi), hi - INTERIOR, hi)
        e_lo0 = np.where(np.isfinite(lo), np.maximum(lo - g0, 0.0), 0.0) + 1e-3
        e_hi0 = np.where(np.isfinite(hi), np.maximum(g0 - hi, 0.0), 0.0) + 1e-3
        a0 = np.asarray(w0[nd + pb.n_t:], float)
        nw = nd + na + 2 * self.m
        lbx = np.r_[pb.lbw[:nd], pb.lbw[nd + pb.n_t:], np.zeros(2 * self.m)]
        ubx = np.r_[pb.ubw[:nd], pb.ubw[nd + pb.n_t:], np.full(2 * self.m, np.inf)]
        x0, iterations = np.r_[z0, a0, e_lo0, e_hi0][:nw], 0
        for rho, (row_lo, row_hi) in ((RHO, (lo, hi)), (0.0, (lbg[self.rows], ubg[self.rows]))):
            res = self.solver(x0=x0, p=np.r_[p, z0, rho], lbx=lbx, ubx=ubx, lbg=row_lo, ubg=row_hi)
            stats = self.solver.stats()
            check_interrupt()   # a Ctrl-C stops IPOPT as a failed solve: stop here (errors.py)
            iterations += int(stats.get("iter_count", 0))
            x = np.asarray(res["x"]).ravel()
            z = np.clip(x[:nd], pb.lbw[:nd], pb.ubw[:nd])
            w = np.r_[z, w0[nd:nd + pb.n_t], x[nd:nd + na]]
            result = Phase1Result(pb.to_x(z), self.violation(w, p, lbg, ubg), stats["return_status"], iterations)
            if result.feasible:
                break
            # from there once more, on the rows' own bounds and without the proximal term: the
            # tightened rows can leave no room where the feasible designs form a narrow band
            # (a stroke equality beside a bound on the ram's depth), and the proximal term can
            # hold the design back where a violation's gradient is weak
            x0 = x
        return result
