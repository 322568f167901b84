"""Seed 1's one-element dynamic model of a mechanism, reduced to its driving element.

For sweep coordinate s and drive coordinate q(s) with k = dq/ds (all by CasADi AD):

    M_s = sum m |dr/ds|^2 + I (dphi/ds)^2          Q_s = dV/ds - sum F . dr/ds - sum T dphi/ds
    M_q = M_s / k^2     dM_q/dq = (dM_q/ds) / k     Q_q = Q_s / k
    u   = Q_q + M_q qdd + 1/2 dM_q/dq qd^2          (Lagrange's equation for one coordinate)

and the seed's names with the efficiency factor c (1/eta while the drive delivers power,
eta while power flows back into it; 1 without efficiency):

    I_zS (m_zS) = c M_q              reduced inertia (mass), eqs. (12), (33)
    T_Su (F_Su) = c Q_q              static reduced load, eqs. (11), (32)
    dT_S (dF_S) = -1/2 qd^2 c dM_q/dq   velocity term, eqs. (15), (36)
    T_S  (F_S)  = T_Su + I_zS eps_S - dT_S = c u                     eqs. (16), (37)

Per body the seed's ratios are derivatives of the same graphs: rotary drive R_z = |dr/dq| and
i_m = 1 / (dphi/dq); linear drive i_v = 1 / |dr/dq| and R_e = 1 / (dphi/dq).  Loads in a scene
are applied loads (a force does positive work when its point moves along it; so does a torque).

Terms a scene does not use (no gravity, no forces, no mass, no inertia, eta = 1, zero speed or
acceleration) are not built: their outputs are absent, not zero.

The scene's force elements ([[forces]]: springs, gas springs, torsion springs, constant forces)
add to Q_s by virtual work, dampers add the damping load D_s qd / k^2 (column ``damping_load``)
at the drive's speed (:mod:`optdesign.model.forces`).
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

from ..errors import DeadCentreError, SceneError
from ..kinematics.mechanism import Mechanism, _fmt_s
from ..kinematics.enclosure import Enclosures, Selected
from ..kinematics.peaks import Request, extrema_of_cases, narrow_minima
from .forces import ForceLoads
from .intervals_compiled import compile_program
from ..kinematics.batches import parameters_used, same_cases
from ..kinematics.mapped import MappedFunction

DEAD_CENTRE_TOL = 1e-9   # the enclosure's tolerance on min |dq/ds|, relative to max |dq/ds| sampled
DEAD_CENTRES_KEPT = 256  # geometries whose dead-centre check a model keeps (ReducedModel.dead_centres)
from ..scene.expressions import Expression


class ReducedModel:
    """The reduced model of a scene with a ``[drive]``: CasADi expressions of (s, p)."""

    def __init__(self, mechanism: Mechanism, efficiency_smoothing: float = 0.0, motion=None, flow: str = "auto"):
        """``motion`` (optional; a load case's, :class:`optdesign.model.profiles.Motion`): the
        drive's speed, acceleration, speed squared (smooth where the speed is a square root)
        and a speed of the same sign (smooth) for the power-flow switch, as expressions of (s,
        p) in place of the constant [drive] speed and acceleration; ``flow`` 'auto' (seed 1's
        switch), 'driving' (c = 1/eta throughout) or 'braking' (c = eta)."""
        scene = mechanism.scene
        if scene.drive is None:
            raise SceneError(f"{scene.path}: the reduced model needs a [drive] table (rotary crank or linear actuator)")
        self.mech = m = mechanism
        self.resolved = mechanism.resolved
        self.scene = scene
        self.rotary = scene.drive.kind == "rotary"
        self.k = m.ds(m.q)
        self.dk = m.ds(self.k)
        drive = scene.drive
        self.uses_efficiency = drive.efficiency is not None and not self.is_one(drive.efficiency)
        self.flow = flow
        if motion is None:
            self.uses_speed = not self.is_zero(drive.speed)
            self.uses_acceleration = not self.is_zero(drive.acceleration)
            self.qd = m.value(drive.speed, "[drive] speed")
            self.qdd = m.value(drive.acceleration, "[drive] acceleration")
            self.qd2, self.flow_speed = _square(self.qd, f"{scene.path}: [drive] speed"), self.qd
        else:
            self.uses_speed = self.uses_acceleration = True
            self.qd, self.qdd, self.qd2, self.flow_speed = motion.qd, motion.qdd, motion.qd2, motion.flow_speed
        self.eta = m.value(drive.efficiency, "[drive] efficiency") if self.uses_efficiency else 1.0
        self.efficiency_smoothing = efficiency_smoothing
        self._k_function = None
        self._k_enclosures = None
        self._dead_centres_seen = {}   # the geometries checked (dead_centres): their results
        self.dead_centre_note = ""   # of the last check: why k's minimum has no enclosure's proof
        self._bodies()
        self._generalised()

    # --- which terms exist ---
    def is_zero(self, expr: Expression | None) -> bool:
        """True when ``expr`` is absent, or zero and independent of design variables and s."""
        return self._constant_equal(expr, 0.0)

    def is_one(self, expr):
        return self._constant_equal(expr, 1.0)

    def _constant_equal(self, expr, target):
        if expr is None:
            return target == 0.0
        value = self.resolved.fixed_value(expr)
        return value is not None and value == target

    # --- building ---
    def _bodies(self):
        m, sc = self.mech, self.scene
        self.massive, self.rotating, self.loaded = [], [], []
        g = None if sc.gravity is None or self.is_zero(sc.gravity.g) else m.value(sc.gravity.g, "[gravity] g")
        self.uses_gravity = g is not None
        self.body_terms = {}
        for b in sc.bodies:
            t = {}
            r_s = m.ds(m.body_com[b.name]) if b.name in m.body_com else None
            phi_s = m.ds(m.body_angle[b.name])
            if not self.is_zero(b.mass):
                t["mass"] = m.value(b.mass, f"[[bodies]] {b.name}.mass")
                t["r_s"] = r_s
                self.massive.append(b.name)
            if not self.is_zero(b.inertia):
                t["inertia"] = m.value(b.inertia, f"[[bodies]] {b.name}.inertia")
                self.rotating.append(b.name)
            t["phi_s"] = phi_s
            load = 0
            if g is not None and "mass" in t:
                load = load + t["mass"] * g * r_s[1]
            if b.force is not None and not all(self.is_zero(f) for f in b.force):
                force = ca.vertcat(*(m.value(f, f"[[bodies]] {b.name}.force") for f in b.force))
                load = load - ca.dot(force, r_s)
            if not self.is_zero(b.torque):
                load = load - m.value(b.torque, f"[[bodies]] {b.name}.torque") * phi_s
            if not (isinstance(load, int) and load == 0):
                t["Q_s"] = load
                self.loaded.append(b.name)
            self.body_terms[b.name] = t
        self.forces = ForceLoads(m)  # [[forces]]: springs, gas springs, dampers (model/forces.py)

    def _generalised(self):
        m = self.mech
        k = self.k
        M_s = 0
        for name, t in self.body_terms.items():
            if "mass" in t:
                M_s = M_s + t["mass"] * ca.sumsqr(t["r_s"])
            if "inertia" in t:
                M_s = M_s + t["inertia"] * t["phi_s"] ** 2
        self.has_inertia = bool(self.massive or self.rotating)
        self.M_s = M_s if self.has_inertia else None
        Q_s = 0
        for t in self.body_terms.values():
            if "Q_s" in t:
                Q_s = Q_s + t["Q_s"]
        if self.forces.static_s is not None:
            Q_s = Q_s + self.forces.static_s
        self.has_static = bool(self.loaded) or self.forces.static_s is not None
        self.Q_s = Q_s if self.has_static else None
        # dampers: Q_s = D_s sd with sd = qd / k (absent without dampers or without speed)
        self.damping_s = self.forces.damping_s if self.uses_speed else None

        # referred to the drive coordinate q
        u = 0
        if self.has_static:
            self.Q_q = self.Q_s / k
            u = u + self.Q_q
        if self.damping_s is not None:
            self.damping_q = self.damping_s * self.qd / k**2
            u = u + self.damping_q
        if self.has_inertia:
            self.M_q = self.M_s / k**2
            self.dM_q = m.ds(self.M_q) / k
            if self.uses_acceleration:
                u = u + self.M_q * self.qdd
            if self.uses_speed:
                u = u + 0.5 * self.dM_q * self.qd2
        self.u = u  # the ideal (eta = 1) drive load
        self.factor = self.flow_factor(u * self.flow_speed) if self.uses_efficiency else 1.0

    def flow_factor(self, power):
        """c for a power of the sign of ``power``: :meth:`efficiency_factor`, or fixed by a load
        case's ``efficiency`` ('driving': 1/eta, 'braking': eta)."""
        if self.flow == "driving":
            return 1 / self.eta
        if self.flow == "braking":
            return self.eta
        return self.efficiency_factor(power)

    def efficiency_factor(self, power):
        """c = 1/eta while the drive delivers power (power > 0), eta while it takes power back.

        With ``efficiency_smoothing`` w > 0 the switch is c = (1/eta + eta)/2 + (1/eta - eta)/2
        tanh(power / w): smooth for the optimiser; it differs from the exact switch only where
        |power| is within a few w of zero, where the drive load error is at most
        0.14 (1/eta - eta) w / |qd| (the maximum of x (1 - tanh x) is 0.278 at x = 0.65)."""
        eta = self.eta
        if self.efficiency_smoothing > 0:
            mean, half = (1 / eta + eta) / 2, (1 / eta - eta) / 2
            return mean + half * ca.tanh(power / self.efficiency_smoothing)
        return ca.if_else(power >= 0, 1 / eta, eta)

    # --- the seed's quantities (absent ones are None) ---
    def outputs(self) -> dict:
        """Named expressions per sample, in the seed's terms, leaving out unused terms."""
        c = self.factor
        out = {"q": self.mech.q, "k": self.k}
        if self.has_inertia:
            out["reduced_inertia"] = c * self.M_q
            out["reduced_inertia_dq"] = c * self.dM_q
        if self.has_static:
            out["static_load"] = c * self.Q_q
        if self.damping_s is not None:
            out["damping_load"] = c * self.damping_q
        if self.has_inertia and self.uses_acceleration:
            out["inertia_term"] = c * self.M_q * self.qdd
        if self.has_inertia and self.uses_speed:
            out["velocity_term"] = -0.5 * self.qd2 * c * self.dM_q
        out["drive"] = c * self.u
        if self.uses_speed:
            out["power"] = c * self.u * self.qd
        if self.uses_efficiency:
            out["efficiency_factor"] = c
        return out

    def body_ratios(self) -> dict:
        """Per body the seed's ratios and their derivatives with respect to q:
        rotary R_z, dR_z/dq (massive bodies), i_m (rotating bodies); linear i_v, di_v/dq, R_e.
        Also the tangential acceleration of the centre of mass, a_C0 + delta_a_C = a_C (eqs. 3,
        24), each part only when the drive's acceleration (a_C0) or speed (delta_a_C) is used."""
        m, k = self.mech, self.k
        out = {}
        for name, t in self.body_terms.items():
            ratios = {}
            if "mass" in t:
                speed_ratio = ca.sqrt(ca.sumsqr(t["r_s"])) / ca.fabs(k)  # |dr/dq| = v_C / qd
                d_speed_ratio = m.ds(speed_ratio) / k
                if self.rotary:
                    ratios["R_z"], ratios["dR_z_dq"] = speed_ratio, d_speed_ratio
                else:
                    ratios["i_v"] = 1 / speed_ratio
                    ratios["di_v_dq"] = -d_speed_ratio / speed_ratio**2
                # lean: a zero drive acceleration (speed) builds no a_C0 (delta_a_C).
                # a_C = d|v_C|/dt (eqs. 3, 24) with |v_C| = speed_ratio |qd|: when the drive runs
                # backwards (qd < 0) both parts change sign.
                direction = ca.sign(self.qd) if self.uses_speed else 1.0
                parts = []
                if self.uses_acceleration:
                    ratios["a_C0"] = direction * speed_ratio * self.qdd
                    parts.append(ratios["a_C0"])
                if self.uses_speed:
                    ratios["delta_a_C"] = direction * d_speed_ratio * self.qd2
                    parts.append(ratios["delta_a_C"])
                if parts:
                    ratios["a_C"] = sum(parts[1:], parts[0])
            if "inertia" in t:
                ratios["i_m" if self.rotary else "R_e"] = k / t["phi_s"]
            if ratios:
                out[name] = ratios
        return out

    def drive_acceleration(self, drive_load):
        """Motion from the drive (eqs. 17, 38): the drive acceleration for a given drive torque
        or force at the scene's speed, I_zS eps_S = T_S - T_Su + dT_S with the same c.
        It inverts :meth:`outputs`' drive exactly only with efficiency_smoothing = 0: with
        smoothing, c is taken at the given power T_S qd, the forward model at the ideal power
        u qd, so near zero power the round trip is off by up to the smoothing error."""
        if not self.has_inertia:
            raise SceneError(f"{self.scene.path}: the mechanism has no mass or inertia: a drive load gives no acceleration")
        c_inv = self.efficiency_inverse(drive_load * self.qd) if self.uses_efficiency else 1.0
        ideal = drive_load * c_inv
        rest = ideal
        if self.has_static:
            rest = rest - self.Q_q
        if self.damping_s is not None:
            rest = rest - self.damping_q
        if self.uses_speed:
            rest = rest - 0.5 * self.dM_q * self.qd2
        return rest / self.M_q

    def efficiency_inverse(self, power):
        """1/c for a given drive power T_S qd (same sign as the ideal power)."""
        return 1.0 / self.efficiency_factor(power)

    def drive_numerator(self, k_ref: float = 1.0):
        """The drive load as N / K with K = (k / k_ref)^4 >= 0 and N free of any division by
        k = dq/ds:  u k^4 = Q_s k^3 + M_s k^2 qdd + 1/2 qd^2 (dM_s/ds k - 2 M_s dk/ds).

        The optimiser constrains |N| <= t K instead of |N / K| <= t: the same set wherever
        k != 0, but bounded and smooth where an iterate nears a dead centre (k -> 0)."""
        k = self.k
        n = 0
        if self.has_static:
            n = n + self.Q_s * k**3
        if self.damping_s is not None:
            n = n + self.damping_s * self.qd * k**2
        if self.has_inertia and self.uses_acceleration:
            n = n + self.M_s * k**2 * self.qdd
        if self.has_inertia and self.uses_speed:
            n = n + 0.5 * self.qd2 * (self.mech.ds(self.M_s) * k - 2 * self.M_s * self.dk)
        n = n / k_ref**4
        if self.uses_efficiency:
            n = n * self.flow_factor(n * self.flow_speed)  # same sign as the power u qd
        return n, (k / k_ref) ** 4

    # --- checks ---
    def check_dead_centre(self, s_values, p_values=None) -> list:
        """Raise :class:`DeadCentreError` where k = dq/ds vanishes in the stroke; else return the
        minima of |k| narrower than the samples' spacing (the one case of :meth:`dead_centres`;
        the note of its proof in :attr:`dead_centre_note`)."""
        p_values = self.mech.parameter_values if p_values is None else np.asarray(p_values, float)
        found = self.dead_centres(s_values, p_values[None, :])[0]
        if isinstance(found, DeadCentreError):
            raise found
        narrow, self.dead_centre_note = found
        return narrow

    def dead_centres(self, s_values, P, K=None) -> list:
        """Per case (a row of the parameters ``P``): ``(narrow, note)`` or the case's
        :class:`DeadCentreError`.  k = dq/ds vanishes at a sample, between two samples where it
        changes sign (located by bisection), or where it touches zero between samples without
        changing sign (its continuous minimum |k|, certified by
        :func:`~optdesign.kinematics.peaks.continuous_maxima_rows`, at most 1e-12 of max |k|):
        an error; else ``narrow``, the minima of |k| narrower than the samples' spacing, (s,
        width) each, and ``note``, why the minimum has no enclosure's proof ("" when it has).
        ``K``: k at the samples, cases x samples, when the caller has it.  k depends on some
        parameters only (the geometry, not a mass): cases equal in those are checked once (the
        same numbers: the check sees nothing else), and a geometry checked before (a study's
        batches of cases differing in masses) is not checked again: its result is kept
        (:data:`DEAD_CENTRES_KEPT` geometries at most; an error is found again each time)."""
        m = self.mech
        if self._k_function is None:
            dk = m.ds(self.k)
            self._k_function = ca.Function("k", [m.s, m.p], [self.k])
            self._k_derivatives = MappedFunction(m.function("k_ds", {"k": self.k, "dk": dk, "d2k": m.ds(dk)}))
            self._k_uses = parameters_used(m, self.k)
        s_values = np.asarray(s_values, float)
        P = np.atleast_2d(np.asarray(P, float))
        if K is None:
            n = len(s_values)
            K = self._k_derivatives(np.tile(s_values, len(P)), np.repeat(P, n, axis=0))[0].reshape(len(P), n)
        groups = same_cases(P, self._k_uses)
        found, between = {}, []   # per group's first case: its result; the groups checked between samples
        seen, keys = self._dead_centres_seen, {}
        for first, _ in groups:
            k = np.asarray(K[first], float)
            # what the check reads of the case: the samples, k there, the parameters k depends on
            key = (s_values.tobytes(), k.tobytes(), P[first, self._k_uses].tobytes())
            if key in seen:
                found[first] = (list(seen[key][0]), seen[key][1])   # the caller's own list
                continue
            keys[first] = key
            scale = np.max(np.abs(k)) if k.size else 1.0
            zero = np.flatnonzero(np.abs(k) <= 1e-12 * max(scale, 1e-300))
            change = np.flatnonzero(np.sign(k[:-1]) * np.sign(k[1:]) < 0)
            if zero.size and (not change.size or zero[0] <= change[0]):
                found[first] = self._dead_centre_error(s_values, s_values[zero[0]], P[first])
            elif change.size:
                i = change[0]
                where = _bisect(lambda x: float(self._k_function(x, P[first])), s_values[i], s_values[i + 1])
                found[first] = self._dead_centre_error(s_values, where, P[first])
            else:
                between.append((first, scale))
        if between:   # all of them at once (the one certification over many cases)
            firsts = [first for first, _ in between]
            for first, (where, narrow, note) in zip(firsts, self._dead_centre_between(
                    s_values, np.asarray(K, float)[firsts], P[firsts], np.array([s for _, s in between]))):
                found[first] = (narrow, note) if where is None else self._dead_centre_error(s_values, where, P[first])
        for first, key in keys.items():
            if not isinstance(found[first], DeadCentreError):
                if len(seen) >= DEAD_CENTRES_KEPT:
                    seen.pop(next(iter(seen)))   # the oldest
                seen[key] = (tuple(found[first][0]), found[first][1])
        out = [None] * len(P)
        for first, members in groups:
            for i in members:
                out[i] = found[first]
        return out

    def _dead_centre_error(self, s_values, where, p_values) -> DeadCentreError:
        """The error of a case whose k = dq/ds vanishes at ``where``: a rest at a stroke end, or
        a dead centre of the drive."""
        what = "crank angle" if self.rotary else "actuator length"
        pins = "-".join(self.scene.drive.pins)
        name = self.scene.sweep.name
        if where in (s_values[0], s_values[-1]) and self._rests_at(where, s_values, p_values):
            return DeadCentreError(
                f"{self.scene.path}: [sweep] {name} = {_fmt_s(where, self.scene)}: the mechanism rests at this end "
                f"of the stroke (dq/d{name} = 0 and every point's d/d{name} = 0): a rest of the motion, not a dead "
                f"centre of the drive ({what} {pins}), but the reduced model along {name} is 0/0 there. State the "
                "motion on the output: make the coordinate that rests (a rocker angle, a ram height) the sweep and "
                "give its law in time as a [profiles] entry (kind = \"cycloidal\", \"modified-sine\", ...; "
                "docs/scenes.md, Example 3): at a rest the drive's dq/d(sweep) stays finite.", s=float(where))
        return DeadCentreError(
            f"{self.scene.path}: [drive] dead centre at {self.scene.sweep.name} = {_fmt_s(where, self.scene)}: the "
            f"drive coordinate ({what} {pins}) stops moving there (dq/d{self.scene.sweep.name} = 0), so "
            "the reduced inertia and load are infinite. Narrow the sweep to exclude it, or move the "
            "drive's pins so that q changes monotonically over the stroke.", s=float(where))

    REST_TOL = 1e-9   # every point's |dr/ds| at most this fraction of its largest sampled: the mechanism rests

    def _rests_at(self, end, s_values, p_values) -> bool:
        """True when, at the stroke's ``end`` where k = 0, every point of the mechanism stops too
        (|dr/ds| <= :data:`REST_TOL` of its largest over the samples): the sweep rests there
        (a time law as the sweep), rather than the drive passing a dead centre while the
        mechanism moves."""
        m = self.mech
        speeds = [ca.norm_2(m.ds(r)) for r in m.points.values() if ca.depends_on(r, m.s)]
        if not speeds:
            return False
        f = ca.Function("point_speeds", [m.s, m.p], [ca.vertcat(*speeds)])
        sampled = np.abs(np.asarray(f.map(len(s_values))(np.asarray(s_values, float)[None, :], p_values)))
        there = np.abs(np.asarray(f(end, p_values), float).ravel())
        return bool(np.all(there <= self.REST_TOL * np.maximum(np.max(sampled, axis=1), 1e-300)))

    def _dead_centre_between(self, s_values, K, P, scales) -> list:
        """Per case (k at the samples in a row of ``K``, one sign over them; its parameters a row
        of ``P``; its max |k| in ``scales``): (where, narrow, note): where |k| comes within 1e-12
        of max |k| between samples, or None; the minima of |k| narrower than the samples' spacing
        (:func:`~optdesign.kinematics.peaks.narrow_minima`); and why the minimum has no
        enclosure's proof ("" when it has).  A k that does not vary (a crank swept by its own
        angle) has neither.  The cases' minima are located and certified together
        (:func:`~optdesign.kinematics.peaks.extrema_of_cases`: each case's numbers its own)."""
        out = [(None, [], "")] * len(P)
        live = [i for i in range(len(P)) if len(s_values) >= 2 and np.ptp(K[i]) > 1e-12 * max(scales[i], 1e-300)]
        if not live or not self._k_varies():
            return out
        K, P, scales = K[live], P[live], scales[live]
        sign = np.where(K[:, 0] > 0, 1.0, -1.0)
        ascending = s_values[-1] >= s_values[0]
        grid, rows = (s_values, K) if ascending else (s_values[::-1], K[:, ::-1])

        def evaluate(s, cases):
            return tuple(sign[cases] * a for a in self._k_derivatives(s, P[cases]))

        if self._k_enclosures is None:
            self._k_enclosures = Enclosures(self._k_derivatives.func, compile_program)   # the same program, in intervals
        enclosure = Selected(self._k_enclosures.at(P), [0], [1.0], case_sign=sign)
        found = extrema_of_cases(evaluate, grid, (sign[:, None] * rows)[:, None, :],
                                 [Request(0, "min", ends=True, tol=DEAD_CENTRE_TOL * scales)], enclosure=enclosure)
        spacing = abs(float(s_values[-1] - s_values[0])) / (len(s_values) - 1)
        # k and its derivatives at every case's candidate minima (narrow_minima's), in one call
        at = [[e.s for e in extrema if e.value > 0] for (extrema,) in found]
        ends = np.cumsum([0] + [len(a) for a in at])
        values = evaluate(np.concatenate([np.array(a, float) for a in at]), np.repeat(np.arange(len(at)), np.diff(ends)))
        for j, (i, (extrema,)) in enumerate(zip(live, found)):
            low = [e for e in extrema if e.value <= 1e-12 * scales[j]]
            if not low:
                mine = tuple(a[0, ends[j]:ends[j + 1]] for a in values)
                out[i] = (None, narrow_minima(lambda s: mine, extrema, spacing), extrema[0].note)
            else:
                out[i] = (min(low, key=lambda e: e.s if ascending else -e.s).s, [], extrema[0].note)
        return out

    def _k_varies(self) -> bool:
        """Whether k depends on the sweep (a crank swept by its own angle: it does not), asked once."""
        if getattr(self, "_k_depends", None) is None:
            self._k_depends = bool(ca.depends_on(self.k, self.mech.s))
        return self._k_depends


def _bisect(f, a, b, iterations=60):
    fa = f(a)
    for _ in range(iterations):
        mid = 0.5 * (a + b)
        fm = f(mid)
        if math.copysign(1, fm) == math.copysign(1, fa):
            a, fa = mid, fm
        else:
            b = mid
    return 0.5 * (a + b)


def _square(x, where):
    """x**2 of a constant (or a CasADi expression); a number whose square overflows is an error."""
    try:
        return x**2
    except OverflowError:
        raise SceneError(f"{where} = {x:g}: too large, its square overflows a float (> 1.8e308); give it in SI "
                         "units (rad/s, m/s)") from None
