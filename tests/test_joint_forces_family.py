"""Joint forces of a family of four-bars (issue 30), each against Newton-Euler written here with
its own kinematics: no optdesign kinematics.

Machines from a Sobol sequence (scipy.stats.qmc) over the geometry (crank r, coupler l, rocker
c, the rocker's pivot D), the three links' masses, centres of mass and inertias, a spring from
a fixed point E to the coupler's pin C, an applied torque on the rocker and gravity, driven at a
crank speed and acceleration; kept where the crank turns fully (Grashof) with a transmission
angle between 20 and 160 deg over the stroke.  Positions in closed form (C on the left of B->D),
velocities and accelerations from the loop B + l e3 = D + c e4 differentiated once and twice
(2 x 2 solves); each link's balance (d'Alembert) gives the forces at A, B, C, D and the drive
torque (9 x 9 per sample).  Every pin force's components and the torque agree with the tool to
1e-10 of the largest pin force (the torque: of its own peak; measured: 5.5e-15 at worst over
the 8 machines), and the tool's two routes (the reactions' power, the drive load by virtual
work) hold to 1e-12.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import qmc

import optdesign

from test_joint_forces import tool

G = 9.81
LOW = np.array([0.10, 0.45, 0.35, 0.45, -0.25, 0.5, 0.5, 0.5, 0.0, 0.0, 100.0, -5.0, 1.0, -3.0])
HIGH = np.array([0.25, 0.95, 0.85, 0.95, 0.25, 4.0, 6.0, 5.0, 0.5, 0.5, 3000.0, 5.0, 6.0, 3.0])
# r, l, c, xD, yD, m2, m3, m4, a3 (coupler com along, fraction), a4 (rocker), k, T4, w, alpha


def _perp(v):
    return np.array([-v[1], v[0]])


def kinematics(x, phi):
    """Positions, velocities, accelerations of B and C, and the links' angles, rates and
    accelerations, at crank angles ``phi`` (crank speed w, acceleration alpha)."""
    r, l, c, xD, yD = x[:5]
    w, alpha = x[12], x[13]
    D = np.array([xD, yD])[:, None]
    e2 = np.array([np.cos(phi), np.sin(phi)])
    B = r * e2
    d = D - B
    dist = np.hypot(*d)
    u = d / dist
    along = (l**2 - c**2 + dist**2) / (2 * dist)
    h = np.sqrt(l**2 - along**2)
    C = B + along * u + h * _perp(u)
    e3, e4 = (C - B) / l, (C - D) / c
    # velocity loop: r w e2p + l w3 e3p = c w4 e4p
    p2, p3, p4 = _perp(e2), _perp(e3), _perp(e4)
    rhs = -r * w * p2
    M = np.stack([np.stack([l * p3[0], -c * p4[0]], -1), np.stack([l * p3[1], -c * p4[1]], -1)], 1)   # (n, 2, 2)
    w3, w4 = np.linalg.solve(M, rhs.T[..., None])[..., 0].T
    # acceleration loop: r al p2 - r w^2 e2 + l a3 p3 - l w3^2 e3 = c a4 p4 - c w4^2 e4
    rhs = -(r * alpha * p2 - r * w**2 * e2 - l * w3**2 * e3 + c * w4**2 * e4)
    a3, a4 = np.linalg.solve(M, rhs.T[..., None])[..., 0].T
    vB, aB = r * w * p2, r * alpha * p2 - r * w**2 * e2
    vC = c * w4 * p4
    aC = c * a4 * p4 - c * w4**2 * e4
    angles = {"crank": (phi, w + 0 * phi, alpha + 0 * phi), "coupler": (np.arctan2(e3[1], e3[0]), w3, a3),
              "rocker": (np.arctan2(e4[1], e4[0]), w4, a4)}
    return {"A": (0 * B, 0 * B, 0 * B), "B": (B, vB, aB), "C": (C, vC, aC), "D": (D + 0 * B, 0 * B, 0 * B)}, angles


def _machine(x):
    """The scene of machine ``x`` (TOML) and its links' numbers."""
    r, l, c, xD, yD, m2, m3, m4, f3, f4, k, T4, w, alpha = (float(v) for v in x)
    links = {"crank": ("A", "B", m2, (0.4 * r, 0.02), 0.5 * m2 * r**2 / 12, 0.0),
             "coupler": ("B", "C", m3, (f3 * l, 0.03), m3 * l**2 / 12, 0.0),
             "rocker": ("D", "C", m4, (f4 * c, -0.02), m4 * c**2 / 12, T4)}
    bodies = "".join(f"""
[[bodies]]
name = "{name}"
frame = ["{o}", "{q}"]
mass = {m!r}
com = [{com[0]!r}, {com[1]!r}]
inertia = {inertia!r}
torque = {torque!r}
""" for name, (o, q, m, com, inertia, torque) in links.items())
    text = f"""
title = "family four-bar"
[sweep]
name = "phi"
from = 0
to = "2*pi"
samples = 73
[points]
A = {{ fixed = [0, 0] }}
D = {{ fixed = [{xD!r}, {yD!r}] }}
E = {{ fixed = [-0.3, 0.6] }}
B = {{ polar = ["A", {r!r}, "phi"] }}
C = {{ dyad = ["B", {l!r}, "D", {c!r}], side = "left" }}
{bodies}
[[forces]]
name = "spring"
kind = "spring"
between = ["E", "C"]
rate = {k!r}
free_length = 0.5
[gravity]
g = {G}
[drive]
type = "rotary"
crank = ["A", "B"]
speed = {w!r}
acceleration = {alpha!r}
"""
    return text, links


def machines(count=8):
    """Sobol points in the box, the first ``count`` whose crank turns fully with a transmission
    angle in [20, 160] deg."""
    out = []
    for x in qmc.scale(qmc.Sobol(14, seed=30).random(256), LOW, HIGH):
        r, l, c, xD, yD = x[:5]
        d = np.hypot(xD, yD)
        if not (r < min(l, c, d) and r + max(l, c, d) <= l + c + d - max(l, c, d)):   # Grashof, the crank shortest
            continue
        phi = np.linspace(0, 2 * np.pi, 721)
        P, _ = kinematics(x, phi)
        if not np.all(np.isfinite(P["C"][0])):
            continue
        e3, e4 = P["C"][0] - P["B"][0], P["C"][0] - P["D"][0]
        gamma = np.arccos(np.sum(e3 * e4, axis=0) / (l * c))
        if np.all((gamma > np.radians(20)) & (gamma < np.radians(160))):
            out.append(x)
        if len(out) == count:
            break
    return out


def newton_euler(x, links, phi):
    """Unknowns: the ground on the crank at A, the crank on the coupler at B, the coupler on the
    rocker at C, the ground on the rocker at D, the drive torque.  The spring pulls the pin C
    towards E: the node's balance puts it on the coupler (the first party at C)."""
    P, angles = kinematics(x, phi)
    n = len(phi)
    pos = {k: v[0] for k, v in P.items()}
    E = np.array([-0.3, 0.6])[:, None]
    dC = E - pos["C"]
    L = np.hypot(*dC)
    spring = x[10] * (L - 0.5) * dC / L
    known = {}
    for name, (o, q, m, (a, b), inertia, torque) in links.items():
        phi_b, omega, eps = angles[name]
        rho = np.array([a * np.cos(phi_b) - b * np.sin(phi_b), a * np.sin(phi_b) + b * np.cos(phi_b)])
        aG = P[o][2] + eps * _perp(rho) - omega**2 * rho
        f = m * (np.array([0, -G])[:, None] - aG)
        moment = rho[0] * f[1] - rho[1] * f[0] + torque - inertia * eps
        if name == "coupler":   # the spring's pull at C
            arm = pos["C"] - pos["B"]
            f, moment = f + spring, moment + arm[0] * spring[1] - arm[1] * spring[0]
        known[name] = (f, moment)
    cols = {"crank": (("A", 0, 1), ("B", 2, -1)), "coupler": (("B", 2, 1), ("C", 4, -1)),
            "rocker": (("C", 4, 1), ("D", 6, 1))}
    origin = {"crank": "A", "coupler": "B", "rocker": "D"}
    out = np.zeros((9, n))
    for i in range(n):
        M, rhs = np.zeros((9, 9)), np.zeros(9)
        for k, name in enumerate(cols):
            o = pos[origin[name]][:, i]
            for point, col, sign in cols[name]:
                arm = pos[point][:, i] - o
                M[3 * k, col] += sign
                M[3 * k + 1, col + 1] += sign
                M[3 * k + 2, col] += -sign * arm[1]
                M[3 * k + 2, col + 1] += sign * arm[0]
            if name == "crank":
                M[3 * k + 2, 8] = 1.0
            rhs[3 * k: 3 * k + 2] = -known[name][0][:, i]
            rhs[3 * k + 2] = -known[name][1][i]
        out[:, i] = np.linalg.solve(M, rhs)
    RA, RB, RC, RD = out[0:2], out[2:4], out[4:6], out[6:8]
    return {"pin A": -RA, "pin B": -RB, "pin C": spring - RC, "pin D": -RD, "drive": out[8]}


FAMILY = machines()


def test_the_family_is_there():
    assert len(FAMILY) == 8


@pytest.mark.parametrize("x", FAMILY, ids=[f"fourbar{i}" for i in range(len(FAMILY))])
def test_fourbar_family_against_newton_euler(x):
    text, links = _machine(x)
    out, s = tool(optdesign.loads(text), 73)
    ours = newton_euler(x, links, s)
    scale = max(np.max(np.hypot(*ours[k])) for k in ("pin A", "pin B", "pin C", "pin D"))
    for k in ("pin A", "pin B", "pin C", "pin D"):
        assert np.max(np.abs(out[k] - ours[k])) <= 1e-10 * scale, (k, np.max(np.abs(out[k] - ours[k])) / scale)
    T = ours["drive"]
    assert np.max(np.abs(out["drive"].ravel() - T)) <= 1e-10 * np.max(np.abs(T))
    # inside the tool: the reactions' power sums to zero, the drive load is the virtual-work one
    assert np.all(np.abs(out["power"]) <= 1e-12 * np.max(out["power size"]))
    assert np.max(np.abs(out["u"] - out["drive"])) <= 1e-12 * np.max(np.abs(T))
