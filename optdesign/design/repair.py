"""Repair of starts that do not assemble: a start is projected onto designs whose
constructions assemble at every point where the solve will evaluate it."""
from __future__ import annotations

import casadi as ca
import numpy as np

from ..errors import check_interrupt
from .problem import DesignProblem

IPOPT_BOUND_PUSH = 0.01  # IPOPT's default bound_push and bound_frac, on the design scaled to [0, 1]


class Repair:
    """Projects a start onto designs whose constructions assemble at the sample points:
    min |z - z0|^2 subject to every dyad/slider margin >= 1e-3 of its start scale."""

    def __init__(self, problem: DesignProblem):
        pb = problem
        self.pb = pb
        self.ok = any(b.kind == "margin" for b in pb.blocks)
        self._solver = None

    @property
    def solver(self):
        """The projection's IPOPT solver, built on first use: most starts assemble and never need
        it (crane_luffing_drive: none of its 60 starts; 0.1 s of CPU per motor of a catalogue,
        before the starts could begin).  The same NLP whenever it is built (in a forked worker
        when that is where a start first needs it)."""
        if self._solver is None:
            self._solver = self._build()
        return self._solver

    def _build(self):
        pb = self.pb
        margins = [b for b in pb.blocks if b.kind == "margin"]
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
        return ca.nlpsol("repair", "ipopt", nlp, {
            "ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes", "error_on_fail": False,
            "show_eval_warnings": False})

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
        check_interrupt()   # a Ctrl-C stops IPOPT as a failed solve (errors.py)
        if not self.solver.stats()["success"]:
            return None
        return pb.to_x(np.asarray(res["x"]).ravel())
