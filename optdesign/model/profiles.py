"""A load case's motion along the stroke: the profile as CasADi graphs of the sweep value s,
the drive's speed and acceleration from it, and the time at each sample.

How a profile maps the stroke to time.  A case runs the sweep from one end of the stroke,
s_begin ([sweep] from for 'forward', to for 'reverse'), to the other, s_end.  With sigma =
sign(s_end - s_begin), the distance run is x = sigma (s - s_begin), from 0 to the stroke's
length L.  The profile gives the sweep speed V(x) >= 0 and the path acceleration A(x) = dV/dt
along the motion, and the time t(x) at which x is reached, each in closed form:

* constant:    V = v, A = 0, t = x / v;
* trapezoidal: V = sqrt(2 a x), A = a, t = sqrt(2 x / a) while speeding up (x < v^2/(2a));
  V = v, A = 0 at the top speed; mirrored with the deceleration d at the end;
* s-curve:     seven phases with jerk j: x = j t^3/6 while the acceleration builds up
  (t = cbrt(6 x / j)), a quadratic in t at constant acceleration, and a cubic while it falls
  back to zero (its root by the trigonometric formula); then the top speed and the mirror
  image with the deceleration;
* law:         V(s) as written (an expression of the sweep), A = sigma V dV/ds, and the time
  t(s) = integral of ds / V by tanh-sinh quadrature (exact to round-off, also where V = 0 at
  an end of the stroke), since a law has no closed-form time.

The sweep's rate and acceleration are then sd = sigma V and sdd = sigma A, and the drive's
(q(s), k = dq/ds): qd = k sd, qdd = k sdd + dk/ds sd^2, qd^2 = k^2 V^2 (a polynomial in x, so
the drive load stays smooth where V is a square root).  A case without a profile runs at the
constant [drive] speed and acceleration (mirrored for 'reverse'), as a scene without cases;
its time is t = |q(s) - q(s_begin)| / |speed|, defined only when the acceleration is 0.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..errors import SceneError
from ..scene.cases import Case, case_values
from ..scene.expressions import evaluate
from ..scene.profiles import Phase, Profile, Shape, profile_shape
from .vectorised import VectorisedSX

_TINY = 1e-300  # keeps square and cube roots away from 0, where their derivative is infinite


@dataclass(frozen=True)
class Motion:
    """The drive's motion in a load case, as expressions of (s, p): speed ``qd``, acceleration
    ``qdd``, ``qd2`` = qd^2 (smooth), and ``flow_speed`` (smooth, with the sign of qd, for the
    power-flow switch)."""

    qd: object
    qdd: object
    qd2: object
    flow_speed: object


def _root(x, power):
    return ca.power(ca.fmax(x, _TINY), power)


def _phase_graph(x, ph: Phase, speed):
    """(t, V, A) at distance x (0 <= x <= ph.distance) into a phase from rest to ``speed``."""
    if ph.jerk == 0.0:  # trapezoid: constant acceleration
        return ca.sqrt(2 * ca.fmax(x, 0.0) / ph.peak), _root(2 * ph.peak * x, 0.5), ph.peak + 0 * x
    j, a = ph.jerk, ph.peak
    tj = a / j                                   # building up the acceleration
    tc = speed / a - a / j                       # at constant acceleration
    x1, v1 = j * tj**3 / 6, j * tj**2 / 2
    x2 = x1 + v1 * tc + a * tc**2 / 2
    t1 = _root(6 * x / j, 1 / 3)
    tau = (-v1 + ca.sqrt(ca.fmax(v1**2 + 2 * a * (x - x1), 0.0))) / a
    # falling back to zero acceleration: sigma before the phase's end, j sigma^3/6 - v sigma + (X - x) = 0
    P, Q = -6 * speed / j, 6 * (ph.distance - x) / j
    arg = ca.fmin(ca.fmax(3 * Q / (2 * P) * math.sqrt(-3 / P), -1.0), 1.0)
    sigma = 2 * math.sqrt(-P / 3) * ca.cos(ca.acos(arg) / 3 - 2 * math.pi / 3)
    t3 = ph.duration - sigma
    t = ca.if_else(x <= x1, ca.power(6 * ca.fmax(x, 0.0) / j, 1 / 3), ca.if_else(x <= x2, tj + tau, t3))
    V = ca.if_else(x <= x1, j * t1**2 / 2, ca.if_else(x <= x2, v1 + a * tau, speed - j * sigma**2 / 2))
    A = ca.if_else(x <= x1, j * t1, ca.if_else(x <= x2, a, j * sigma))
    return t, V, A


def _phase_breaks(ph: Phase, speed):
    """Distances into a phase where its acceleration changes law (s-curve only)."""
    if ph.jerk == 0.0 or ph.distance == 0.0:
        return []
    j, a = ph.jerk, ph.peak
    tj, tc = a / j, speed / a - a / j
    x1, v1 = j * tj**3 / 6, j * tj**2 / 2
    return [x1, x1 + v1 * tc + a * tc**2 / 2]


class MotionProfile:
    """A profile on the stroke of one case: (sd, sdd, V^2, t) as CasADi graphs of s, and its
    times and breakpoints as numbers."""

    def __init__(self, profile: Profile, shape: Shape, s_begin: float, s_end: float, values: dict, sweep_name: str):
        self.profile, self.shape = profile, shape
        self.s_begin, self.s_end = float(s_begin), float(s_end)
        self.sigma = 1.0 if s_end > s_begin else -1.0
        self.length = abs(s_end - s_begin)
        self._time_function = None
        self._speed_function = None   # speed_function's, built on first use
        self.law_speed = None  # a law's V(s) as a numpy function, at the case's parameter values
        if shape.kind == "law":
            s = ca.SX.sym("s")
            env = dict(values, **{sweep_name: s})
            self.law_speed = _numpy_of(s, evaluate(shape.law, env, {}, str(profile.where("speed"))))

    @property
    def reference_speed(self) -> float:
        """A typical sweep speed: the top speed, or a law's largest on 201 points."""
        if self.shape.kind != "law":
            return float(self.shape.speed)
        return float(np.max(self.law_speed(np.linspace(self.s_begin, self.s_end, 201))))

    # --- graphs of s ---
    def graphs(self, s, law_value=None, time=None):
        """(sd, sdd, V^2, t) at sweep value ``s``; t is None for a law.  ``law_value(expr)``
        evaluates a law's speed expression in the caller's graph of s.  ``time``: for a law in
        time, the fraction tau of its duration as its own symbol, used in place of the law's
        inverse at s (the caller puts s = :meth:`sweep_at` (tau): every graph then smooth in
        tau, also at a rest, where tau(s) has an infinite derivative)."""
        sh, sigma = self.shape, self.sigma
        if sh.kind == "law":
            V = law_value(sh.law)
            dV = ca.jacobian(V, s)
            return sigma * V, V * dV, V**2, None
        x = ca.fmin(ca.fmax(sigma * (s - self.s_begin), 0.0), self.length)
        y = ca.fmin(ca.fmax(sigma * (self.s_end - s), 0.0), self.length)
        return self.along(x, y, time)

    def along(self, x, y, time=None):
        """(sd, sdd, V^2, t) at distance x from the motion's beginning and y = L - x before its
        end (both given, so that each is exact next to its own end); ``time``: :meth:`graphs`."""
        sh, sigma = self.shape, self.sigma
        if sh.kind == "constant":
            v = sh.speed
            return sigma * v + 0 * x, 0 * x, v**2 + 0 * x, x / v
        if sh.motion_law is not None:   # a law in time: tau = f^-1(x/L), t = T tau
            T, L = sh.time, self.length
            tau = sh.motion_law.inverse(x / L) if time is None else time
            _, speed, acceleration, _ = sh.motion_law.derivatives(tau)
            V = L / T * speed
            return sigma * V, sigma * L / T**2 * acceleration, V**2, T * tau
        up, down, v = sh.accelerate, sh.decelerate, sh.speed
        t_up, V_up, A_up = _phase_graph(x, up, v)
        t_dn, V_dn, A_dn = _phase_graph(y, down, v)
        t_cruise = up.duration + (x - up.distance) / v
        speeding, slowing = x <= up.distance, x >= self.length - down.distance
        t = ca.if_else(speeding, t_up, ca.if_else(slowing, sh.time - t_dn, t_cruise))
        V = ca.if_else(speeding, V_up, ca.if_else(slowing, V_dn, v))
        A = ca.if_else(speeding, A_up, ca.if_else(slowing, -A_dn, 0.0))
        if up.jerk == 0.0:  # V^2 as a polynomial: 2 a x, v^2, 2 d (L - x)
            V2 = ca.if_else(speeding, 2 * up.peak * x, ca.if_else(slowing, 2 * down.peak * y, v**2))
        else:
            V2 = V**2
        return sigma * V, sigma * A, V2, t

    def jerk(self, s, time=None):
        """The sweep's jerk at ``s`` along a law in time: sigma L/T^3 f^(3)(tau); ``time``: :meth:`graphs`."""
        sh = self.shape
        tau = self.tau_at(s) if time is None else time
        return self.sigma * self.length / sh.time**3 * sh.motion_law.derivatives(tau)[3]

    def tau_at(self, s):
        """A law in time's fraction tau of its duration at sweep value ``s``: its inverse (a CasADi graph)."""
        x = ca.fmin(ca.fmax(self.sigma * (s - self.s_begin), 0.0), self.length)
        return self.shape.motion_law.inverse(x / self.length)

    @property
    def in_time(self) -> bool:
        """A law in time (a motion law or segments): closed form in tau, its inverse not."""
        return self.shape.motion_law is not None

    def sweep_at(self, tau):
        """The sweep value at the fraction ``tau`` of a law in time's duration (a CasADi graph)."""
        return self.s_begin + self.sigma * self.length * self.shape.motion_law.derivatives(tau)[0]

    def motion(self, mech, law_value=None, time=None) -> Motion:
        """The drive's motion (:class:`Motion`) along this profile in ``mech``'s graphs; ``time``: :meth:`graphs`."""
        s = mech.s
        sd, sdd, V2, _ = self.graphs(s, law_value or (lambda e: mech.value(e, "[profiles] speed")), time)
        k = mech.ds(mech.q)
        dk = mech.ds(k)
        return Motion(k * sd, k * sdd + dk * V2, k**2 * V2, k * self.sigma * self.reference_speed)

    # --- numbers ---
    @property
    def duration(self) -> float:
        """The time for the stroke [s] (a law: by quadrature)."""
        if self.shape.kind != "law":
            return float(self.shape.time)
        return float(self.times(np.array([self.s_end]))[0])

    def breakpoints(self) -> np.ndarray:
        """Sweep values inside the stroke where the profile's acceleration law changes."""
        sh = self.shape
        if sh.motion_law is not None:   # a law in time: its acceleration is continuous, its pieces' ends are
            return np.array(getattr(sh.motion_law, "stops", ()), float)   # nodes; segments: the stops between them
        if sh.kind in ("law", "constant"):
            return np.zeros(0)
        xs = [sh.accelerate.distance, self.length - sh.decelerate.distance]
        xs += _phase_breaks(sh.accelerate, sh.speed)
        xs += [self.length - b for b in _phase_breaks(sh.decelerate, sh.speed)]
        xs = sorted({round(x, 15) for x in xs if 0 < x < self.length})
        return np.array([self.s_begin + self.sigma * x for x in xs])

    JERK_NODES = 16  # intervals per jerk segment of an s-curve (evenly spaced in time)

    def jerk_segments(self) -> list:
        """The s-curve's jerk segments as (s_lo, s_hi, interior nodes evenly spaced in time); a
        law in time: each of its pieces (smooth in time, not in s at a rest), LAW_NODES over
        the whole motion."""
        sh = self.shape
        if sh.motion_law is not None:
            return self._law_segments()
        if sh.kind != "s-curve":
            return []
        out = []
        for ph, sign_end in ((sh.accelerate, False), (sh.decelerate, True)):
            j, a, v = ph.jerk, ph.peak, sh.speed
            tj = a / j
            frac = np.arange(1, self.JERK_NODES) / self.JERK_NODES * tj
            x1 = j * tj**3 / 6
            first = [(0.0, x1, j * frac**3 / 6)]                      # from rest: x = j t^3/6
            last = [(ph.distance - (v * tj - j * tj**3 / 6), ph.distance,
                     ph.distance - (v * frac - j * frac**3 / 6))]      # to the top speed
            for lo, hi, inner in first + last:
                if sign_end:  # the deceleration: distances before the end of the motion
                    lo, hi, inner = self.length - hi, self.length - lo, self.length - inner
                s_lo, s_hi = sorted((self.s_begin + self.sigma * lo, self.s_begin + self.sigma * hi))
                out.append((s_lo, s_hi, self.s_begin + self.sigma * np.asarray(inner)))
        return out

    LAW_NODES = 96   # nodes evenly spaced in time over a law in time (segments: about this many per law)

    def law_nodes(self) -> np.ndarray:
        """A law in time's nodes, in the motion's order: each piece's ends and a multiple of 4
        intervals evenly spaced in time inside it (about LAW_NODES over the motion), so that
        Simpson's rule in time on them and on every other one pairs them within each piece."""
        return self.law_sweep(self._law_taus())

    def law_times(self) -> np.ndarray:
        """The times of :meth:`law_nodes` [s]."""
        return self.shape.time * self._law_taus()

    def _law_taus(self) -> np.ndarray:
        law = self.shape.motion_law
        edges = (0.0,) + law.breaks + (1.0,)
        per_law = self.LAW_NODES * max(1, len(getattr(law, "segments", ())))   # segments: about LAW_NODES each
        tau = [0.0]
        for a, b in zip(edges[:-1], edges[1:]):
            n = 4 * max(1, math.ceil(per_law * (b - a) / 4))
            tau += list(np.linspace(a, b, n + 1)[1:])
        return np.array(tau)

    def law_sweep(self, tau) -> np.ndarray:
        """The sweep value at the fractions ``tau`` of a law in time's duration; during a dwell
        of segments the stop's value exactly (where the case's graph has the rest)."""
        tau = np.asarray(tau, float)
        s = self.s_begin + self.sigma * self.shape.motion_law.evaluate(tau)[0] * self.length
        for a, b, stop in getattr(self.shape.motion_law, "rests", ()):
            s = np.where((tau >= a) & (tau <= b), stop, s)
        return s

    def _law_segments(self) -> list:
        s = self.law_nodes()
        return [(float(min(s[0], s[-1])), float(max(s[0], s[-1])), s[1:-1])]

    def times(self, s_values) -> np.ndarray:
        """The time at each sweep value (at s_begin: 0)."""
        s_values = np.asarray(s_values, float)
        if self.shape.kind != "law":
            if self._time_function is None:
                s = ca.SX.sym("s")
                self._time_function = _numpy_of(s, self.graphs(s)[3])
            return self._time_function(s_values)
        x = np.unique(np.r_[0.0, np.clip(self.sigma * (s_values - self.s_begin), 0.0, self.length), self.length])
        s_nodes = self.s_begin + self.sigma * x
        pieces = tanh_sinh(lambda s, d_a, d_b: 1.0 / self.law_speed(s.ravel()).reshape(s.shape),
                           np.minimum(s_nodes[:-1], s_nodes[1:]), np.maximum(s_nodes[:-1], s_nodes[1:]))
        return np.interp(self.sigma * (s_values - self.s_begin), x, np.r_[0.0, np.cumsum(pieces)])


def _numpy_of(s, expr):
    """A numpy function of s (any shape) evaluating the SX expression ``expr`` of ``s``."""
    f = VectorisedSX(ca.Function("f", [s, ca.SX.sym("p", 0)], [expr], ["s", "p"], ["v"]))

    def run(x):
        x = np.asarray(x, float)
        return np.broadcast_to(f(x.ravel(), np.zeros(0))["v"], (x.size,)).reshape(x.shape).copy()
    return run


def speed_function(profile):
    """V(x, y) of a profile, vectorised with numpy (x, y: arrays of one shape, the distances
    from the motion's beginning and to its end; the smaller one is used exactly, except by a
    law, a function of the sweep value itself).  Built once per profile (its graph and program
    took 2-6 ms, asked for by the duty cycle and the integrals in time in every run)."""
    if profile._speed_function is None:
        profile._speed_function = _speed_function(profile)
    return profile._speed_function


def _speed_function(profile):
    if profile.law_speed is not None:
        def law(a, b):
            a, b = np.asarray(a, float), np.asarray(b, float)
            s = np.where(a <= b, profile.s_begin + profile.sigma * a, profile.s_end - profile.sigma * b)
            return profile.law_speed(s)
        return law
    z, L = ca.SX.sym("z"), profile.length
    # one input: z = x in the first half of the motion, z = -y in the second
    x, y = ca.if_else(z >= 0, z, L + z), ca.if_else(z >= 0, L - z, -z)
    f = VectorisedSX(ca.Function("V", [z, ca.SX.sym("p", 0)], [ca.fabs(profile.along(x, y)[0])], ["z", "p"], ["V"]))

    def speed(a, b):
        a, b = np.asarray(a, float), np.asarray(b, float)
        zz = np.where(a <= b, a, -b).ravel()
        return np.broadcast_to(f(zz, np.zeros(0))["V"], zz.shape).reshape(a.shape)
    return speed


def tanh_sinh(f, a, b, h=1 / 16, levels=48):
    """Integrals of ``f`` over the intervals [a_i, b_i] by tanh-sinh quadrature (double
    exponential: exact to round-off for smooth f, and for integrable singularities such as
    1/sqrt(x) at the ends).  ``f(s, d_a, d_b)`` takes the nodes (intervals x nodes) and their
    distances from a and from b, each exact next to its own end (where a singular integrand
    needs it); the nodes themselves may round onto an end."""
    a, b = np.atleast_1d(np.asarray(a, float)), np.atleast_1d(np.asarray(b, float))
    k = np.arange(-levels, levels + 1) * h
    u = 0.5 * math.pi * np.sinh(k)
    w = 0.5 * math.pi * h * np.cosh(k) / np.cosh(u) ** 2
    half = 0.5 * (b - a)
    from_a = half[:, None] * (2.0 / (1.0 + np.exp(-2.0 * u)))[None, :]     # (1 + tanh u) half
    from_b = half[:, None] * (2.0 / (1.0 + np.exp(2.0 * u)))[None, :]      # (1 - tanh u) half
    near_a = (u <= 0)[None, :]
    d_a = np.where(near_a, from_a, 2 * half[:, None] - from_b)
    d_b = np.where(near_a, 2 * half[:, None] - from_a, from_b)
    s = np.where(near_a, a[:, None] + d_a, b[:, None] - d_b)
    with np.errstate(all="ignore"):
        values = np.asarray(f(s, d_a, d_b), float).reshape(s.shape)
    values = np.where(np.isfinite(values), values, 0.0)
    return half * (values @ w)


def case_profile(scene, case: Case, start: float, stop: float, values=None) -> MotionProfile | None:
    """The :class:`MotionProfile` of ``case`` on the stroke [start, stop] (None without a
    profile), its numbers evaluated with the case's parameters."""
    if case.profile is None:
        return None
    profile = case.profile if isinstance(case.profile, Profile) else next(
        p for p in scene.profiles if p.name == case.profile)
    values = case_values(scene, case, values)
    begin, end = (start, stop) if case.sign > 0 else (stop, start)
    shape = profile_shape(profile, values, abs(stop - start), f" (with the parameters of case {case.name!r})", (begin, end))
    return MotionProfile(profile, shape, begin, end, values, scene.sweep.name)


def constant_motion(mech, case: Case) -> Motion:
    """The [drive] speed and acceleration as a case's motion ('reverse' mirrors both)."""
    drive = mech.scene.drive
    qd = case.sign * mech.value(drive.speed, "[drive] speed")
    qdd = case.sign * mech.value(drive.acceleration, "[drive] acceleration")
    return Motion(qd, qdd, qd**2, qd)


def check_law(profile: MotionProfile, s_values, speed_values, case_name, path=None):
    """A law's speed must be finite, >= 0, and > 0 inside the stroke, and where it is 0 at an
    end, reach it no faster than a square root (a finite time); ``path``: the scene file's."""
    from ..scene.where import fail
    v = np.asarray(speed_values, float)
    inside = (s_values != profile.s_begin) & (s_values != profile.s_end)
    bad = np.flatnonzero(~np.isfinite(v) | (v < 0) | (inside & (v <= 0)))
    if bad.size:
        i = bad[0]
        fail(profile.profile.where("speed"), f"the law's speed is {v[i]:.6g} at s = {s_values[i]:.6g} "
                         f"(case {case_name!r}); expected a speed > 0 inside the stroke (0 is allowed only at its ends)", path=path)
    # at an end where the speed is 0 the time to leave or reach it, the integral of dx / V(x), is
    # finite only where V falls more slowly than the distance x (a trapezoid's V = sqrt(2 a x));
    # V ~ x (1.2*sin(2*theta) at theta = 0 and 90 deg) never gets there: its quadrature gave 26.7 s
    scale = max(float(np.max(np.abs(v))), 1e-300)
    for end, inward in ((profile.s_begin, profile.sigma), (profile.s_end, -profile.sigma)):
        with np.errstate(all="ignore"):
            v0, v1, v2 = (float(profile.law_speed(np.array([end + inward * f * profile.length]))[0])
                          for f in (0.0, 1e-5, 1e-7))
        if not (abs(v0) <= 1e-9 * scale and v1 > 0 and v2 > 0):
            continue
        power = math.log(v1 / v2) / math.log(100.0)
        if power >= 0.95:
            fail(profile.profile.where("speed"),
                f"the law's speed falls to 0 at s = {end:.6g} (case {case_name!r}) "
                f"as the distance to it does (V ~ x^{power:.2f}): the motion would take forever to leave or reach "
                "that end; let the speed fall no faster than a square root of the distance there (a start-up "
                "like a trapezoid's, V = sqrt(2 a x)), or keep it above 0 at the stroke's ends", path=path)
