"""Motion in time under a drive law: seed 1's "motion from drive" (eqs. 17, 38) integrated.

The drive delivers T_m = law(q, qd) (a torque T_S for a rotary drive, a force F_S for a linear
one; ``[drive] law``) and has its own inertia J_d (``[drive] inertia``: rotor [kg m^2] or moving
piston mass [kg]).  What reaches the mechanism is T_S = T_m - J_d qdd, and the mechanism takes
T_S = c (T_Su + I_zS' eps_S - dT_S') in the seed's terms (c: efficiency factor, ' = ideal).

**Which coordinate.**  The seed writes the motion in the drive coordinate q:
I_zS eps_S = T_S - T_Su + dT_S with I_zS = M_s / k^2, k = dq/ds.  Where k -> 0 (a linear drive
at a dead centre) I_zS and T_Su blow up although nothing physical does.  We integrate in the
sweep coordinate s instead (state s, sd), multiplying the equation by k:

    (c M_s + J_d k^2) sdd = k T_m - J_d k k' sd^2 - c (1/2 M_s' sd^2 + Q_s)

(M_s, Q_s: the sweep-referred inertia and static load of :class:`~optdesign.model.reduction.ReducedModel`,
' = d/ds).  This form is regular wherever the total inertia c M_s + J_d k^2 > 0, in particular
at a dead centre of a linear drive (k = 0, M_s > 0).  For a rotary crank whose angle is the
sweep (the slider-crank), k = 1 and it is the seed's equation (17) itself; there M_s -> 0 at the
piston's dead centres, and only the rotor inertia J_d keeps the equation regular (a small J_d
makes the problem stiff: the crank whips through the dead centres).  A stroke where the total
inertia vanishes is reported as a :class:`~optdesign.errors.DeadCentreError` before integrating.

**Efficiency.**  c = 1/eta while power flows into the mechanism (T_S qd > 0), eta while it flows
back, as in :class:`~optdesign.model.reduction.ReducedModel` (an exact switch).  With drive inertia
T_S depends on the acceleration, but the sign of T_S qd does not depend on c: solving the
equation above for both c gives T_S k = c E_s with
E_s = [M_s (k T_m - J_d k k' sd^2) + J_d k^2 (1/2 M_s' sd^2 + Q_s)] / (c M_s + J_d k^2),
whose sign is that of the bracket.  So the direction of power flow, and with it c, is unique at
every state: the switch is exact (no smoothing changes the physics); the integrators see a jump
in acceleration at a switch and step through it by rejecting a step or two.

**Self-locking (stall).**  Where a drive with eta < 1 brings the mechanism to rest at a position
whose drive load lies between eta and 1/eta times the static load, the switch holds it there
(moving on, the drive divided by eta is too small; moving back, the load times eta pushes it
forward again): the acceleration flips sign with ds/dt, and the integrators either give up or,
at looser tolerances, step on through the chatter (tiny steps: the run's cost, not its stop;
so a drive with eta < 1 is integrated in chunks of output intervals, each checked for a held
rest before the next).  Neither is used to find the stop: the
approach to rest is smooth, so the instant of rest is the root of ds/dt on the *one-sided*
equation, the same equation with the power's direction taken from the direction of motion
(d * bracket instead of sd * bracket, d = +-1), which continues smoothly through ds/dt = 0.  An
output interval is examined where its end sample has failed, reversed, or could have lost its
speed in the interval (|ds/dt| <= |s''| dt); the root is located like a stroke end, and the run
stops 'stalled' there if the drive holds the mechanism (either way out of rest decelerates back).

**Integrators** (CasADi's ``integrator``): 'bdf' = CVODES BDF with Newton iterations (implicit,
for stiff cases), 'adams' = CVODES Adams with functional iteration (non-stiff, no Jacobian),
'rk4' = CasADi's fixed-step explicit RK4 (``steps`` per output sample; no error control of its
own, so the run is repeated with half the steps and the Richardson estimate of its error must be
within the tolerance, else a :class:`~optdesign.errors.SolverError`).  CVODES in CasADi 3.8 has
only experimental event support, so the stroke ends are found by us: the run goes over the
output grid, and where the sweep leaves the stroke the crossing time is located by re-integrating
the last interval over a variable length h (time-scaled ODE) and solving s(h) = end (Illinois
regula falsi, to 1e-12 of the interval).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from ..errors import DeadCentreError, SceneError, SolverError
from ..scene.expressions import constant_value, evaluate
from ..kinematics.mechanism import Mechanism, _fmt_s
from ..model.reduction import ReducedModel
from ..scene.elements import INTEGRATORS, Scene

DEFAULT_TOLERANCE = 1e-8
DEFAULT_RK4_STEPS = 20
MAX_STEPS = 20000  # CVODES steps per output interval before it gives up ("too much work")
STALL_CHUNK = 10   # output intervals per integrator call where a self-locking drive can stall


@dataclass(frozen=True)
class SimulationResult:
    """A motion in time (arrays over the output samples, the last one at the stop).

    ``q``, ``qd``, ``qdd``: drive coordinate (crank angle alpha [rad] or actuator length x [m]),
    its rate and acceleration; ``s``, ``sd``, ``sdd``: the sweep coordinate and its rates;
    ``drive``: the law's torque/force T_m; ``transmitted``: T_m - J_d qdd, what reaches the
    mechanism (the seed's T_S or F_S); ``kinetic_energy``: 1/2 M_s sd^2 + 1/2 J_d qd^2 (mechanism
    and drive); ``power``: T_m qd; ``efficiency_factor`` (only with eta < 1).  ``stop`` is
    'stroke end', 't_end' or 'stalled' (a self-locking drive under eta < 1 brought the
    mechanism to rest, where it stays); ``stop_end`` 'from' or 'to' (which end of [sweep]) or None.
    ``stats``: integrator counts (steps, rhs_evaluations, error_test_failures,
    nonlinear_iterations) summed over every integrator call of the run, and ``timings``."""

    scene: Scene
    drive_kind: str
    integrator: str
    tolerance: float
    steps_per_sample: int | None
    t: np.ndarray
    columns: dict
    stop: str
    stop_end: str | None
    stats: dict
    timings: dict = field(default_factory=dict)
    error_estimate: float | None = None

    def __getattr__(self, name):
        columns = self.__dict__.get("columns", {})
        if name in columns:
            return columns[name]
        raise AttributeError(name)

    @property
    def t_stop(self) -> float:
        return float(self.t[-1])


class Simulator:
    """The compiled equation of motion of one scene; :meth:`run` integrates it (a class under
    :func:`simulate`, reusable over integrators and tolerances)."""

    def __init__(self, scene: Scene):
        t0 = time.perf_counter()
        if scene.drive is None or scene.drive.law is None:
            raise SceneError(f"{scene.path}: [drive] law: the scene gives no drive law, so there is no motion "
                             "to simulate; add law = \"...\" to [drive] (a torque or force in q, qd and "
                             "parameters, e.g. law = \"T0*(1 - qd/omega0)\" or law = 50)")
        if scene.simulation is None:
            raise SceneError(f"{scene.path}: [simulation]: missing table: expected [simulation] with start "
                             "(sweep value at t = 0), speed (drive speed at t = 0) and t_end [s]")
        self.scene = scene
        self.mech = mech = Mechanism(scene)
        self.model = model = ReducedModel(mech)
        self.rotary = model.rotary
        self.values = scene.parameter_values()
        self._build(mech, model)
        sim = scene.simulation
        self.s_start = constant_value(sim.start, self.values, "[simulation] start")
        self.qd_start = constant_value(sim.speed, self.values, "[simulation] speed")
        self.t_end = constant_value(sim.t_end, self.values, "[simulation] t_end")
        lo, hi = (constant_value(e, self.values, "[sweep]") for e in (scene.sweep.start, scene.sweep.stop))
        self.ends = {"from": lo, "to": hi}
        self.lo, self.hi = min(lo, hi), max(lo, hi)
        self.stroke_grid = np.linspace(self.lo, self.hi, max(scene.sweep.samples, 2001))
        mech.check_assembly(self.stroke_grid)
        self._check_inertia()
        self.x0 = self._initial_state()
        self.build_time = time.perf_counter() - t0

    # --- the equation of motion ---
    def _build(self, mech, model):
        sym, s, p = mech.sym, mech.s, mech.p
        d = self.scene.drive
        k, dk = model.k, model.dk
        sd = sym.sym("sd")
        M_s = model.M_s if model.has_inertia else 0
        dM_s = mech.ds(M_s) if model.has_inertia else 0
        Q_s = model.Q_s if model.has_static else 0
        J = mech.value(d.inertia, "[drive] inertia") if d.inertia is not None else 0
        qd = k * sd
        # the rotary drive's angle is an atan2 (wrapped): the law sees the continuous angle,
        # carried as a third state q' = k sd
        q_state = sym.sym("q") if self.rotary else None
        q = q_state if self.rotary else mech.q
        env = dict(mech.env, q=q, qd=qd)
        T_m = evaluate(d.law, env, mech.points, "[drive] law")
        V = 0.5 * dM_s * sd**2  # velocity term in s: -dT_S referred to s
        rest = k * T_m - J * k * dk * sd**2
        if model.uses_efficiency:
            eta = model.eta
            bracket = M_s * rest + J * k**2 * (V + Q_s)  # T_S qd = sd * bracket / (c M_s + J k^2)
            c = ca.if_else(sd * bracket >= 0, 1 / eta, eta)  # sign of T_S qd, independent of c
        else:
            c = 1.0

        def acceleration(c):
            return (rest - c * (V + Q_s)) / (c * M_s + J * k**2)

        sdd = acceleration(c)
        qdd = k * sdd + dk * sd**2
        # Functions of the state's parts (an MX state cannot be a vertcat of symbols)
        states = [s, sd, q_state] if self.rotary else [s, sd]
        self.n_x = len(states)

        def rate(sdd):
            return ca.vertcat(sd, sdd, qd) if self.rotary else ca.vertcat(sd, sdd)

        self.rhs = ca.Function("rhs", states + [p], [rate(sdd)])
        if model.uses_efficiency:  # the one-sided equation: power direction from d = +-1, not sd
            direction = sym.sym("d")
            c_one = ca.if_else(direction * bracket >= 0, 1 / eta, eta)
            self.rhs_one = ca.Function("rhs_one", states + [p, direction], [rate(acceleration(c_one))])
        outs = {"q": q, "qd": qd, "qdd": qdd, "sdd": sdd, "drive": T_m, "transmitted": T_m - J * qdd,
                "kinetic_energy": 0.5 * M_s * sd**2 + 0.5 * J * qd**2, "power": T_m * qd}
        if model.uses_efficiency:
            outs["efficiency_factor"] = c
        self.output_names = list(outs)
        f = ca.Function("outputs", states + [p], [ca.vertcat(*[o + 0 * s for o in outs.values()])])
        xs = sym.sym("x", self.n_x)
        self.outputs = ca.Function("outputs", [xs, p], [f(*[xs[i] for i in range(self.n_x)], p)])
        self.inertia_check = ca.Function("inertia", [s, p], [M_s + J * k**2 + 0 * s, k + 0 * s])

    def _check_inertia(self):
        """The equation is singular where M_s + J_d k^2 vanishes (no mass moves and the drive has
        no inertia of its own): find the smallest value over the stroke, refined between samples."""
        f = self.inertia_check.map(len(self.stroke_grid))
        v = np.asarray(f(self.stroke_grid[None, :], self.mech.parameter_values)[0]).ravel()
        top = float(np.max(v)) if v.size else 0.0
        where = self.stroke_grid[int(np.argmin(v))]
        low = float(np.min(v))
        i = int(np.argmin(v))
        if 0 < i < len(v) - 1:  # golden-section refinement of the smallest sample's neighbourhood
            where, low = _golden(lambda x: float(self.inertia_check(x, self.mech.parameter_values)[0]),
                                 self.stroke_grid[i - 1], self.stroke_grid[i + 1])
        if not top > 0 or low <= 1e-12 * top:
            name, unit = self.scene.sweep.name, "kg m^2 (rotor)" if self.rotary else "kg (moving piston and rod)"
            raise DeadCentreError(
                f"{self.scene.path}: [drive] the reduced inertia vanishes at {name} = {_fmt_s(where)} "
                f"(smallest M_s + J_d k^2 = {low:.3g}, largest {top:.3g}): no mass moves with the drive "
                "there, so any drive torque or force gives an infinite acceleration (a dead centre of the "
                f"one-element model). Give the drive its own inertia ([drive] inertia, {unit}), or "
                "narrow the sweep to exclude it.")

    def _initial_state(self):
        s0 = self.s_start
        k0 = float(self.inertia_check(s0, self.mech.parameter_values)[1])
        if abs(k0) < 1e-12:
            if self.qd_start != 0:
                raise DeadCentreError(
                    f"{self.scene.path}: [simulation] start: {self.scene.sweep.name} = {_fmt_s(s0)} is a dead "
                    f"centre of the drive (dq/d{self.scene.sweep.name} = 0), where the drive cannot have the "
                    f"speed {self.qd_start:g}; start elsewhere or with speed = 0")
            sd0 = 0.0
        else:
            sd0 = self.qd_start / k0
        x0 = [s0, sd0]
        if self.rotary:
            x0.append(float(np.unwrap([0.0, float(self._q_of(s0))])[1]))
        return np.array(x0)

    def _q_of(self, s):
        if not hasattr(self, "_q_function"):
            self._q_function = ca.Function("q", [self.mech.s, self.mech.p], [self.mech.q])
        return float(self._q_function(s, self.mech.parameter_values))

    # --- integrators ---
    def _scales(self):
        """State scales: tolerances are relative to the stroke length and a reference sweep rate."""
        length = self.hi - self.lo
        rate = max(abs(self.x0[1]), length / self.t_end)
        scale = [length, rate] + ([abs(self.x0[2]) + length] if self.rotary else [])
        return np.array(scale)

    def _integrator(self, method, tolerance, tau, total_steps=None, max_steps=None, one_sided=False):
        """A CasADi integrator over the tau grid (0 .. 1) of the time-scaled ODE
        dy/dtau = h f(y * scale) / scale: the state y is scaled to order one (so that one
        absolute tolerance fits s, its rate and q), and the interval length h is a parameter
        (one integrator serves every interval, which the stroke-end search needs).  With
        ``one_sided`` f is the one-sided equation and the direction d is a parameter before h."""
        scale = self._scales()
        sym = self.mech.sym
        y, p, h = sym.sym("y", self.n_x), sym.sym("p", len(self.mech.parameter_values)), sym.sym("h")
        x = y * scale
        states = [x[i] for i in range(self.n_x)]
        if one_sided:
            d = sym.sym("d")
            ode, params = h * self.rhs_one(*states, p, d) / scale, ca.vertcat(p, d, h)
        else:
            ode, params = h * self.rhs(*states, p) / scale, ca.vertcat(p, h)
        dae = {"x": y, "p": params, "ode": ode}
        if method == "rk4":
            opts = {"number_of_finite_elements": int(total_steps), "show_eval_warnings": False}
            return ca.integrator("simulate", "rk", dae, 0.0, list(tau), opts), scale
        opts = {"abstol": tolerance, "reltol": tolerance, "max_num_steps": max_steps or MAX_STEPS,
                "disable_internal_warnings": True, "show_eval_warnings": False}
        if method == "bdf":
            opts.update(linear_multistep_method="bdf", nonlinear_solver_iteration="newton")
        else:
            opts.update(linear_multistep_method="adams", nonlinear_solver_iteration="functional")
        return ca.integrator("simulate", "cvodes", dae, 0.0, list(tau), opts), scale

    def run(self, integrator: str | None = None, tolerance: float | None = None, steps: int | None = None,
            samples: int | None = None, t_end: float | None = None, error_check: bool = True) -> SimulationResult:
        """Integrate from the scene's start over [0, t_end] or to a stroke end.  ``error_check``
        False skips RK4's half-step error estimate (for work-precision studies only)."""
        sim = self.scene.simulation
        method = integrator or sim.integrator
        if method not in INTEGRATORS:
            raise SceneError(f"integrator {method!r}: expected one of {', '.join(INTEGRATORS)}")
        tol = tolerance if tolerance is not None else (
            constant_value(sim.tolerance, self.values, "[simulation] tolerance") if sim.tolerance is not None
            else DEFAULT_TOLERANCE)
        n = samples or sim.samples
        t_end = self.t_end if t_end is None else float(t_end)
        steps = (steps or DEFAULT_RK4_STEPS) if method == "rk4" else None
        if method == "rk4" and steps < 2:
            raise SceneError(f"rk4 needs at least 2 steps per output sample (found {steps}): the error "
                             "estimate compares the run with one at half the steps")
        counts = _Counts()
        t0 = time.perf_counter()
        grid = np.linspace(0.0, t_end, n)
        X = self._integrate_grid(method, tol, steps, grid, counts)
        t, X, stop, end = self._stop(method, tol, steps, grid, X, counts)
        error = None
        if method == "rk4" and error_check:
            error = self._rk4_error(tol, steps, t, X, stop, counts)
        wall = time.perf_counter() - t0
        cols = self._columns(X)
        return SimulationResult(self.scene, self.scene.drive.kind, method, tol, steps, t, cols, stop, end,
                                counts.as_dict(), {"build_s": self.build_time, "integrate_s": wall},
                                error)

    def _call(self, F, scale, x0, h, counts, method, direction=None):
        extra = [] if direction is None else [direction]
        p = np.concatenate([self.mech.parameter_values, extra, [h]])
        try:
            xf = np.asarray(F(x0=x0 / scale, p=p)["xf"]) * scale[:, None]
        except RuntimeError as exc:
            counts.add(F.stats(), method)
            raise _IntegratorFailed(str(exc)) from None
        counts.add(F.stats(), method)
        return xf

    def _integrate_grid(self, method, tol, steps, grid, counts):
        """The whole run in one integrator call; on failure, interval by interval to find where.

        Where a self-locking drive can bring the mechanism to rest (eta < 1, CVODES), in chunks
        of STALL_CHUNK output intervals, each checked for a held rest before the next: past
        that instant CVODES steps on through the switch's chatter up to t_end, at loose
        tolerances about ten thousand steps per output interval."""
        n = len(grid) - 1
        chunk = STALL_CHUNK if self.model.uses_efficiency and method != "rk4" else n
        cols, i = [self.x0], 0
        while i < n:
            j = min(i + chunk, n)
            tau = (grid[i + 1:j + 1] - grid[i]) / (grid[j] - grid[i])
            F, scale = self._integrator(method, tol, tau, steps * (j - i) if steps else None)
            try:
                cols += list(self._call(F, scale, cols[-1], grid[j] - grid[i], counts, method).T)
            except _IntegratorFailed:
                return self._integrate_stepwise(method, tol, steps, grid, counts, np.column_stack(cols))
            first, i = i + 1, j
            if i < n and chunk < n:
                X = np.column_stack(cols)
                left = not (np.isfinite(X[:, first:]).all() and np.all((X[0, first:] >= self.lo) & (X[0, first:] <= self.hi)))
                if left or self._held_rest(method, tol, steps, grid[:i + 1], X, i, counts, first) is not None:
                    return np.column_stack([X, np.full((X.shape[0], n - i), np.nan)])
        return np.column_stack(cols)

    def _integrate_stepwise(self, method, tol, steps, grid, counts, X0=None):
        """Interval by interval (restarts) from the columns ``X0`` already integrated (the start
        alone by default): the states up to the interval where the integrator fails; a failing
        interval gets a NaN column, which :meth:`_stop` examines."""
        F, scale = self._integrator(method, tol, [1.0], steps)
        cols = [self.x0] if X0 is None else list(X0.T)
        for i in range(len(cols) - 1, len(grid) - 1):
            try:
                x = self._call(F, scale, cols[-1], grid[i + 1] - grid[i], counts, method)[:, 0]
            except _IntegratorFailed:
                x = np.full_like(self.x0, np.nan)
            cols.append(x)
            if not (np.all(np.isfinite(x)) and self.lo <= x[0] <= self.hi):
                break
        X = np.column_stack(cols)
        return np.column_stack([X, np.full((X.shape[0], len(grid) - X.shape[1]), np.nan)])

    def _stop(self, method, tol, steps, grid, X, counts):
        """Cut the run at the first rest where a self-locking drive holds the mechanism (up to
        the first failed or out-of-stroke sample), or where the sweep leaves the stroke
        (locating the crossing time), or report an integrator failure with its time and state."""
        s = X[0]
        bad = np.flatnonzero(~(np.isfinite(X).all(axis=0) & (s >= self.lo) & (s <= self.hi)))
        if self.model.uses_efficiency:
            stall = self._held_rest(method, tol, steps, grid, X, int(bad[0]) if bad.size else len(grid) - 1, counts)
            if stall is not None:
                j, h, x = stall
                return np.append(grid[:j], grid[j - 1] + h), np.column_stack([X[:, :j], x]), "stalled", None
        if not bad.size:
            return grid, X, "t_end", None
        i = int(bad[0])
        x_prev, dt = X[:, i - 1], grid[i] - grid[i - 1]
        if np.isfinite(X[:, i]).all():
            target = self.hi if X[0, i] > self.hi else self.lo
        else:
            target = self.hi if x_prev[1] >= 0 else self.lo
        h, x_end = None, None
        sdd = float(self.outputs(x_prev, self.mech.parameter_values)[3])
        reach = abs(x_prev[1]) * dt + 0.5 * abs(sdd) * dt**2  # how far s can plausibly get in dt
        if np.isfinite(X[:, i]).all() or abs(target - x_prev[0]) <= 4 * reach:
            h, x_end = self._locate(method, tol, steps, x_prev, dt, target, X[:, i], counts)
        if x_end is None:
            name = self.scene.sweep.name
            qd = float(self.outputs(x_prev, self.mech.parameter_values)[1])
            what = ("its solution blew up (NaN or inf): the fixed step is beyond RK4's stability limit, the "
                    "motion is stiff here" if method == "rk4" else
                    "CVODES gave up (too many steps, or repeated error-test or convergence failures)")
            if self.model.uses_efficiency and abs(x_prev[1]) < 1e-2 * np.nanmax(np.abs(X[1, :i])):
                raise SolverError(
                    f"{self.scene.path}: the drive stalls near t = {grid[i - 1]:.6g} s, {name} = {_fmt_s(x_prev[0])}, "
                    f"speed {qd:.3g}, but the instant the mechanism comes to rest could not be located: "
                    "tighten the tolerance or use more samples.")
            hint = {"bdf": "tighten or loosen the tolerance, or check the law and the loads for a blow-up",
                    "adams": "use the implicit integrator (integrator = \"bdf\"), which handles stiff cases",
                    "rk4": "use more steps per sample or the implicit integrator (integrator = \"bdf\")"}[method]
            raise SolverError(
                f"{self.scene.path}: the {method} integrator failed between t = {grid[i - 1]:.6g} s and "
                f"{grid[i]:.6g} s, from {name} = {_fmt_s(x_prev[0])}, drive speed {qd:.6g}, "
                f"d{name}/dt = {x_prev[1]:.6g}: {what}; {hint}.")
        end = "to" if target == self.ends["to"] else "from"
        x_end[0] = target
        t = np.append(grid[:i], grid[i - 1] + h)
        return t, np.column_stack([X[:, :i], x_end]), "stroke end", end

    def _held_rest(self, method, tol, steps, grid, X, last, counts, first=1):
        """The first output interval (up to sample ``last``) in which a self-locking drive brings
        the mechanism to rest and holds it: (j, h, state), the rest at t = grid[j-1] + h with
        ds/dt = 0 exactly, or None.  Past that instant the switch chatters: the integrator gives
        up, or (looser tolerances) steps on through it with |ds/dt| tiny; so examined are the
        intervals whose end sample has failed, reversed, or could have lost its speed within
        the interval (d sd_j <= |s''_j| dt, d the direction of motion at the interval's start);
        those from sample ``first`` on."""
        sdd = np.asarray(self.outputs.map(X.shape[1])(X, self.mech.parameter_values))[3]
        for j in range(first, last + 1):
            x_prev, dt = X[:, j - 1], grid[j] - grid[j - 1]
            d = float(np.sign(x_prev[1]))
            if d == 0 or d * X[1, j] > abs(sdd[j]) * dt:  # (False for a failed sample: NaN)
                continue
            rest = self._rest(method, tol, steps, x_prev, dt, d, counts)
            if rest is not None and self._held(rest[1], d, np.max(np.abs(X[1, :j]))):
                return (j, *rest)
        return None

    def _rest(self, method, tol, steps, x_prev, dt, d, counts):
        """(h, state): the instant in (0, dt] where ds/dt reaches 0 on the one-sided equation from
        x_prev moving in direction d (smooth up to and through the rest), or None."""
        F, scale = self._integrator(method, tol, [1.0], steps, one_sided=True)
        try:
            x_dt = self._call(F, scale, x_prev, dt, counts, method, d)[:, 0]
        except _IntegratorFailed:
            x_dt = np.full_like(x_prev, np.nan)
        if np.isfinite(x_dt).all() and d * x_dt[1] > 0:
            return None
        h, x = self._locate(method, tol, steps, x_prev, dt, 0.0, x_dt, counts, component=1, direction=d)
        if x is None:
            return None
        x = np.array(x, float)
        x[1] = 0.0
        return h, x

    def _held(self, x, d, speed_scale):
        """The drive holds the mechanism at rest in state x (ds/dt = 0), reached moving in
        direction d: either way out of rest decelerates back to it."""
        nudge = 1e-9 * speed_scale
        p = self.mech.parameter_values
        ahead, back = (float(self.outputs(np.r_[x[0], e * nudge, x[2:]], p)[3]) for e in (d, -d))
        return d * ahead < 0 and d * back > 0

    def _locate(self, method, tol, steps, x_prev, dt, target, x_next, counts, component=0, direction=None):
        """The time h in (0, dt] after which the state's ``component`` (0: s, 1: ds/dt) reaches
        ``target``, by re-integrating from x_prev (Illinois regula falsi where both ends are
        finite, bisection past a failure); with a ``direction`` on the one-sided equation."""
        F, scale = self._integrator(method, tol, [1.0], steps, one_sided=direction is not None)
        length = scale[component]  # the stroke length, or the reference rate

        def g(h):
            try:
                x = self._call(F, scale, x_prev, h, counts, method, direction)[:, 0]
            except _IntegratorFailed:
                return None, None
            return (x[component] - target if np.isfinite(x).all() else None), x

        a, ga, xa = 0.0, x_prev[component] - target, x_prev
        b, gb = dt, (x_next[component] - target if np.isfinite(x_next).all() else None)
        xb = x_next
        side = 0
        for _ in range(200):
            if gb is not None and ga != gb:
                c = b - gb * (b - a) / (gb - ga)
                if not a < c < b:
                    c = 0.5 * (a + b)
            else:
                c = 0.5 * (a + b)
            gc, xc = g(c)
            if gc is not None and abs(gc) <= 1e-13 * length:
                return c, xc
            if gc is not None and math.copysign(1, gc) == math.copysign(1, ga):
                a, ga, xa = c, gc, xc
                if side == -1 and gb is not None:
                    gb *= 0.5
                side = -1
            else:
                b, gb, xb = c, gc, xc
                if side == 1:
                    ga *= 0.5
                side = 1
            if b - a <= 1e-12 * dt:
                break
        if gb is not None and abs(gb) <= 1e-9 * length:
            return b, xb
        if abs(ga) <= 1e-9 * length:
            return a, xa
        return None, None

    def _rk4_error(self, tol, steps, t, X, stop, counts):
        """RK4's global error, estimated by Richardson from a run with half the steps over the
        same output times: err ~ max |x_N - x_{N/2}| / 15 (scaled states)."""
        m = len(t) if stop == "t_end" else len(t) - 1  # samples on the uniform grid
        scale = self._scales()
        cols = [self.x0]
        if m >= 2:
            F, _ = self._integrator("rk4", tol, t[1:m] / t[m - 1], (steps // 2) * (m - 1))
            cols += list(self._call(F, scale, self.x0, t[m - 1], counts, "rk4").T)
        if m < len(t):  # the stroke end or the rest, reached in a shorter last interval
            d = math.copysign(1.0, X[1, m - 1]) if stop == "stalled" else None  # the rest: one-sided
            F, _ = self._integrator("rk4", tol, [1.0], steps // 2, one_sided=d is not None)
            cols.append(self._call(F, scale, cols[-1], t[-1] - t[m - 1], counts, "rk4", d)[:, 0])
        diff = (X - np.column_stack(cols)) / scale[:, None]
        error = float(np.max(np.abs(diff))) / 15 if np.isfinite(diff).all() else math.inf
        if not error <= tol:
            need = steps * max(2.0, (error / tol) ** 0.25) if math.isfinite(error) else 10 * steps
            raise SolverError(
                f"{self.scene.path}: the rk4 integrator with {steps} steps per output sample is not accurate "
                f"enough: its estimated error {error:.3g} (relative to the stroke length and the reference "
                f"rate; from a run with half the steps) exceeds the tolerance {tol:.3g}. Use about "
                f"{math.ceil(need)} steps per sample (--steps), or the implicit integrator (bdf).")
        return error

    def _columns(self, X):
        f = self.outputs.map(X.shape[1])
        out = np.asarray(f(X, self.mech.parameter_values))
        cols = {"s": X[0].copy(), "sd": X[1].copy()}
        for i, name in enumerate(self.output_names):
            cols[name] = out[i].copy()
        return cols


class _IntegratorFailed(Exception):
    pass


class _Counts:
    """Integrator statistics summed over calls, in common names for CVODES and RK4."""

    def __init__(self):
        self.steps = self.rhs = self.error_fails = self.nonlinear = self.calls = 0

    def add(self, stats, method):
        self.calls += 1
        if method == "rk4":
            n = int(stats.get("n_call_step", 0))
            self.steps += n
            self.rhs += 4 * n
        else:
            self.steps += int(stats.get("nsteps", 0))
            self.rhs += int(stats.get("nfevals", 0))
            self.error_fails += int(stats.get("netfails", 0))
            self.nonlinear += int(stats.get("nniters", 0))

    def as_dict(self):
        return {"steps": self.steps, "rhs_evaluations": self.rhs, "error_test_failures": self.error_fails,
                "nonlinear_iterations": self.nonlinear, "integrator_calls": self.calls}


def _golden(f, a, b, iterations=80):
    """Minimum of f on [a, b] by golden-section search: (x, f(x))."""
    r = (math.sqrt(5) - 1) / 2
    c, d = b - r * (b - a), a + r * (b - a)
    fc, fd = f(c), f(d)
    for _ in range(iterations):
        if fc <= fd:
            b, d, fd = d, c, fc
            c = b - r * (b - a)
            fc = f(c)
        else:
            a, c, fc = c, d, fd
            d = a + r * (b - a)
            fd = f(d)
    x = 0.5 * (a + b)
    return x, f(x)


def simulate(scene: Scene, integrator: str | None = None, tolerance: float | None = None,
             steps: int | None = None, samples: int | None = None, t_end: float | None = None) -> SimulationResult:
    """The motion of ``scene`` in time under its ``[drive] law`` from its ``[simulation]`` start
    (front door).  ``integrator`` ('bdf', 'adams', 'rk4'), ``tolerance``, ``samples`` and
    ``t_end`` override the scene's; ``steps`` is RK4's steps per output sample."""
    return Simulator(scene).run(integrator, tolerance, steps, samples, t_end)
