"""The motor's power in a load case is the mechanism's energy rate through the efficiencies plus
the rotor's: T_m omega_m = c_g c dE/dt + J_r omega_m alpha_m, with E the bodies' kinetic and
potential energy, c = 1/eta (c_g = 1/eta_g) while the motor drives and eta (eta_g) while power
flows back.  The reference is a hand-written numpy model of problems/crane_luffing_drive.toml
(its points, bodies and trapezoidal profile; derivatives in the jib angle by central
differences), not the code under test, which reduces the bodies to the crank (seed 1's
Lagrange reduction) and puts the gearbox and the rotor behind it.  The identity holds for
every design: a motor whose constraints at one sample cannot give the power the bodies need
there cannot fit (issue 31's lead for the motor catalogue)."""
import math
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

import optdesign
from optdesign.design.catalogue import motor_order, with_motor
from optdesign.kinematics.mechanism import Mechanism
from optdesign.model.cases import CaseModel

SCENE = Path(__file__).resolve().parent.parent / "problems" / "crane_luffing_drive.toml"
G, ETA, ETA_G = 9.81, 0.92, 0.94
PAYLOAD = {"in, rated load": 3000.0, "out, rated load": 3000.0, "in, empty hook": 200.0,
           "out, empty hook": 200.0, "test load": 1.25 * 3000.0}
V, A = math.radians(1.0), math.radians(0.25)        # the profile's top speed and acceleration
S0, S1 = math.radians(20.0), math.radians(75.0)


def bodies(s, d, mP):
    """[(mass, inertia, com (2 x n), angle)] of the crane's bodies at jib angles ``s`` for design
    ``d`` and payload ``mP``, and the crank O -> P (2 x n)."""
    L, b, f, mJ, mT, lT = 18.0, 5.0, 0.6, 4000.0, 6000.0, 2.5
    c, n = np.cos(s), np.sin(s)
    B = np.array([b * c + f * n, b * n - f * c])       # b along the jib, f below its axis
    O = np.array([d["xO"], d["yO"]])[:, None]
    dv = B - O
    d2 = np.sum(dv**2, axis=0)
    along = d2 + d["r"] ** 2 - d["lc"] ** 2
    h = np.sqrt(4 * d2 * d["r"] ** 2 - along**2)
    P = O + (along * dv - h * np.array([-dv[1], dv[0]])) / (2 * d2)   # the dyad's right-hand point
    mR = 130 * d["lc"]
    rod = B - P
    return [(mJ, mJ * L**2 / 12, 0.45 * L * np.array([c, n]), s),
            (mT, 0.0, -lT * np.array([c, n]), s),
            (mP, 0.0, L * np.array([c, n]), s),
            (mR, mR * d["lc"] ** 2 / 12, (P + B) / 2, np.arctan2(rod[1], rod[0]))], P - O


def wrap(angle):
    """An angle's difference in (-pi, pi] (atan2's cut between two neighbouring points)."""
    return (angle + np.pi) % (2 * np.pi) - np.pi


def profile(s, forward):
    """(sd, sdd) of the trapezoidal profile at ``s`` (1 deg/s, 0.25 deg/s^2 up and down)."""
    x = (s - S0) if forward else (S1 - s)
    y = (S1 - S0) - x
    ramp = V**2 / (2 * A)
    up, down = np.sqrt(2 * A * np.maximum(x, 0)), np.sqrt(2 * A * np.maximum(y, 0))
    speed = np.where(x < ramp, up, np.where(y < ramp, down, V))
    accel = np.where(x < ramp, A, np.where(y < ramp, -A, 0.0))
    sign = 1.0 if forward else -1.0
    return sign * speed, sign * accel


def reduced_mass(s, d, mP, h=1e-6):
    """M(s) = sum m |dr/ds|^2 + I (dangle/ds)^2 and dV/ds of the bodies (central differences)."""
    lo, hi = bodies(s - h, d, mP)[0], bodies(s + h, d, mP)[0]
    M = sum(m * np.sum(((c1 - c0) / (2 * h)) ** 2, axis=0) + J * (wrap(a1 - a0) / (2 * h)) ** 2
            for (m, J, c0, a0), (_, _, c1, a1) in zip(lo, hi))
    return M, sum(m * G * (c1[1] - c0[1]) / (2 * h) for (m, _, c0, _), (_, _, c1, _) in zip(lo, hi))


def reference_power(s, d, case, inertia):
    """The motor's power from the bodies' energy rate, the efficiencies and the rotor."""
    mP = PAYLOAD[case]
    sd, sdd = profile(s, case.startswith("in") or case == "test load")
    M, dV = reduced_mass(s, d, mP)
    dM = (reduced_mass(s + 1e-4, d, mP)[0] - reduced_mass(s - 1e-4, d, mP)[0]) / 2e-4
    load = sd * dV + M * sd * sdd + 0.5 * dM * sd**3   # dE/dt of the bodies (E = M sd^2 / 2 + V)
    c = np.where(load >= 0, 1 / ETA, ETA)
    c_g = np.where(load >= 0, 1 / ETA_G, ETA_G)
    hp = 1e-4   # the crank angle's second difference: rounding ~1e-16 / hp^2, truncation ~hp^2
    phi = [np.arctan2(r[1], r[0]) for r in (bodies(s + k * hp, d, mP)[1] for k in (-1, 0, 1))]
    up, down = wrap(phi[2] - phi[1]), wrap(phi[1] - phi[0])
    dphi, ddphi = (up + down) / (2 * hp), (up - down) / hp**2
    omega = d["i"] * dphi * sd
    alpha = d["i"] * (ddphi * sd**2 + dphi * sdd)
    return c_g * c * load + inertia * omega * alpha


DESIGNS = [{"xO": 2.5, "yO": -1.2, "r": 1.6, "lc": 4.5, "i": 2500.0},                  # the scene's start
           {"xO": 1.27905, "yO": -0.8, "r": 2.11896, "lc": 5.81042, "i": 3869.52},     # the 7.5 kW optimum
           {"xO": 1.81, "yO": -3.709, "r": 1.923, "lc": 6.657, "i": 1639.551}]   # (assembles over the stroke)
INERTIA = {0: 0.012, 2: 0.028}   # the 4 kW and 7.5 kW rotors of the scene's [[motors]]


@pytest.mark.parametrize("design", range(len(DESIGNS)))
@pytest.mark.parametrize("motor", [0, 2])
def test_motor_power_is_the_energy_rate_through_the_efficiencies(design, motor):
    scene = optdesign.load(SCENE)
    one = with_motor(scene, motor_order(scene)[motor])
    mech = Mechanism(one)
    d = DESIGNS[design]
    p_values = mech.parameter_values.copy()
    for name, value in d.items():
        p_values[list(mech.parameter_names).index(name)] = value
    inertia = INERTIA[motor]
    # interior samples of the stroke, off the profile's phase breaks (22 and 73 deg)
    s = np.radians(np.r_[np.linspace(20.1, 21.9, 7), np.linspace(22.1, 72.9, 41), np.linspace(73.1, 74.9, 7)])
    for case in one.cases:
        cm = CaseModel(mech, case)
        out = cm.outputs()
        torque = out["motor_load_torque"] + inertia * out["motor_acceleration"]
        f = ca.Function("f", [mech.s, mech.p], ca.substitute([torque * out["motor_speed"]], [mech.p],
                                                             [cm.case_parameters(mech.p)]))
        model = np.asarray(f.map(len(s))(s[None, :], p_values)).ravel()
        ref = reference_power(s, d, case.name, inertia)
        scale = np.max(np.abs(ref))
        assert scale > 1e3, case.name                      # a real power, kilowatts
        assert np.max(np.abs(model - ref)) <= 1e-7 * scale, (case.name, np.max(np.abs(model - ref)) / scale)
