"""The energy proof that a catalogue motor cannot fit (design/energy_bound.py), against
independent models: crane_luffing_drive written out in numpy from the toml's numbers (positions,
energies by finite differences in time, the motor's energy with the power-flow switch), a
generated family of one-crank scenes whose feasible designs are found by sampling, and scenes
outside the proof (a spring, a body force, a case without a profile) getting no proof."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.stats import qmc

from optdesign.design.energy_bound import EnergyBound, Unproven
from optdesign.scene import load, loads

ROOT = Path(__file__).resolve().parents[1]
CRANE = ROOT / "problems" / "crane_luffing_drive.toml"
DEG = math.pi / 180

# --- crane_luffing_drive in numpy (numbers from its toml) -------------------------------------
L, B_ALONG, F_BELOW, G = 18.0, 5.0, 0.6, 9.81
M_JIB, M_TAIL, L_TAIL, M_LOAD = 4000.0, 6000.0, 2.5, 1.25 * 3000.0     # the test load
ETA = 0.92 * 0.94
BOX = np.array([[0.5, 4.0], [-4.0, -0.8], [0.8, 2.5], [2.0, 7.0]])     # xO, yO, r, lc
RATIO = (500.0, 6000.0)


def theta_of_t(t):
    """The test load's trapezoid: 20 -> 75 deg, 1 deg/s, 0.25 deg/s^2 up and down (59 s)."""
    a, v, T = 0.25 * DEG, 1.0 * DEG, 59.0
    t = np.asarray(t, float)
    up = 20 * DEG + 0.5 * a * t**2
    cruise = 20 * DEG + 2 * DEG + v * (t - 4)
    down = 75 * DEG - 0.5 * a * (T - t) ** 2
    return np.where(t < 4, up, np.where(t > T - 4, down, cruise))


def crane(design, t):
    """Per time: (assembles, angles OPB and PBA [rad], energy E [J], crank angle q) of a design."""
    xO, yO, r, lc = design
    th = theta_of_t(t)
    e, n = np.stack([np.cos(th), np.sin(th)]), np.stack([-np.sin(th), np.cos(th)])
    Bp = B_ALONG * e - F_BELOW * n
    O = np.array([xO, yO])[:, None]
    d = Bp - O
    dist = np.hypot(*d)
    ok = (dist <= r + lc) & (dist >= abs(r - lc))
    # the circles' intersection to the right of O -> B (negative cross product)
    a = (dist**2 + r**2 - lc**2) / (2 * dist)
    h = np.sqrt(np.maximum(r**2 - a**2, 0.0))
    u = d / dist
    P = O + a * u + h * np.stack([u[1], -u[0]])
    assert np.all(u[0] * (P - O)[1] - u[1] * (P - O)[0] <= 1e-9)
    dt = np.gradient(t)
    vel = lambda x: np.gradient(x, t, axis=-1)  # noqa: E731
    com_jib = 0.45 * L * e
    om = vel(th)
    mR = 130 * lc
    mid = 0.5 * (P + Bp)
    phi = np.unwrap(np.arctan2(*(Bp - P)[::-1]))
    ke = 0.5 * (M_JIB * (0.45 * L) ** 2 + M_JIB * L**2 / 12 + M_TAIL * L_TAIL**2 + M_LOAD * L**2) * om**2
    ke = ke + 0.5 * mR * np.sum(vel(mid) ** 2, axis=0) + 0.5 * mR * lc**2 / 12 * vel(phi) ** 2
    pe = G * (M_JIB * com_jib[1] - M_TAIL * L_TAIL * e[1] + M_LOAD * L * e[1] + mR * mid[1])
    def angle(p, q, s):
        cos = np.sum((p - q) * (s - q), 0) / np.hypot(*(p - q)) / np.hypot(*(s - q))
        return np.arccos(np.clip(cos, -1, 1))
    q = np.unwrap(np.arctan2(*(P - O)[::-1]))
    del dt
    return ok, angle(O, P, Bp), angle(P, Bp, np.zeros((2, 1))), ke + pe, q


def motor_energy(E):
    """int c P dt over a fine grid: c = 1/eta while the energy rises, eta while it falls."""
    dE = np.diff(E)
    return float(np.sum(np.where(dE > 0, dE / ETA, dE * ETA)))


def feasible_kinematics(ok, opb, pba, tol=1e-6):
    lo, hi = 30 * DEG - tol, 150 * DEG + tol
    return bool(np.all(ok) and np.all((opb >= lo) & (opb <= hi)) and np.all((pba >= lo) & (pba <= hi)))


@pytest.fixture(scope="module")
def bound():
    return EnergyBound(load(CRANE))


def _sub_boxes(seed, n, scale):
    """n Sobol designs in the box, each inside a random sub-box of up to ``scale`` of the box."""
    x = qmc.scale(qmc.Sobol(4, seed=seed).random(n), BOX[:, 0], BOX[:, 1])
    rng = np.random.default_rng(seed)
    w = (BOX[:, 1] - BOX[:, 0]) * scale * rng.random((n, 4))
    lo = np.maximum(x - w * rng.random((n, 4)), BOX[:, 0])
    return x, lo, np.minimum(lo + w, BOX[:, 1])


@pytest.mark.parametrize("motor, stage", [((70.0, 157.0, 0.012), "positions"), ((95.0, 157.0, 0.017), "full")])
def test_verdicts_hold_for_designs_in_their_boxes(bound, motor, stage):
    """Every box the proof settles holds the designs sampled in it to the verdict: by energy,
    the design's own motor energy over the window (independent model) is at least the bound's
    need, and what any gear ratio within the speed limit lets the motor give is at most the
    bound's available; by assembly, the design does not assemble or breaks a constraint."""
    tp, wm, jr = motor
    case = next(c for c in bound.cases if c.name == "test load")
    x, lo, hi = _sub_boxes(7 if stage == "positions" else 11, 64, 0.08)
    used = np.flatnonzero(bound.used)
    if stage == "positions":
        verdicts = case.settle_positions(lo.T, hi.T, tp, wm)
    else:
        verdicts = case.settle(lo.T, hi.T, used, tp, wm, jr)
    t = np.union1d(np.linspace(0.0, 59.0, 59 * 400 + 1), case.t)   # (the nodes' times among them)
    seen = {}
    for b, (v, _, info) in enumerate(verdicts):
        seen[v] = seen.get(v, 0) + 1
        if v is None:
            continue
        ok, opb, pba, E, q = crane(x[b], t)
        if v == "assembly":
            assert not feasible_kinematics(ok, opb, pba, tol=-1e-9)
            continue
        if v == "speed" or not feasible_kinematics(ok, opb, pba):
            continue   # (the energy verdict is about designs that assemble: the others are not designs)
        t1, t2 = info["window"]
        inside = (t >= t1 - 1e-9) & (t <= t2 + 1e-9)
        rotor = 0.0 if t1 == 0.0 else -0.5 * jr * wm**2
        assert motor_energy(E[inside]) + rotor >= info["needed"] * (1 - 1e-6)
        qd = np.abs(np.gradient(q, t))
        i_max = min(RATIO[1], wm / qd.max())
        assert tp * i_max * np.trapezoid(qd[inside], t[inside]) <= info["available"] * (1 + 1e-4)
        assert info["needed"] > info["available"]
    assert seen.get("energy", 0) > 0 or stage == "full"


def test_four_kw_proved_and_sampled_designs_agree(bound):
    """The 4 kW motor is proved not to fit; no sampled design that assembles within the
    constraints has, over the proof's window, less motor energy to give than its peak power
    times the window (so none fits: the proof's claim, sampled)."""
    scene = load(CRANE)
    motor = next(m for m in scene.motors if m.name == "4 kW")
    proof = bound.prove(motor)
    assert proof is not None and proof.case == "test load"
    t = np.linspace(0.0, 59.0, 59 * 200 + 1)
    t1, t2 = proof.window
    inside = (t >= t1 - 1e-9) & (t <= t2 + 1e-9)
    x = qmc.scale(qmc.Sobol(4, seed=3).random(256), BOX[:, 0], BOX[:, 1])
    checked = 0
    for design in x:
        ok, opb, pba, E, _ = crane(design, t)
        if feasible_kinematics(ok, opb, pba):
            checked += 1
            assert motor_energy(E[inside]) > 70.0 * 157.0 * (t2 - t1)
    assert checked >= 10


# --- a generated family: one crank lifting an arm ---------------------------------------------
def crank_scene(arm_lo, arm_hi, mass, speed, accel, motors, eta_g):
    rows = "\n".join(f'[[motors]]\nname = "m{k}"\ninertia = {j}\nrated_torque = {tp}\npeak_torque = {tp}\n'
                     f"max_speed = {wm}\n" for k, (tp, wm, j) in enumerate(motors))
    return f"""
title = "arm"
[parameters]
a = {{ value = {0.5 * (arm_lo + arm_hi)}, min = {arm_lo}, max = {arm_hi} }}
i = {{ value = 50, min = 10, max = 200 }}
m = {mass}
[sweep]
name = "q"
from = "-30 deg"
to = "60 deg"
samples = 61
[points]
O = {{ fixed = [0, 0] }}
T = {{ polar = ["O", "a", "q"] }}
[[bodies]]
name = "arm"
frame = ["O", "T"]
mass = "m*a"
com = ["a/2", 0]
inertia = "m*a^3/12"
[gravity]
g = 9.81
[drive]
type = "rotary"
crank = ["O", "T"]
speed = 1.0
acceleration = 0.0
efficiency = 0.9
[gearbox]
ratio = "i"
efficiency = {eta_g}
[profiles.p]
kind = "trapezoidal"
speed = {speed}
acceleration = {accel}
deceleration = {accel}
[[cases]]
name = "up"
direction = "forward"
profile = "p"
{rows}
[objective]
minimise = "peak(motor_torque)"
"""


def arm_fits(a, i, mass, speed, accel, motor, eta_g):
    """Whether the arm of length ``a`` with ratio ``i`` meets the motor's peak torque and speed
    over the stroke (independent: closed-form trapezoid, Lagrange's equation for one link)."""
    tp, wm, jr = motor
    q0, q1 = -30 * DEG, 60 * DEG
    length = q1 - q0
    ta, vtop = speed / accel, speed
    T = 2 * ta + (length - accel * ta**2) / vtop
    t = np.linspace(0, T, 4001)
    qd = np.where(t < ta, accel * t, np.where(t > T - ta, accel * (T - t), vtop))
    qdd = np.where(t < ta, accel, np.where(t > T - ta, -accel, 0.0))
    q = q0 + np.concatenate([[0.0], np.cumsum(0.5 * (qd[1:] + qd[:-1]) * np.diff(t))])
    m = mass * a
    inertia = m * a**2 / 12 + m * (a / 2) ** 2
    u = inertia * qdd + m * 9.81 * (a / 2) * np.cos(q)
    power = u * qd
    c = np.where(power >= 0, 1 / (0.9 * eta_g), 0.9 * eta_g)
    torque = c * u / i + jr * i * qdd
    return bool(np.all(np.abs(torque) <= tp * (1 - 1e-3)) and np.all(i * qd <= wm * (1 - 1e-3)))


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(arm=st.tuples(st.floats(0.3, 1.0), st.floats(0.1, 1.0)), mass=st.floats(5.0, 50.0),
       speed=st.floats(0.3, 2.0), accel_factor=st.floats(1.05, 10.0), eta_g=st.floats(0.7, 1.0),
       torques=st.lists(st.floats(0.05, 20.0), min_size=2, max_size=2),
       speeds=st.lists(st.floats(20.0, 300.0), min_size=2, max_size=2))
def test_no_proof_for_a_motor_with_a_feasible_design(arm, mass, speed, accel_factor, eta_g, torques, speeds):
    """A motor for which sampling finds a feasible design (independent model) is never proved
    not to fit."""
    accel = speed**2 / (90 * DEG) * accel_factor   # the top speed reached within the stroke
    lo, hi = arm[0], arm[0] + arm[1]
    motors = [(tp, wm, 1e-4) for tp, wm in zip(torques, speeds)]
    scene = loads(crank_scene(lo, hi, mass, speed, accel, motors, eta_g))
    bound = EnergyBound(scene)
    grid = [(a, i) for a in np.linspace(lo, hi, 9) for i in np.geomspace(10, 200, 25)]
    for motor, m in zip(motors, scene.motors):
        fits = any(arm_fits(a, i, mass, speed, accel, motor, eta_g) for a, i in grid)
        proof = bound.prove(m)
        if fits:
            assert proof is None


def test_crank_family_proves_a_hopeless_motor():
    """A motor far too weak for the arm (its peak power below the mean power of the lift) is
    proved not to fit: the proof is not vacuous on the family."""
    scene = loads(crank_scene(0.5, 1.0, 40.0, 1.0, 2.0, [(0.05, 100.0, 1e-4), (50.0, 300.0, 1e-4)], 0.9))
    bound = EnergyBound(scene)
    assert bound.prove(scene.motors[0]) is not None
    assert bound.prove(scene.motors[1]) is None


# --- scenes outside the proof -------------------------------------------------------------------
def _crane_text():
    return CRANE.read_text()


@pytest.mark.parametrize("extra, why", [
    ('\n[[forces]]\nname = "spring"\nkind = "spring"\nbetween = ["O", "B"]\nrate = 1000\nfree_length = 3\n', "forces"),
    ('\n[[forces]]\nname = "damper"\nkind = "damper"\nbetween = ["O", "B"]\nrate = 1000\n', "forces"),
])
def test_forces_give_no_proof(extra, why):
    text = _crane_text().replace("[gravity]", extra + "\n[gravity]")
    try:
        scene = loads(text, str(CRANE))
    except Exception as exc:   # noqa: BLE001 - the element's syntax: shown
        pytest.fail(f"scene did not load: {exc}")
    with pytest.raises(Unproven, match=why):
        EnergyBound(scene)


def test_body_force_gives_no_proof():
    text = _crane_text().replace('mass = "mP"\ncom = ["L", 0]', 'mass = "mP"\ncom = ["L", 0]\nforce = [500, 0]')
    assert "force = [500, 0]" in text
    with pytest.raises(Unproven, match="force"):
        EnergyBound(loads(text, str(CRANE)))


def test_catalogue_keeps_the_starts_without_a_proof():
    """A catalogue whose scene has a spring: no proof, Prover says why."""
    from optdesign.design.catalogue import Prover

    text = _crane_text().replace("[gravity]", '[[forces]]\nname = "s"\nkind = "spring"\nbetween = ["O", "B"]\n'
                                 'rate = 1000\nfree_length = 3\n\n[gravity]')
    scene = loads(text, str(CRANE))
    prover = Prover(scene)
    assert prover.prove(scene.motors[0]) is None and "forces" in prover.why


def test_a_proved_motor_in_the_catalogues_json_and_summary():
    """A motor proved not to fit is recorded as not fitting, with its proof, in result.json's
    catalogue (``proofs``, its result's start_plan) and the summary's line of the motor."""
    import json

    from optdesign.design.catalogue import CatalogueResult, proved_result
    from optdesign.report.design import result_json
    from optdesign.report.design_cases import motor_outcomes

    scene = loads(crank_scene(0.5, 1.0, 40.0, 1.0, 2.0, [(0.05, 100.0, 1e-4), (50.0, 300.0, 1e-4)], 0.9))
    proof = EnergyBound(scene).prove(scene.motors[0])
    result = proved_result(scene, proof)
    cat = CatalogueResult({"m0": result}, None, result, ("m1",), motors=tuple(scene.motors), proofs={"m0": proof})
    doc = json.loads(json.dumps(result_json(result, cat)))
    assert doc["motors"] == {"m0": "does not fit", "m1": "not tried"} and doc["chosen_motor"] is None
    p = doc["proofs"]["m0"]
    assert p["energy_needed_J"] > p["energy_available_J"] > 0 and p["window_s"][1] > p["window_s"][0] >= 0
    assert doc["catalogue"]["m0"]["start_plan"]["proof"] == p and doc["catalogue"]["m0"]["starts_total"] == 0
    assert p["bodies"]["arm"].startswith(">=")
    (name, outcome, what), = [o for o in motor_outcomes(cat) if o[1] != "not tried"]
    assert (name, outcome) == ("m0", "does not fit") and "energy proof" in what
    from optdesign.report.drive_train import catalogue_outcome
    shown = catalogue_outcome(doc["motors"]["m0"], p)   # report.html's catalogue table
    assert shown.startswith("does not fit: energy proof") and f"{p['energy_needed_J']:,.0f} J" in shown
    assert catalogue_outcome("fits", None) == "fits"
