"""A duty cycle in time: the phases of ``[[simulation.phases]]`` run one after the other.

Each phase has its own drive law (:mod:`.phase_laws`: a law, the motor's speed-torque curve, a
speed controller tracking a profile, a brake) compiled into its own equation of motion
(:class:`.equations.Equations`, with the time since the phase began as a state and the
integrals over time that the cycle's figures need: int T_m^2 dt, the motor's work int T_m
omega_m dt and the drive's int T_S qd dt), and is run by :func:`.motion.run_motion` from the
state where the phase before it ended until its own end: a position (an event located as a
stroke end is), a rest (the speed through zero), a time, or its profile's end.  A hold keeps
the mechanism at rest for its time, the motor carrying the static load (T = c Q_q at the drive,
c = 1/(eta_m eta_g) as :mod:`optdesign.model.duty` has it) or a brake holding it (the motor
idle).  Every phase change is an event ('phase') in the result, next to the events of the
phases' own runs (reversals, power-flow switches, ...) at their times in the cycle.

Bad input is a :class:`~optdesign.errors.SceneError` naming the phase and the state: a law that
is NaN or infinite at the phase's start, a phase that has not ended by t_end (its state there),
phases that do not connect (a hold or a profile that starts where the phase before has not
left the mechanism), a stroke end or a stall before a phase's end.
"""
from __future__ import annotations

import math
import time

import casadi as ca
import numpy as np

from ..errors import OptdesignError, SceneError, SolverError
from ..kinematics.mechanism import Mechanism, _fmt_s
from ..model.profiles import case_profile
from ..model.reduction import ReducedModel
from ..model.train import motor_numbers
from ..scene.cases import Case
from ..scene.expressions import evaluate
from .equations import Equations, check_inertia, initial_state
from .integrate import DEFAULT_TOLERANCE, Counts, Integration, state_scales
from .events import at_rest
from .motion import run_motion
from .time_peaks import locate_peaks
from .phase_laws import PhaseLaw, profile_kinks
from .result import SimulationResult, event_record

QUADRATURES = ("motor_squared", "motor_work", "drive_work")
OVERRUN = 1e-2  # a phase may run this share of the stroke past its ends (where the mechanism assembles)
CONNECT = 1e-3   # a profile connects where the state is within this share of the stroke of its start
TIGHTEST = 1e-12  # a controller's phase is integrated at no tighter a tolerance (:meth:`PhasedSimulator._controller_tolerance`)
HOLD_REST = 1e-3  # a hold connects where the kinetic energy left is within this share of the cycle's peak so far


class PhasedSimulator:
    """The compiled phases of one scene's ``[simulation]``; :meth:`run` runs the cycle."""

    def __init__(self, scene):
        t0 = time.perf_counter()
        self.scene = scene
        self.sim = sim = scene.simulation
        self.mech = mech = Mechanism(scene)
        self.model = model = ReducedModel(mech)
        self.resolved = res = mech.resolved
        self.where = (scene.path, scene.sweep.name, scene)
        lo, hi = res.start, res.stop
        self.lo, self.hi = min(lo, hi), max(lo, hi)
        self.stroke_grid = np.linspace(self.lo, self.hi, max(scene.sweep.samples, 2001))
        mech.check_assembly(self.stroke_grid)
        # a phase may overrun the stroke a little (a controller's overshoot at a stroke end)
        # where the mechanism assembles there
        margin = OVERRUN * (self.hi - self.lo)
        try:
            mech.check_assembly(np.r_[np.linspace(self.lo - margin, self.lo, 11), np.linspace(self.hi, self.hi + margin, 11)])
        except OptdesignError:
            margin = 0.0
        self.overrun = margin
        sign = 1.0 if hi >= lo else -1.0
        self.ends = {"from": lo - sign * margin, "to": hi + sign * margin}
        values = res.values
        self.motor, self.ratio, eta_g = None, 1.0, None
        if scene.gearbox is not None:
            self.ratio = float(evaluate(scene.gearbox.ratio, values, {}, "[gearbox] ratio"))
            if scene.gearbox.efficiency is not None:
                eta_g = float(evaluate(scene.gearbox.efficiency, values, {}, "[gearbox] efficiency"))
        if scene.motors and scene.gearbox is not None:
            chosen = next(m for m in scene.motors if m.name == sim.motor) if sim.motor else scene.motors[0]
            self.motor_name = chosen.name
            self.motor = motor_numbers(chosen, values)
        self.eta_g = eta_g if eta_g is not None and eta_g != 1.0 else None
        self.cases = {c.name: c for c in scene.cases}
        self.t_end = res.constant(sim.t_end, "[simulation] t_end")
        self.s_start = res.constant(sim.start, "[simulation] start")
        self.qd_start = res.constant(sim.speed, "[simulation] speed")
        self._hold = ca.Function("hold", [mech.s, mech.p], [model.Q_s if model.has_static else 0 * mech.s,
                                                            model.k])
        self.build_time = time.perf_counter() - t0

    # --- per phase ---
    def parameters(self, phase):
        """The parameter vector of a phase: the scene's, with its case's overrides."""
        p = self.mech.parameter_values.copy()
        case = self.cases.get(phase.case)
        if case is None or not case.overrides:
            return p
        res = self.resolved
        env = res.environment(p)
        return np.array([float(evaluate(case.overrides[n], env, {}, f"[[cases]] {case.name}.set.{n}"))
                         if n in case.overrides else p[i] for i, n in enumerate(res.leaf_names)])

    def target(self, phase):
        """A controller's profile on the stroke: its MotionProfile (sigma, shape, s_begin)."""
        case = self.cases.get(phase.case)
        profile = phase.setting.get("profile", case.profile if case else None)
        direction = phase.setting.get("direction", case.direction if case else None)
        ad_hoc = Case(f"phase {phase.name}", direction, dict(case.overrides) if case else {}, "auto", profile)
        res = self.resolved
        return case_profile(self.scene, ad_hoc, res.start, res.stop, res.values)

    def equations_of(self, phase, direction, profile):
        """The phase's equation of motion (compiled per phase: its law, through the gearbox)."""
        mech, model = self.mech, self.model
        law = PhaseLaw(phase.kind, phase.setting, mech, self.motor, self.ratio,
                       (profile.sigma, profile.shape, profile.s_begin) if profile is not None else None, direction)
        J = mech.value(self.scene.drive.inertia, "[drive] inertia") if self.scene.drive.inertia is not None else 0
        eta = None
        if self.motor is not None:
            J = J + self.motor["inertia"] * self.ratio**2
        if self.eta_g is not None:
            eta = (model.eta if model.uses_efficiency else 1.0) * self.eta_g
        eta_g, i = self.eta_g, self.ratio

        def gear_factor(c):
            return 1.0 if eta_g is None else ca.if_else(c >= 1, 1 / eta_g, eta_g)

        quads = {"motor_squared": lambda e: (e["drive"] / i) ** 2,
                 "motor_work": lambda e: e["drive"] * e["qd"],
                 "drive_work": lambda e: (e["drive"] - J * e["qdd"]) / gear_factor(e["c"]) * e["qd"]}
        return Equations(mech, model, self.scene.drive, law=law, inertia=J, eta=eta, timed=True, quadratures=quads)

    # --- the cycle ---
    def run(self, integrator=None, tolerance=None, samples=None, t_end=None):
        sim, res = self.sim, self.resolved
        method = integrator or sim.integrator
        if method == "rk4":
            raise SceneError(f"{self.scene.path}: [simulation] phases: rk4 is not offered for a duty cycle (its "
                             "error estimate needs a second run through every phase); use bdf or adams")
        tol = tolerance if tolerance is not None else (
            res.constant(sim.tolerance, "[simulation] tolerance") if sim.tolerance is not None else DEFAULT_TOLERANCE)
        n = samples or sim.samples
        t_end = self.t_end if t_end is None else float(t_end)
        dt = t_end / (n - 1)
        t_wall = time.perf_counter()
        p0 = self.mech.parameter_values
        base = initial_state(_FirstLaw(self), self.scene, self.s_start, self.qd_start, p0)
        scale0 = state_scales(base, self.lo, self.hi, t_end, self.model.rotary)
        torque = self.motor["peak_torque"] if self.motor else 1.0
        speed = self.motor["max_speed"] if self.motor else float(scale0[1])
        scale = np.r_[scale0, t_end, max(torque**2 * t_end, 1.0), max(torque * speed * t_end, 1.0),
                      max(torque * speed * t_end, 1.0)]
        t0, x = 0.0, base
        pieces, events, phases, counts = [], [], [], []
        for k, ph in enumerate(sim.phases):
            where = ph.where()
            if t0 >= t_end * (1 - 1e-12):
                raise SceneError(f"{self.scene.path}: {where}: the cycle reaches t_end = {t_end:g} s before this phase "
                                 f"starts ({self._state(x)}); raise [simulation] t_end")
            p = self.parameters(ph)
            if ph.kind == "hold":
                piece, record = self._hold_phase(ph, x, p, t0, t_end, dt, pieces)
            else:
                piece, record, evs, cnt = self._moving_phase(ph, x, p, t0, t_end, dt, method, tol, scale)
                events.extend(evs)
                counts.append(cnt)
            start = sum(len(pc["t"]) for pc in pieces)
            record["rows"] = [start, start + len(piece["t"])]   # its samples in the cycle's columns
            pieces.append(piece)
            phases.append(record)
            t0 = record["t_end"]
            x = np.array([piece["s"][-1], piece["sd"][-1]] + ([piece["q"][-1]] if self.model.rotary else []))
            if k + 1 < len(sim.phases):
                nxt = sim.phases[k + 1].name
                events.append({"t": t0, "kind": "phase", "phase": nxt, "previous": ph.name, "end": ph.until,
                               "state": {"s": float(x[0]), "sd": float(x[1]), "q": float(piece["q"][-1]),
                                         "qd": float(piece["qd"][-1])}})
        events.sort(key=lambda e: e["t"])
        t = np.concatenate([pc["t"] for pc in pieces])
        names = [k for k in pieces[0] if k != "t" and all(k in pc for pc in pieces)]
        cols = {k: np.concatenate([pc[k] for pc in pieces]) for k in names}
        stats = _sum_counts(counts)
        wall = time.perf_counter() - t_wall
        return SimulationResult(self.scene, self.scene.drive.kind, method, tol, None, t, cols, "cycle end", None,
                                stats, {"build_s": self.build_time, "integrate_s": wall}, None, events, phases)

    def _moving_phase(self, ph, x, p, t0, t_end, dt, method, tol, scale):
        where = ph.where()
        direction = float(np.sign(x[1])) if x[1] != 0 else 0.0
        profile = None
        if ph.kind == "controller":
            profile = self.target(ph)
            gap = abs(x[0] - profile.s_begin)
            if gap > CONNECT * (self.hi - self.lo):
                raise SceneError(f"{self.scene.path}: {where}: the phases do not connect: the controller's profile starts "
                                 f"at {self.scene.sweep.name} = {_fmt_s(profile.s_begin, self.scene)}, but the phase starts at "
                                 f"t = {t0:.9g} s with {self._state(x)}; end the phase before at the profile's start, "
                                 "or track a profile that starts there")
        if ph.kind == "brake" and direction == 0.0:
            raise SceneError(f"{self.scene.path}: {where}: a brake acts against the motion, but the phase starts at rest "
                             f"(t = {t0:.9g} s, {self._state(x)}); brake a moving mechanism, or hold it")
        k0 = float(self._hold(x[0], p)[1])
        eq = self.equations_of(ph, direction * math.copysign(1.0, k0), profile)
        check_inertia(eq, self.scene, self.stroke_grid, p)
        x_full = np.r_[x, 0.0, np.zeros(len(QUADRATURES))]
        self._check_law(eq, ph, x_full, p, t0)
        if ph.kind == "controller":
            tol = self._controller_tolerance(ph, tol, scale, p)
        run = Integration(eq, p, x_full, self.ends, scale, method, tol, None)
        own = math.inf
        if ph.until == "time":
            own = self.resolved.constant(ph.until_value, f"{where}, until.time")
        elif ph.until == "profile":
            own = profile.duration
        elif ph.until == "position":
            target = self.resolved.constant(ph.until_value, f"{where}, until.position")
            if abs(target - x[0]) <= 1e-12 * (self.hi - self.lo):
                raise SceneError(f"{self.scene.path}: {where}, until.position: the phase starts where it ends "
                                 f"({self.scene.sweep.name} = {_fmt_s(target, self.scene)}, t = {t0:.9g} s); the phases do not "
                                 "connect: end the phase before elsewhere, or remove this one")
            run.phase_end = ("position", math.copysign(1.0, target - x[0]), target)
        else:
            d = direction
            if d == 0.0:  # from rest: the way it moves off
                d = float(np.sign(eq.output("sdd", x_full, p, 1.0)))
            run.phase_end = ("rest", d)
        duration = min(own, t_end - t0)
        n_base = len(x)
        ts, Xs, cs, helds, events, held_squared = [], [], [], [], [], 0.0
        t_local, x_cur, stop = 0.0, x_full, None
        while True:
            run.x0 = x_cur
            span = duration - t_local
            grid = np.linspace(0.0, span, max(int(math.ceil(span / dt - 1e-9)) + 1, 2))
            try:
                kinks = [k - t_local for k in profile_kinks(profile.shape)] if profile is not None else []
                motion = locate_peaks(run, run_motion(run, grid, self.where), kinks)
            except SolverError as exc:
                self._law_at_failure(exc, eq, ph, p, t0)
                raise SolverError(f"{where} (from t = {t0 + t_local:.9g} s): {exc}") from None
            keep = slice(1, None) if ts else slice(None)
            ts.append(t_local + motion.t[keep])
            Xs.append(motion.X[:, keep])
            cs.append(motion.c[keep])
            helds.append(motion.held[keep])
            events += [(t_local, e) for e in motion.events]
            t_local += float(motion.t[-1])
            stop = motion.stop
            if stop != "stalled" or t_local >= duration * (1 - 1e-12):
                break
            # a law of time may move a held mechanism again: wait, held, until it does
            x_held = motion.X[:, -1].copy()
            t_move, wait_t, wait_T = self._released(run, x_held, n_base, t_local, duration, dt, eq, p)
            ts.append(wait_t[1:])
            Xs.append(np.repeat(x_held[:, None], len(wait_t) - 1, axis=1))
            Xs[-1][n_base] = wait_t[1:]
            cs.append(np.full(len(wait_t) - 1, motion.c[-1]))
            helds.append(np.ones(len(wait_t) - 1))
            held_squared += float(np.trapezoid(wait_T**2, wait_t))
            t_local = float(wait_t[-1])
            if t_move is None:
                stop = "held"
                break
            x_cur = x_held.copy()
            x_cur[n_base] = t_move
        T, X = np.concatenate(ts), np.column_stack(Xs)
        last = X[:, -1]
        reached = stop == "phase end" or (stop in ("t_end", "held") and own <= t_end - t0)
        if not reached:
            t_at = t0 + T[-1]
            why = {"t_end": f"the cycle reached t_end = {t_end:g} s before the phase's end",
                   "held": f"the mechanism is held at rest until t_end = {t_end:g} s",
                   "stroke end": f"the motion reached the stroke's end '{motion.stop_end}' before the phase's end",
                   "stalled": "the self-locking drive holds the mechanism at rest before the phase's end"}[stop]
            goal = {"position": f"{self.scene.sweep.name} = {_fmt_s(run.phase_end[2], self.scene) if ph.until == 'position' else ''}",
                    "rest": "a rest", "time": "its time", "profile": "its profile's end"}[ph.until]
            raise SceneError(f"{self.scene.path}: {where}: the phase never reaches its end ({goal}): {why}, at "
                             f"t = {t_at:.9g} s with {self._state(last)}; check the phase's law and its end, or "
                             "raise [simulation] t_end")
        cols = eq.columns(X, p, np.concatenate(cs), np.concatenate(helds))
        piece = self._motor_columns({"t": t0 + T, **cols}, None)
        if ph.until == "profile" and abs(last[0] - profile.s_end) > CONNECT * (self.hi - self.lo):
            raise SceneError(f"{self.scene.path}: {where}: the motion did not follow the profile: at its end "
                             f"(t = {t0 + T[-1]:.9g} s) {self._state(last)}, against the profile's end "
                             f"{self.scene.sweep.name} = {_fmt_s(profile.s_end, self.scene)}{self._saturated(piece)}; the next "
                             "phase could not start where it should. Give a stronger motor or another gear ratio "
                             "(the sized one: simulate --design RESULT_JSON), or a slower profile")
        integrals = {name: float(last[n_base + 1 + i]) for i, name in enumerate(QUADRATURES)}
        integrals["motor_squared"] += held_squared
        record = {"name": ph.name, "kind": ph.kind, "until": ph.until, "case": ph.case, "t_start": t0,
                  "t_end": t0 + float(T[-1]), "integrals": integrals, "tolerance": run.tol}
        evs = []
        for offset, e in events:
            if e.kind == "phase end":
                continue
            rec = event_record(e, eq, p)
            rec["t"] += t0 + offset
            rec["phase"] = ph.name
            evs.append(rec)
        return piece, record, evs, run.statistics()

    def _controller_tolerance(self, ph, tol, scale, p):
        """The tolerance a controller's phase is integrated at.  Its torque K (i k (sd* + K_p
        (s* - s)) - i k sd) magnifies the states' error: ``tol`` on the states (relative to their
        scales) would be tol K i k (scale_sd + K_p scale_s) on the torque, 4.4 times the press's
        peak torque at tol 1e-4 (its forming stroke then saturated, its return stroke's int T_m^2
        dt came out negative).  So the phase runs at the tolerance that keeps the torque's error
        within tol of the motor's peak torque, and at no less than ``TIGHTEST``."""
        values, where = self.resolved.values, ph.where(ph.kind)
        gain = float(evaluate(ph.setting["gain"], values, {}, f"{where}.gain"))
        kp = ph.setting.get("position_gain")
        kp = float(evaluate(kp, values, {}, f"{where}.position_gain")) if kp is not None else 0.0
        k = float(np.max(np.abs(np.asarray(self._hold.map(len(self.stroke_grid))(self.stroke_grid[None, :], p)[1]))))
        torque = gain * self.ratio * k * (scale[1] + kp * scale[0])
        return min(tol, max(tol * self.motor["peak_torque"] / torque, TIGHTEST)) if torque > 0 else tol

    def _released(self, run, x, n_base, t_local, duration, dt, eq, p):
        """Where a mechanism held at rest at x (local time t_local) moves again under a law of
        time: (the instant, to 1e-12 of the phase, or None before ``duration``; the times of
        the held stretch; the motor torque at them)."""
        def moves(t):
            y = x.copy()
            y[n_base] = t
            return at_rest(run, t, y, None).kind != "stall"

        n = max(int(math.ceil((duration - t_local) / dt - 1e-9)), 1)
        grid = np.linspace(t_local, duration, n + 1)
        found = None
        for a, b in zip(grid[:-1], grid[1:]):
            if moves(b):
                found = (a, b)
                break
        if found is not None:
            a, b = found
            while b - a > 1e-12 * max(duration, 1e-300):
                m = 0.5 * (a + b)
                a, b = (a, m) if moves(m) else (m, b)
            grid = np.r_[grid[grid < b], b]
        times = grid
        y = np.repeat(x[:, None], len(times), axis=1)
        y[n_base] = times
        torque = np.asarray(eq.columns(y, p, np.ones(len(times)), np.ones(len(times)))["drive"]) / self.ratio
        return (None if found is None else float(times[-1])), times, torque

    def _hold_phase(self, ph, x, p, t0, t_end, dt, before):
        where = ph.where()
        # at rest, judged on the cycle's own motion: the kinetic energy the hold would take away
        # against the most the cycle had before it (not a speed against stroke / t_end, which a
        # longer t_end or a looser tolerance's residual speed at a profile's end tripped)
        peak = max((float(np.max(np.abs(pc["kinetic_energy"]))) for pc in before), default=0.0)
        energy = abs(float(before[-1]["kinetic_energy"][-1])) if before else 0.0
        if (energy > HOLD_REST * peak) if before else x[1] != 0.0:
            share = f"; its kinetic energy is {energy / peak:.3g} of the cycle's peak before it" if before else ""
            raise SceneError(f"{self.scene.path}: {where}: the phases do not connect: a hold keeps the mechanism at "
                             f"rest, but it is moving at t = {t0:.9g} s ({self._state(x)}{share}); end the phase "
                             "before with until = \"rest\"")
        duration = min(self.resolved.constant(ph.until_value, f"{where}, until.time"), t_end - t0)
        Q_s, k = (float(v) for v in self._hold(x[0], p))
        eta_m = float(ca.Function("eta", [self.mech.p], [self.model.eta])(p)) if self.model.uses_efficiency else 1.0
        c = 1 / (eta_m * (self.eta_g or 1.0))
        drive = c * Q_s / k if ph.setting == "motor" else 0.0
        n = max(int(math.ceil(duration / dt - 1e-9)) + 1, 2)
        t = t0 + np.linspace(0.0, duration, n)
        one = np.ones(n)
        q = x[2] if self.model.rotary else float(ca.Function("q", [self.mech.s, self.mech.p], [self.mech.q])(x[0], p))
        cols = {"t": t, "s": x[0] * one, "sd": 0 * one, "q": q * one, "qd": 0 * one, "qdd": 0 * one, "sdd": 0 * one,
                "drive": drive * one, "transmitted": drive * one, "kinetic_energy": 0 * one, "power": 0 * one}
        if self.eta_g is not None or self.model.uses_efficiency:
            cols["efficiency_factor"] = c * one
        piece = self._motor_columns(cols, None)
        motor = drive / self.ratio
        record = {"name": ph.name, "kind": "hold", "until": "time", "case": ph.case, "t_start": t0,
                  "t_end": t0 + duration, "hold_torque": motor,
                  "integrals": {"motor_squared": motor**2 * duration, "motor_work": 0.0, "drive_work": 0.0}}
        return piece, record

    def _saturated(self, piece):
        """', the motor at its peak torque for .. s of the phase (from t = ..)', or ''."""
        if self.motor is None:
            return ""
        at = np.abs(piece["motor_torque"]) >= self.motor["peak_torque"] * (1 - 1e-3)
        if not at.any():
            return ""
        t = piece["t"]
        spent = float(np.sum(np.diff(t)[at[:-1]]))
        return (f", the motor at its peak torque {self.motor['peak_torque']:g} N m for {spent:.3g} s of the phase "
                f"(from t = {t[np.argmax(at)]:.6g} s)")

    def _motor_columns(self, cols, c):
        cols["motor_torque"] = cols["drive"] / self.ratio
        cols["motor_speed"] = cols["qd"] * self.ratio
        return cols

    def _law_at_failure(self, exc, eq, ph, p, t0):
        """Where the integrator gave up: is the law NaN or infinite just ahead (the state
        carried on along its rate from the last good one)?  Then that is the error."""
        x = getattr(exc, "state", None)
        if x is None:
            return
        c = exc.branch.c if getattr(exc, "branch", None) is not None else 1.0
        rate = np.asarray(eq.rhs_branch(*[x[i] for i in range(eq.n_x)], p, c), float).ravel()
        for tau in np.linspace(0.0, exc.span, 257):
            y = x + tau * rate
            value = eq.output("drive", y, p, c)
            if not math.isfinite(value):
                raise SceneError(f"{self.scene.path}: {ph.where(ph.kind)}: the law gives {value} where the integrator "
                                 f"gave up (phase {ph.name!r}, t = {t0 + y[eq.n_x - 1 - len(QUADRATURES)]:.9g} s, "
                                 f"q = {eq.output('q', y, p):.9g}, qd = {eq.output('qd', y, p):.9g}); write a law "
                                 "that is finite over the motion") from None

    def _check_law(self, eq, ph, x, p, t0):
        value = eq.output("drive", x, p, 1.0)
        if not math.isfinite(value):
            qd = eq.output("qd", x, p)
            q = eq.output("q", x, p)
            raise SceneError(f"{self.scene.path}: {ph.where(ph.kind)}: the law gives {value} at the phase's start "
                             f"(phase {ph.name!r}, t = {t0:.9g} s, q = {q:.9g}, qd = {qd:.9g}); write a law that is "
                             "finite there")

    def _state(self, x):
        name = self.scene.sweep.name
        return f"{name} = {_fmt_s(x[0], self.scene)}, d{name}/dt = {x[1]:.6g}"


class _FirstLaw:
    """What :func:`.equations.initial_state` needs of the equations (k at the start, the
    crank's angle), without a law."""

    def __init__(self, ps):
        mech = ps.mech
        self.rotary = ps.model.rotary
        self.mech = mech
        self.inertia_check = ca.Function("inertia", [mech.s, mech.p], [0 * mech.s, ps.model.k + 0 * mech.s])


def _sum_counts(counts):
    """The integrator statistics of every phase's run, summed (zeros where only holds ran)."""
    out = Counts().as_dict()
    for c in counts:
        for k, v in c.items():
            if isinstance(v, dict):
                d = out.setdefault(k, {})
                for kk, vv in v.items():
                    d[kk] = d.get(kk, 0) + vv
            else:
                out[k] = out.get(k, 0) + v
    return out
