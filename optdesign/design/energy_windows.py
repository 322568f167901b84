"""One load case's part of the energy proof (:mod:`.energy_bound`): its energy, drive speed
ratio k = dq/ds, assembly margins and kinematic constraints as SX graphs of (s, x), numbers at
its nodes, and the two stages that settle boxes of the design variables x:
:meth:`CaseEnergy.settle_positions` (windows from rest, positions alone: the potential energy
bounds the change, the motor at peak torque and speed throughout) and :meth:`CaseEnergy.settle`
(every window, with the kinetic energy, the rotor, and the speed limit's bound on the time the
motor can run at its speed)."""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

from ..kinematics.box_intervals import BoxProgram

RELATIVE = 1e-3        # the energy needed must exceed the motor's by this fraction
TANH_GAP = 0.2785      # > max over x > 0 of x (1 - tanh x) (0.27846 at x = 0.6392)


class CaseEnergy:
    """One eligible case: its energy, drive speed ratio k = dq/ds and assembly margins as graphs
    of (s, x); numbers at its nodes; :meth:`settle` over boxes."""

    NODES = 32   # the windows' ends: about this many of the case's samples (its phase boundaries among them)

    def __init__(self, name, profile, x, free, dep, names, k, margins, ratio, a, etas, cm):
        self.name, self.profile, self.x, self.cm = name, profile, x, cm
        self.free, self.dep, self.names = free, dep, names
        self.k, self.margins, self.ratio, self.a, self.etas = k, margins, ratio, a, etas
        exprs = ca.vertcat(*([e for pair in dep for e in pair] + [k] + margins))
        self.uses = np.array([bool(ca.depends_on(exprs, x[j])) for j in range(x.numel())], bool)

    def finish(self, bound, r):
        m, prof = bound.mech, self.profile
        samples = np.unique(np.r_[m.stroke(), prof.breakpoints()])
        keep = set(range(0, len(samples), max(1, len(samples) // self.NODES))) | {len(samples) - 1}
        keep |= {int(np.argmin(np.abs(samples - b))) for b in prof.breakpoints()}
        nodes = samples[sorted(keep)]
        if prof.sigma < 0:
            nodes = nodes[::-1]
        self.nodes, self.t = nodes, prof.times(nodes)
        s = m.s
        v2 = ca.Function("v2", [s], [prof.graphs(s, lambda e: m.value(e, ""))[2]])
        self.speed = np.sqrt(np.maximum(np.asarray(v2.map(len(nodes))(nodes[None, :]), float).ravel(), 0.0))
        free = ca.Function("free", [s], [ca.vertcat(*self.free)] if self.free else [ca.SX(0, 1)])
        self.e_free = np.asarray(free.map(len(nodes))(nodes[None, :]), float).reshape(len(self.free), len(nodes))
        self.free_names = [n for n, how in self.names.items() if how == "exact"]
        xu = ca.vertcat(*[self.x[j] for j in np.flatnonzero(bound.used)])
        self.nu = xu.numel()
        pe_dep = sum((pe for pe, _ in self.dep), ca.SX(0))
        ke_dep = sum((ke for _, ke in self.dep), ca.SX(0))
        e_dep = pe_dep + ke_dep
        # at the nodes: the energy of the bodies the design moves (and its parts), k, their gradients
        self.at_nodes = BoxProgram(ca.Function("energy_nodes", [s, xu], [
            e_dep, ca.jacobian(e_dep, xu).T, self.k, ca.jacobian(self.k, xu).T, pe_dep, ke_dep]))
        # the cheap stage (positions alone): the potential energy and its gradient
        self.positions = BoxProgram(ca.Function("energy_positions", [s, xu], [pe_dep, ca.jacobian(pe_dep, xu).T]))
        # the assembly margins and the scene's constraints on the kinematics (each >= 0 where it holds)
        self.checks = BoxProgram(ca.Function("energy_checks", [s, xu], [
            ca.vertcat(*self.margins) if self.margins else ca.SX(0, 1)]))
        # between the nodes: h = k(s) / k(s*), the drive's speed relative to its speed at s*
        star = ca.SX.sym("star")
        h = self.k / ca.substitute(self.k, s, star)
        self.between = BoxProgram(ca.Function("energy_between", [s, star, xu], [
            h, ca.jacobian(h, xu).T, ca.jacobian(h, s), self.k, ca.jacobian(self.k, xu).T, ca.jacobian(self.k, s)]))
        # the gear ratio's least |i| over the whole box of the design variables (not split)
        ratio = BoxProgram(ca.Function("ratio", [self.x], [self.ratio]))
        (i_lo, i_hi), = ratio([(bound.lower[:, None], bound.upper[:, None])])[0]
        i_lo, i_hi = float(i_lo[0, 0]), float(i_hi[0, 0])
        self.ratio_min = 0.0 if (i_lo <= 0 <= i_hi) or math.isnan(i_lo + i_hi) else min(abs(i_lo), abs(i_hi))
        self.ratio_max = max(abs(i_lo), abs(i_hi)) if not math.isnan(i_lo + i_hi) else math.inf
        # the optimiser's smoothing width (design/cases.py: its share of the largest |u flow_speed| at
        # the scene's values, on its grid): on the case's samples here, with a factor 10 of room
        self.smooth_rate = 0.0
        if self.cm.case.efficiency == "auto":
            f = m.function("power", {"power": self.cm.model.u * self.cm.model.flow_speed})
            pc = self.cm.case_parameters(m.parameter_values)
            power = np.abs(np.asarray(f.map(len(samples))(samples[None, :], pc), float))
            width = 10 * bound.smoothing * max(float(np.nanmax(power)), 1e-12)
            rho = 2 * float(np.max(self.speed)) / prof.reference_speed   # qd / flow_speed = V / V_ref
            (ed, eg) = self.etas
            self.smooth_rate = TANH_GAP * width * rho * ((1 / ed - ed) / 2 / eg + (1 / eg - eg) / 2)

    @staticmethod
    def _run(program, s_lo, s_hi, lo, hi, star=None):
        """``program`` over s-intervals x boxes (x in [lo, hi], columns; ``star`` per box):
        outputs (rows, s, boxes) and the jumps (s, boxes)."""
        ns, nb = len(s_lo), lo.shape[1]
        ins = [(np.repeat(s_lo, nb)[None, :], np.repeat(s_hi, nb)[None, :])]
        if star is not None:
            ins.append((np.tile(star, ns)[None, :],) * 2)
        ins.append((np.tile(lo, (1, ns)), np.tile(hi, (1, ns))))
        out, jump = program(ins)
        return [(a.reshape(a.shape[0], ns, nb), b.reshape(b.shape[0], ns, nb)) for a, b in out], jump.reshape(ns, nb)

    def settle_positions(self, lo, hi, tp, wm):
        """The cheap stage, per box: ('energy' | 'assembly' | None, slack, info) from the windows that
        start at rest (no kinetic energy there, >= 0 at their end: the potential energy bounds the
        change) against the motor at its peak torque and speed throughout (T_peak w_max (t2 - t1))."""
        nb = lo.shape[1]
        c = 0.5 * (lo + hi)
        half = np.maximum(c - lo, hi - c) * (1 + 2.0**-40)
        nodes = self.nodes
        rest = np.flatnonzero(self.speed == 0.0)
        (M,), _ = self._run(self.checks, nodes, nodes, lo, hi)
        assembly_out = np.any(M[1] < 0, axis=(0, 1)) if M[1].size else np.zeros(nb, bool)
        out = [("assembly", None, None) if a else (None, None, None) for a in assembly_out]
        self.last_split, self.last_slack = np.full(nb, -1), np.full(nb, -np.inf)
        if not rest.size:
            return out
        (PE, GP), jump = self._run(self.positions, nodes, nodes, lo, hi)
        (PEc, _), _ = self._run(self.positions, nodes, nodes, c, c)
        i, j = np.meshgrid(rest, np.arange(len(nodes)), indexing="ij")
        i, j = i.ravel(), j.ravel()
        keep = (self.t[j] > self.t[i])
        i, j = i[keep], j[keep]
        T = self.t[j] - self.t[i]
        d_free = (self.e_free[:, j] - self.e_free[:, i]).sum(axis=0) if self.e_free.size else np.zeros(len(i))
        d_dep = _difference(PE, PEc, GP, half, ~jump, i, j)
        need = self.a * (d_free[:, None] + d_dep) - self.smooth_rate * T[:, None]
        available = (tp * wm * T)[:, None] * np.ones((1, nb))
        slack = need - available * (1 + RELATIVE)
        slack = np.where(np.isnan(slack), -np.inf, slack)
        best = np.argmax(slack, axis=0)
        self.last_slack = slack[best, np.arange(nb)] / np.maximum(available[best, np.arange(nb)], 1e-300)
        # where to split a box left open: the side whose share of the mean-value form's spread at
        # its best window is largest (-1: none finite, the widest side then)
        bi, bj = i[best], j[best]
        g = np.maximum(np.abs(GP[0][:, bj, np.arange(nb)] - GP[1][:, bi, np.arange(nb)]),
                       np.abs(GP[1][:, bj, np.arange(nb)] - GP[0][:, bi, np.arange(nb)])) * half
        self.last_split = (np.where(np.all(np.isfinite(g), axis=0), np.argmax(np.nan_to_num(g, nan=0.0), axis=0), -1)
                           if len(g) else np.full(nb, -1))
        for b in range(nb):
            w = best[b]
            if out[b][0] is None and slack[w, b] > 0:
                out[b] = ("energy", float(slack[w, b] / available[w, b]),
                          self._info(i[w], j[w], need[w, b], available[w, b], d_free[w], d_dep[w, b], 0.0, T[w],
                                     None, T[w], "potential energy over the box (kinetic energy >= 0)"))
        return out

    def settle(self, lo, hi, used, tp, wm, jr):
        """Per box (columns of lo, hi): ('energy' | 'speed' | 'assembly' | None, slack, info)."""
        nb = lo.shape[1]
        c = 0.5 * (lo + hi)
        half = np.maximum(c - lo, hi - c) * (1 + 2.0**-40)
        nodes = self.nodes
        (E, G, K, GK, PE, KE), jump = self._run(self.at_nodes, nodes, nodes, lo, hi)
        (Ec, _, Kc, _, _, _), _ = self._run(self.at_nodes, nodes, nodes, c, c)
        (M,), _ = self._run(self.checks, nodes, nodes, lo, hi)
        ok = ~jump   # where a mean-value form holds (it also needs finite derivatives)
        k_lo, k_hi = _mean_value(K[0][0], K[1][0], Kc[0][0], Kc[1][0], GK, half, ok)
        abs_lo = np.where((k_lo <= 0) & (k_hi >= 0), 0.0, np.minimum(np.abs(k_lo), np.abs(k_hi)))
        abs_lo = np.where(np.isnan(abs_lo), 0.0, abs_lo)
        q_low = np.max(abs_lo * self.speed[:, None], axis=0) * (1 - 2.0**-40)   # <= max |qd| over the case
        speed_out = q_low * self.ratio_min * (1 - 2.0**-40) > wm * (1 + RELATIVE)   # |i| max|qd| <= w_max fails
        assembly_out = np.any(M[1] < 0, axis=(0, 1)) if M[1].size else np.zeros(nb, bool)
        # max |qd| >= |k(s*)| sd(s*), s* where the box's centre runs fastest: int |qd| dt / max |qd| <=
        # int |k(s) / k(s*)| ds / sd(s*), the integral bounded by sup |h| over each interval between nodes
        star_i = np.argmax(np.abs(Kc[0][0]) * self.speed[:, None], axis=0)
        star = nodes[star_i]
        s_a, s_b = np.minimum(nodes[:-1], nodes[1:]), np.maximum(nodes[:-1], nodes[1:])
        mid = 0.5 * (s_a + s_b)
        (H, GH, DH, KS, GKS, DKS), jump_s = self._run(self.between, s_a, s_b, lo, hi, star)
        (Hm, _, _, Km, _, _), _ = self._run(self.between, mid, mid, c, c, star)
        ds_half = (np.maximum(mid - s_a, s_b - mid) * (1 + 2.0**-40))[:, None]
        cum, cum_k = (np.r_[np.zeros((1, nb)), np.cumsum(_sup(*_mean_value(
            F[0][0], F[1][0], Fm[0][0], Fm[1][0], GF, half, ~jump_s, DF, ds_half)) * (s_b - s_a)[:, None], axis=0)]
            * (1 + 1e-12) for F, Fm, GF, DF in ((H, Hm, GH, DH), (KS, Km, GKS, DKS)))
        # the windows: every pair of nodes (i before j along the motion)
        i, j = np.triu_indices(len(nodes), 1)
        T = self.t[j] - self.t[i]
        d_free = (self.e_free[:, j] - self.e_free[:, i]).sum(axis=0) if self.e_free.size else np.zeros(len(i))
        # positions alone: the kinetic energy >= 0 at the end, 0 at a start from rest (no derivative
        # of the kinematics, which a box near a lock-up position leaves unbounded)
        ke_start = np.where(self.speed[i][:, None] == 0.0, 0.0, KE[1][0][i])
        by_pe = PE[0][0][j] - PE[1][0][i] - ke_start
        d_dep = np.fmax(_difference(E, Ec, G, half, ok, i, j), np.where(np.isnan(by_pe), -np.inf, by_pe))
        rotor = np.where(self.speed[i] == 0.0, 0.0, 0.5 * jr * wm**2)[:, None]   # 0 from rest
        need = self.a * (d_free[:, None] + d_dep) - rotor - self.smooth_rate * T[:, None]
        with np.errstate(invalid="ignore"):
            travel = (cum[j] - cum[i]) / self.speed[star_i][None, :]
        # (and int |qd| dt = int |k| ds with |i| <= its largest: the motor's speed times T at most)
        with np.errstate(invalid="ignore"):   # (inf - inf: no bound, NaN, dropped by fmin)
            available = tp * np.fmin(wm * np.fmin(T[:, None], travel), self.ratio_max * (cum_k[j] - cum_k[i]))
        slack = need - available * (1 + RELATIVE)
        slack = np.where(np.isnan(slack), -np.inf, slack)
        best = np.argmax(slack, axis=0)
        self.last_slack = slack[best, np.arange(nb)] / np.maximum(available[best, np.arange(nb)], 1e-300)
        out = []
        for b in range(nb):
            w = best[b]
            if slack[w, b] > 0:
                out.append(("energy", float(slack[w, b] / max(available[w, b], 1e-300)),
                            self._info(i[w], j[w], need[w, b], available[w, b], d_free[w], d_dep[w, b], rotor[w, 0],
                                       T[w], q_low[b], travel[w, b], "energy over the box")))
            else:
                out.append(("speed" if speed_out[b] else "assembly" if assembly_out[b] else None, None, None))
        return out

    def _info(self, i, j, need, available, d_free, d_dep, rotor, T, q_low, travel, how):
        bodies = {n: f"exact: {self.e_free[q, j] - self.e_free[q, i]:.6g} J" for q, n in enumerate(self.free_names)}
        bounded = [n for n, kind in self.names.items() if kind == "bounded"]
        if bounded:
            bodies[" + ".join(bounded)] = f">= {d_dep:.6g} J: {how} (interval arithmetic, branch and bound)"
        return {"case": self.name, "window": (float(self.t[i]), float(self.t[j])),
                "sweep": (float(self.nodes[i]), float(self.nodes[j])), "needed": float(need),
                "available": float(available), "bodies": bodies,
                "terms": {"efficiency_factor": self.a, "rotor_J": float(rotor),
                          "smoothing_J": float(self.smooth_rate * T),
                          "energy_exact_J": float(d_free), "energy_bounded_J": float(d_dep),
                          "max_drive_speed_lower": None if q_low is None else float(q_low),
                          "time_at_motor_speed_upper_s": float(min(T, travel))}}


def _difference(F, Fc, G, half, ok, i, j):
    """Lower bounds of f(s_j) - f(s_i) over the boxes: the natural form, or the mean-value form
    f_c(s_j) - f_c(s_i) + (grad f(s_j) - grad f(s_i)) . (x - c) where it holds; (pairs, boxes)."""
    nat = F[0][0][j] - F[1][0][i]
    gd = np.maximum(np.abs(G[0][:, j] - G[1][:, i]), np.abs(G[1][:, j] - G[0][:, i]))
    mv = Fc[0][0][j] - Fc[1][0][i] - np.einsum("kpb,kb->pb", gd, half) * (1 + 2.0**-40)
    mv = mv - 2.0**-40 * (np.abs(Fc[0][0][j]) + np.abs(Fc[0][0][i]))   # (the sums' rounding)
    mv = np.where(ok[i] & ok[j] & np.isfinite(mv), mv, -np.inf)
    return np.fmax(np.where(np.isnan(nat), -np.inf, nat), mv)


def _sup(lo, hi):
    """sup |f| of enclosures (inf where there is none)."""
    sup = np.maximum(np.abs(lo), np.abs(hi))
    return np.where(np.isnan(sup), np.inf, sup)


def _mean_value(lo, hi, c_lo, c_hi, grad, half, ok, ds_grad=None, ds_half=None):
    """f over the boxes: the natural enclosure [lo, hi] intersected with the mean-value form
    f(centre) + grad(box) . (x - centre) (|x - centre| <= half; also along s with ``ds_grad``
    and ``ds_half``) where ``ok`` (no jump) and finite.  Arrays (nodes, boxes); grad (nu, nodes, boxes)."""
    g = np.maximum(np.abs(grad[0]), np.abs(grad[1]))
    spread = np.einsum("kpb,kb->pb", g, half)
    if ds_grad is not None:
        spread = spread + np.maximum(np.abs(ds_grad[0][0]), np.abs(ds_grad[1][0])) * ds_half
    spread = spread * (1 + 2.0**-40) + 2.0**-40 * np.maximum(np.abs(c_lo), np.abs(c_hi))   # (the sum's rounding)
    mv_lo, mv_hi = c_lo - spread, c_hi + spread
    good = ok & np.isfinite(mv_lo) & np.isfinite(mv_hi)
    lo = np.where(good, np.fmax(lo, mv_lo), lo)
    hi = np.where(good, np.fmin(hi, mv_hi), hi)
    return lo, hi
