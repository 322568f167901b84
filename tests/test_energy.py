"""Energy: the free motion (no loads, eta = 1, no drive torque) keeps its kinetic energy to the
integrator's tolerance, and with loads the kinetic energy changes by the work done.  Kinetic
energies and works are computed here from hand-written positions of the mechanisms, not by
the code under test."""
import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

import optdesign
from optdesign.dynamics.simulator import simulate

PROBLEMS = Path(__file__).resolve().parent.parent / "problems"


# --- rotary: the slider-crank (crank pin straight down at alpha = 0, piston above S) ---
def slider_crank_energy(alpha, omega, r=0.1, l=0.35, m=12.0, J=0.0):
    sa, ca = np.sin(alpha), np.cos(alpha)
    dy = r * sa - r**2 * sa * ca / np.sqrt(l**2 - r**2 * sa**2)   # dy_C/dalpha
    return 0.5 * m * (dy * omega) ** 2 + 0.5 * J * omega**2


@pytest.mark.parametrize("integrator,rotor", [("bdf", "I_peak"), ("bdf", "1e-2*I_peak"), ("adams", "1e-2*I_peak"),
                                             ("rk4", "I_peak")])
def test_free_slider_crank_keeps_its_energy(integrator, rotor):
    """No motor torque (T0 = 0): 1/2 (m v_C^2 + J omega^2) stays constant over two turns through
    four dead centres to within the accumulated local error: measured at tolerance 1e-10, bdf
    8.0e-8 (1,905 steps) with a rotor of the piston's peak reduced inertia (speed ratio 1.4) and
    7.4e-7 (4,542 steps) with 1e-2 of it (the crank speeds up 3.8x through each dead centre);
    adams 2.2e-7 (2,582 steps); rk4 (fixed step) 1.0e-12.  (Before the stroke end was located by
    Newton steps on dense output, the same drifts took 2.5 to 3.2 times the steps, the location's
    re-integrations included.)"""
    scene = optdesign.load(PROBLEMS / "sim_slider_crank.toml", {"T0": 0.0, "J_rotor": rotor})
    tol = 1e-10
    res = simulate(scene, integrator=integrator, tolerance=tol, t_end=1.0,
                   steps=200 if integrator == "rk4" else None)
    J = scene.parameter_values()["J_rotor"]
    E = slider_crank_energy(res.s, res.sd, J=J)
    assert res.stop == "stroke end" and res.s[-1] == pytest.approx(4.5 * math.pi, rel=1e-14)
    drift = np.max(np.abs(E - E[0])) / E[0]
    assert drift < 1e-6 if integrator != "rk4" else drift < 1e-11
    assert np.max(np.abs(res.kinetic_energy - E)) / E[0] < 1e-12   # the reported one is the same


# --- linear: the jib of seed 1, section 3.5, cylinder with a moving rod mass ---
PSI = math.radians(-60)


def jib_geometry(theta, e=1.6, b=2.4, psi=PSI):
    """x = |DB| with B = b (cos theta, sin theta), D = e (cos psi, sin psi), and dx/dtheta."""
    x = np.sqrt(b**2 + e**2 - 2 * b * e * np.cos(theta - psi))
    return x, b * e * np.sin(theta - psi) / x


def jib_energy(theta, theta_d, mC=500.0, l=4.0, m_rod=60.0):
    _, dx = jib_geometry(theta)
    return 0.5 * mC * (l * theta_d) ** 2 + 0.5 * m_rod * (dx * theta_d) ** 2


@pytest.mark.parametrize("integrator", ["bdf", "adams"])
def test_free_jib_keeps_its_energy(integrator):
    """No weight (g = 0), no cylinder force (F = 0): the jib coasts from v_S = 0.05 m/s and its
    kinetic energy 1/2 mC (l theta')^2 + 1/2 m_rod x'^2 stays constant to 1e-8 relative."""
    scene = optdesign.load(PROBLEMS / "sim_jib.toml", {"g": 0.0, "F": 0.0})
    res = simulate(scene, integrator=integrator, tolerance=1e-10)
    E = jib_energy(res.s, res.sd)
    assert np.max(np.abs(E - E[0])) / E[0] < 1e-8
    assert res.qd[0] == pytest.approx(0.05, rel=1e-14)


def test_jib_work_energy_identity():
    """With weight and a constant cylinder force: KE(t) - KE(0) = F (x - x0) - mC g (y_C - y_C0),
    y_C = l sin theta (the work of F along the cylinder and of the weight), to 1e-8 of F (x - x0)."""
    scene = optdesign.load(PROBLEMS / "sim_jib.toml")
    res = simulate(scene, tolerance=1e-11)
    F, mC, g, l = 14000.0, 500.0, 9.81, 4.0
    x, _ = jib_geometry(res.s)
    E = jib_energy(res.s, res.sd)
    work = F * (x - x[0]) - mC * g * l * (np.sin(res.s) - np.sin(res.s[0]))
    assert res.stop == "stroke end" and res.stop_end == "to" and x[-1] == pytest.approx(3.2, rel=1e-9)
    assert np.max(np.abs(E - E[0] - work)) < 1e-8 * F * (x[-1] - x[0])
    assert np.max(np.abs(res.q - x)) < 1e-12                       # the cylinder length


def test_slider_crank_work_energy_with_gas_force_and_constant_torque():
    """Constant torque T and gas force FC down on the piston: KE change = T (alpha - alpha0)
    - FC (y_C - y_C0), to 1e-8 of T times the angle turned."""
    base = optdesign.load(PROBLEMS / "sim_slider_crank.toml", {"FC": 1500.0, "J_rotor": 0.02})
    scene = dataclasses.replace(base, drive=dataclasses.replace(base.drive, law="300"))
    res = simulate(scene, tolerance=1e-11)
    r, l, FC, T = 0.1, 0.35, 1500.0, 300.0
    a = res.s
    y = -r * np.cos(a) + np.sqrt(l**2 - (r * np.sin(a)) ** 2)
    E = slider_crank_energy(a, res.sd, J=0.02)
    work = T * (a - a[0]) - FC * (y - y[0])
    assert np.max(np.abs(E - E[0] - work)) < 1e-8 * T * (a[-1] - a[0])


def test_jib_with_efficiency_loses_one_minus_eta_of_the_transmitted_work():
    """eta = 0.9 while the cylinder lifts (power into the mechanism throughout): the mechanism
    gets eta of the work passed on by the rod, so KE_jib change + mC g (y_C - y_C0)
    = eta (F (x - x0) - KE_rod change), all from hand-written positions; to 1e-8 of F (x - x0)."""
    text = (PROBLEMS / "sim_jib.toml").read_text().replace('inertia = "m_rod"', 'inertia = "m_rod"\nefficiency = 0.9')
    res = simulate(optdesign.loads(text, "jib_eta.toml").with_parameters(F=16000.0), tolerance=1e-11)
    F, mC, g, l, m_rod, eta = 16000.0, 500.0, 9.81, 4.0, 60.0, 0.9
    x, dx = jib_geometry(res.s)
    ke_jib = 0.5 * mC * (l * res.sd) ** 2
    ke_rod = 0.5 * m_rod * (dx * res.sd) ** 2
    assert np.all(res.transmitted * res.qd > 0) and np.all(res.efficiency_factor == 1 / eta)
    lhs = ke_jib - ke_jib[0] + mC * g * l * (np.sin(res.s) - np.sin(res.s[0]))
    rhs = eta * (F * (x - x[0]) - (ke_rod - ke_rod[0]))
    assert np.max(np.abs(lhs - rhs)) < 1e-8 * F * (x[-1] - x[0])
    assert res.stop == "stroke end"


@pytest.mark.parametrize("tolerance, balance_tol", [(1e-8, 1e-6), (1e-10, 1e-8)])
def test_self_locking_drive_stalls_where_the_work_is_used_up(tolerance, balance_tol):
    """eta F = 12.6 kN is below the static load (12.0 .. 12.9 kN) and F/eta above it: the jib slows
    to rest and the efficiency switch holds it there.  The run stops 'stalled' at the instant of
    rest, at the angle theta* where the work balance (hand-written positions) is used up:
    mC g l (sin theta* - sin theta0) - KE_jib0 = eta (F (x* - x0) + KE_rod0), found here by brentq;
    and at theta* the drive holds the jib: eta F <= F_Su(theta*) <= F / eta, with the static load
    F_Su = mC g l cos(theta) / (dx/dtheta) from the moment balance about A."""
    from scipy.optimize import brentq

    text = (PROBLEMS / "sim_jib.toml").read_text().replace('inertia = "m_rod"', 'inertia = "m_rod"\nefficiency = 0.9')
    res = simulate(optdesign.loads(text, "jib_eta.toml"), tolerance=tolerance, t_end=2.0)
    F, mC, g, l, m_rod, eta = 14000.0, 500.0, 9.81, 4.0, 60.0, 0.9
    theta0 = res.s[0]
    x0, dx0 = jib_geometry(theta0)
    ke_jib0 = 0.5 * mC * (l * res.sd[0]) ** 2
    ke_rod0 = 0.5 * m_rod * (dx0 * res.sd[0]) ** 2

    def balance(theta):
        x, _ = jib_geometry(theta)
        return mC * g * l * (np.sin(theta) - np.sin(theta0)) - ke_jib0 - eta * (F * (x - x0) + ke_rod0)

    theta_star = brentq(balance, theta0 + 1e-9, 0.5, xtol=1e-15)
    assert res.stop == "stalled" and res.stop_end is None
    # the balance is flat near theta* (its slope dx/dtheta (F_Su - eta F) nearly vanishes):
    # judge the stop by the balance's residual, to 1e-8 of the drive's work at tolerance 1e-10
    # as the tests above (1e-6 at the default tolerance 1e-8)
    x_star, _ = jib_geometry(theta_star)
    assert abs(balance(res.s[-1])) < balance_tol * F * (x_star - x0)
    assert abs(res.s[-1] - theta_star) < 100 * balance_tol * theta_star
    assert res.sd[-1] == 0.0 and np.all(res.sd[:-1] > 0)
    _, dx = jib_geometry(theta_star)
    F_Su = mC * g * l * np.cos(theta_star) / dx
    assert eta * F <= F_Su <= F / eta


# --- rotary self-locking drives: a motor with efficiency eta < 1 lifts a load and comes to rest ---
# Reference (seed 1, eq. (5)): eta = P_u / P_in, P_in = T_S omega the power delivered to the crank,
# P_u what the mechanism takes (the rate of its kinetic and potential energy).  The rotor J is the
# drive's own inertia, outside the mechanism ([drive] inertia), so T_S = T - J omega'.  While the
# drive delivers power (T_S omega > 0): d/dt(KE_mech + V) = eta (T omega - d/dt(1/2 J omega^2)); to
# rest (omega* = 0): V* - V0 - KE_mech0 = eta (T (q* - q0) + 1/2 J omega0^2).
def _edited(text, *pairs):
    """``text`` with each (old, new) replaced; every old must occur exactly once (a changed
    problems/ file makes the test fail here instead of silently testing something else)."""
    for old, new in pairs:
        assert text.count(old) == 1, old
        text = text.replace(old, new)
    return text


def self_locking_bar():
    """problems/sim_bar.toml raised against gravity by T = 12 N m through eta = 0.8, from phi0 = 0.3
    at omega0 = 1.9 rad/s; the sweep narrowed to [0, pi/2] (simulate's tolerances are relative to
    the stroke length, which should be the motion's scale here, not twenty turns)."""
    text = _edited((PROBLEMS / "sim_bar.toml").read_text(),
                   ('to = "40*pi"', 'to = "pi/2"'),
                   ('[drive]', '[gravity]\ng = 9.81\n\n[drive]'),
                   ('inertia = "J_rotor"', 'inertia = "J_rotor"\nefficiency = 0.8'),
                   ('speed = 2.0', 'speed = 1.9'))
    return optdesign.loads(text, "bar_eta.toml").with_parameters(T=12.0)


@pytest.mark.parametrize("tolerance, balance_tol, t_end", [(1e-6, 1e-4, 1.0), (1e-8, 1e-6, 5.0), (1e-10, 1e-8, 5.0)])
def test_self_locking_motor_stalls_the_bar_where_the_work_is_used_up(tolerance, balance_tol, t_end):
    """Bar of mass m, length L turned about its end O (I_O = m L^2/3, weight torque
    T_Su = m g L/2 cos phi from the moment balance about O): eta T = 9.6 N m is below T_Su over
    the whole motion (phi < 0.996) and T/eta = 15 N m above it from phi = 0.556 on, so the bar
    slows to rest and the switch holds it.  The stop phi* solves the balance above,
    m g L/2 (sin phi* - sin phi0) - 1/2 I_O omega0^2 = eta (T (phi* - phi0) + 1/2 J omega0^2) (brentq);
    judged by the balance's residual, to 1e-8 of the drive's work T (phi* - phi0) at tolerance 1e-10
    as the tests above (1e-6 at the default 1e-8, 1e-4 at 1e-6), and the angle to the same residual
    over the balance's slope T_Su(phi*) - eta T.  The crank is the bar (k = 1): the carried angle q
    obeys q' = s', which every integrator keeps as q - s = const to rounding, so q = phi to 1e-12.
    t_end 5 s (the scene's, 101 samples, dt = 0.05 s) leaves the last sample before rest at 1.2 % of
    the start speed; at tolerance 1e-6 the integrator steps on through the switch's chatter at rest."""
    from scipy.optimize import brentq

    res = simulate(self_locking_bar(), tolerance=tolerance, t_end=t_end)
    m, L, g, J, T, eta, phi0, omega0 = 3.0, 1.2, 9.81, 0.05, 12.0, 0.8, 0.3, 1.9
    I_O = m * L**2 / 3

    def T_Su(phi):
        return m * g * L / 2 * np.cos(phi)

    def balance(phi):
        lifted = m * g * L / 2 * (np.sin(phi) - np.sin(phi0)) - 0.5 * I_O * omega0**2
        return lifted - eta * (T * (phi - phi0) + 0.5 * J * omega0**2)

    phi_star = brentq(balance, phi0, math.acos(eta * T / (m * g * L / 2)), xtol=1e-15)
    work = T * (phi_star - phi0)
    assert res.stop == "stalled" and res.stop_end is None
    assert res.s[0] == phi0 and res.qd[0] == pytest.approx(omega0, rel=1e-14)
    moving = slice(0, -1)  # power flows into the bar all the way (the balance's premise)
    assert np.all(res.transmitted[moving] * res.qd[moving] > 0) and np.all(res.efficiency_factor[moving] == 1 / eta)
    assert abs(balance(res.s[-1])) < balance_tol * work
    assert abs(res.s[-1] - phi_star) < balance_tol * work / (T_Su(phi_star) - eta * T)
    assert res.sd[-1] == 0.0 and res.qd[-1] == 0.0 and np.all(res.sd[moving] > 0)
    assert eta * T <= T_Su(res.s[-1]) <= T / eta
    assert abs(res.q[0] - phi0) < 1e-15 and abs(res.q[-1] - res.s[-1]) < 1e-12


# the piston of the seed's slider-crank (r, l, mC), swept by its height y; a motor on the crank S->A
# lifts it.  The drive angle q(y) differs from the sweep: k = dq/dy runs from 18.7 to 10.5 rad/m.
PISTON_LIFT = """
title = "piston lifted by a self-locking motor on the crank, swept by the piston height"
[parameters]
r = 0.1
l = 0.35
mC = 12.0
J_rotor = 0.002
T = 10.0
[sweep]
name = "y"
from = 0.26
to = 0.44
samples = 201
[points]
S = { fixed = [0, 0] }
C = { polar = ["S", "y", "90 deg"] }                 # the piston pin at height y above S
A = { dyad = ["S", "r", "C", "l"], side = "right" }  # the crank pin, right of S -> C
U = { polar = ["C", 1, "90 deg"] }
[[bodies]]
name = "piston"
frame = ["C", "U"]
mass = "mC"
com = [0, 0]
[gravity]
g = 9.81
[drive]
type = "rotary"
crank = ["S", "A"]
speed = 1.0
acceleration = 0.0
efficiency = 0.8
law = "T"
inertia = "J_rotor"
[simulation]
start = 0.27
speed = 6.0
t_end = 1.0
samples = 101
"""


def piston_crank_angle(y, r=0.1, l=0.35):
    """The crank angle q of S -> A and dq/dy: the triangle S A C with |SA| = r, |AC| = l, |SC| = y
    has the angle beta at S with cos beta = (r^2 + y^2 - l^2) / (2 r y); A lies right of the
    upward S -> C, so q = pi/2 - beta."""
    c = (r**2 + y**2 - l**2) / (2 * r * y)
    dc = (y**2 - r**2 + l**2) / (2 * r * y**2)
    return np.pi / 2 - np.arccos(c), dc / np.sqrt(1 - c**2)


@pytest.mark.parametrize("tolerance, balance_tol", [(1e-8, 1e-6), (1e-10, 1e-8)])
def test_self_locking_motor_on_a_crank_stalls_and_carries_its_angle(tolerance, balance_tol):
    """T = 10 N m through eta = 0.8 lifts the piston from y0 = 0.27 m at omega0 = 6 rad/s; the
    static crank torque T_Su = mC g dy/dq (virtual work) exceeds eta T = 8 N m beyond y = 0.283 and
    stays below T/eta = 12.5 N m (its peak is 12.2): the piston comes to rest and is held.  The
    stop y* solves mC g (y* - y0) - 1/2 mC y0'^2 = eta (T (q(y*) - q0) + 1/2 J omega0^2),
    y0' = omega0 / q'(y0) (brentq), judged as the bar's.  The drive angle is not the sweep
    (k = dq/dy = 18.7 .. 10.5 rad/m): simulate carries it as a state of its own (q' = k s'), so q - q(s)
    is that state's integration error, held to the same measure, balance_tol of the angle turned
    (measured 1.9e-9 of 0.70 rad at tolerance 1e-10, 7.2e-8 at 1e-8), at every sample and at the
    rest.  dt = 0.01 s leaves the last sample before rest at 6 % of the start speed."""
    from scipy.optimize import brentq

    res = simulate(optdesign.loads(PISTON_LIFT, "piston_lift.toml"), tolerance=tolerance)
    mC, g, J, T, eta, y0, omega0 = 12.0, 9.81, 0.002, 10.0, 0.8, 0.27, 6.0
    q0, k0 = piston_crank_angle(y0)
    yd0 = omega0 / k0

    def balance(y):
        q, _ = piston_crank_angle(y)
        return mC * g * (y - y0) - 0.5 * mC * yd0**2 - eta * (T * (q - q0) + 0.5 * J * omega0**2)

    y_star = brentq(balance, 0.3, 0.4, xtol=1e-15)
    q_star, k_star = piston_crank_angle(y_star)
    work = T * (q_star - q0)
    assert res.stop == "stalled" and res.stop_end is None
    moving = slice(0, -1)  # power flows into the piston all the way (the balance's premise)
    assert np.all(res.transmitted[moving] * res.qd[moving] > 0) and np.all(res.efficiency_factor[moving] == 1 / eta)
    assert abs(balance(res.s[-1])) < balance_tol * work
    assert abs(res.s[-1] - y_star) < balance_tol * work / (mC * g - eta * T * k_star)
    assert res.sd[-1] == 0.0 and res.qd[-1] == 0.0 and np.all(res.sd[moving] > 0)
    assert eta * T <= mC * g / piston_crank_angle(res.s[-1])[1] <= T / eta
    q_hand, k_hand = piston_crank_angle(res.s)
    assert abs(res.q[0] - q0) < 1e-14 and np.all(k_hand > 10)
    assert np.max(np.abs(res.q - q_hand)) < balance_tol * (q_star - q0)
    assert abs(res.q[-1] - q_hand[-1]) < balance_tol * (q_star - q0)  # at the rest


def test_a_loose_tolerance_stops_at_the_stall_without_stepping_through_the_chatter():
    """At tolerance 1e-6 CVODES can step on through the switch's chatter after the rest, 1e4
    steps per output interval up to t_end (about 1.2 million for the bar over 5 s): the run
    is integrated in chunks, each checked for a held rest, so it stops at the rest having taken
    the steps of the motion (a few hundred; bound: one output interval's step limit, 20,000),
    and the stop still satisfies the bar's work balance as in the test above."""
    res = simulate(self_locking_bar(), tolerance=1e-6, t_end=5.0)
    m, L, g, J, T, eta, phi0, omega0 = 3.0, 1.2, 9.81, 0.05, 12.0, 0.8, 0.3, 1.9
    lifted = m * g * L / 2 * (np.sin(res.s[-1]) - np.sin(phi0)) - 0.5 * (m * L**2 / 3) * omega0**2
    balance = lifted - eta * (T * (res.s[-1] - phi0) + 0.5 * J * omega0**2)
    assert res.stop == "stalled"
    assert res.stats["steps"] < 20000
    assert abs(balance) < 1e-4 * T * (res.s[-1] - phi0)
