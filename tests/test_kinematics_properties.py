"""Properties of the kinematic graphs, checked with hypothesis at random designs and sweep values.

Four mechanisms, each built once with its design and its ground frame as parameters: a
four-bar from a dyad and as a Newton loop, a slider-crank from a slider and as a semi-closed
loop.  The ground frame enters as a rotation ``alpha`` and a shift (tx, ty) applied to every
fixed point and to every angle measured from ground (the crank angle, the slider line).

- AD against central differences: d/ds and d2/ds2 of every point and body angle, and d/dp of
  every point (through the Newton solve for the loops).
- Loop closure: the loops' residuals and the distances of their closing points from D or from
  the slider line stay below 1e-12, and the loops sit on the same branch as the closed forms.
- Moving or rotating the ground frame changes no length(), angle() or distance, turns every
  point, velocity and acceleration by alpha and every body angle by alpha, and leaves the
  angular velocities and accelerations alone.
"""
from __future__ import annotations

import functools
import math

import casadi as ca
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import optdesign as od
from optdesign.scene.expressions import parse

PROFILE = settings(max_examples=30, deadline=None)

FRAME_PARAMS = """
alpha = 0.0    # rotation of the ground frame
tx = 0.0       # shift of the ground frame
ty = 0.0
"""
SWEEP = """
[sweep]
name = "phi"
from = 0
to = "2*pi"
samples = 5
rate = 1.0
acceleration = 0.0
"""

FOURBAR = """
title = "crank-rocker in a moved ground frame"
[parameters]
a = 0.15       # crank AB: 0.1 .. 0.2
b = 0.8        # coupler BC: 0.7 .. 1.0
c = 0.9        # rocker DC: 0.7 .. 1.0
d = 0.85       # ground AD: 0.7 .. 1.0 (so a + max <= 1.2 < 1.4 <= sum of the other two)
""" + FRAME_PARAMS + SWEEP + """
[points]
A = { fixed = ["tx", "ty"] }
D = { fixed = ["tx + d*cos(alpha)", "ty + d*sin(alpha)"] }
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
# triangle B C D at its mean shape (|BD| = d): angles at B and at D, for the loop's guesses
BETA0 = "acos((b^2 + d^2 - c^2)/(2*b*d))"
DELTA0 = "acos((c^2 + d^2 - b^2)/(2*c*d))"
TO_D = "(alpha + atan2(-a*sin(phi), d - a*cos(phi)))"  # direction B -> D


def fourbar_scene(kind, side="left"):
    if kind == "dyad":
        body = f"""
B = {{ polar = ["A", "a", "phi + alpha"] }}
C = {{ dyad = ["B", "b", "D", "c"], side = "{side}" }}
"""
    else:  # guesses: the triangle at its mean shape, on the side's branch (see test_loops_vs_dyads)
        sign = 1 if side == "left" else -1
        th2 = f"({TO_D} + {sign}*{BETA0})"
        th3 = f"({TO_D} - {sign}*{DELTA0})"
        body = f"""
[points.chain]
loop = "A"
lengths = ["a", "b", "c"]
angles = ["phi + alpha", "phi2", "phi3"]
joints = ["B", "C", "D3"]
unknowns = {{ phi2 = "{th2} - phi - alpha", phi3 = "{th3} - {th2}" }}
closure = {{ point = "D3", fixed = "D" }}
"""
    return od.loads(FOURBAR + body + FOURBAR_BODIES, f"<four-bar {kind} {side}>")


SLIDER = """
title = "offset slider-crank in a moved ground frame"
[parameters]
r = 0.1        # crank OA: 0.05 .. 0.2
l = 0.8        # rod AB: 0.6 .. 1.2
e = 0.05       # offset of the line from O: -0.15 .. 0.15 (so r + |e| < l)
""" + FRAME_PARAMS + SWEEP + """
[points]
O = { fixed = ["tx", "ty"] }
E = { fixed = ["tx - e*sin(alpha)", "ty + e*cos(alpha)"] }
"""
SLIDER_BODIES = """
[[bodies]]
name = "rod"
frame = ["A", "B"]
inertia = 1.0
"""


def slider_scene(kind, side="ahead"):
    if kind == "slider":
        body = f"""
A = {{ polar = ["O", "r", "phi + alpha"] }}
B = {{ slider = ["A", "l", "E", "alpha"], side = "{side}" }}
"""
    else:
        rod = "0" if side == "ahead" else "pi"
        body = f"""
[points.chain]
loop = "O"
lengths = ["r", "l"]
angles = ["phi + alpha", "phi2"]
joints = ["A", "B"]
unknowns = {{ phi2 = "{rod} - phi" }}
closure = {{ point = "B", line = ["E", "alpha"] }}
"""
    return od.loads(SLIDER + body + SLIDER_BODIES, f"<slider-crank {kind} {side}>")


SCENES = {
    "fourbar-dyad": lambda: fourbar_scene("dyad"),
    "fourbar-loop": lambda: fourbar_scene("loop"),
    "fourbar-dyad-right": lambda: fourbar_scene("dyad", "right"),
    "fourbar-loop-right": lambda: fourbar_scene("loop", "right"),
    "slider": lambda: slider_scene("slider"),
    "slider-loop": lambda: slider_scene("loop"),
    "slider-behind": lambda: slider_scene("slider", "behind"),
    "slider-loop-behind": lambda: slider_scene("loop", "behind"),
}
MEASURES = {  # length() and angle() expressions per family, evaluated in the mechanism's graph
    "fourbar": ["length(B, D)", "length(A, C)", "angle(B, C, D)", "angle(A, B, C)", "angle(C, D, A)"],
    "slider": ["length(O, B)", "length(A, E)", "angle(O, A, B)", "angle(A, B, E)"],
}


class Graphs:
    """One mechanism's CasADi Functions of (s, p): points, their d/ds and d2/ds2, body angles
    and their derivatives, d(points)/dp, loop residuals, and the length/angle measures."""

    def __init__(self, key):
        self.mech = mech = od.Mechanism(SCENES[key]())
        self.names = list(mech.points)
        self.bodies = list(mech.body_angle)
        X = ca.vertcat(*[mech.points[n] for n in self.names])
        TH = ca.vertcat(*[mech.body_angle[n] for n in self.bodies])
        X_s, TH_s = mech.ds(X), mech.ds(TH)
        family = "fourbar" if key.startswith("fourbar") else "slider"
        measures = ca.vertcat(*[mech.value(parse(m), m) for m in MEASURES[family]])
        residual = ca.vertcat(*[g.residual for g in mech.loops if g.solution is not None] or [ca.DM(0)])
        self.f = mech.function(key.replace("-", "_"), {
            "X": X, "X_s": X_s, "X_ss": mech.ds(X_s), "X_p": ca.jacobian(X, mech.p),
            "TH": TH, "TH_s": TH_s, "TH_ss": mech.ds(TH_s), "measures": measures, "residual": residual,
        })

    def __call__(self, s, **params):
        values = dict(zip(self.mech.parameter_names, self.mech.parameter_values))
        values.update(params)
        p = np.array([values[n] for n in self.mech.parameter_names])
        out = self.f(s=s, p=p)
        res = {k: np.asarray(v, dtype=float).squeeze(-1) if k != "X_p" else np.asarray(v) for k, v in out.items()}
        res["p"] = p
        return res

    def points(self, res):
        return {n: res["X"][2 * i: 2 * i + 2] for i, n in enumerate(self.names)}


@functools.lru_cache(maxsize=None)
def graphs(key) -> Graphs:
    return Graphs(key)


# --- strategies ---------------------------------------------------------------------------
sweep_values = st.floats(0.0, 2 * math.pi)
fourbar_designs = st.fixed_dictionaries({
    "a": st.floats(0.1, 0.2), "b": st.floats(0.7, 1.0), "c": st.floats(0.7, 1.0), "d": st.floats(0.7, 1.0)})
slider_designs = st.fixed_dictionaries({
    "r": st.floats(0.05, 0.2), "l": st.floats(0.6, 1.2), "e": st.floats(-0.15, 0.15)})
frames = st.fixed_dictionaries({
    "alpha": st.floats(-math.pi, math.pi), "tx": st.floats(-5.0, 5.0), "ty": st.floats(-5.0, 5.0)})
FOURBARS = ["fourbar-dyad", "fourbar-loop", "fourbar-dyad-right", "fourbar-loop-right"]
SLIDERS = ["slider", "slider-loop", "slider-behind", "slider-loop-behind"]


def design_for(key, fourbar, slider):
    return fourbar if key.startswith("fourbar") else slider


def wrap(angle):
    """An angle difference brought into (-pi, pi] (body angles jump by 2 pi at atan2's cut)."""
    return np.remainder(angle + math.pi, 2 * math.pi) - math.pi


# --- AD against central differences ---------------------------------------------------------
# Step and tolerance: a central difference with step h errs by h^2/6 |f'''| (truncation, about
# 2e-11 here) plus about eps |f| / h (rounding; 1e-11 for the closed forms, and up to 1e-9 for
# the loops, whose Newton solution carries up to 1e-14 of residual).  TOL = 1e-7, relative to
# the size of the derivative (at least 1), leaves two orders of margin and still catches any
# wrong term (a missing chain-rule factor is an O(1) error).
H = 1e-5
TOL = 1e-7


def close(ad, fd, tol=TOL):
    scale = max(1.0, float(np.abs(ad).max()))
    return float(np.abs(ad - fd).max()) <= tol * scale, float(np.abs(ad - fd).max()), scale


@PROFILE
@given(key=st.sampled_from(FOURBARS + SLIDERS), s=sweep_values, fourbar=fourbar_designs,
       slider=slider_designs, frame=frames)
def test_ad_first_and_second_derivatives_in_s_match_central_differences(key, s, fourbar, slider, frame):
    g = graphs(key)
    params = {**design_for(key, fourbar, slider), **frame}
    mid, plus, minus = (g(s + k * H, **params) for k in (0, 1, -1))
    # d/ds of the points and body angles against the central difference of the values
    ok, err, scale = close(mid["X_s"], (plus["X"] - minus["X"]) / (2 * H))
    assert ok, f"dX/ds: error {err:.3g} at scale {scale:.3g}"
    ok, err, scale = close(mid["TH_s"], wrap(plus["TH"] - minus["TH"]) / (2 * H))
    assert ok, f"dtheta/ds: error {err:.3g}"
    # d2/ds2 against the central difference of the AD first derivative ...
    ok, err, scale = close(mid["X_ss"], (plus["X_s"] - minus["X_s"]) / (2 * H))
    assert ok, f"d2X/ds2 vs difference of dX/ds: error {err:.3g}"
    ok, err, scale = close(mid["TH_ss"], (plus["TH_s"] - minus["TH_s"]) / (2 * H))
    assert ok, f"d2theta/ds2: error {err:.3g}"
    # ... and against the second difference of the values alone: step 1e-4, rounding
    # 4 eps |f| / h^2 ~ 1e-6 with the frame shifted by up to 5, and for the loops Newton's
    # residual of up to 1e-14 / h^2 = 1e-6; truncation h^2/12 |f''''| ~ 1e-9.  Seen: 2.3e-6
    # in 2400 random cases, so 2e-5 (a wrong term would be O(1)).
    h2 = 1e-4
    p2, m2 = g(s + h2, **params), g(s - h2, **params)
    ok, err, scale = close(mid["X_ss"], (p2["X"] - 2 * mid["X"] + m2["X"]) / h2**2, tol=2e-5)
    assert ok, f"d2X/ds2 vs second difference: error {err:.3g}"


@PROFILE
@given(key=st.sampled_from(FOURBARS + SLIDERS), s=sweep_values, fourbar=fourbar_designs,
       slider=slider_designs, frame=frames, direction=st.lists(st.floats(-1, 1), min_size=7, max_size=7))
def test_ad_derivative_in_the_design_matches_central_difference(key, s, fourbar, slider, frame, direction):
    """d(points)/dp (the optimiser's gradient, through Newton's solve for the loops) along a
    random direction of the parameter vector."""
    g = graphs(key)
    params = {**design_for(key, fourbar, slider), **frame}
    mid = g(s, **params)
    names = g.mech.parameter_names
    u = np.array(direction[: len(names)])
    if not np.any(u):
        u[0] = 1.0
    step = dict(zip(names, mid["p"] + H * u))
    back = dict(zip(names, mid["p"] - H * u))
    fd = (g(s, **step)["X"] - g(s, **back)["X"]) / (2 * H)
    ok, err, scale = close(mid["X_p"] @ u, fd)
    assert ok, f"dX/dp u: error {err:.3g} at scale {scale:.3g}"


# --- loop closure ---------------------------------------------------------------------------
CLOSURE = 1e-12


@PROFILE
@given(side=st.sampled_from(["left", "right"]), s=sweep_values, design=fourbar_designs, frame=frames)
def test_fourbar_loop_closes_on_D_and_on_the_dyads_branch(side, s, design, frame):
    suffix = "" if side == "left" else "-right"
    loop = graphs("fourbar-loop" + suffix)(s, **design, **frame)
    dyad = graphs("fourbar-dyad" + suffix)(s, **design, **frame)
    assert np.abs(loop["residual"]).max() < CLOSURE
    P = graphs("fourbar-loop" + suffix).points(loop)
    Q = graphs("fourbar-dyad" + suffix).points(dyad)
    assert np.hypot(*(P["D3"] - P["D"])) < CLOSURE
    # the links keep their lengths (an independent check of the chain's joints)
    for (p, q), length in ((("A", "B"), design["a"]), (("B", "C"), design["b"]), (("C", "D"), design["c"])):
        assert abs(np.hypot(*(P[q] - P[p])) - length) < CLOSURE
    for name in ("B", "C"):  # Newton found the branch the guesses aimed at
        assert np.abs(P[name] - Q[name]).max() < 1e-10


@PROFILE
@given(side=st.sampled_from(["ahead", "behind"]), s=sweep_values, design=slider_designs, frame=frames)
def test_slider_loop_closes_on_the_line_and_on_the_sliders_branch(side, s, design, frame):
    suffix = "" if side == "ahead" else "-behind"
    loop = graphs("slider-loop" + suffix)(s, **design, **frame)
    closed = graphs("slider" + suffix)(s, **design, **frame)
    assert np.abs(loop["residual"]).max() < CLOSURE
    P = graphs("slider-loop" + suffix).points(loop)
    Q = graphs("slider" + suffix).points(closed)
    normal = np.array([-math.sin(frame["alpha"]), math.cos(frame["alpha"])])
    assert abs(normal @ (P["B"] - P["E"])) < CLOSURE
    assert abs(np.hypot(*(P["B"] - P["A"])) - design["l"]) < CLOSURE
    assert np.abs(P["B"] - Q["B"]).max() < 1e-10


# --- invariance under moving the ground frame -------------------------------------------------
@PROFILE
@given(key=st.sampled_from(FOURBARS + SLIDERS), s=sweep_values, fourbar=fourbar_designs,
       slider=slider_designs, frame=frames)
def test_moving_the_ground_frame_changes_no_length_or_angle(key, s, fourbar, slider, frame):
    g = graphs(key)
    design = design_for(key, fourbar, slider)
    base = g(s, **design, alpha=0.0, tx=0.0, ty=0.0)
    moved = g(s, **design, **frame)
    tol = 1e-12 * (1 + abs(frame["tx"]) + abs(frame["ty"]))
    # length() and angle() measures of the scene language
    np.testing.assert_allclose(moved["measures"], base["measures"], rtol=0, atol=tol)
    # every distance between two points
    P0, P1 = g.points(base), g.points(moved)
    for i, m in enumerate(g.names):
        for n in g.names[i + 1:]:
            assert abs(np.hypot(*(P1[m] - P1[n])) - np.hypot(*(P0[m] - P0[n]))) < tol, (m, n)
    # points turn and shift with the frame; velocities and accelerations (per unit rate) turn
    c, sn = math.cos(frame["alpha"]), math.sin(frame["alpha"])
    rot = np.array([[c, -sn], [sn, c]])
    shift = np.array([frame["tx"], frame["ty"]])
    for key_, offset in (("X", shift), ("X_s", np.zeros(2)), ("X_ss", np.zeros(2))):
        before = base[key_].reshape(-1, 2).T
        after = moved[key_].reshape(-1, 2).T
        np.testing.assert_allclose(after, rot @ before + np.reshape(offset, (2, 1)), rtol=0, atol=tol, err_msg=key_)
    # body angles turn by alpha; their rates do not change
    np.testing.assert_allclose(wrap(moved["TH"] - base["TH"] - frame["alpha"]), 0.0, atol=1e-12)
    np.testing.assert_allclose(moved["TH_s"], base["TH_s"], rtol=0, atol=1e-11)
    np.testing.assert_allclose(moved["TH_ss"], base["TH_ss"], rtol=0, atol=1e-10)


@PROFILE
@given(s=sweep_values, design=fourbar_designs)
def test_mirroring_the_four_bar_swaps_the_dyad_side(s, design):
    """Reflecting in the ground line AD (crank angle -phi) mirrors every point when the dyad
    side is swapped: left and right are each other's mirror images."""
    left = graphs("fourbar-dyad").points(graphs("fourbar-dyad")(s, **design))
    right = graphs("fourbar-dyad-right").points(graphs("fourbar-dyad-right")(-s, **design))
    flip = np.array([1.0, -1.0])
    for name in ("A", "B", "C", "D"):
        np.testing.assert_allclose(right[name], flip * left[name], rtol=0, atol=1e-13, err_msg=name)
