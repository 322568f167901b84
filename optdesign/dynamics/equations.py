"""The equation of motion of seed 1 ("motion from drive", eqs. 17, 38), compiled once per scene.

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
inertia vanishes is reported as a :class:`~optdesign.errors.DeadCentreError` before integrating
(:func:`check_inertia`).

**Efficiency.**  c = 1/eta while power flows into the mechanism (T_S qd > 0), eta while it flows
back, as in :class:`~optdesign.model.reduction.ReducedModel` (an exact switch).  With drive inertia
T_S depends on the acceleration, but the sign of T_S qd does not depend on c: solving the
equation above for either c gives T_S k = c B / (c M_s + J_d k^2) with the bracket
B = M_s (k T_m - J_d k k' sd^2) + J_d k^2 (1/2 M_s' sd^2 + Q_s), so T_S qd has the sign of sd B
and the direction of power flow, and with it c, is unique at every state.  On each branch (c
fixed) the equation is smooth; a branch ends where

- the speed passes through zero (the power's direction follows the direction of motion: with
  eta < 1 the acceleration jumps there), or
- B passes through zero at nonzero speed (the power-flow switch: there both branches give the
  same acceleration, sdd = -(1/2 M_s' sd^2 + Q_s)/M_s, and its rate jumps).

:mod:`.events` integrates one branch at a time, locates where it ends and restarts on the new
branch; at a rest the one-sided accelerations (``rest``: each direction of motion with the c of
its own power direction) decide whether the mechanism moves off, and which way, or is held by a
self-locking drive.
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

from ..errors import DeadCentreError, ResultError, SceneError
from ..kinematics.mechanism import _fmt_s
from ..scene.expressions import evaluate

PEAKED = ("drive", "qd", "power", "transmitted")  # the columns whose peaks in time are located


class Equations:
    """The compiled equation of motion of one scene.  The state x is (s, sd), and for a rotary
    drive also the continuous crank angle q (``n_x`` components); ``p`` the parameter values.

    - ``rhs_branch`` (state parts, p, c -> dx/dt): the equation on one branch of the efficiency
      switch, c = 1/eta or eta given (1 without efficiency): smooth, what the integrators see;
    - ``indicators`` (x, p, c -> columns): what :mod:`.events` watches, ``INDICATORS`` in order:
      s, sd, sdd (on branch c), the power-direction bracket (T_S qd has the sign of sd times it),
      its rate on branch c and its size (the sum of its terms' magnitudes, for round-off);
      ``power`` (x, p -> bracket, size): the part of it watched at every point (no rates);
    - ``rest`` (x, p -> sdd+, c+, sdd-, c-, size): the one-sided accelerations at rest (sd = 0)
      for motion starting forward (+) and backward (-), each with the c of its power direction,
      and the size of the terms (for round-off);
    - ``outputs`` (x, p, c, held -> the result's columns, names in ``output_names``); held = 1 is
      a rest the drive holds (no acceleration);
    - ``inertia_check`` (s, p -> total inertia M_s + J_d k^2, k); ``eta`` (p -> eta).
    """

    INDICATORS = ("s", "sd", "sdd", "bracket", "bracket_rate", "bracket_size")

    def __init__(self, mech, model, drive, law=None, inertia=None, eta=None, timed=False, quadratures=None):
        """``law``, ``inertia`` and ``eta`` replace the drive's law, its inertia and the
        efficiency (:mod:`.phases`: a phase's law through the gearbox): ``law(env)`` gives the
        torque at the drive from ``env`` (the mechanism's names, ``q``, ``qd``, ``t``, ``sd``,
        ``k``).  ``timed`` adds the time t (rate 1) to the state, ``quadratures`` (name ->
        integrand(env)) their integrals over time (``env`` then also has ``sdd``, ``qdd``, ``c``)."""
        self.mech = mech
        self._mapped = {}
        self.rotary = model.rotary
        self.uses_efficiency = model.uses_efficiency or eta is not None
        sym, s, p = mech.sym, mech.s, mech.p
        k, dk = model.k, model.dk
        sd = sym.sym("sd")
        M_s = model.M_s if model.has_inertia else 0
        dM_s = mech.ds(M_s) if model.has_inertia else 0
        Q_s = model.Q_s if model.has_static else 0
        if model.forces.damping_s is not None:  # dampers ([[forces]]): Q_s = D_s sd at the state's own speed
            Q_s = Q_s + model.forces.damping_s * sd
        if inertia is not None:
            J = inertia
        else:
            J = mech.value(drive.inertia, "[drive] inertia") if drive.inertia is not None else 0
        qd = k * sd
        # the rotary drive's angle is an atan2 (wrapped): the law sees the continuous angle,
        # carried as a third state q' = k sd
        q_state = sym.sym("q") if self.rotary else None
        t_state = sym.sym("t") if timed else None
        quadratures = quadratures or {}
        quad_states = [sym.sym(f"quad_{i}") for i in range(len(quadratures))]
        self.quadrature_names = list(quadratures)
        q = q_state if self.rotary else mech.q
        env = dict(mech.env, q=q, qd=qd)
        if law is not None:
            T_m = law(dict(env, t=t_state if timed else 0, sd=sd, k=k, s=s))
        else:
            T_m = evaluate(drive.law, env, mech.points, "[drive] law")
        V = 0.5 * dM_s * sd**2  # velocity term in s: -dT_S referred to s
        rest = k * T_m - J * k * dk * sd**2
        # T_S qd = sd * bracket / (c M_s + J k^2): the sign of the power flow, independent of c
        bracket = M_s * rest + J * k**2 * (V + Q_s)
        size = ca.fabs(M_s * k * T_m) + ca.fabs(M_s * J * k * dk * sd**2) + ca.fabs(J * k**2 * V) \
            + ca.fabs(J * k**2 * Q_s)
        bracket, size = bracket + 0 * s, size + 0 * s
        if eta is None:
            eta = model.eta if model.uses_efficiency else 1.0
        self.eta = ca.Function("eta", [p], [sym(eta) if isinstance(eta, (int, float)) else eta])

        def acceleration(c):
            return (rest - c * (V + Q_s)) / (c * M_s + J * k**2)

        c = sym.sym("c")
        sdd = acceleration(c)
        qdd = k * sdd + dk * sd**2
        # Functions of the state's parts (an MX state cannot be a vertcat of symbols)
        states = ([s, sd, q_state] if self.rotary else [s, sd]) + ([t_state] if timed else []) + quad_states
        self.n_x = len(states)
        self.timed = timed
        quad_env = dict(env, t=t_state if timed else 0, sd=sd, k=k, s=s, sdd=sdd, qdd=qdd, c=c, drive=T_m)
        quad_rates = [f(quad_env) + 0 * s for f in quadratures.values()]

        def rate(sdd):
            return ca.vertcat(sd, sdd, *([qd] if self.rotary else []), *([1 + 0 * s] if timed else []), *quad_rates)

        self.rhs_branch = self._function("rhs_branch", states + [p, c], [rate(sdd)])
        xs = sym.sym("x", self.n_x)
        parts = [xs[i] for i in range(self.n_x)]
        # the bracket's rate along the motion on branch c (AD: d/dt = sd d/ds + sdd d/dsd + qd d/dq)
        bracket_rate = ca.jacobian(bracket, s) * sd + ca.jacobian(bracket, sd) * sdd
        if self.rotary:
            bracket_rate = bracket_rate + ca.jacobian(bracket, q_state) * qd
        if timed:
            bracket_rate = bracket_rate + ca.jacobian(bracket, t_state)
        inds = self._function("indicators", states + [p, c], [ca.vertcat(s, sd, sdd, bracket, bracket_rate, size)])
        self.indicators = self._function("indicators", [xs, p, c], [inds(*parts, p, c)])
        power = self._function("power", states + [p], [ca.vertcat(bracket, size)])
        self.power = self._function("power", [xs, p], [power(*parts, p)])
        # at rest: the one-sided accelerations, each on the branch of its own power direction
        at_rest = [xs[0], 0] + [xs[i] for i in range(2, self.n_x)]
        c_plus = ca.if_else(bracket >= 0, 1 / eta, eta) if self.uses_efficiency else 1.0
        c_minus = ca.if_else(-bracket >= 0, 1 / eta, eta) if self.uses_efficiency else 1.0
        scale = (ca.fabs(rest) + ca.fabs(V + Q_s) / eta) / (eta * M_s + J * k**2)  # eta <= 1
        rest_f = self._function("rest", states + [p], [ca.vertcat(acceleration(c_plus), c_plus, acceleration(c_minus),
                                                              c_minus, scale)])
        self.rest = self._function("rest", [xs, p], [rest_f(*at_rest, p)])
        held = sym.sym("held")
        sdd_out = (1 - held) * sdd
        qdd_out = k * sdd_out + dk * sd**2
        outs = {"q": q, "qd": qd, "qdd": qdd_out, "sdd": sdd_out, "drive": T_m, "transmitted": T_m - J * qdd_out,
                "kinetic_energy": 0.5 * M_s * sd**2 + 0.5 * J * qd**2, "power": T_m * qd}
        if self.uses_efficiency:
            outs["efficiency_factor"] = c
        self.output_names = list(outs)
        f = self._function("outputs", states + [p, c, held], [ca.vertcat(*[o + 0 * s for o in outs.values()])])
        self.outputs = self._function("outputs", [xs, p, c, held], [f(*parts, p, c, held)])
        # the peaked columns and their rates along the motion on branch c (AD, as the bracket's):
        # what :mod:`.time_peaks` locates the peaks in time with
        moving = {"drive": T_m, "qd": qd, "power": T_m * qd, "transmitted": T_m - J * qdd}
        peaked = ca.vertcat(*[moving[n] + 0 * s for n in PEAKED])
        flow = rate(sdd)
        peaked_rate = sum((ca.jacobian(peaked, st) * flow[i] for i, st in enumerate(states)),
                          ca.DM.zeros(len(PEAKED)))
        f = self._function("peaked", states + [p, c], [peaked, peaked_rate])
        self.peaked = self._function("peaked", [xs, p, c], list(f(*parts, p, c)))
        self.inertia_check = self._function("inertia", [s, p], [M_s + J * k**2 + 0 * s, k + 0 * s])

    def _function(self, name, inputs, outputs):
        """A CasADi Function; SX graphs with common subexpressions eliminated (the four-bar's
        indicators: 3,230 -> 1,101 instructions, same numbers)."""
        opts = {"cse": True} if self.mech.sym is ca.SX else {}
        return ca.Function(name, inputs, outputs, opts)

    def mapped(self, name, n):
        """The Function ``name`` (e.g. 'indicators') mapped over n columns, compiled once."""
        key = (name, n)
        f = self._mapped.get(key)
        if f is None:
            f = self._mapped[key] = getattr(self, name).map(n)
        return f

    def output(self, name, x, p, c=1.0, held=0.0):
        """One output (e.g. 'sdd', 'qd') at the state x on branch c."""
        return float(self.outputs(x, p, c, held)[self.output_names.index(name)])

    def columns(self, X, p, c, held):
        """The result's columns over the states X (columns), each on its branch c (a row) and
        held (1) or not (0): s, sd and every output."""
        out = np.asarray(self.outputs.map(X.shape[1])(X, p, np.asarray(c, float)[None, :], np.asarray(held, float)[None, :]))
        cols = {"s": X[0].copy(), "sd": X[1].copy()}
        for i, name in enumerate(self.output_names):
            cols[name] = out[i].copy()
        return cols


def check_inertia(eq, scene, stroke_grid, p):
    """The equation is singular where M_s + J_d k^2 vanishes (no mass moves and the drive has
    no inertia of its own): find the smallest value over the stroke, refined between samples."""
    f = eq.inertia_check.map(len(stroke_grid))
    v = np.asarray(f(stroke_grid[None, :], p)[0]).ravel()
    bad = np.flatnonzero(~np.isfinite(v))
    if bad.size:   # NaN/inf: name the scene's first item that is not finite there (model/finite.py)
        from types import SimpleNamespace

        from ..model.finite import cause

        i = int(bad[0])
        raise ResultError(
            f"{scene.path}: the reduced inertia (M_s + J_d k^2) is {'NaN' if np.isnan(v[i]) else 'infinite'} at "
            f"{scene.sweep.name} = {_fmt_s(stroke_grid[i], scene)} (sample {i + 1} of {len(v)} of the stroke)"
            + cause(SimpleNamespace(mech=eq.mech, scene=scene), stroke_grid[i], p))
    top = float(np.max(v)) if v.size else 0.0
    where = stroke_grid[int(np.argmin(v))]
    low = float(np.min(v))
    i = int(np.argmin(v))
    if 0 < i < len(v) - 1:  # golden-section refinement of the smallest sample's neighbourhood
        where, low = _golden(lambda x: float(eq.inertia_check(x, p)[0]), stroke_grid[i - 1], stroke_grid[i + 1])
    if not top > 0 or low <= 1e-12 * top:
        name, unit = scene.sweep.name, "kg m^2 (rotor)" if eq.rotary else "kg (moving piston and rod)"
        raise DeadCentreError(
            f"{scene.path}: [drive] the reduced inertia vanishes at {name} = {_fmt_s(where, scene)} "
            f"(smallest M_s + J_d k^2 = {low:.3g}, largest {top:.3g}): no mass moves with the drive "
            "there, so any drive torque or force gives an infinite acceleration (a dead centre of the "
            f"one-element model). Give the drive its own inertia ([drive] inertia, {unit}), or "
            "narrow the sweep to exclude it.")


def initial_state(eq, scene, s0, qd0, p):
    """The state at t = 0 from the sweep value s0 and the drive speed qd0 (sd0 = qd0 / k; for a
    rotary drive also the crank angle, unwrapped from 0)."""
    k0 = float(eq.inertia_check(s0, p)[1])
    if abs(k0) < 1e-12:
        if qd0 != 0:
            raise DeadCentreError(
                f"{scene.path}: [simulation] start: {scene.sweep.name} = {_fmt_s(s0, scene)} is a dead "
                f"centre of the drive (dq/d{scene.sweep.name} = 0), where the drive cannot have the "
                f"speed {qd0:g}; start elsewhere or with speed = 0")
        sd0 = 0.0
    else:
        sd0 = qd0 / k0
    x0 = [s0, sd0]
    if eq.rotary:
        q_of = ca.Function("q", [eq.mech.s, eq.mech.p], [eq.mech.q])
        x0.append(float(np.unwrap([0.0, float(q_of(s0, p))])[1]))
    x0 = np.array(x0)
    if not hasattr(eq, "output"):   # a duty cycle's phases check each phase's law (dynamics/phases.py)
        return x0
    law = eq.output("drive", x0, p)
    if not math.isfinite(law):   # e.g. 1/qd from rest: the motion could never start
        raise SceneError(
            f"{scene.path}: [drive] law = {scene.drive.law.source!r} is {'NaN' if math.isnan(law) else 'infinite'} at "
            f"the start ({scene.sweep.name} = {_fmt_s(s0, scene)}, q = {eq.output('q', x0, p):.6g}, qd = {qd0:g}): the "
            "law must be finite at every state the motion reaches; guard a division (e.g. by qd) or start "
            "with another [simulation] speed")
    return x0


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
