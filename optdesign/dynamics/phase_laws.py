"""The drive law of one phase of a duty cycle in time (:mod:`.phases`), as a CasADi graph.

Behind a rotary drive with a [gearbox] of ratio i and a motor (rotor inertia J_r, peak torque
T_pk, maximum speed omega_max), the motor turns at omega_m = i qd and delivers the torque T_m;
the gearbox passes i T_m - J_r i^2 qdd on to the crank, divided by eta_g while the motor drives
(multiplied while power flows back), exactly as :mod:`optdesign.model.train` has it.  So the
equation of motion of :mod:`.equations` holds with the drive's torque i T_m, its inertia
J_r i^2 (+ [drive] inertia) and the efficiency eta_m eta_g (the two switch together: the power
flows one way through the gearbox and the crank).  The laws give T_m:

- ``law``: the expression, in parameters, q, qd and t (since the phase began);
- ``motor``: the speed-torque curve at full torque, T_m = d T_pk (1 - d omega_m / omega_max)
  (d = +1 forward, -1 reverse: the peak torque at standstill, none at the maximum speed);
- ``controller``: T_m = K (omega_m* - omega_m) saturated at +-T_pk, omega_m* = i k sd*(t)
  with sd*(t) the profile's sweep rate at the time since the phase began (:func:`profile_rate`),
  plus K_p (s*(t) - s) with a ``position_gain`` K_p [1/s] (s*(t): the profile's position,
  :func:`profile_distance`): a cascade of a position loop around the speed loop;
- ``brake``: T_m = -d0 B against the direction d0 of the motion at the phase's start.

Without a motor (``law`` and ``brake`` only) i = 1 and the torque is the drive's T_S.
"""
from __future__ import annotations

import casadi as ca

from ..scene.expressions import evaluate
from ..scene.profiles import Phase as ProfilePhase


def _phase_rate(tau, ph: ProfilePhase, speed):
    """The sweep speed tau after the start of a profile's phase from rest to ``speed``."""
    if ph.jerk == 0.0:
        return ph.peak * tau
    j, a = ph.jerk, ph.peak
    tj, tc = a / j, speed / a - a / j
    v1 = j * tj**2 / 2
    v2 = v1 + a * tc
    t3 = tau - tj - tc
    return ca.if_else(tau <= tj, j * tau**2 / 2, ca.if_else(tau <= tj + tc, v1 + a * (tau - tj),
                                                            v2 + a * t3 - j * t3**2 / 2))


def _phase_distance(tau, ph: ProfilePhase, speed):
    """The distance run tau after the start of a profile's phase from rest to ``speed``."""
    if ph.jerk == 0.0:
        return ph.peak * tau**2 / 2
    j, a = ph.jerk, ph.peak
    tj, tc = a / j, speed / a - a / j
    v1, x1 = j * tj**2 / 2, j * tj**3 / 6
    v2, x2 = v1 + a * tc, x1 + v1 * tc + a * tc**2 / 2
    t2, t3 = tau - tj, tau - tj - tc
    return ca.if_else(tau <= tj, j * tau**3 / 6, ca.if_else(tau <= tj + tc, x1 + v1 * t2 + a * t2**2 / 2,
                                                            x2 + v2 * t3 + a * t3**2 / 2 - j * t3**3 / 6))


def profile_distance(shape, t):
    """The distance x(t) run along a profile ``shape`` t after its start (0 before, its
    length after its end)."""
    T, L = shape.time, shape.length
    tt = ca.fmin(ca.fmax(t, 0.0), T)
    if shape.kind == "constant":
        return shape.speed * tt
    if shape.motion_law is not None:   # a law in time: L f(t/T)
        return L * shape.motion_law.derivatives(tt / T)[0]
    up, down, v = shape.accelerate, shape.decelerate, shape.speed
    return ca.if_else(tt <= up.duration, _phase_distance(tt, up, v),
                      ca.if_else(tt >= T - down.duration, L - _phase_distance(T - tt, down, v),
                                 up.distance + v * (tt - up.duration)))


def profile_rate(shape, t):
    """The sweep speed V(t) >= 0 of a profile ``shape`` (:class:`optdesign.scene.profiles.Shape`)
    t after its start: closed forms in time (0 before the start and after the end)."""
    T = shape.time
    tt = ca.fmin(ca.fmax(t, 0.0), T)
    if shape.kind == "constant":
        return ca.if_else(ca.logic_and(t >= 0, t <= T), shape.speed, 0.0)
    if shape.motion_law is not None:   # a law in time: L/T f'(t/T)
        return ca.if_else(ca.logic_and(t >= 0, t <= T), shape.length / T * shape.motion_law.derivatives(tt / T)[1], 0.0)
    up, down, v = shape.accelerate, shape.decelerate, shape.speed
    return ca.if_else(tt <= up.duration, _phase_rate(tt, up, v),
                      ca.if_else(tt >= T - down.duration, _phase_rate(T - tt, down, v), v))


def profile_kinks(shape) -> list:
    """The instants after its start where a profile ``shape``'s acceleration jumps (its
    phases' ends, an s-curve's jerk segments', a law's pieces'; a controller tracking it has
    a kink in its torque there), its end included."""
    T = shape.time
    if shape.motion_law is not None:
        return sorted({float(p.end) * T for p in shape.motion_law.pieces})
    out = {T}
    if shape.kind != "constant":
        for ph, mirrored in ((shape.accelerate, False), (shape.decelerate, True)):
            tj = ph.peak / ph.jerk if ph.jerk else 0.0
            for tau in (tj, ph.duration - tj, ph.duration):
                out.add(T - tau if mirrored else tau)
    return sorted(t for t in out if 0.0 < t <= T)


class PhaseLaw:
    """The torque law of one phase as a callable ``law(env)`` for :class:`.equations.Equations`
    (the torque at the drive, i T_m) and its motor torque ``motor_torque(env)``.  ``kind`` and
    ``setting`` as :class:`optdesign.scene.simulation.Phase`; ``motor``: the motor's numbers
    (None without one), ``ratio`` i (1 without a gearbox), ``target``: (sigma, Shape) of a
    controller's profile, ``direction``: d0 of a brake, ``mech``: for expressions."""

    def __init__(self, kind, setting, mech, motor=None, ratio=1.0, target=None, direction=1.0):
        self.kind, self.setting, self.mech = kind, setting, mech
        self.motor, self.ratio, self.target, self.direction = motor, ratio, target, direction

    def motor_torque(self, env):
        i, m = self.ratio, self.motor
        omega = i * env["qd"]
        if self.kind == "law":
            return evaluate(self.setting, env, self.mech.points, "[[simulation.phases]] law")
        if self.kind == "brake":
            return -self.direction * evaluate(self.setting, env, self.mech.points, "[[simulation.phases]] brake")
        if self.kind == "motor":
            d = 1.0 if self.setting == "forward" else -1.0
            return d * m["peak_torque"] * (1 - d * omega / m["max_speed"])
        sigma, shape, begin = self.target
        gain = evaluate(self.setting["gain"], env, {}, "[[simulation.phases]] controller.gain")
        rate = sigma * profile_rate(shape, env["t"])
        if self.setting.get("position_gain") is not None:  # the outer loop: the profile's position
            kp = evaluate(self.setting["position_gain"], env, {}, "[[simulation.phases]] controller.position_gain")
            rate = rate + kp * (begin + sigma * profile_distance(shape, env["t"]) - env["s"])
        wanted = i * env["k"] * rate
        limit = m["peak_torque"]
        return ca.fmin(ca.fmax(gain * (wanted - omega), -limit), limit)

    def __call__(self, env):
        return self.ratio * self.motor_torque(env)
