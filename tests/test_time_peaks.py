"""simulate's peaks in time located between its output samples, against a reference written here.

The servo press of problems/press_servo_cycle.toml at its sized design runs its duty cycle
(forming stroke on an s-curve, return stroke on a trapezoid, both tracked by the stiff speed
controller with a position loop; a dwell on the brake).  The reference is the press by hand:
the offset slider-crank's kinematics and virtual work (reduced inertia M(phi) and its
derivative by hand, the static load Q(phi) of gravity and the drawing force), the profiles' closed
forms in time, the controller T_m = clip(K i (sigma V + K_p (s* - phi) - phi'), +-T_pk), the
gearbox and crank efficiencies switched with the power flow, and

    (c M + J) phi'' = i T_m - c (1/2 M' phi'^2 + Q),   J = J_r i^2,

integrated by scipy's Radau at rtol 1e-12 piece by piece between the profiles' kinks, each
power-flow switch and reversal located as a terminal event, and every extreme of the motor
torque, the motor speed, the power and the transmitted torque located as an event on its
rate (d/dt along the motion), its state then integrated to that instant.  Nothing of
optdesign is used but the scene's numbers.
"""
from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import optdesign
from optdesign.dynamics.simulator import simulate
from optdesign.report.cycle import cycle_figures

PROBLEMS = Path(__file__).resolve().parent.parent / "problems"
SIZED = {"l": 0.4178431511311544, "e": -0.08, "i": 50.0}   # as tests/test_duty_simulation.py
H, MR, G_ACC, F0, D0, W = 0.10, 400.0, 9.81, 400e3, 0.015, 0.008
J_R, T_PK, K, KP = 0.04, 480.0, 2000.0, 100.0
ETA = 0.95 * 0.96
STROKE = 2 * math.pi / 3


def press_model(l, e):
    """M(phi), M'(phi), Q(phi, F0) of the offset slider-crank, its derivatives in phi by hand."""
    r = H / 2 * math.sqrt(1 - 4 * e**2 / (4 * l**2 - H**2))
    a_bdc = -math.pi / 2 + math.asin(e / (l + r))
    y_bdc = -math.sqrt((l + r) ** 2 - e**2)
    m_rod, i_rod = 150 * l, 150 * l * l**2 / 12

    @functools.lru_cache(maxsize=16)
    def kinematics(phi):
        """(value, d/dphi, d2/dphi2) of the ram's height y_C, the rod's centre (x_G, y_G) and
        the rod's direction A -> C (dx, dy)."""
        th = a_bdc + phi
        c, s = math.cos(th), math.sin(th)
        ax, ay = (r * c, -r * s, -r * c), (r * s, r * c, -r * s)
        u = (e - ax[0], -ax[1], -ax[2])                      # dx
        S = (l**2 - u[0] ** 2, -2 * u[0] * u[1], -2 * (u[1] ** 2 + u[0] * u[2]))
        w0 = math.sqrt(S[0])
        w = (w0, S[1] / (2 * w0), S[2] / (2 * w0) - S[1] ** 2 / (4 * w0**3))
        yc = tuple(a - b for a, b in zip(ay, w))
        gx = tuple(0.5 * a for a in ax)
        gy = tuple(0.5 * (a + b) for a, b in zip(ay, yc))
        dy = tuple(-b for b in w)
        return yc, gx, gy, u, dy

    @functools.lru_cache(maxsize=16)
    def M_and_dM(phi):
        yc, gx, gy, dx, dy = kinematics(phi)
        w = (dx[0] * dy[1] - dy[0] * dx[1]) / l**2           # the rod's rate of turn per unit phi
        dw = (dx[0] * dy[2] - dy[0] * dx[2]) / l**2
        M = MR * yc[1] ** 2 + m_rod * (gx[1] ** 2 + gy[1] ** 2) + i_rod * w**2
        dM = 2 * (MR * yc[1] * yc[2] + m_rod * (gx[1] * gx[2] + gy[1] * gy[2]) + i_rod * w * dw)
        return M, dM

    def Q(phi, f0):
        yc, _, gy, _, _ = kinematics(phi)
        force = f0 * math.exp(-(((yc[0] - y_bdc - D0) / W) ** 2))
        return G_ACC * (MR * yc[1] + m_rod * gy[1]) - force * yc[1]

    return (lambda phi: M_and_dM(phi)[0]), (lambda phi: M_and_dM(phi)[1]), Q


def profile(speed, accel, jerk):
    """(duration, kinks, V(tau), A(tau), X(tau)) of a rest-to-rest profile over STROKE: an
    s-curve (jerk) or a trapezoid (jerk None)."""
    tj = accel / jerk if jerk else 0.0
    ta = speed / accel + tj                       # the acceleration phase
    da = speed * ta / 2
    T = 2 * ta + (STROKE - 2 * da) / speed

    def up(tau):                                  # (V, A, X) tau into the acceleration phase
        if jerk and tau <= tj:
            return jerk * tau**2 / 2, jerk * tau, jerk * tau**3 / 6
        if tau <= ta - tj:
            v1, x1, u = jerk * tj**2 / 2 if jerk else 0.0, jerk * tj**3 / 6 if jerk else 0.0, tau - tj
            return v1 + accel * u, accel, x1 + v1 * u + accel * u**2 / 2
        u = ta - tau
        return speed - (jerk * u**2 / 2 if jerk else 0.0), jerk * u if jerk else 0.0, \
            da - (speed * u - (jerk * u**3 / 6 if jerk else 0.0))

    def at(tau):
        tau = min(max(tau, 0.0), T)
        if tau <= ta:
            return up(tau)
        if tau >= T - ta:
            v, a, x = up(T - tau)
            return v, -a, STROKE - x
        return speed, 0.0, da + speed * (tau - ta)

    kinks = sorted({tj, ta - tj, ta, T - ta, T - ta + tj, T - tj} - {0.0})
    return T, kinks, at


class Press:
    def __init__(self, l, e, i):
        self.M, self.dM, self.Q = press_model(l, e)
        self.i, self.J = i, J_R * i**2

    def torque(self, t, y, ph):
        v, _, x = ph["at"](t - ph["t0"])
        wanted = self.i * (ph["sigma"] * v + KP * (ph["begin"] + ph["sigma"] * x - y[0]))
        return min(max(K * (wanted - self.i * y[1]), -T_PK), T_PK)

    def terms(self, t, y, ph):
        Tm = self.torque(t, y, ph)
        load = 0.5 * self.dM(y[0]) * y[1] ** 2 + self.Q(y[0], ph["F0"])
        return Tm, load, self.M(y[0])

    def bracket(self, t, y, ph):   # the power into the mechanism has the sign of phi' times it
        Tm, load, M = self.terms(t, y, ph)
        return M * self.i * Tm + self.J * load

    def acceleration(self, t, y, ph, c):
        Tm, load, M = self.terms(t, y, ph)
        return (self.i * Tm - c * load) / (c * M + self.J)

    def columns(self, t, y, ph, c):
        Tm = self.torque(t, y, ph)
        return {"motor_torque": Tm, "motor_speed": self.i * y[1], "power": self.i * Tm * y[1],
                "transmitted": self.i * Tm - self.J * self.acceleration(t, y, ph, c)}


NAMES = ("motor_torque", "motor_speed", "power", "transmitted")
OPTS = {"method": "Radau", "rtol": 1e-12, "atol": 1e-12}


def run_phase(press, ph, y, extremes):
    """Integrate one phase from y; record every located extreme (name, t, value) in
    ``extremes``; the state at the phase's end."""
    t, end = ph["t0"], ph["t0"] + ph["T"]

    def choose(t, y):   # the branch: c from the directions of motion and of the power flow
        B = press.bracket(t, y, ph)
        for c in (1 / ETA, ETA):
            d = np.sign(y[1]) if y[1] != 0 else np.sign(press.acceleration(t, y, ph, c))
            if (d * B > 0) == (c > 1):
                return c, d, np.sign(B)
        return 1 / ETA, np.sign(y[1]), np.sign(B)

    c, d, side = choose(t, y)
    for stop in [ph["t0"] + k for k in ph["kinks"] if 0 < k < ph["T"]] + [end]:
        while t < stop * (1 - 1e-15):
            def rhs(t, y, c=c):
                return [y[1], press.acceleration(t, y, ph, c)]

            def power(t, y):
                return press.bracket(t, y, ph)

            def speed(t, y):
                return y[1]

            power.terminal, power.direction = True, -side
            speed.terminal, speed.direction = True, -d
            memo = {}

            def rates_at(t, y, c=c):   # d(column)/dt along the motion, central differences
                key = (t, y.tobytes())
                if key not in memo:
                    h, f = 1e-8, np.array(rhs(t, y))
                    ahead, behind = press.columns(t + h, y + h * f, ph, c), press.columns(t - h, y - h * f, ph, c)
                    memo.clear()
                    memo[key] = {n: (ahead[n] - behind[n]) / (2 * h) for n in NAMES}
                return memo[key]

            rates = [lambda t, y, name=name: rates_at(t, y)[name] for name in NAMES]
            sol = solve_ivp(rhs, (t, stop), y, events=[power, speed] + rates, **OPTS)
            steps = sol.t
            for k, name in enumerate(NAMES):
                for te in sol.t_events[2 + k]:
                    j = max(int(np.searchsorted(steps, te)) - 1, 0)   # the state at te, integrated to it
                    ye = solve_ivp(rhs, (steps[j], te), sol.y[:, j], **OPTS).y[:, -1] if te > steps[j] else sol.y[:, j]
                    extremes.append((name, float(te), press.columns(te, ye, ph, c)[name]))
            t, y = float(sol.t[-1]), sol.y[:, -1].copy()
            if sol.status == 1:
                if sol.t_events[0].size:
                    side = -side
                else:
                    d = -d
                    y[1] = 0.0
                c = 1 / ETA if d * side > 0 else ETA
        for name, value in press.columns(t, y, ph, c).items():   # the ends of each piece
            extremes.append((name, t, value))
    return y


def reference(strokes):
    """Every located extreme (name, t, value) of the cycle's first ``strokes`` strokes."""
    press = Press(**SIZED)
    forming, back = profile(4.0, 40.0, 1000.0), profile(6.0, 60.0, None)
    phases = [{"t0": 0.0, "T": forming[0], "kinks": forming[1], "at": forming[2], "sigma": 1.0, "begin": -STROKE,
               "F0": F0},
              {"t0": forming[0], "T": back[0], "kinks": back[1], "at": back[2], "sigma": -1.0, "begin": 0.0, "F0": 0.0}]
    extremes, y = [], np.array([-STROKE, 0.0])
    for ph in phases[:strokes]:
        y = run_phase(press, ph, y, extremes)
    if strokes == 2:   # the dwell: at rest on the brake, the motor idle
        extremes += [(name, math.nan, 0.0) for name in NAMES]
    return extremes


def simulated(strokes):
    """simulate's run of the cycle (the forming stroke alone for ``strokes`` = 1)."""
    path = PROBLEMS / "press_servo_cycle.toml"
    text = path.read_text()
    if strokes == 1:
        cut = text.index('[[simulation.phases]]\nname = "return stroke"')
        text = text[:cut] + text[text.index("[objective]"):]
    return simulate(optdesign.loads(text, str(path)).with_parameters(**SIZED), tolerance=1e-12)


def test_reference_inertia_derivative():
    M, dM, _ = press_model(SIZED["l"], SIZED["e"])
    for phi in np.linspace(-STROKE, 0.0, 7):
        h = 1e-5
        assert dM(phi) == pytest.approx((M(phi + h) - M(phi - h)) / (2 * h), rel=1e-7, abs=1e-9)


def check_peaks(result, extremes):
    """Each column's largest and smallest value over the run within 1e-6 of the reference's
    (relative to the column's peak |value|: the forming stroke's motor speed ends a hair below
    zero, -0.0098 rad/s, its overshoot at the end)."""
    cols = result.columns
    for name in NAMES:
        ref = [v for n, _, v in extremes if n == name]
        for sign in (1.0, -1.0):
            want = max(sign * v for v in ref)
            got = float(np.max(sign * cols[name]))
            assert got == pytest.approx(want, rel=1e-6, abs=1e-6 * max(map(abs, ref))), (name, sign, got, want)
    fig = cycle_figures(result)
    for key, name in (("peak_motor_torque", "motor_torque"), ("peak_motor_speed", "motor_speed")):
        assert fig[key] == pytest.approx(max(abs(v) for n, _, v in extremes if n == name), rel=1e-6), key


def test_forming_stroke_peaks_against_located_reference():
    check_peaks(simulated(1), reference(1))


@pytest.mark.slow
def test_cycle_peaks_against_located_reference():
    check_peaks(simulated(2), reference(2))
