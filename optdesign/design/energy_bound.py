"""A proof that a motor of a catalogue cannot fit, by energy, before its starts (issue 31).

In a load case whose motion is prescribed in time (a [profiles] law of the sweep) and whose
only load is gravity (no [[forces]], body forces or torques), the reduced model's ideal drive
load u (model/reduction.py) is Lagrange's: u qd = dE/dt, E = 1/2 M_s sd^2 + sum m g y_C the
mechanism's energy.  The motor (model/train.py, design/cases.py) gives

    T_m w_m = c_g c u qd + J_r w_m dw_m/dt,      w_m = i qd,

c (the drive's) and c_g (the gearbox's) being 1/eta while power flows to the load and eta while
it flows back.  Over a window [t1, t2] of the case:

* c_g c P >= a P for either sign of P = u qd, a = 1/(eta eta_g) (a case fixed 'braking': a =
  eta eta_g): so the load takes at least a (E(t2) - E(t1)).  The optimiser's smoothed switch,
  (1/eta + eta)/2 + (1/eta - eta)/2 tanh(P' / w), falls short of 1/eta only while P > 0, by at
  most (1/eta - eta)/2 * 0.2785 w * (qd / flow_speed) per unit time (max x (1 - tanh x) <
  0.2785); that, for both switches, is subtracted (``smoothing``); the analysed model (w = 0)
  has none.
* the rotor's energy change is at least -1/2 J_r w_m(t1)^2 >= -1/2 J_r w_max^2 (0 when the
  window starts at rest);
* |T_m| <= T_peak and |i qd| <= w_max at every moment of every case (the motor's constraints,
  certified between samples), so i <= w_max / max|qd| and the motor gives at most
  T_peak i int|qd| dt <= T_peak w_max min(t2 - t1, int|qd| dt / max|qd|).

A design fits only if, for every window, what the load takes is at most what the motor gives.
Bodies whose energy does not depend on a design variable contribute exact numbers; the rest's
energy change, int |qd| and max |qd| are enclosed over boxes of the design variables (interval
arithmetic, :mod:`optdesign.kinematics.box_intervals`, outward rounded; natural and mean-value
forms) by branch and bound: a box is settled when some window of some case needs more than the
motor can give, or when no design in it assembles or meets the motor's speed limit with the
gear ratio's bounds.  When every box is settled, no design fits: a proof.  The claim is
required to clear the motor's energy by RELATIVE (covering the optimiser's and the continuous
check's tolerances on the constraints, 1e-7, and round-off outside the interval arithmetic).

Anything outside this argument (no gearbox, a force element, a body force or torque, an
efficiency or gravity that depends on the design, a loop closed by Newton (MX), a design
variable without bounds, a case without a profile) gives no proof, and the motor's starts run.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from ..model.cases import CaseModel
from ..model.train import motor_numbers
from .energy_windows import RELATIVE, CaseEnergy  # noqa: F401  (RELATIVE: the claim's margin, said here)

WORK = 5000            # the branch and bound's budget, in boxes of the cheap stage, counted, not timed, so that
FULL_COST = 24         # every machine reaches the same verdict; a box of the full stage counts 24 (measured on
                       # crane_luffing_drive: 7.3 ms a box against 0.41, rounded up for its batches of 64): about
                       # 2 s of CPU, which a motor that fits spends when no design settles alone
BATCH = 1024           # boxes per evaluation at most
CASES = 1              # the cases tried on each box: those with the largest margins at the box's centre


@dataclass(frozen=True)
class EnergyProof:
    """Why a motor cannot fit: in ``case`` over ``window`` (t1, t2) [s] (sweep ``sweep``), the
    load needs at least ``needed`` J at the motor, the motor gives at most ``available`` J; the
    bodies' energy changes (``bodies``: name -> how bounded); over ``boxes`` boxes of the
    design variables (``settled``: how many by energy, by the speed limit, by assembly).  The
    window and numbers are those of the box settled with the least margin."""

    motor: str
    case: str
    window: tuple
    sweep: tuple
    needed: float
    available: float
    bodies: dict
    boxes: int
    settled: dict
    variables: tuple
    terms: dict = field(default_factory=dict)

    def message(self) -> str:
        return (f"cannot fit (energy proof; its tightest box): in case {self.case!r} from t = "
                f"{self.window[0]:.4g} to "
                f"{self.window[1]:.4g} s the load needs >= {self.needed:.6g} J at the motor, the motor gives "
                f"<= {self.available:.6g} J (peak torque x speed); " + (
                    f"every design of the box ({', '.join(self.variables)}) settled in {self.boxes} boxes"
                    if self.variables else "no design variable moves the mechanism"))

    def to_dict(self) -> dict:
        return {"case": self.case, "window_s": list(self.window), "sweep": list(self.sweep),
                "energy_needed_J": self.needed, "energy_available_J": self.available, "bodies": dict(self.bodies),
                "boxes": self.boxes, "settled": dict(self.settled), "variables": list(self.variables),
                "terms": dict(self.terms)}


class Unproven(Exception):
    """The scene is outside what the proof covers (its message says why)."""


class EnergyBound:
    """The energy pieces of a scene's eligible cases, built once; :meth:`prove` per motor."""

    def __init__(self, scene, settings=None):
        from ..kinematics.mechanism import Mechanism

        self.scene = scene
        self.smoothing = 1e-3 if settings is None else settings.efficiency_smoothing
        self.mech = m = Mechanism(scene)
        r = m.resolved
        _eligible(scene, r)
        if m.sym is not ca.SX:
            raise Unproven("a loop closed by Newton (MX): no interval enclosure")
        params = {p.name: p for p in scene.parameters}
        self.design = [n for n in r.design_names]
        lower = np.array([params[n].lower if params[n].lower is not None else -math.inf for n in self.design], float)
        upper = np.array([params[n].upper if params[n].upper is not None else math.inf for n in self.design], float)
        idx = [r.leaf_names.index(n) for n in self.design]
        x = ca.SX.sym("x", len(self.design))
        parts = [ca.SX(v) for v in r.leaf_values]
        for j, i in enumerate(idx):
            parts[i] = x[j]
        p_full = ca.vertcat(*parts)
        eta_d = _fixed(r, scene.drive.efficiency, "[drive] efficiency")
        eta_g = _fixed(r, scene.gearbox.efficiency, "[gearbox] efficiency")
        self.cases = []
        for case in scene.cases:
            if case.profile is None:
                continue
            cm = CaseModel(m, case)
            prof = cm.profile
            pc = cm.case_parameters(p_full)
            sub = lambda e: ca.substitute(e, m.p, pc)  # noqa: E731
            _, _, V2, _ = prof.graphs(m.s, lambda e: m.value(e, "[profiles] speed"))
            if ca.depends_on(V2, m.p):
                continue   # a law whose speed depends on the parameters: not prescribed in time
            g = 0.0 if scene.gravity is None else sub(m.value(scene.gravity.g, "[gravity] g"))
            free, dep, names = [], [], {}
            for b in scene.bodies:
                pe, ke = 0, 0   # potential and kinetic energy
                phi_s = m.ds(m.body_angle[b.name])
                if b.mass is not None:
                    if b.name not in m.body_com:
                        raise Unproven(f"[[bodies]] {b.name}: a mass without a centre of mass")
                    mass = m.value(b.mass, "")
                    com = m.body_com[b.name]
                    ke = ke + 0.5 * mass * ca.sumsqr(m.ds(com)) * V2
                    pe = mass * g * com[1]
                if b.inertia is not None:
                    ke = ke + 0.5 * m.value(b.inertia, "") * phi_s**2 * V2
                if isinstance(pe + ke, int):
                    continue
                pe, ke = sub(pe + 0 * m.s), sub(ke + 0 * m.s)
                if ca.depends_on(ca.vertcat(pe, ke), x):
                    dep.append((pe, ke))
                    names[b.name] = "bounded"
                else:
                    free.append(pe + ke)
                    names[b.name] = "exact"
            k = sub(m.ds(m.q))
            margins = [sub(mg.expr) for mg in m.margins if mg.kind in ("dyad", "slider")]
            limits = _limits(scene, m, r, p_full)
            ratio = sub(m.value(scene.gearbox.ratio, "[gearbox] ratio"))
            flow = case.efficiency
            a = eta_d * eta_g if flow == "braking" else 1 / (eta_d * eta_g)
            self.cases.append(CaseEnergy(case.name, prof, x, free, dep, names, k, margins + limits, ratio, a,
                                    (eta_d, eta_g), cm))
        if not self.cases:
            raise Unproven("no load case with a profile in time")
        used = np.zeros(len(self.design), bool)
        for c in self.cases:
            used |= c.uses
        self.used = used
        if not np.all(np.isfinite(lower[used]) & np.isfinite(upper[used])):
            raise Unproven("a design variable the energy depends on has no bounds")
        pad = 1e-6 * (upper - lower)   # the solver's bounds, relaxed by at most 1e-8 of their size
        self.lower, self.upper = lower - pad, upper + pad
        for c in self.cases:
            c.finish(self, r)

    def prove(self, motor) -> EnergyProof | None:
        """The proof that ``motor`` cannot fit, or None (not found within the budget WORK)."""
        begun = self._begin(motor)
        if begun is None:
            return None
        root, cases, tp, wm, jr = begun
        for full in (False, True):   # the cheap stage alone, else (a design it cannot settle) both stages
            if self._unsettled_point(root, cases, full, tp, wm, jr):
                continue   # a design no verdict settles even alone: no box holding it can be
            return self._branch_and_bound(motor, root, cases, full, tp, wm, jr)
        return None

    def likely(self, motor) -> bool:
        """Whether a proof of ``motor`` looks likely: the cheap stage settles every design that
        :meth:`prove` tries alone first (a guess of what to build while the proof is sought,
        design/catalogue.py; never a verdict)."""
        begun = self._begin(motor)
        return begun is not None and not self._unsettled_point(*begun[:2], False, *begun[2:])

    def _begin(self, motor):
        """(the root box, the cases ranked for it, peak torque, top speed, rotor inertia) of
        ``motor``, or None when its numbers admit no proof."""
        nums = motor_numbers(motor, self.mech.resolved.values)
        tp, wm, jr = nums["peak_torque"], nums["max_speed"], nums["inertia"]
        if not (tp > 0 and wm > 0 and jr >= 0 and math.isfinite(tp * wm)):
            return None
        used = np.flatnonzero(self.used)
        root = (self.lower[used].copy(), self.upper[used].copy())
        return root, self._ranked(root, tp, wm, jr)[:CASES], tp, wm, jr

    def _branch_and_bound(self, motor, root, cases, full, tp, wm, jr):
        used = np.flatnonzero(self.used)
        queue = [root]
        settled = {"energy": 0, "speed": 0, "assembly": 0}
        tightest, boxes, work = None, 0, 0
        while queue:
            if work > WORK:
                return None
            size = BATCH if not full else BATCH // 16   # (the full stage: ~7 ms a box; the budget is checked per batch)
            batch, queue = queue[:size], queue[size:]
            boxes += len(batch)
            work += len(batch) * (FULL_COST if full else 1)
            lo = np.array([b[0] for b in batch]).T
            hi = np.array([b[1] for b in batch]).T
            open_ = np.ones(len(batch), bool)
            side = np.full(len(batch), -1)
            stages = [lambda c, a, b: c.settle_positions(a, b, tp, wm)]
            if full:
                stages.append(lambda c, a, b: c.settle(a, b, used, tp, wm, jr))
            for stage in stages:
                for c in cases:
                    if not open_.any():
                        break
                    sel = np.flatnonzero(open_)
                    verdicts = stage(c, lo[:, sel], hi[:, sel])
                    if c is cases[0] and len(verdicts) == len(batch) and stage is stages[0]:
                        side = c.last_split
                    for j, (v, sl, inf) in zip(sel, verdicts):
                        if v is not None:
                            open_[j] = False
                            settled[v] += 1
                            if v == "energy" and (tightest is None or sl < tightest[0]):
                                tightest = (sl, inf)
            if open_.any() and not len(used):
                return None   # (no design variable moves the mechanism: nothing to split)
            for j in np.flatnonzero(open_):
                queue.append(_split(lo[:, j], hi[:, j], root[0], root[1], side=side[j]))
                queue.append(_split(lo[:, j], hi[:, j], root[0], root[1], right=True, side=side[j]))
        if tightest is None:
            return None
        _, inf = tightest
        return EnergyProof(motor.name, inf["case"], inf["window"], inf["sweep"], inf["needed"], inf["available"],
                           inf["bodies"], boxes, settled, tuple(self.design[i] for i in used), inf["terms"])


    POINTS = 16   # designs tried alone before the branch and bound (random, and the scene's own)

    def _unsettled_point(self, root, cases, full, tp, wm, jr) -> bool:
        """Whether some design (the scene's, or one of POINTS spread over the box) is settled by
        no verdict of ``cases`` even as a box of its own: then no proof can be found."""
        used = np.flatnonzero(self.used)
        r = self.mech.resolved
        own = np.array([r.values[self.design[k]] for k in used])
        spread = root[0] + (root[1] - root[0]) * np.random.default_rng(0).random((self.POINTS, len(used)))
        pts = np.vstack([own, spread]).T
        open_ = np.ones(pts.shape[1], bool)
        for c in cases:
            stages = [lambda a: c.settle_positions(a, a, tp, wm)] + [lambda a: c.settle(a, a, used, tp, wm, jr)] * full
            for stage in stages:
                sel = np.flatnonzero(open_)
                if sel.size:
                    open_[sel] = [v is None for v, _, _ in stage(pts[:, sel])]
        return bool(open_.any())

    def _ranked(self, root, tp, wm, jr):
        """The cases, the one with the largest margin at the box's centre first."""
        c = 0.5 * (root[0] + root[1])
        margins = []
        for case in self.cases:   # (the cheap stage's margin)
            case.settle_positions(c[:, None], c[:, None], tp, wm)
            margins.append(case.last_slack[0])
        return [self.cases[k] for k in np.argsort(-np.asarray(margins), kind="stable")]


def _split(lo, hi, root_lo, root_hi, right=False, side=-1):
    """Half of the box [lo, hi]: split across ``side``, or its widest side relative to the root box's."""
    j = int(side) if side >= 0 else int(np.argmax((hi - lo) / np.maximum(root_hi - root_lo, 1e-300)))
    mid = 0.5 * (lo[j] + hi[j])
    lo, hi = lo.copy(), hi.copy()
    if right:
        lo[j] = mid
    else:
        hi[j] = mid
    return lo, hi


def _limits(scene, m, r, p_full) -> list:
    """The scene's constraints on the kinematics alone (not a case's columns, not an aggregate),
    each bound as an expression >= 0 where it holds (with a tolerance of 1e-6 of the bound's
    size: the optimiser's and the continuous check's are smaller), of (s, x)."""
    from ..scene.cases import is_case_constraint
    from .bounds import numeric_bounds

    out = []
    for c in scene.constraints:
        if is_case_constraint(scene, c) or c.expr.is_aggregate:
            continue
        try:
            expr = ca.substitute(m.value(c.expr, ""), m.p, p_full)
        except Exception:   # noqa: BLE001 - a model quantity (not kinematics): not used, which is sound
            continue
        lo, hi = numeric_bounds(r, c)
        if math.isfinite(lo):
            out.append(expr - (lo - 1e-6 * (1 + abs(lo))))
        if math.isfinite(hi):
            out.append((hi + 1e-6 * (1 + abs(hi))) - expr)
    return out


def _fixed(r, expr, where):
    if expr is None:
        return 1.0
    v = r.fixed_value(expr)
    if v is None or not 0 < v <= 1:
        raise Unproven(f"{where} depends on the design or is not in (0, 1]")
    return float(v)


def _eligible(scene, r):
    """Raise :class:`Unproven` unless gravity is the scene's only load and a gearbox gives the motor torque."""
    if scene.drive is None or scene.gearbox is None:
        raise Unproven("no [drive] with a [gearbox]: no motor torque")
    if scene.forces:
        raise Unproven("[[forces]] (springs, dampers, forces): not gravity alone")
    if not scene.cases:
        raise Unproven("no load cases")
    zero = lambda e: e is None or r.fixed_value(e) == 0.0  # noqa: E731  (0 for every design and case)
    for b in scene.bodies:
        if b.force is not None and not all(zero(f) for f in b.force):
            raise Unproven(f"[[bodies]] {b.name}: a force")
        if not zero(b.torque):
            raise Unproven(f"[[bodies]] {b.name}: a torque")
