"""The drive train (issue 16, piece 4): a gearbox and a motor behind a rotary drive, a hydraulic
cylinder as a linear one.

References written here, sharing nothing with optdesign's reduced model:

* the motor torque by virtual work (d'Alembert) on the Scotch yoke: the lifted mass's
  acceleration from its position y = r sin(theta) differentiated by hand, the force m (y'' + g)
  it needs, its virtual displacement r cos(theta) dtheta, and the rotor's inertia torque J_r
  eps_m through the gear's virtual rotation i dtheta:  T_m i dtheta = m (y'' + g) r cos(theta)
  dtheta + J_r i theta'' i dtheta;
* the inertia ratio and sqrt(J_load / J_r) from J_load = max m r^2 cos^2 theta;
* the smallest motor of a catalogue that fits, by a loop over the motors;
* Euler's buckling load pi^2 E I / (K L)^2, I = pi d^4/64, and the bore from the pressure.
"""
import math

import numpy as np
import pytest

from optdesign.model.analysis import analyse
from optdesign.model.train import euler_force
from optdesign.scene.file import loads

R, G, M, U0, U1 = 0.2, 9.81, 30.0, 0.2, 2.6
V, A, D = 0.8, 0.5, 0.3

YOKE = f'''title = "Scotch yoke behind a gearbox and a motor"
[parameters]
r = {R}
m = {M}
i = 12.0
[sweep]
name = "u"
from = {U0}
to = {U1}
samples = 67
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
speed = 1.0
acceleration = 0.0
[profiles.trap]
kind = "trapezoidal"
speed = {V}
acceleration = {A}
deceleration = {D}
[[cases]]
name = "up"
direction = "forward"
profile = "trap"
[[cases]]
name = "down"
direction = "reverse"
profile = "trap"
[gearbox]
ratio = "i"
GEAR_EFFICIENCY
[[motors]]
name = "small"
inertia = 2e-4
rated_torque = 1.0
peak_torque = 3.0
max_speed = 200
[[motors]]
name = "medium"
inertia = 6e-4
rated_torque = 2.5
peak_torque = 7.5
max_speed = 200
[[motors]]
name = "large"
inertia = 2e-3
rated_torque = 6.0
peak_torque = 18.0
max_speed = 200
'''


def scene(gear_efficiency=None):
    return loads(YOKE.replace("GEAR_EFFICIENCY", "" if gear_efficiency is None else f"efficiency = {gear_efficiency}"))


def profile(u, sign):
    """Sweep rate and acceleration of the trapezoid at u (closed form, by phase)."""
    L = U1 - U0
    x = (u - U0) if sign > 0 else (U1 - u)
    xa, xd = V**2 / (2 * A), V**2 / (2 * D)
    speed = np.where(x < xa, np.sqrt(2 * A * np.maximum(x, 0)), np.where(x > L - xd, np.sqrt(2 * D * np.maximum(L - x, 0)), V))
    acc = np.where(x < xa, A, np.where(x > L - xd, -D, 0.0))
    return sign * speed, sign * acc


def virtual_work(u, sign, ratio, J_r):
    """(T_S, theta', theta'', T_m at eta = 1) by d'Alembert."""
    ud, udd = profile(u, sign)
    th, g1, g2 = u + 0.3 * np.sin(u), 1 + 0.3 * np.cos(u), -0.3 * np.sin(u)
    thd, thdd = g1 * ud, g1 * udd + g2 * ud**2
    ydd = R * np.cos(th) * thdd - R * np.sin(th) * thd**2
    T_S = M * (ydd + G) * R * np.cos(th)            # T_S dtheta = m (y'' + g) dy
    return T_S, thd, thdd, T_S / ratio + J_r * ratio * thdd


@pytest.fixture(scope="module")
def ideal():
    return analyse(scene()).cases


@pytest.mark.parametrize("case", ["up", "down"])
def test_motor_torque_with_rotor_inertia_against_virtual_work(ideal, case):
    c = ideal.cases[case]
    shown = ideal.train["shown"]
    J_r = {"small": 2e-4, "medium": 6e-4, "large": 2e-3}[shown]
    T_S, thd, thdd, T_m = virtual_work(c.columns["s"], 1 if case == "up" else -1, 12.0, J_r)
    scale = np.max(np.abs(T_m))
    assert np.max(np.abs(c.columns["drive"] - T_S)) <= 1e-9 * np.max(np.abs(T_S))
    assert np.max(np.abs(c.columns["motor_torque"] - T_m)) <= 1e-9 * scale
    assert np.allclose(c.columns["motor_speed"], 12.0 * thd, rtol=0, atol=1e-12)
    assert np.allclose(c.columns["motor_acceleration"], 12.0 * thdd, rtol=0, atol=1e-9)


def test_gear_efficiency_switches_with_the_power_flow():
    cases = analyse(scene(0.9)).cases
    for name, sign in (("up", 1), ("down", -1)):
        c = cases.cases[name]
        J_r = cases.train["motors"][cases.train["shown"]]["inertia"]
        T_S, thd, thdd, _ = virtual_work(c.columns["s"], sign, 12.0, J_r)
        moving = np.where(np.abs(thd) > 0, np.sign(thd), sign)
        c_g = np.where(T_S * moving >= 0, 1 / 0.9, 0.9)
        expected = c_g * T_S / 12.0 + J_r * 12.0 * thdd
        assert np.max(np.abs(c.columns["motor_torque"] - expected)) <= 1e-9 * np.max(np.abs(expected))


def test_inertia_ratio_and_the_classical_optimal_ratio(ideal):
    u = np.linspace(U0, U1, 200_001)
    J_load = np.max(M * R**2 * np.cos(u + 0.3 * np.sin(u)) ** 2)
    for name, m in ideal.train["motors"].items():
        # J_load over the cases' samples: within the samples' resolution of the continuous max
        assert m["load_inertia"] == pytest.approx(J_load, rel=1e-3)
        assert m["inertia_ratio"] == pytest.approx(m["load_inertia"] / (12.0**2 * m["inertia"]), rel=1e-14)
        assert m["optimal_ratio"] == pytest.approx(math.sqrt(m["load_inertia"] / m["inertia"]), rel=1e-14)


def test_smallest_motor_that_fits_against_a_loop(ideal):
    cycle = sum(c.duration for c in ideal.cases.values())
    fits = []
    for name, J_r in (("small", 2e-4), ("medium", 6e-4), ("large", 2e-3)):
        peak, squares, speed = 0.0, 0.0, 0.0
        for case, sign in (("up", 1), ("down", -1)):
            u = np.linspace(U0, U1, 400_001)
            _, thd, _, T_m = virtual_work(u, sign, 12.0, J_r)
            peak, speed = max(peak, np.max(np.abs(T_m))), max(speed, 12.0 * np.max(np.abs(thd)))
            dt = np.abs(np.diff(u)) / np.maximum(np.abs(profile(0.5 * (u[1:] + u[:-1]), sign)[0]), 1e-300)
            squares += np.sum(0.5 * (T_m[1:] ** 2 + T_m[:-1] ** 2) * dt)
        rms = math.sqrt(squares / cycle)
        motor = ideal.train["motors"][name]
        assert motor["rms"] == pytest.approx(rms, rel=2e-3)
        assert motor["peak"] == pytest.approx(peak, rel=2e-3)
        limits = {"small": (1.0, 3.0), "medium": (2.5, 7.5), "large": (6.0, 18.0)}[name]
        if rms <= limits[0] and peak <= limits[1] and speed <= 200:
            fits.append(name)
    assert fits, "the catalogue was meant to hold a motor that fits"
    assert ideal.train["smallest_fitting"] == fits[0]
    assert [n for n, m in ideal.train["motors"].items() if m["fits"]] == fits


# --- the cylinder ------------------------------------------------------------------------------
JIB = '''title = "jib on a cylinder, sized"
[parameters]
l = 4.0
e = 1.6
b = 2.4
psi = "-60 deg"
mC = 5000.0
d_rod = 0.06
[sweep]
name = "theta"
from = "-10 deg"
to = "60 deg"
samples = 81
[points]
A = { fixed = [0, 0] }
D = { fixed = ["e*cos(psi)", "e*sin(psi)"] }
B = { polar = ["A", "b", "theta"] }
C = { polar = ["A", "l", "theta"] }
[[bodies]]
name = "load"
frame = ["A", "B"]
mass = "mC"
com = ["l", 0]
[gravity]
g = 9.81
[drive]
type = "linear"
between = ["D", "B"]
speed = 0.1
acceleration = 0.0
[[cases]]
name = "luff up"
direction = "forward"
profile = { kind = "trapezoidal", speed = 0.1, acceleration = 0.05, deceleration = 0.05 }
[[cases]]
name = "luff down"
direction = "reverse"
set = { mC = 3000 }
[cylinder]
pressure = 20e6
modulus = 210e9
buckling_safety = 3.5
length_factor = 1.0
rod = "d_rod"
'''


def test_euler_buckling_against_the_textbook_formula():
    E, d, L, K = 210e9, 0.04, 3.1, 0.7
    I = math.pi * d**4 / 64
    assert euler_force(E, d, L, K) == pytest.approx(math.pi**2 * E * I / (K * L) ** 2, rel=1e-15)


def test_cylinder_sizes_from_pressure_peak_force_and_speed():
    res = analyse(loads(JIB)).cases
    cyl = res.train
    th = np.radians([-10.0, 60.0])
    e, b, psi = 1.6, 2.4, math.radians(-60)
    lengths = np.sqrt(e**2 + b**2 - 2 * e * b * np.cos(th - psi))
    L = float(np.max(lengths))                               # full extension: at a stroke end
    push = max(float(np.max(c.columns["drive"])) for c in res.cases.values())
    assert cyl["full_extension"] == pytest.approx(L, rel=1e-14)
    assert cyl["peak_push"] == push
    pull = max(float(np.max(-c.columns["drive"])) for c in res.cases.values())
    d, p = 0.06, 20e6
    assert cyl["bore_needed"] == pytest.approx(max(math.sqrt(4 * push / (math.pi * p)),
                                                   math.sqrt(4 * max(pull, 0) / (math.pi * p) + d**2)), rel=1e-14)
    assert cyl["bore_needed"] > d
    E, S = 210e9, 3.5
    rod = (64 * S * push * L**2 / (math.pi**3 * E)) ** 0.25
    assert cyl["rod_needed_buckling"] == pytest.approx(rod, rel=1e-14)
    I = math.pi * d**4 / 64
    assert cyl["euler_force"] == pytest.approx(math.pi**2 * E * I / L**2, rel=1e-14)
    assert cyl["buckling_utilisation"] == pytest.approx(push * S / (math.pi**2 * E * I / L**2), rel=1e-14)
    # per sample: the force against the rod's Euler load at full extension
    for c in res.cases.values():
        util = np.maximum(c.columns["drive"], 0) * S / (math.pi**2 * E * I / L**2)
        assert np.allclose(c.columns["rod_buckling"], util, rtol=1e-12, atol=0)
    # the pump: the bore's area times the largest extending speed (or the annulus retracting)
    bore = cyl["bore"]
    extend = max(float(np.max(c.columns["drive_speed"])) for c in res.cases.values())
    retract = max(float(np.max(-c.columns["drive_speed"])) for c in res.cases.values())
    assert cyl["pump_flow"] == pytest.approx(max(math.pi * bore**2 / 4 * extend,
                                                 math.pi * (bore**2 - d**2) / 4 * retract), rel=1e-14)


def test_rod_buckling_as_a_constraint_of_optimise():
    """A longer lever b lowers the cylinder force but lengthens the cylinder, and Euler's load
    falls with the square of the length: with a thin rod the least peak force lies where the
    buckling constraint is active.  Against a dense scan of b with the jib's force by virtual
    work (F dx = (m l^2 theta'' + m g l cos theta) dtheta, x the cylinder length)."""
    from optdesign.design import optimise

    text = JIB.replace("b = 2.4", "b = { value = 2.0, min = 1.0, max = 3.5 }").replace("d_rod = 0.06", "d_rod = 0.088")
    down = '[[cases]]\nname = "luff down"\ndirection = "reverse"\nset = { mC = 3000 }\n'
    assert down in text
    sc = loads(text.replace(down, "") + '\n[objective]\nminimise = "peak(drive)"\n')
    assert sc.cylinder is not None and [c.name for c in sc.cases] == ["luff up"]
    result = optimise(sc, starts=3)
    assert result.success
    e, psi, l, m, g = 1.6, math.radians(-60), 4.0, 5000.0, 9.81
    E, S, d = 210e9, 3.5, 0.088
    th0, th1 = math.radians(-10), math.radians(60)
    L = th1 - th0
    xa = 0.1**2 / (2 * 0.05)
    x = np.linspace(0, L, 20001)
    x = np.sort(np.r_[x, xa, L - xa])
    th = th0 + x
    thdd = np.where(x < xa, 0.05, np.where(x > L - xa, -0.05, 0.0))

    def peak_and_buckling(b):
        length = np.sqrt(e**2 + b**2 - 2 * e * b * np.cos(th - psi))
        dx = e * b * np.sin(th - psi) / length
        F = (m * l**2 * thdd + m * g * l * np.cos(th)) / dx
        full = max(length[0], length[-1])
        util = np.max(F) * S * full**2 * 64 / (math.pi**3 * E * d**4)
        return np.max(np.abs(F)), util

    bs = np.linspace(1.0, 3.5, 2501)
    feasible = [(peak_and_buckling(b)[0], b) for b in bs if peak_and_buckling(b)[1] <= 1.0]
    best, b_best = min(feasible)
    assert result.objective == pytest.approx(best, rel=2e-4)
    assert result.design["b"] == pytest.approx(b_best, abs=2e-3)
    entry = result.constraints["rod buckling in case 'luff up'"]
    assert entry["active"] == "upper" and entry["value"] == pytest.approx(1.0, rel=1e-6)
