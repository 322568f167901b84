"""Power balance of the reduced model (issue 3, "Done when" item 2).

At every sample of every shipped scene with a ``[drive]`` (problems/*.toml, found by glob so
that new scenes are covered as they are added) and of two test-built scenes (a four-bar closed
by a Newton-solved loop, MX graphs; the jib with an extra force, torque and moment of inertia),
the drive power must balance the mechanism:

    P_in = T_S * qd  (F_S * v_S for a linear drive)       drive power, from the reduced model
    P_u  = dE/dt - P_applied                             what the mechanism takes, independent
    dE/dt     = sum m v_C . a_C + I omega epsilon        (rate of kinetic energy)
    P_applied = sum F . v_C + T omega - m g v_Cy         (power of the applied loads and weight)

and with the seed's efficiency rule (eqs. 5, 26 and the closing remarks of sections 2.4/3.4):
P_u = eta P_in while the drive delivers power (P_in > 0), P_in = eta P_u while power flows back
into it (P_in < 0).  The right-hand side is computed here in plain numpy from
optdesign.kinematics (point velocities and accelerations, body omegas and epsilons)
and from the masses and loads as written in the scene, never from the reduced model.

Tolerance: |P_in - expected| <= 1e-9 * (|P_in| + |dE/dt| + |P_applied|) at each sample (the
size of the balance there), or <= 1e-13 * the stroke's peak of that size at samples where every
term vanishes to round-off (the slider-crank's piston at its dead centres, where v_C = 0).
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from optdesign.model.analysis import analyse
from optdesign.scene.expressions import constant_value, evaluate
from optdesign.kinematics.mechanism import kinematics
from optdesign.scene.file import load, loads

PROBLEMS = Path(__file__).resolve().parent.parent / "problems"
RTOL = 1e-9
FLOOR = 1e-13

# A four-bar closed by seed 2's Newton-solved loop (MX graphs), with every body massive and
# rotating, a force, a torque and weight: the generic case of the reduced model.
FOURBAR_LOOP = """
title = "test: four-bar loop with masses, loads and a rotary drive"
[parameters]
R = 0.4
L = 0.2
[sweep]
name = "phi1"
from = "20 deg"
to = "60 deg"
samples = 41
[points]
A = { fixed = [0, 0] }
D = { fixed = ["L", 0] }
[points.chain]
loop = "A"
lengths = ["R", "L", "R"]
angles = ["phi1", "phi2", "phi3"]
joints = ["B", "C", "D3"]
unknowns = { phi2 = "90 deg", phi3 = "pi - phi1" }
closure = { point = "D3", fixed = "D" }
[[bodies]]
name = "crank"
frame = ["A", "B"]
mass = 1.5
com = ["R/2", 0.01]
inertia = 0.02
force = [30, -5]
[[bodies]]
name = "coupler"
frame = ["B", "C"]
mass = 0.8
com = ["L/2", 0.05]
inertia = 0.01
torque = 3.0
[[bodies]]
name = "rocker"
frame = ["D", "C"]
mass = 2.0
com = [0.2, -0.03]
inertia = 0.05
force = [5, -20]
torque = -1.5
[gravity]
g = 9.81
[drive]
type = "rotary"
crank = ["A", "B"]
speed = 3.0
acceleration = 2.0
"""


# The same four-bar with one force element of each kind (issue 30): a spring with a preload
# from the ground to the coupler, a gas spring by its table from the ground to the rocker, a
# damper across the coupler's ends, a constant pull, and torsion springs between the ground
# and the crank and between the coupler and the rocker.  The strut's compression runs from
# 0.074 to 0.197 m: over two segments of its table and beyond its last row.
FOURBAR_FORCES = FOURBAR_LOOP + """
[[forces]]
name = "counterbalance"
kind = "spring"
between = ["A", "C"]
rate = 800.0
length = 0.3
preload = 120.0
[[forces]]
name = "strut"
kind = "gas_spring"
between = ["B", "D"]
extended_length = 0.42
table = [[0.0, 150.0], [0.05, 180.0], [0.12, 260.0], [0.18, 300.0]]
[[forces]]
name = "damper"
kind = "damper"
between = ["A", "C"]
rate = 55.0
[[forces]]
name = "cable"
kind = "constant"
between = ["B", "D"]
tension = 40.0
[[forces]]
name = "crank spring"
kind = "torsion"
bodies = ["crank"]
rate = 12.0
free_angle = "10 deg"
[[forces]]
name = "knee spring"
kind = "torsion"
bodies = ["coupler", "rocker"]
rate = 7.0
angle = "-20 deg"
preload = 4.0
"""


def shipped_scenes():
    """Every shipped scene with a [drive]: (id, scene)."""
    out = []
    for path in sorted(PROBLEMS.glob("*.toml")):
        scene = load(path)
        if scene.drive is not None:
            out.append((path.stem, scene))
    return out


def jib_with_extra_loads():
    """The seed-1 jib with a moment of inertia, a horizontal force and a torque on its body, so
    that R_e (linear drive, rotating body) and the torque's sign are balanced as well."""
    scene = load(PROBLEMS / "seed1_jib.toml")
    body = dataclasses.replace(scene.bodies[0], inertia=800.0, force=(1500.0, 0.0), torque=-2500.0)
    return dataclasses.replace(scene, bodies=(body,))


def all_scenes():
    scenes = shipped_scenes()
    assert any(s.drive.kind == "rotary" for _, s in scenes) and any(s.drive.kind == "linear" for _, s in scenes), \
        "the shipped scenes should include the seed-1 slider-crank (rotary) and jib (linear)"
    scenes.append(("test_fourbar_loop", loads(FOURBAR_LOOP, "<test fourbar loop>")))
    scenes.append(("test_jib_extra_loads", jib_with_extra_loads()))
    scenes.append(("test_fourbar_forces", loads(FOURBAR_FORCES, "<test fourbar forces>")))
    return scenes


SCENES = all_scenes()


def drive_values(scene):
    """The drive's speed and acceleration as numbers (they are constants of the scene)."""
    values = scene.parameter_values()
    d = scene.drive
    return constant_value(d.speed, values, "speed"), constant_value(d.acceleration, values, "acceleration")


def with_drive(scene, speed, acceleration, efficiency):
    """A copy of ``scene`` whose drive runs at the given speed/acceleration and efficiency."""
    drive = dataclasses.replace(scene.drive, speed=speed, acceleration=acceleration, efficiency=efficiency)
    return dataclasses.replace(scene, drive=drive)


def variants(scene):
    """(label, scene) with eta = 1 and with eta < 1 moving forwards and backwards and
    accelerating or braking, so that power flows both ways."""
    v0, a0 = drive_values(scene)
    v = v0 if v0 != 0 else 1.0
    a = a0 if a0 != 0 else abs(v)
    return [
        ("eta=1", with_drive(scene, v, a, None)),
        ("eta=0.8 +v +a", with_drive(scene, v, a, 0.8)),
        ("eta=0.8 -v +a", with_drive(scene, -v, a, 0.8)),
        ("eta=0.7 +v -a", with_drive(scene, v, -3 * a, 0.7)),
        ("eta=0.6 -v -a", with_drive(scene, -v, -3 * a, 0.6)),
    ]


def _numeric(expr, scene, s, points, n):
    """A scene expression (parameters, sweep, points) evaluated over the samples, in numpy."""
    values = dict(scene.parameter_values())
    values[scene.sweep.name] = ca.DM(s[None, :])
    pts = {k: ca.DM(np.vstack([p["x"], p["y"]])) for k, p in points.items()}
    out = evaluate(expr, values, pts, "test")
    return np.broadcast_to(np.asarray(ca.DM(out)).ravel() if not isinstance(out, (int, float)) else out, (n,))


def mechanism_power(scene):
    """dE/dt and P_applied per sample from the kinematics and the scene's masses and loads."""
    kin = kinematics(scene)
    n = len(kin.s)
    g = 0.0 if scene.gravity is None else constant_value(scene.gravity.g, scene.parameter_values(), "g")
    dEdt = np.zeros(n)
    applied = np.zeros(n)
    num = lambda e: _numeric(e, scene, kin.s, kin.points, n)  # noqa: E731
    for b in scene.bodies:
        body = kin.bodies[b.name]
        phi, omega, eps = body["angle"], body["omega"], body["epsilon"]
        if b.com is not None:
            o = kin.points[b.frame[0]]
            ca_, cb = num(b.com[0]), num(b.com[1])
            # centre of mass: origin + a e_x + b e_y, e_x = (cos phi, sin phi), e_y = e_x turned +90 deg
            rho = np.array([ca_ * np.cos(phi) - cb * np.sin(phi), ca_ * np.sin(phi) + cb * np.cos(phi)])
            k_rho = np.array([-rho[1], rho[0]])  # k x rho
            v = np.array([o["vx"], o["vy"]]) + omega * k_rho
            a = np.array([o["ax"], o["ay"]]) + eps * k_rho - omega**2 * rho
            if b.mass is not None:
                m = num(b.mass)
                dEdt += m * (v[0] * a[0] + v[1] * a[1])
                applied += -m * g * v[1]
            if b.force is not None:
                fx, fy = num(b.force[0]), num(b.force[1])
                applied += fx * v[0] + fy * v[1]
        if b.inertia is not None:
            dEdt += num(b.inertia) * omega * eps
        if b.torque is not None:
            applied += num(b.torque) * omega
    applied += forces_power(scene, kin, num)
    return kin, dEdt, applied


def forces_power(scene, kin, num):
    """The power of the scene's [[forces]] from the kinematics, by their laws as written in
    docs/scenes.md: an element of tension T (pulling its points together) between P and Q takes
    T dL/dt, a torsion spring of torque M (turning B back towards its reference angle) takes
    M (omega_B - omega_A); a damper's tension is c dL/dt."""
    power = 0.0
    for f in scene.forces:
        n = {k: num(e) for k, e in f.numbers.items()}
        if f.kind == "torsion":
            bodies = [kin.bodies[b] for b in f.bodies]
            theta = bodies[-1]["angle"] - (bodies[0]["angle"] if len(bodies) == 2 else 0)
            omega = bodies[-1]["omega"] - (bodies[0]["omega"] if len(bodies) == 2 else 0)
            ref = n.get("free_angle", n.get("angle"))
            turned = np.mod(theta - ref + np.pi, 2 * np.pi) - np.pi
            power = power - (n.get("preload", 0.0) + n["rate"] * turned) * omega
            continue
        p, q = (kin.points[name] for name in f.between)
        d = np.array([q["x"] - p["x"], q["y"] - p["y"]])
        v = np.array([q["vx"] - p["vx"], q["vy"] - p["vy"]])
        length = np.hypot(d[0], d[1])
        rate = (d[0] * v[0] + d[1] * v[1]) / length
        if f.kind == "spring":
            ref = n.get("free_length", n.get("length"))
            tension = n.get("preload", 0.0) + n["rate"] * (length - ref)
        elif f.kind == "damper":
            tension = n["rate"] * rate
        elif f.kind == "constant":
            tension = n["tension"]
        elif f.table is not None:
            x, y = np.array(f.table).T
            c = n["extended_length"] - length
            inside = np.interp(c, x, y)
            below = y[0] + (y[1] - y[0]) / (x[1] - x[0]) * (c - x[0])
            above = y[-1] + (y[-1] - y[-2]) / (x[-1] - x[-2]) * (c - x[-1])
            tension = -np.where(c < x[0], below, np.where(c > x[-1], above, inside))
        else:
            stroke = (n["extended_length"] - length) / (n["extended_length"] - n["compressed_length"])
            tension = -n["extended_force"] * (1 + (n["progression"] - 1) * stroke)
        power = power - tension * rate
    return power


def check_balance(scene, label):
    """Assert the power balance at every sample; return the signs of P_in seen."""
    result = analyse(scene)
    kin, dEdt, applied = mechanism_power(scene)
    np.testing.assert_allclose(result.columns["s"], kin.s, rtol=0, atol=0)
    qd, _ = drive_values(scene)
    eta = 1.0 if scene.drive.efficiency is None else constant_value(scene.drive.efficiency, {}, "eta")
    P_in = result.columns["drive"] * qd
    P_u = dEdt - applied
    expected = np.where(P_u > 0, P_u / eta, P_u * eta)
    size = np.abs(P_in) + np.abs(dEdt) + np.abs(applied)
    tol = np.maximum(RTOL * size, FLOOR * size.max())
    err = np.abs(P_in - expected)
    bad = np.flatnonzero(~(err <= tol))
    assert not bad.size, (
        f"{label}: power balance fails at {bad.size} samples, first {scene.sweep.name} = {kin.s[bad[0]]:.6g}: "
        f"P_in = {P_in[bad[0]]:.12g}, expected {expected[bad[0]]:.12g} (dE/dt {dEdt[bad[0]]:.6g}, "
        f"P_applied {applied[bad[0]]:.6g}, eta {eta})"
    )
    significant = size > 1e-6 * size.max()
    return set(np.sign(P_in[significant]).astype(int)) - {0}


@pytest.mark.parametrize("name,scene", SCENES, ids=[n for n, _ in SCENES])
def test_power_balance_every_sample(name, scene):
    """Drive power = d/dt(kinetic energy) + power against the loads, eta = 1 and eta < 1,
    and eta < 1 is exercised in both power-flow directions."""
    signs_with_losses = set()
    for label, sc in variants(scene):
        signs = check_balance(sc, f"{name} [{label}]")
        if sc.drive.efficiency is not None:
            signs_with_losses |= signs
    assert signs_with_losses == {-1, 1}, (
        f"{name}: the eta < 1 variants should make power flow both ways (signs of P_in seen: "
        f"{sorted(signs_with_losses)}); choose other speeds/accelerations in variants()"
    )


def test_balance_detects_a_wrong_efficiency_rule():
    """The check can fail: the jib lowering its load (power flows back into the cylinder) with
    eta applied the wrong way round (dividing instead of multiplying) misses by 1/eta^2."""
    scene = load(PROBLEMS / "seed1_jib.toml")
    v0, a0 = drive_values(scene)
    lowering = with_drive(scene, -v0, a0, 0.8)
    result = analyse(lowering)
    _, dEdt, applied = mechanism_power(lowering)
    P_in = result.columns["drive"] * -v0
    P_u = dEdt - applied
    assert np.all(P_u < 0), "lowering the weight at constant speed returns power to the drive"
    np.testing.assert_allclose(P_in, 0.8 * P_u, rtol=RTOL)
    assert np.all(np.abs(P_in - P_u / 0.8) > 0.3 * np.abs(P_u))
