"""Closed-form dyads against Newton-solved loops (seed 2's transmission matrices).

One four-bar and one slider-crank are each built twice, once from ``dyad``/``slider``
constructions (closed form, SX graphs) and once as a ``loop`` whose unknown angles Newton finds
(MX graphs, derivatives through the implicit function theorem).  Over a full crank revolution,
on both assembly branches, positions, velocities and accelerations of every shared point and
the angular motion of every body must agree to 1e-10.  Neither build is the reference for the
other: they share nothing but the scene language, so a slip in either one shows.

The four-bar is a Grashof crank-rocker (crank + coupler < rocker + ground) and the slider-crank
has its rod longer than crank plus line offset, so neither meets a singular position anywhere
in the revolution.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

import optdesign as od

AGREE = 1e-10
SAMPLES = 145  # 2.5 degrees apart over the full revolution
MOTION = 'rate = 2.5\nacceleration = -1.3'

FOURBAR_HEAD = f"""
title = "crank-rocker"
[parameters]
a = 0.2        # crank AB
b = 0.6        # coupler BC
c = 0.5        # rocker DC
xD = 0.5
yD = -0.15     # ground pivot D: |AD| = 0.522, so a + b = 0.8 < c + |AD| = 1.022
[sweep]
name = "phi"
from = 0
to = "2*pi"
samples = {SAMPLES}
{MOTION}
[points]
A = {{ fixed = [0, 0] }}
D = {{ fixed = ["xD", "yD"] }}
"""

FOURBAR_BODIES = """
[[bodies]]
name = "coupler"
frame = ["B", "C"]
inertia = 1.0
[[bodies]]
name = "rocker"
frame = ["D", "C"]
inertia = 1.0
"""


def fourbar_dyad(side):
    return od.loads(FOURBAR_HEAD + f"""
B = {{ polar = ["A", "a", "phi"] }}
C = {{ dyad = ["B", "b", "D", "c"], side = "{side}" }}
""" + FOURBAR_BODIES, f"<fourbar dyad {side}>")


def fourbar_loop(side):
    """The same four-bar as a closed loop A -> B -> C -> D3 = D.

    Initial guesses follow the branch: with beta (at B) and delta (at D) the triangle B C D's
    angles (here 43..56 and 55..91 degrees), C to the left of B -> D has coupler angle
    th2 = dir(B -> D) + beta and rocker link angle th3 = dir(C -> D) = dir(D -> B) - delta + pi;
    the guesses take beta = 50 deg, delta = 73 deg and turn them into relative angles."""
    sign = 1 if side == "left" else -1
    to_D = "atan2(yD - a*sin(phi), xD - a*cos(phi))"  # dir(B -> D); dir(D -> B) = to_D + pi
    th2 = f"({to_D} + {sign}*50 deg)"
    th3 = f"({to_D} - {sign}*73 deg)"
    return od.loads(FOURBAR_HEAD + f"""
[points.chain]
loop = "A"
lengths = ["a", "b", "c"]
angles = ["phi", "phi2", "phi3"]
joints = ["B", "C", "D3"]
unknowns = {{ phi2 = "{th2} - phi", phi3 = "{th3} - {th2}" }}
closure = {{ point = "D3", fixed = "D" }}
""" + FOURBAR_BODIES, f"<fourbar loop {side}>")


SLIDER_HEAD = f"""
title = "offset slider-crank"
[parameters]
r = 0.1        # crank OA
l = 0.35       # rod AB
xE = 0.03
yE = -0.04     # a point of the slider line
gamma = "15 deg"   # the line's direction: offset 0.046 < l - r
[sweep]
name = "phi"
from = 0
to = "2*pi"
samples = {SAMPLES}
{MOTION}
[points]
O = {{ fixed = [0, 0] }}
E = {{ fixed = ["xE", "yE"] }}
"""

SLIDER_BODIES = """
[[bodies]]
name = "rod"
frame = ["A", "B"]
inertia = 1.0
"""


def slider_closed_form(side):
    return od.loads(SLIDER_HEAD + f"""
A = {{ polar = ["O", "r", "phi"] }}
B = {{ slider = ["A", "l", "E", "gamma"], side = "{side}" }}
""" + SLIDER_BODIES, f"<slider-crank closed form {side}>")


def slider_loop(side):
    """The same slider-crank as a semi-closed loop O -> A -> B, B on the line (E, gamma).
    'ahead' puts B further along the line's direction than A's foot: the rod points roughly
    along gamma (guess phi2 = gamma - phi); 'behind': roughly against it (gamma + pi - phi)."""
    rod = "gamma" if side == "ahead" else "gamma + pi"
    return od.loads(SLIDER_HEAD + f"""
[points.chain]
loop = "O"
lengths = ["r", "l"]
angles = ["phi", "phi2"]
joints = ["A", "B"]
unknowns = {{ phi2 = "{rod} - phi" }}
closure = {{ point = "B", line = ["E", "gamma"] }}
""" + SLIDER_BODIES, f"<slider-crank loop {side}>")


def assert_same_motion(closed, looped):
    """Every point and body of the closed-form build moves as in the loop build."""
    assert np.array_equal(closed.s, looped.s)
    for name, cols in closed.points.items():
        for key, values in cols.items():
            np.testing.assert_allclose(looped.points[name][key], values, rtol=0, atol=AGREE,
                                       err_msg=f"point {name}.{key}")
    for name, cols in closed.bodies.items():
        for key, values in cols.items():
            other = looped.bodies[name][key]
            if key == "angle":  # the same direction, possibly a whole turn apart after unwrap
                other = values + np.remainder(other - values + math.pi, 2 * math.pi) - math.pi
            np.testing.assert_allclose(other, values, rtol=0, atol=AGREE, err_msg=f"body {name}.{key}")


@pytest.mark.parametrize("side", ["left", "right"])
def test_fourbar_dyad_equals_newton_loop(side):
    closed = od.kinematics(fourbar_dyad(side))
    looped = od.kinematics(fourbar_loop(side))
    assert_same_motion(closed, looped)
    # the loop's end D3 sits on D, at rest, all the way round
    D3 = looped.points["D3"]
    for key, target in (("x", 0.5), ("y", -0.15), ("vx", 0), ("vy", 0), ("ax", 0), ("ay", 0)):
        np.testing.assert_allclose(D3[key], target, rtol=0, atol=AGREE, err_msg=key)


def test_fourbar_branches_are_distinct_and_mirror_about_BD():
    """The two branches really are different assemblies: C and its mirror image in the line BD."""
    left, right = (od.kinematics(fourbar_dyad(s)).points for s in ("left", "right"))
    B = np.array([left["B"]["x"], left["B"]["y"]])
    D = np.array([[0.5], [-0.15]])
    CL = np.array([left["C"]["x"], left["C"]["y"]])
    CR = np.array([right["C"]["x"], right["C"]["y"]])
    assert np.min(np.hypot(*(CL - CR))) > 0.1
    u = (D - B) / np.hypot(*(D - B))
    mirror = B + 2 * np.sum((CL - B) * u, axis=0) * u - (CL - B)
    np.testing.assert_allclose(mirror, CR, atol=1e-12)
    cross = lambda p, q: p[0] * q[1] - p[1] * q[0]  # noqa: E731
    assert np.all(cross(D - B, CL - B) > 0) and np.all(cross(D - B, CR - B) < 0)


@pytest.mark.parametrize("side", ["ahead", "behind"])
def test_slider_crank_closed_form_equals_newton_loop(side):
    closed = od.kinematics(slider_closed_form(side))
    looped = od.kinematics(slider_loop(side))
    assert_same_motion(closed, looped)


def test_slider_branches_lie_on_the_line_on_either_side_of_A():
    """'ahead' lies further along (cos 15, sin 15) than A's foot on the line, 'behind' further back."""
    u = np.array([math.cos(math.radians(15)), math.sin(math.radians(15))])
    E = np.array([0.03, -0.04])
    for side, sign in (("ahead", 1), ("behind", -1)):
        P = od.kinematics(slider_closed_form(side)).points
        A = np.array([P["A"]["x"], P["A"]["y"]])
        B = np.array([P["B"]["x"], P["B"]["y"]])
        assert np.abs((B - E[:, None]).T @ np.array([-u[1], u[0]])).max() < 1e-14
        np.testing.assert_allclose(np.hypot(*(B - A)), 0.35, atol=1e-14)
        assert np.all(sign * (u @ (B - A)) > 0.2)
