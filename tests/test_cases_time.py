"""Load cases over time (issue 16, piece 2): each case's drive load along its motion profile, its
time, and the duty cycle's RMS over time, energy and mean power, against an independent numpy
calculation of the same mechanism and profiles on a fine grid.

The mechanism is a Scotch yoke whose crank angle is theta = u + 0.3 sin u of the sweep u (so
that dq/ds varies and the drive's speed and acceleration follow from the profile's by the
chain rule), lifting a mass m on a vertical slot: y = r sin theta.  Its drive torque in closed
form (no optdesign): M(theta) = m r^2 cos^2 theta, Q = m g r cos theta,

    T_ideal = M theta'' + 1/2 dM/dtheta theta'^2 + Q,   T_S = c T_ideal,

c = 1/eta while T_ideal theta' >= 0, else eta.  The reference runs each profile in time on a
fine grid from its acceleration law (integrated numerically, not inverted), maps u to theta,
and integrates with numpy's trapezoid rule.
"""
import math

import numpy as np
import pytest

from optdesign.model.analysis import analyse
from optdesign.scene.file import loads

R, G, ETA, U0, U1 = 0.2, 9.81, 0.8, 0.2, 2.6

YOKE = f'''title = "Scotch yoke lifting a mass, crank angle u + 0.3 sin u"

[parameters]
r = {R}
m = 30.0

[sweep]
name = "u"
from = {U0}
to = {U1}
samples = SAMPLES

[points]
S = {{ fixed = [0, 0] }}
A = {{ polar = ["S", "r", "u + 0.3*sin(u)"] }}
C = {{ fixed = [0, "r*sin(u + 0.3*sin(u))"] }}
D = {{ fixed = [1, "r*sin(u + 0.3*sin(u))"] }}

[[bodies]]
name = "yoke"
frame = ["C", "D"]
mass = "m"
com = [0, 0]

[gravity]
g = {G}

[drive]
type = "rotary"
crank = ["S", "A"]
speed = 1.5
acceleration = 0.0
efficiency = {ETA}

[profiles.trap]
kind = "trapezoidal"
speed = 0.8
acceleration = 0.5
deceleration = 0.3

[[cases]]
name = "up"
direction = "forward"
profile = "trap"

[[cases]]
name = "down"
direction = "reverse"
set = {{ m = 20 }}
profile = {{ kind = "s-curve", speed = 0.9, acceleration = 0.6, deceleration = 0.4, jerk = 2.0 }}

[[cases]]
name = "cam"
direction = "forward"
profile = {{ kind = "law", speed = "0.6 + 0.3*sin(2*u)" }}

[[cases]]
name = "steady"
direction = "reverse"
set = {{ m = 45 }}

[duty]
cycle = ["up", {{ hold = 2.0, case = "up" }}, "down", {{ dwell = 3.0 }}, {{ case = "cam", repeat = 2 }}, "steady",
         {{ hold = 1.5, case = "steady", at = "start", efficiency = "braking" }}]
'''


def scene(samples=201):
    return loads(YOKE.replace("SAMPLES", str(samples)), "yoke.toml")


# --- the independent reference -------------------------------------------------------------
def theta_of(u):
    return u + 0.3 * np.sin(u), 1 + 0.3 * np.cos(u), -0.3 * np.sin(u)


def drive_torque(theta, thd, thdd, m, direction):
    """T_S; at rest (theta' = 0, the ends of a profile) the power flows as in the motion there
    (``direction``: the sign of theta' while moving)."""
    M = m * R**2 * np.cos(theta) ** 2
    dM = -2 * m * R**2 * np.cos(theta) * np.sin(theta)
    ideal = M * thdd + 0.5 * dM * thd**2 + m * G * R * np.cos(theta)
    moving = np.where(np.abs(thd) > 1e-9, np.sign(thd), direction)
    c = np.where(ideal * moving >= 0, 1 / ETA, ETA)
    return c * ideal


def run_in_time(accel_law, T, n=400_001):
    """t, x, xdot, xddot of a rest-to-rest motion whose path acceleration is accel_law(t)."""
    t = np.linspace(0.0, T, n)
    a = accel_law(t)
    v = np.r_[0.0, np.cumsum(0.5 * (a[1:] + a[:-1]) * np.diff(t))]
    x = np.r_[0.0, np.cumsum((v[1:] + v[:-1]) / 2 * np.diff(t) + (a[:-1] - a[1:]) / 12 * np.diff(t) ** 2)]
    return t, x, v, a


def trapezoid_law(v, a, d, L):
    ta, td = v / a, v / d
    T = ta + td + (L - v**2 / (2 * a) - v**2 / (2 * d)) / v
    return (lambda t: np.where(t < ta, a, np.where(t > T - td, -d, 0.0))), T


def s_curve_law(v, a, d, j, L):
    def phase(rate):
        peak = min(rate, math.sqrt(v * j))
        tj = peak / j
        return peak, tj, v / peak - tj
    (pa, ja, ca), (pd, jd, cd) = phase(a), phase(d)
    Ta, Td = 2 * ja + ca, 2 * jd + cd
    T = Ta + Td + (L - v * Ta / 2 - v * Td / 2) / v

    def ramp(tau, peak, tj, tc):
        return np.clip(np.minimum(j * tau, peak - j * (tau - tj - tc)), 0.0, peak)

    return (lambda t: np.where(t < Ta, ramp(t, pa, ja, ca), np.where(t > T - Td, -ramp(T - t, pd, jd, cd), 0.0))), T


def reference_case(law_and_T, sign, m):
    """drive_squared, energy, duration of a profile along u (sign +1: from U0)."""
    law, T = law_and_T
    t, x, xd, xdd = run_in_time(law, T)
    u = (U0 + x) if sign > 0 else (U1 - x)
    ud, udd = sign * xd, sign * xdd
    th, g1, g2 = theta_of(u)
    thd, thdd = g1 * ud, g1 * udd + g2 * ud**2
    T_S = drive_torque(th, thd, thdd, m, sign)
    return np.trapezoid(T_S**2, t), np.trapezoid(T_S * thd, t), T, T_S


def reference_cam(m):
    """The law V(u) = 0.6 + 0.3 sin 2u: time from int du / V on a fine grid in u."""
    u = np.linspace(U0, U1, 400_001)
    V = 0.6 + 0.3 * np.sin(2 * u)
    dV = 0.6 * np.cos(2 * u)
    th, g1, g2 = theta_of(u)
    thd, thdd = g1 * V, g1 * V * dV + g2 * V**2
    T_S = drive_torque(th, thd, thdd, m, 1.0)
    return np.trapezoid(T_S**2 / V, u), np.trapezoid(T_S * thd / V, u), np.trapezoid(1 / V, u), T_S


def reference_steady(m, speed=1.5):
    """Constant drive speed backwards (theta' = -1.5), no acceleration: time = |dtheta| / 1.5."""
    th = np.linspace(theta_of(U0)[0], theta_of(U1)[0], 400_001)
    T_S = drive_torque(th, -speed, 0.0, m, -1.0)
    return (np.trapezoid(T_S**2, th) / speed, -np.trapezoid(T_S, th), (th[-1] - th[0]) / speed, T_S)


@pytest.fixture(scope="module")
def references():
    L = U1 - U0
    return {"up": reference_case(trapezoid_law(0.8, 0.5, 0.3, L), +1, 30.0),
            "down": reference_case(s_curve_law(0.9, 0.6, 0.4, 2.0, L), -1, 20.0),
            "cam": reference_cam(30.0), "steady": reference_steady(45.0)}


@pytest.fixture(scope="module")
def result():
    return analyse(scene()).cases


# --- the tests ------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["up", "down", "cam", "steady"])
def test_each_case_over_time_against_the_fine_grid(result, references, name):
    sq, energy, T, T_S = references[name]
    case = result.cases[name]
    assert case.duration == pytest.approx(T, rel=1e-9)
    # the rule on 201 samples (+ phase boundaries) against 400,001 points: second order
    assert case.integrals["drive_squared"] == pytest.approx(sq, rel=5e-5)
    # energy is a difference of driving and braking parts: its error is measured against int |P| dt
    # (at most RMS * T * 1 rad/s here: the speeds stay below 1.3 rad/s)
    assert case.integrals["energy"] == pytest.approx(energy, rel=5e-5, abs=1e-4 * math.sqrt(sq * T))
    assert case.peaks["drive"] == pytest.approx(np.max(np.abs(T_S)), rel=2e-3)


def test_the_samples_carry_time_speed_and_acceleration(result):
    case = result.cases["up"]
    s, t = case.columns["s"], case.columns["t"]
    law, T = trapezoid_law(0.8, 0.5, 0.3, U1 - U0)
    tt, x, xd, xdd = run_in_time(law, T)
    # the time at each sample: where the fine run reaches that u
    moving = np.interp(s - U0, x, xd) > 0.05   # where a small error in x is a small one in t
    assert np.allclose(t[moving], np.interp(s - U0, x, tt)[moving], atol=2e-6)
    th, g1, g2 = theta_of(s)
    xd_s = np.interp(s - U0, x, xd)
    assert np.allclose(case.columns["drive_speed"][moving], (g1 * xd_s)[moving], atol=1e-5)
    assert np.all(np.diff(t) >= 0) and t[0] == 0.0 and t[-1] == pytest.approx(T, rel=1e-12)


def test_the_cycle_against_the_fine_grid(result, references):
    duty = result.duty
    ref = references
    hold_up = (1 / ETA) * 30.0 * G * R * math.cos(theta_of(U1)[0])        # at rest at the end of 'up'
    hold_steady = ETA * 45.0 * G * R * math.cos(theta_of(U1)[0])          # 'steady' starts at U1; braking
    T = ref["up"][2] + 2.0 + ref["down"][2] + 3.0 + 2 * ref["cam"][2] + ref["steady"][2] + 1.5
    squares = (ref["up"][0] + hold_up**2 * 2.0 + ref["down"][0] + 2 * ref["cam"][0] + ref["steady"][0]
               + hold_steady**2 * 1.5)
    energy = ref["up"][1] + ref["down"][1] + 2 * ref["cam"][1] + ref["steady"][1]
    assert duty["cycle_time"] == pytest.approx(T, rel=1e-9)
    assert duty["rms_time"]["drive"] == pytest.approx(math.sqrt(squares / T), rel=2e-5)
    assert duty["energy"] == pytest.approx(energy, rel=5e-5)
    assert duty["mean_power"] == pytest.approx(energy / T, rel=5e-5)
    assert [s["kind"] for s in duty["steps"]] == ["case", "hold", "case", "dwell", "case", "case", "hold"]
    assert duty["steps"][1]["load"] == pytest.approx(hold_up, rel=1e-12)


def test_the_rule_converges_at_second_order(references):
    """Halving the sample spacing divides the error of the rule on the samples (the NLP's,
    kept as ``sampled``) by about four; the reported integral, by adaptive quadrature, does not
    depend on the samples (issue 27)."""
    sq = references["up"][0] + references["down"][0]
    errors, certified = [], []
    for n in (26, 51, 101):
        cases = analyse(scene(n)).cases.cases
        sampled = [cases[k].integrals["sampled"]["drive_squared"] for k in ("up", "down")]
        errors.append(abs(sum(sampled) - sq) / sq)
        certified.append(cases["up"].integrals["drive_squared"] + cases["down"].integrals["drive_squared"])
    assert errors[1] < errors[0] / 3 and errors[2] < errors[1] / 3, errors
    assert max(certified) - min(certified) <= 1e-10 * certified[0]


def test_governing_case_against_a_brute_force_loop(result):
    """The governing case of each peak is the one a loop over the cases finds."""
    for key in ("drive", "static_load", "power"):
        loop = max(((float(np.max(np.abs(c.columns[key]))), name) for name, c in result.cases.items()),
                   key=lambda v: v[0])
        assert result.governing[key]["case"] == loop[1]
        assert result.governing[key]["value"] == loop[0]


def test_a_scene_without_cases_has_no_case_result():
    text = YOKE.replace("SAMPLES", "21")
    text = text[:text.index("[profiles.trap]")]
    assert analyse(loads(text)).cases is None


def test_rms_sweep_is_the_rms_over_the_sweep():
    """``rms(NAME)`` keeps its meaning (the mean over the sweep's samples, not over time) and has
    the explicit name ``rms_sweep(NAME)``."""
    from pathlib import Path

    from optdesign.design import DesignProblem

    text = (Path(__file__).resolve().parents[1] / "problems" / "crank_press_rms.toml").read_text()
    assert 'minimise = "rms(drive)"' in text
    plain = DesignProblem(loads(text, "rms.toml"))
    named = DesignProblem(loads(text.replace('minimise = "rms(drive)"', 'minimise = "rms_sweep(drive)"'), "x"))
    assert named.objective_kind == plain.objective_kind == "rms"
    assert named.rms(named.start) == plain.rms(plain.start)


def test_case_weights_share_the_cycle_without_duty():
    """Without [duty] the cycle runs each case `weight` times: its time and integrals scale."""
    text = YOKE.replace("SAMPLES", "41")
    text = text[:text.index("[duty]")]
    plain = analyse(loads(text)).cases
    weighted = analyse(loads(text.replace('name = "cam"\n', 'name = "cam"\nweight = 2.5\n'))).cases
    cam = plain.cases["cam"]
    assert weighted.duty["cycle_time"] == pytest.approx(plain.duty["cycle_time"] + 1.5 * cam.duration, rel=1e-12)
    assert weighted.duty["energy"] == pytest.approx(plain.duty["energy"] + 1.5 * cam.integrals["energy"], rel=1e-12)
