"""What analyse, kinematics, simulate and analyse-mode studies report holds on the whole stroke,
not just at the samples (issue 21).

Every reference is written here, by hand, in numpy, and shares nothing with optdesign but the
scene text:

* a four-bar (crank A->B from the origin, coupler B->C, rocker D->C) with C placed by the law
  of cosines, its velocities and accelerations by solving the differentiated closure equations,
  and the drive torque by the power balance T omega = sum (m v.a + I Omega alpha) + sum m g v_y
  at constant crank speed; its relative dyad margin is sin^2 of the angle at B;
* a slider-crank with the slider on any line, the same way (relative margin 1 - (h/l)^2, h the
  crank pin's distance from the line);
* the crank press of problems/crank_press_peak.toml with its forming force.

A *dense peak* is the largest |value| on 200,001 samples, polished by Brent's method on the
same numpy function (the raw 200,001-sample maximum is checked against it too).

The toggle: with a = 0.10, b = 0.35, c = 0.25 and D = (0.30, 0.40), |AD| + a = 0.6 = b + c, so
once per turn B lies on the line D-A beyond A, |BD| = b + c and coupler and rocker are in line
(the dyad's margin touches zero without changing sign: no sample sees it below zero).  The
closed form of that crank angle is theta* = atan2(-yD, -d) + 2 pi = 4.068887871591405 rad.
"""
from __future__ import annotations

import csv
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize_scalar

import optdesign
from optdesign import AssemblyError, DeadCentreError, analyse, kinematics, loads, simulate
from optdesign.study import Study, grid, values

ROOT = Path(__file__).resolve().parents[1]
G = 9.81
A_, B_, C_ = 0.10, 0.35, 0.25          # crank, coupler, rocker
D_TOGGLE = (0.30, 0.40)
THETA_TOGGLE = math.atan2(-0.40, -0.30) + 2 * math.pi
MASSES = (2.0, 5.0, 4.0)
OMEGA = 10.0


# --- numpy references --------------------------------------------------------------------------
def cross(u, v):
    return u[0] * v[1] - u[1] * v[0]


def solve2(r1, r2, b1, b2):
    """x with r1.x = b1 and r2.x = b2, per sample (r1, r2: 2 x n)."""
    det = r1[0] * r2[1] - r1[1] * r2[0]
    return np.array([(b1 * r2[1] - b2 * r1[1]) / det, (r1[0] * b2 - r2[0] * b1) / det])


def bar(m, L, P, Pd, Pdd, Q, Qd, Qdd):
    """A uniform bar P->Q: (m v.a + I Omega alpha, m g v_y, m v^2 + I Omega^2) of its motion."""
    v, a = 0.5 * (Pd + Qd), 0.5 * (Pdd + Qdd)
    r = Q - P
    omega, alpha = cross(r, Qd - Pd) / L**2, cross(r, Qdd - Pdd) / L**2
    inertia = m * L**2 / 12
    return (m * np.sum(v * a, 0) + inertia * omega * alpha, m * G * v[1],
            m * np.sum(v * v, 0) + inertia * omega**2)


def crank(theta, a, w):
    th = np.asarray(theta, float)
    e = np.array([np.cos(th), np.sin(th)])
    return a * e, a * w * np.array([-e[1], e[0]]), -a * w**2 * e


def quantities(terms, w, extra_power=0.0, extra_static=0.0, extra_kinetic=0.0):
    inertial = sum(t[0] for t in terms) + extra_power
    gravity = sum(t[1] for t in terms) + extra_static
    kinetic = sum(t[2] for t in terms) + extra_kinetic
    return {"drive": (inertial + gravity) / w, "static_load": gravity / w,
            "reduced_inertia": kinetic / w**2, "power": inertial + gravity}


def fourbar(theta, a, b, c, D, side="left", w=OMEGA, masses=MASSES):
    """The four-bar by the law of cosines: C to the ``side`` of B -> D."""
    D = np.asarray(D, float)[:, None]
    B, Bd, Bdd = crank(theta, a, w)
    BD = D - B
    rho = np.hypot(BD[0], BD[1])
    cos_b = (b**2 + rho**2 - c**2) / (2 * b * rho)
    beta = np.arccos(np.clip(cos_b, -1.0, 1.0)) * (1.0 if side == "left" else -1.0)
    u = BD / rho
    C = B + b * np.array([np.cos(beta) * u[0] - np.sin(beta) * u[1], np.sin(beta) * u[0] + np.cos(beta) * u[1]])
    zero = np.zeros_like(rho)
    Cd = solve2(C - B, C - D, np.sum((C - B) * Bd, 0), zero)
    Cdd = solve2(C - B, C - D, np.sum((C - B) * Bdd, 0) - np.sum((Cd - Bd) ** 2, 0), -np.sum(Cd**2, 0))
    O = np.zeros_like(B)
    m1, m2, m3 = masses
    out = quantities([bar(m1, a, O, O, O, B, Bd, Bdd), bar(m2, b, B, Bd, Bdd, C, Cd, Cdd),
                      bar(m3, c, D + O, O, O, C, Cd, Cdd)], w)
    out["margin"] = 1 - cos_b**2
    out["centres"] = rho**2 / (b**2 + c**2)   # 0: B on D, the dyad's circles one circle (b = c)
    return out


def slider_crank(theta, r, l, E, gamma, side="ahead", w=OMEGA, masses=MASSES):
    """Crank O -> A, rod A -> C, C on the line through E at angle gamma ('ahead': further along
    it), a point mass (the piston) at C."""
    E = np.asarray(E, float)[:, None]
    A, Ad, Add = crank(theta, r, w)
    u = np.array([[math.cos(gamma)], [math.sin(gamma)]])
    n = np.array([[-math.sin(gamma)], [math.cos(gamma)]])
    h = np.sum((A - E) * n, 0)
    t = np.sum((A - E) * u, 0) + (1.0 if side == "ahead" else -1.0) * np.sqrt(np.maximum(l**2 - h**2, 0.0))
    C = E + t * u
    CA = C - A
    Cd = np.sum(CA * Ad, 0) / np.sum(CA * u, 0) * u
    Cdd = (np.sum(CA * Add, 0) - np.sum((Cd - Ad) ** 2, 0)) / np.sum(CA * u, 0) * u
    O = np.zeros_like(A)
    m1, m2, m3 = masses
    out = quantities([bar(m1, r, O, O, O, A, Ad, Add), bar(m2, l, A, Ad, Add, C, Cd, Cdd)], w,
                     m3 * np.sum(Cd * Cdd, 0), m3 * G * Cd[1], m3 * np.sum(Cd**2, 0))
    out["margin"] = 1 - (h / l) ** 2
    return out


def crank_press(phi, l, e, w=6.283185307179586):
    """problems/crank_press_peak.toml: ram pin C on the line x = e below the crank pin, rod A-C
    (150 kg/m, a uniform bar), ram 400 kg with the 400 kN forming-force bump."""
    H, F0, d0, width, m_ram = 0.10, 400e3, 0.015, 0.008, 400.0
    r = H / 2 * math.sqrt(1 - 4 * e**2 / (4 * l**2 - H**2))
    y_bdc = -math.sqrt((l + r) ** 2 - e**2)
    phi = np.asarray(phi, float)
    A, Ad, Add = crank(-math.pi / 2 + math.asin(e / (l + r)) + phi, r, w)
    C = np.array([np.full_like(phi, e), A[1] - np.sqrt(l**2 - (e - A[0]) ** 2)])
    CA = C - A
    Cd = np.array([np.zeros_like(phi), Ad[1] + CA[0] * Ad[0] / CA[1]])
    Cdd = np.array([np.zeros_like(phi), Add[1] + (CA[0] * Add[0] - np.sum((Cd - Ad) ** 2, 0)) / CA[1]])
    force = F0 * np.exp(-(((C[1] - y_bdc - d0) / width) ** 2)) / (1 + np.exp(phi / math.radians(2)))
    # the forming force is an applied load: its power -F v_y is part of the static load
    return quantities([bar(150 * l, l, A, Ad, Add, C, Cd, Cdd)], w, m_ram * Cd[1] * Cdd[1],
                      m_ram * G * Cd[1] - force * Cd[1], m_ram * Cd[1] ** 2)


def dense_peak(f, lo, hi, n=200_001):
    """(polished, raw): max |f| on n samples of [lo, hi], its four largest samples polished by
    Brent's method on f (to 1e-14 in s)."""
    s = np.linspace(lo, hi, n)
    v = np.abs(f(s))
    raw = float(np.max(v))
    best = raw
    for i in np.argsort(v)[::-1][:4]:
        a, b = s[max(i - 1, 0)], s[min(i + 1, n - 1)]
        res = minimize_scalar(lambda x: -abs(float(f(np.array([x]))[0])), bounds=(a, b), method="bounded",
                              options={"xatol": 1e-14})
        best = max(best, -float(res.fun))
    return best, raw


# --- scenes --------------------------------------------------------------------------------------
def fourbar_scene(*args, **kwargs):
    return loads(fourbar_text(*args, **kwargs), "<four-bar>")


def fourbar_text(D=D_TOGGLE, samples=361, start=0.0, stop="2*pi", side="left", bounded=False, extra="",
                 lengths=(A_, B_, C_)):
    d, yD = D
    box = lambda v: f"{{ value = {v!r}, min = -0.2, max = 0.45 }}" if bounded else repr(v)  # noqa: E731
    return f"""
title = "crank-rocker, rocker pivot D"
[parameters]
a = {lengths[0]!r}
b = {lengths[1]!r}
c = {lengths[2]!r}
d = {box(d)}
yD = {box(yD)}
[sweep]
name = "theta"
from = {start!r}
to = {stop if isinstance(stop, str) else repr(stop)!r}
samples = {samples}
[points]
A = {{ fixed = [0, 0] }}
D = {{ fixed = ["d", "yD"] }}
B = {{ polar = ["A", "a", "theta"] }}
C = {{ dyad = ["B", "b", "D", "c"], side = "{side}" }}
[[bodies]]
name = "crank"
frame = ["A", "B"]
mass = {MASSES[0]!r}
com = ["a/2", 0]
inertia = "{MASSES[0]!r}*a^2/12"
[[bodies]]
name = "coupler"
frame = ["B", "C"]
mass = {MASSES[1]!r}
com = ["b/2", 0]
inertia = "{MASSES[1]!r}*b^2/12"
[[bodies]]
name = "rocker"
frame = ["D", "C"]
mass = {MASSES[2]!r}
com = ["c/2", 0]
inertia = "{MASSES[2]!r}*c^2/12"
[gravity]
g = {G!r}
[drive]
type = "rotary"
crank = ["A", "B"]
speed = {OMEGA!r}
acceleration = 0.0
{extra}"""


def slider_scene(r, l, E, gamma, side="ahead", samples=181, start=0.0, stop=2 * math.pi):
    return loads(f"""
title = "slider-crank on any line"
[parameters]
r = {r!r}
l = {l!r}
xE = {E[0]!r}
yE = {E[1]!r}
gamma = {gamma!r}
[sweep]
name = "theta"
from = {start!r}
to = {stop!r}
samples = {samples}
[points]
O = {{ fixed = [0, 0] }}
E = {{ fixed = ["xE", "yE"] }}
A = {{ polar = ["O", "r", "theta"] }}
C = {{ slider = ["A", "l", "E", "gamma"], side = "{side}" }}
U = {{ polar = ["C", 0.1, "gamma"] }}
[[bodies]]
name = "crank"
frame = ["O", "A"]
mass = {MASSES[0]!r}
com = ["r/2", 0]
inertia = "{MASSES[0]!r}*r^2/12"
[[bodies]]
name = "rod"
frame = ["A", "C"]
mass = {MASSES[1]!r}
com = ["l/2", 0]
inertia = "{MASSES[1]!r}*l^2/12"
[[bodies]]
name = "piston"
frame = ["C", "U"]
mass = {MASSES[2]!r}
com = [0, 0]
[gravity]
g = {G!r}
[drive]
type = "rotary"
crank = ["O", "A"]
speed = {OMEGA!r}
acceleration = 0.0
""", "<slider-crank>")


def named_position(exc, name="theta"):
    """The located sweep value of an error: its attribute, which the message shows too."""
    assert exc.s is not None
    assert f"{name} = {exc.s:.10g}" in str(exc), str(exc)
    return exc.s


# --- the toggle ----------------------------------------------------------------------------------
def test_the_toggle_is_what_the_docstring_says():
    assert math.hypot(*D_TOGGLE) + A_ == pytest.approx(B_ + C_, abs=1e-15)
    th = np.linspace(0, 2 * np.pi, 2_000_001)
    margin = fourbar(th, A_, B_, C_, D_TOGGLE)["margin"]
    assert th[np.argmin(margin)] == pytest.approx(THETA_TOGGLE, abs=1e-5)
    assert np.min(margin) < 1e-10
    for n in (101, 361, 1001):  # no sample sees it: every sample's margin is clearly positive
        assert np.min(fourbar(np.linspace(0, 2 * np.pi, n), A_, B_, C_, D_TOGGLE)["margin"]) > 1e-7


@pytest.mark.parametrize("samples", [101, 361, 1001])
def test_a_toggle_between_samples_is_refused_naming_its_angle(samples):
    with pytest.raises(AssemblyError) as info:
        analyse(fourbar_scene(samples=samples))
    assert info.value.construction == "C"
    assert "[points] C (dyad)" in str(info.value) and "lock-up" in str(info.value)
    assert named_position(info.value) == pytest.approx(THETA_TOGGLE, abs=1e-6)
    with pytest.raises(AssemblyError) as again:
        kinematics(fourbar_scene(samples=samples))
    assert named_position(again.value) == pytest.approx(THETA_TOGGLE, abs=1e-6)


def test_simulate_refuses_the_toggle_too():
    scene = fourbar_scene(extra='law = "1.0"\ninertia = 0.01\n[simulation]\nstart = 0.0\nspeed = 10.0\nt_end = 1.0\n')
    with pytest.raises(AssemblyError) as info:
        simulate(scene)
    assert named_position(info.value) == pytest.approx(THETA_TOGGLE, abs=1e-6)


def test_a_loop_at_its_singular_position_between_samples_is_refused():
    """The same four-bar closed by Newton's method (a loop A -> B -> C -> D3 = D): its closure
    Jacobian turns singular at the toggle, between the samples."""
    for n in (101, 361, 1001):
        scene = loads(f"""
title = "four-bar loop"
[parameters]
a = {A_!r}
b = {B_!r}
c = {C_!r}
d = 0.30
yD = 0.40
[sweep]
name = "theta"
from = 0
to = "2*pi"
samples = {n}
rate = 1.0
[points]
A = {{ fixed = [0, 0] }}
D = {{ fixed = ["d", "yD"] }}
[points.chain]
loop = "A"
lengths = ["a", "b", "c"]
angles = ["theta", "phi2", "phi3"]
joints = ["B", "C", "D3"]
unknowns = {{ phi2 = "atan2(yD - a*sin(theta), d - a*cos(theta)) + 20 deg - theta", phi3 = "-100 deg" }}
closure = {{ point = "D3", fixed = "D" }}
""", "<loop>")
        with pytest.raises(AssemblyError) as info:
            kinematics(scene)
        assert info.value.construction == "chain" and "(loop)" in str(info.value)
        assert named_position(info.value) == pytest.approx(THETA_TOGGLE, abs=1e-6)


def test_just_off_the_toggle_the_certified_peak_is_the_dense_peak():
    """|AD| + a = b + c - 1e-3: the linkage assembles over the whole turn (least relative
    margin 2.4e-3), and every peak analyse reports is the dense numpy peak."""
    D = (0.30 * 0.998, 0.40 * 0.998)
    assert math.hypot(*D) + A_ == pytest.approx(B_ + C_ - 1e-3, abs=1e-15)
    res = analyse(fourbar_scene(D))
    f = lambda th: fourbar(th, A_, B_, C_, D)  # noqa: E731
    assert np.min(f(np.linspace(0, 2 * np.pi, 200_001))["margin"]) > 2e-3
    for k in ("drive", "static_load", "reduced_inertia", "power"):
        polished, raw = dense_peak(lambda th: f(th)[k], 0, 2 * np.pi)
        assert res.peaks[k] == pytest.approx(polished, rel=1e-10), k
        assert res.peaks[k] == pytest.approx(raw, rel=1e-8), k
        assert res.peaks_sampled[k] <= res.peaks[k]
        at = res.peak_at[k]
        assert abs(f(np.array([at["s"]]))[k][0]) == pytest.approx(res.peaks[k], rel=1e-10)
    # the default 361 samples read the drive 0.08 % low; the certified peak does not
    assert res.peaks_sampled["drive"] < res.peaks["drive"] * (1 - 5e-4)


# --- the crank press ------------------------------------------------------------------------------
OPTIMUM = json.loads((ROOT / "results" / "crank_press_peak" / "result.json").read_text())


@pytest.mark.parametrize("where", ["start", "optimum"])
def test_crank_press_analyse_peak_is_the_dense_peak(where):
    scene = optdesign.load(ROOT / "problems" / "crank_press_peak.toml")
    l, e = (0.30, 0.0) if where == "start" else (OPTIMUM["design"]["l"], OPTIMUM["design"]["e"])
    res = analyse(scene.with_parameters(l=l, e=e))
    for k in ("drive", "static_load", "reduced_inertia", "power"):
        polished, raw = dense_peak(lambda ph: crank_press(ph, l, e)[k], -math.pi, math.pi)
        assert res.peaks[k] == pytest.approx(polished, rel=1e-10), k
        assert res.peaks[k] == pytest.approx(raw, rel=1e-8), k
    if where == "start":  # as shipped: the 721 samples read 15,129.00 N m, the stroke 15,130.08
        assert res.peaks_sampled["drive"] == pytest.approx(15129.004, abs=1e-3)
        assert res.peaks["drive"] == pytest.approx(15130.0773, abs=1e-4)
    else:  # at the optimum it is optimise's certificate
        assert res.peaks["drive"] == pytest.approx(OPTIMUM["peak_certified"], rel=1e-10)
        assert res.peaks["drive"] == pytest.approx(14816.396, abs=1e-3)


def test_analyse_json_says_which_peak_is_which():
    out = subprocess.run([sys.executable, "-m", "optdesign", "analyse", str(ROOT / "problems" / "crank_press_peak.toml"),
                          "--json"], capture_output=True, text=True, check=True).stdout
    data = json.loads(out)
    drive = np.array([row["drive"] for row in data["samples"]])
    assert data["peaks_sampled"]["drive"] == float(np.max(np.abs(drive)))
    assert data["peaks"]["drive"] > data["peaks_sampled"]["drive"]
    assert data["peak_at"]["drive"]["value"] == data["peaks"]["drive"]
    assert -math.pi < data["peak_at"]["drive"]["s"] < math.pi
    rod = data["constraint_extremes"]["rod angle to the ram line"]
    angles = [row["constraints"]["rod angle to the ram line"] for row in data["samples"]]
    assert rod["max"] >= rod["max_sampled"] == max(angles) and rod["min"] <= rod["min_sampled"] == min(angles)
    assert data["constraints"]["ram pin depth"] >= data["constraints_sampled"]["ram pin depth"]
    table = subprocess.run([sys.executable, "-m", "optdesign", "analyse", str(ROOT / "problems" / "crank_press_peak.toml")],
                           capture_output=True, text=True, check=True).stdout
    assert "peak |drive| = 15130.077 N m at phi = -0.76089622" in table
    helptext = subprocess.run([sys.executable, "-m", "optdesign", "analyse", "--help"],
                              capture_output=True, text=True, check=True).stdout
    assert "The drive load at each position is the load at the drive speed and acceleration" in " ".join(helptext.split())


def test_without_certification_the_peaks_are_the_samples():
    scene = optdesign.load(ROOT / "problems" / "crank_press_peak.toml")
    res = analyse(scene, certify=False)
    assert res.peaks == res.peaks_sampled
    assert res.peaks["drive"] == float(np.max(np.abs(res.columns["drive"])))


# --- a slider at its limit, a dead centre between samples -------------------------------------------
def test_a_slider_at_its_limit_between_samples_is_refused():
    """Crank radius 0.1 about the origin, the slider line y = -0.3 (horizontal), rod 0.4: at
    theta = pi/2 the crank pin (0, 0.1) is 0.4 from the line, the rod stands perpendicular to
    it and the slider's two branches meet (relative margin 1 - (h/l)^2 touches zero).  100
    samples over [0, 2 pi] miss pi/2 (it would be sample 24.75)."""
    scene = slider_scene(0.1, 0.4, (0.0, -0.3), 0.0, samples=100)
    assert np.min(slider_crank(np.linspace(0, 2 * np.pi, 100), 0.1, 0.4, (0.0, -0.3), 0.0)["margin"]) > 5e-5
    with pytest.raises(AssemblyError) as info:
        analyse(scene)
    assert info.value.construction == "C" and "(slider)" in str(info.value)
    assert named_position(info.value) == pytest.approx(0.5 * math.pi, abs=1e-6)
    # 1 mm longer, it assembles, and its peaks are the dense ones
    res = analyse(slider_scene(0.1, 0.401, (0.0, -0.3), 0.0, samples=100))
    polished, _ = dense_peak(lambda th: slider_crank(th, 0.1, 0.401, (0.0, -0.3), 0.0)["drive"], 0, 2 * math.pi)
    assert res.peaks["drive"] == pytest.approx(polished, rel=1e-9)


def test_a_dead_centre_between_samples_is_refused():
    """A linear drive whose length L = sqrt(x^2 + 1), x = (s - 1/2)^3 + 5, stops for an instant
    at s = 1/2 (dL/ds = 3 x (s - 1/2)^2 / L touches zero without changing sign) between the
    samples -1, -0.9, ..., 1.3."""
    scene = loads("""
title = "a drive that stops for an instant"
[sweep]
name = "s"
from = -1
to = 1.3
samples = 24
[points]
O = { fixed = [0, 0] }
P = { fixed = ["(s - 0.5)^3 + 5", 1.0] }
[[bodies]]
name = "m"
frame = ["O", "P"]
mass = 1.0
com = [0, 0]
[gravity]
g = 9.81
[drive]
type = "linear"
between = ["O", "P"]
speed = 0.1
acceleration = 0.0
""", "<dead centre>")
    with pytest.raises(DeadCentreError) as info:
        analyse(scene)
    assert info.value.s == pytest.approx(0.5, abs=1e-6)
    assert "s = 0.5" in str(info.value)


# --- random linkages --------------------------------------------------------------------------------
def _singular(values):
    """The numpy margins of a linkage at some positions: the relative margin and, for a dyad,
    how close its two centres come (B on D: with b = c its point is not determined), least first."""
    return np.fmin(values["margin"], values.get("centres", np.inf))


def _check(scene_fn, reference, start, stop, samples):
    """Either an error naming a position where the numpy margin is <= 0 (to round-off: 1e-9 of
    its scale), or no error, a linkage whose dense numpy margin is > 0 everywhere, and a
    certified peak equal to the dense peak."""
    try:
        res = analyse(scene_fn())
    except AssemblyError as exc:
        s = exc.s
        assert exc.construction == "C"
        assert min(start, stop) <= s <= max(start, stop)
        assert _singular(reference(np.array([s])))[0] <= 1e-9, str(exc)
        return "error"
    dense = reference(np.linspace(start, stop, 200_001))
    kappa = float(np.min(_singular(dense)))
    assert kappa > 0, f"a finite peak for a linkage that does not assemble (least margin {kappa:.3g})"
    polished, _ = dense_peak(lambda th: reference(th)["drive"], start, stop)
    # evaluating near a limit loses about eps/kappa of the value's accuracy (in both models)
    rtol = max(1e-8, 100 * np.finfo(float).eps / kappa)
    assert res.peaks["drive"] == pytest.approx(polished, rel=rtol)
    return "ok"


sweeps = st.tuples(st.floats(-math.pi, math.pi), st.floats(0.2, 2 * math.pi), st.sampled_from([61, 181, 361]))
# None: lengths at random; else a signed offset from the limit (|delta| from 1e-9 to 1e-3), so
# that the linkage barely reaches, touches or barely passes its limit, often between samples
nearness = st.one_of(st.none(), st.tuples(st.sampled_from([-1.0, 1.0]), st.floats(-9, -3)).map(lambda x: x[0] * 10 ** x[1]))


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(a=st.floats(0.05, 0.3), b=st.floats(0.15, 0.6), c=st.floats(0.15, 0.6), ground=st.floats(0.15, 0.8),
       angle=st.floats(-math.pi, math.pi), side=st.sampled_from(["left", "right"]), sweep=sweeps, near=nearness)
def test_random_four_bars(a, b, c, ground, angle, side, sweep, near):
    """Random four-bars; with ``near``, coupler and rocker are chosen so that b + c = |AD| + a -
    near (at its farthest, B is near beyond reach, by near: < 0 it cannot assemble there)."""
    start, span, samples = sweep
    stop = start + span
    if near is not None:
        c = c / 0.6 * (ground + a) * 0.8   # in (0.2, 0.8) of |AD| + a
        b = ground + a - c - near
    D = (ground * math.cos(angle), ground * math.sin(angle))
    _check(lambda: fourbar_scene(D, samples, start, stop, side, lengths=(a, b, c)),
           lambda th: fourbar(th, a, b, c, D, side), start, stop, samples)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(r=st.floats(0.05, 0.3), l=st.floats(0.1, 0.6), ex=st.floats(-0.3, 0.3), ey=st.floats(-0.3, 0.3),
       gamma=st.floats(-math.pi, math.pi), side=st.sampled_from(["ahead", "behind"]), sweep=sweeps, near=nearness)
def test_random_slider_cranks(r, l, ex, ey, gamma, side, sweep, near):
    """Random slider-cranks; with ``near``, the rod is l = (crank pin's farthest distance from the
    line) + near."""
    start, span, samples = sweep
    stop = start + span
    if near is not None:
        l = abs(-ex * -math.sin(gamma) + -ey * math.cos(gamma)) + r + near
    _check(lambda: slider_scene(r, l, (ex, ey), gamma, side, samples, start, stop),
           lambda th: slider_crank(th, r, l, (ex, ey), gamma, side), start, stop, samples)


# --- studies ------------------------------------------------------------------------------------------
def test_grid_ends_exactly_and_may_leave_the_design_box_in_analyse_mode(tmp_path):
    """`--grid yD=-0.2:0.45:14` with yD's max 0.45: the last value is exactly 0.45 (computed as
    -0.2 + 0.65*13/13 it would be 0.45000000000000007, outside the box); the case at
    yD = 0.4000000000000001 is the toggle, failed with the message naming its angle."""
    scene_file = tmp_path / "fourbar.toml"
    scene_file.write_text(fourbar_text(bounded=True))
    out = tmp_path / "study"
    run = subprocess.run([sys.executable, "-m", "optdesign", "study", str(scene_file), "--mode", "analyse",
                          "--grid", "yD=-0.2:0.45:14", "--workers", "1", "--no-figures", "--out", str(out)],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    rows = list(csv.DictReader((out / "cases.csv").open()))
    assert len(rows) == 14 and rows[-1]["yD"] == "0.45" and rows[0]["yD"] == "-0.2"
    toggle = next(r for r in rows if abs(float(r["yD"]) - 0.4) < 1e-12)
    assert toggle["success"] == "false" and "[points] C (dyad) is at its limit (lock-up)" in toggle["status"]
    assert f"theta = {THETA_TOGGLE:.10g}"[:-1] in toggle["status"]
    good = [r for r in rows if r["success"] == "true"]
    assert good and all(float(r["peak:drive"]) >= float(r["peak_sampled:drive"]) for r in good)
    # analyse mode has no design box: a grid beyond max = 0.45 runs
    study = Study(fourbar_scene(bounded=True), [values("yD", [0.3, 0.5])], mode="analyse")
    result = study.run(out=tmp_path / "outside", workers=1, figures=False)
    assert [r["yD"] for r in result.rows] == [0.3, 0.5]
    assert result.rows[0]["success"] and result.rows[0]["peak:drive"] > 0


def test_out_of_box_values_are_refused_for_optimisation_in_full_precision():
    scene = fourbar_scene(bounded=True)
    with pytest.raises(optdesign.SceneError) as info:
        scene.with_parameters(yD=0.45000000000001)
    assert "the start value 0.45000000000001 lies outside its bounds [-0.2, 0.45]" in str(info.value)
    assert scene.with_parameters(yD=0.45000000000000007).parameter("yD").value.tree.value == 0.45000000000000007
    assert grid("yD", -0.2, 0.45, 14).points[-1] == (("yD", 0.45),)


def test_an_analyse_study_keeps_terms_whose_base_value_is_zero(tmp_path):
    """A mass swept from the scene's 0 kg: the analysis built for the study must not leave the
    mass's terms out (they would be zero for every case)."""
    scene = optdesign.load(ROOT / "problems" / "seed1_jib.toml")
    study = Study(scene.with_parameters(mC=0.0), [values("mC", [0.0, 500.0])], mode="analyse")
    rows = study.run(out=tmp_path / "s", workers=1, figures=False).rows
    assert rows[1]["peak:drive"] == pytest.approx(analyse(scene).peaks["drive"], rel=1e-12)
    assert rows[0]["peak:drive"] == pytest.approx(analyse(scene.with_parameters(mC=0.0)).peaks["drive"], rel=1e-12)
