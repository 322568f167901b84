"""The two design scenes of the level-luffing crane (seed 1, Fig. 10), checked against physics
written here in plain numpy, not against the optimiser's own numbers.

* problems/level_luffing_path.toml (the four-bar A-B-D-E for a level hook path, minimise
  max(y(T)) - min(y(T)) over xE, yE, L_ED): at the reported optimum the four-bar is solved again
  by the law of cosines in triangle B-D-E; the tip height's range over a dense sweep, with each
  extreme refined by a bounded scalar search, must equal the reported objective, be well below
  the shipped four-bar's 0.44 m, and show the alternation that a minimax optimum has (the
  Chebyshev property); the outreach constraint the result calls active must sit on its bound;
  and an independent minimax (scipy SLSQP on the numpy model, started from the shipped
  four-bar) must reach the same levelness.
* problems/level_luffing_cylinder.toml (cylinder pins xF, yF, aS for the least peak cylinder
  force): the force F_S(theta) is recomputed from energies (Lagrange's equation for the one
  coordinate x = |FS|: static part dV/dx, inertia part m_zS a, velocity part 1/2 dm_zS/dx v^2,
  and the seed's efficiency rule), its peak over the continuous stroke must equal the reported
  certified peak; and the active set must be the one physics predicts: the peak force falls as
  the rod eye moves out along the jib until the cylinder's transmission angle at full luffing
  in reaches its 40 deg limit, and falls as the base F moves forward and up, so F sits in the
  upper corner of its box; the optimum is then found again by a one-dimensional root (the
  angle at theta_in = 40 deg) and its sensitivities to the two bounds are the reported
  multipliers; the reported sensitivities to the masses are the numpy peak's derivatives, and
  show the level path (a kilogram of payload costs the cylinder less than one of jib).

The scenes' inputs are read with tomllib; nothing of optdesign is used for the references.
"""
from __future__ import annotations

import functools
import itertools
import math
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq, minimize, minimize_scalar

from optdesign.design import optimise
from optdesign.scene.file import load, loads

ROOT = Path(__file__).resolve().parents[1]
PATH_SCENE = ROOT / "problems" / "level_luffing_path.toml"
CYLINDER_SCENE = ROOT / "problems" / "level_luffing_cylinder.toml"
SHIPPED_SCENE = ROOT / "problems" / "level_luffing_crane.toml"
G = 9.81
DENSE = 20001  # samples of the dense sweep (a sampled extreme is then refined by brent)


# --- the scenes' inputs, read without optdesign ------------------------------------------
def _number(value, known):
    """A scene number: a float, a design table {value = ...}, 'N deg', or a parameter's name."""
    if isinstance(value, dict):
        value = value["value"]
    if isinstance(value, str):
        if value.strip() in known:
            return known[value.strip()]
        m = re.fullmatch(r"\s*([-+0-9.eE]+)\s*deg\s*", value)
        assert m, f"unexpected scene value {value!r}"
        return math.radians(float(m.group(1)))
    return float(value)


@functools.cache
def scene_data(path):
    """(parameters, (theta_from, theta_to), drive {v, a, eta}, constraints {name: table})."""
    data = tomllib.loads(Path(path).read_text())
    p = {}
    for k, v in data["parameters"].items():
        if isinstance(v, str) and not re.fullmatch(r"\s*([-+0-9.eE]+)\s*deg\s*", v):
            continue  # derived values are not used by these scenes' numbers
        p[k] = _number(v, p)
    sweep = data["sweep"]
    drive = data["drive"]
    return (p, (_number(sweep["from"], p), _number(sweep["to"], p)),
            {"v": float(drive["speed"]), "a": float(drive["acceleration"]), "eta": float(drive["efficiency"])},
            {c["name"]: c for c in data.get("constraints", [])})


@functools.cache
def optimum(path):
    return optimise(load(path), starts=20, seed=0)


# --- the crane in numpy -------------------------------------------------------------------
def _perp(v):
    return np.array([-v[1], v[0]])


def _norm(v):
    return np.sqrt(v[0] ** 2 + v[1] ** 2)  # complex-step safe (no abs)


class Crane:
    """Points and bodies of the crane as functions of the jib angle theta (real or complex).

    The four-bar: B on the circle of radius L_AB about A; D at distance L_BD from B and L_ED
    from E, to the right of B->E, found from the angle at B of triangle B-D-E (law of cosines).
    Bodies as the scenes describe them: jib (A->B, centre of mass at 0.45 L_AB, I = m L^2/12),
    beak (frame origin B, axis to D, centre of mass at (-2.5, -0.5), I = m (L_BD - aT)^2/12),
    connector (E->D, mid-length, I = m L_ED^2/12), barrel (F->S, 0.48 L_barrel from F,
    I = m L_barrel^2/12), rod (from S back towards F, L_rod/2 from S, I = m L_rod^2/12), and the
    payload, a point mass at the tip T = B + aT e + bT perp(e)."""

    def __init__(self, p):
        self.p = p

    def points(self, th):
        p = self.p
        A = np.array([p["xA"], p["yA"]])[:, None]
        E = np.array([p["xE"], p["yE"]])[:, None]
        F = np.array([p["xF"], p["yF"]])[:, None]
        B = A + p["L_AB"] * np.array([np.cos(th), np.sin(th)])
        d = _norm(E - B)
        u = (E - B) / d
        beta = np.arccos((p["L_BD"] ** 2 + d**2 - p["L_ED"] ** 2) / (2 * p["L_BD"] * d))
        e = np.cos(beta) * u - np.sin(beta) * _perp(u)  # u turned clockwise by beta
        D = B + p["L_BD"] * e
        T = B + p["aT"] * e + p["bT"] * _perp(e)
        e_jib = (B - A) / p["L_AB"]
        S = A + p["aS"] * e_jib + p["bS"] * _perp(e_jib)
        return {"A": A, "B": B, "D": D, "E": E, "F": F, "S": S, "T": T, "e_beak": e, "e_jib": e_jib}

    def bodies(self, th):
        """name -> (mass, centre of mass, unit axis or None, inertia about the centre of mass)."""
        p, P = self.p, self.points(th)
        e_con = (P["D"] - P["E"]) / p["L_ED"]
        e_cyl = (P["S"] - P["F"]) / _norm(P["S"] - P["F"])
        e = P["e_beak"]
        return {
            "jib": (p["m2"], P["A"] + 0.45 * p["L_AB"] * P["e_jib"], P["e_jib"], p["m2"] * p["L_AB"] ** 2 / 12),
            "beak": (p["m3"], P["B"] - 2.5 * e - 0.5 * _perp(e), e, p["m3"] * (p["L_BD"] - p["aT"]) ** 2 / 12),
            "connector": (p["m4"], P["E"] + 0.5 * p["L_ED"] * e_con, e_con, p["m4"] * p["L_ED"] ** 2 / 12),
            "barrel": (p["m_barrel"], P["F"] + 0.48 * p["L_barrel"] * e_cyl, e_cyl,
                       p["m_barrel"] * p["L_barrel"] ** 2 / 12),
            "rod": (p["m_rod"], P["S"] - 0.5 * p["L_rod"] * e_cyl, e_cyl, p["m_rod"] * p["L_rod"] ** 2 / 12),
            "payload": (p["m_L"], P["T"], None, 0.0),
        }

    def cylinder_length(self, th):
        P = self.points(th)
        return _norm(P["S"] - P["F"])

    def potential(self, th):
        return sum(G * m * com[1] for m, com, _, _ in self.bodies(th).values())


def angle_at(P, Q, R):
    """The angle at Q between Q->P and Q->R, 0 .. pi."""
    u, v = P - Q, R - Q
    return np.arctan2(np.abs(u[0] * v[1] - u[1] * v[0]), u[0] * v[0] + u[1] * v[1])


H_CS = 1e-30


def d_theta(f, th):
    """df/dtheta by complex step (exact to round-off: every formula above is analytic)."""
    return np.imag(f(np.asarray(th, dtype=complex) + 1j * H_CS)) / H_CS


def cylinder_force(crane, motion, th):
    """F_S(theta) from Lagrange's equation for x = |FS|:  F = dV/dx + m_zS a + 1/2 dm_zS/dx v^2,
    with m_zS = 2 E_kin / v^2 = (sum m |dr/dtheta|^2 + I (dphi/dtheta)^2) / (dx/dtheta)^2, and
    the seed's efficiency rule (F/eta while the cylinder delivers power, eta F otherwise).
    dm_zS/dtheta by a fourth-order central difference (step 1e-4 rad: truncation ~1e-10
    relative, see tests/test_crane.py); the velocity part it feeds is below 0.1 % of F here."""
    x_th = d_theta(crane.cylinder_length, th)

    def m_zS(t):
        tc = np.asarray(t, dtype=complex) + 1j * H_CS
        twice_T = 0.0
        for m, com, axis, inertia in crane.bodies(tc).values():
            r_th = np.imag(com) / H_CS
            twice_T = twice_T + m * (r_th[0] ** 2 + r_th[1] ** 2)
            if axis is not None:
                e, e_th = np.real(axis), np.imag(axis) / H_CS
                twice_T = twice_T + inertia * (e[0] * e_th[1] - e[1] * e_th[0]) ** 2
        return twice_T / d_theta(crane.cylinder_length, t) ** 2

    h = 1e-4
    dm_th = (-m_zS(th + 2 * h) + 8 * m_zS(th + h) - 8 * m_zS(th - h) + m_zS(th - 2 * h)) / (12 * h)
    static = d_theta(crane.potential, th) / x_th
    inertia = m_zS(th) * motion["a"]
    velocity = 0.5 * dm_th / x_th * motion["v"] ** 2
    ideal = static + inertia + velocity
    c = np.where(ideal * motion["v"] > 0, 1 / motion["eta"], motion["eta"])
    return c * ideal, {"static": c * static, "inertia": c * inertia, "velocity": c * velocity}


def refine(f, th, i, sense):
    """The extreme (sense=+1 largest, -1 smallest) of f near sample i of the grid th: a bounded
    Brent search between the sample's neighbours (to 1e-13 rad), or the sample itself if that
    is better (an extreme at an end of the stroke).  Returns (value, theta)."""
    a, b = th[max(i - 1, 0)], th[min(i + 1, len(th) - 1)]
    res = minimize_scalar(lambda t: -sense * f(np.array([t]))[0], bounds=(a, b), method="bounded",
                          options={"xatol": 1e-13})
    at_sample = sense * f(th[i:i + 1])[0]
    return (-sense * res.fun, res.x) if -res.fun > at_sample else (sense * at_sample, th[i])


def stroke_extreme(f, lo, hi, sense):
    """The largest (sense=+1) or smallest (-1) value of f over [lo, hi] and where: the best of
    DENSE samples, refined by :func:`refine`."""
    th = np.linspace(lo, hi, DENSE)
    return refine(f, th, int(np.argmax(sense * f(th))), sense)


def with_design(path, design):
    p, sweep, motion, constraints = scene_data(path)
    return dict(p, **design), sweep, motion, constraints


# --- the level path ----------------------------------------------------------------------
def tip_height(p):
    crane = Crane(p)
    return lambda th: crane.points(th)["T"][1]


def levelness(p, sweep):
    y = tip_height(p)
    return stroke_extreme(y, *sweep, +1)[0] - stroke_extreme(y, *sweep, -1)[0]


def test_path_optimum_is_more_level_than_the_shipped_four_bar():
    """The reported levelness is the tip's height range of the four-bar solved here (dense sweep,
    extremes refined: agreement to 1e-6 relative, the optimiser certifies its stroke extremes
    to 1e-8); the shipped four-bar's range, from the same numpy model, is the 0.44 m its scene
    states, and the optimum is at least 30 % better."""
    result = optimum(PATH_SCENE)
    assert result.success, result.message
    p, sweep, _, _ = with_design(PATH_SCENE, result.design)
    ours = levelness(p, sweep)
    assert ours == pytest.approx(result.objective, rel=1e-6)
    shipped_p, shipped_sweep, _, _ = scene_data(SHIPPED_SCENE)
    shipped = levelness(shipped_p, shipped_sweep)
    assert shipped == pytest.approx(0.44, abs=0.005)  # "a 0.44 m deviation" (the scene's comment)
    assert ours < 0.7 * shipped


def test_path_constraints_and_the_active_outreach():
    """At the reported design (numpy four-bar): the angle at D between beak and connector stays
    within 20 .. 160 deg on the dense sweep; the outreach with the jib lowered is at least 30 m;
    the outreach with the jib raised is at its 9.5 m limit (to 1e-6 m), and that is the one
    constraint the result calls active (the levelness alone would trade the minimum outreach for
    a flatter path).  The scene writes each end outreach as a ramp x(T) + 100 (theta - theta_end)
    whose extreme over the stroke is at that end: the reported extremes must be the end values."""
    result = optimum(PATH_SCENE)
    p, (t_out, t_in), _, constraints = with_design(PATH_SCENE, result.design)
    crane = Crane(p)
    P = crane.points(np.linspace(t_out, t_in, DENSE))
    at_D = angle_at(P["B"], P["D"], P["E"])
    assert np.degrees(at_D.min()) >= 20 - 1e-6 and np.degrees(at_D.max()) <= 160 + 1e-6
    x_out = crane.points(np.array([t_out]))["T"][0, 0]
    x_in = crane.points(np.array([t_in]))["T"][0, 0]
    assert x_out >= constraints["maximum outreach"]["min"] - 1e-6
    assert x_in == pytest.approx(constraints["minimum outreach"]["max"], abs=1e-6)
    # the ramp rows x(T) + 100 (theta - theta_end) report exactly the two end outreaches
    assert result.constraints["maximum outreach"]["min"] == pytest.approx(x_out, abs=1e-6)
    assert result.constraints["minimum outreach"]["max"] == pytest.approx(x_in, abs=1e-6)
    active = {name for name, c in result.constraints.items() if c.get("active")}
    assert active == {"minimum outreach"}, active


@pytest.mark.parametrize("lowered, raised", [("start(x(T))", "end(x(T))"), ("max(x(T))", "min(x(T))")],
                         ids=["end values", "located extremes"])
def test_path_with_the_outreach_stated_directly(lowered, raised):
    """The two end outreaches stated directly instead of by the ramps: as the values at the
    stroke's ends (start(x(T)) >= 30, end(x(T)) <= 9.5), or as the outreach's largest and
    smallest values over the stroke (max(x(T)) >= 30, min(x(T)) <= 9.5: a lower bound on a max
    and an upper bound on a min, held at their located extremes).  The outreach falls along the
    stroke, so both say what the ramps say: the same optimum (1e-9), and the reported values
    are the end outreaches of the numpy four-bar (1e-9 m)."""
    text = PATH_SCENE.read_text()
    for old, new in (('"x(T) + 100*(theta - theta_out)"', f'"{lowered}"'), ('"x(T) + 100*(theta - theta_in)"', f'"{raised}"')):
        assert old in text
        text = text.replace(old, new)
    stated = optimise(loads(text, "level_luffing_path_stated.toml"), starts=20, seed=0)
    ramps = optimum(PATH_SCENE)
    assert stated.success, stated.message
    assert stated.objective == pytest.approx(ramps.objective, rel=1e-9)
    assert stated.design == pytest.approx(ramps.design, abs=1e-6)
    p, (t_out, t_in), _, _ = with_design(PATH_SCENE, stated.design)
    T = Crane(p).points(np.array([t_out, t_in]))["T"]
    assert stated.constraints["maximum outreach"]["value"] == pytest.approx(T[0, 0], abs=1e-9)
    assert stated.constraints["minimum outreach"]["value"] == pytest.approx(9.5, abs=1e-9)
    assert T[0, 1] == pytest.approx(9.5, abs=1e-8)
    active = {name: c["active"] for name, c in stated.constraints.items() if c.get("active")}
    assert active == {"minimum outreach": "upper"}, active


def test_path_optimum_equioscillates():
    """A minimax optimum over n free parameters touches its extremes at n + 1 alternating
    points (Chebyshev): here 3 design variables and the mean height, less the one active
    outreach constraint, so the tip height must reach its maximum and its minimum
    alternately at (at least) 4 separated angles.  Each touch is a local extreme of the dense
    sweep refined by Brent; it counts when it is within 1e-6 of the range of the global one
    (the optimiser solves to about 1e-8 of it)."""
    result = optimum(PATH_SCENE)
    p, sweep, _, _ = with_design(PATH_SCENE, result.design)
    y_of = tip_height(p)
    th = np.linspace(*sweep, DENSE)
    y = y_of(th)
    local = [i for i in range(len(th))
             if (i == 0 or i == len(th) - 1 or (y[i] - y[i - 1]) * (y[i + 1] - y[i]) <= 0)]
    touches = []  # (angle, +1 for a maximum, -1 for a minimum, refined value)
    for i in local:
        for sense in (+1, -1):
            neighbours = [j for j in (i - 1, i + 1) if 0 <= j < len(th)]
            if any(sense * y[j] > sense * y[i] for j in neighbours):
                continue  # not an extreme of this sense
            touches.append((th[i], sense, refine(y_of, th, i, sense)[0]))
    top = max(v for _, s, v in touches if s > 0)
    bottom = min(v for _, s, v in touches if s < 0)
    tol = 1e-6 * (top - bottom)
    signs = [s for _, s, v in sorted(touches) if abs(v - (top if s > 0 else bottom)) <= tol]
    alternations = 1 + sum(a != b for a, b in itertools.pairwise(signs))
    assert alternations >= 4, [(round(math.degrees(t), 3), s, v) for t, s, v in sorted(touches)]


def test_path_optimum_found_again_by_an_independent_minimax():
    """scipy SLSQP on the numpy model (levelness as an epigraph over 801 samples, the constraints
    of the scene), started from the shipped four-bar, must reach the reported levelness: the
    sampled epigraph misses the continuous range by about y'' h^2 / 8 ~ 1e-6 m, so 1e-5 relative."""
    result = optimum(PATH_SCENE)
    p0, (t_out, t_in), _, constraints = scene_data(PATH_SCENE)
    names = ["xE", "yE", "L_ED"]
    th = np.linspace(t_out, t_in, 801)
    ends = np.array([t_out, t_in])
    lo_angle, hi_angle = math.radians(20), math.radians(160)
    x_min_out = constraints["maximum outreach"]["min"]
    x_max_in = constraints["minimum outreach"]["max"]

    def parts(z):
        crane = Crane(dict(p0, **dict(zip(names, z[:3]))))
        with np.errstate(invalid="ignore"):
            P, Q = crane.points(th), crane.points(ends)
        return P, Q

    def g(z):
        P, Q = parts(z)
        y, c, half = P["T"][1], z[3], z[4]
        at_D = angle_at(P["B"], P["D"], P["E"])
        out = np.r_[half - (y - c), half + (y - c), at_D - lo_angle, hi_angle - at_D,
                    Q["T"][0, 0] - x_min_out, x_max_in - Q["T"][0, 1]]
        return np.where(np.isfinite(out), out, -1.0)

    P, _ = parts(np.r_[[p0[n] for n in names], 0, 0])
    y = P["T"][1]
    z0 = np.r_[[p0[n] for n in names], 0.5 * (y.max() + y.min()), 0.5 * (y.max() - y.min())]
    res = minimize(lambda z: 2 * z[4], z0, method="SLSQP", constraints=[{"type": "ineq", "fun": g}],
                   options={"maxiter": 500, "ftol": 1e-14})
    assert res.success, res.message
    assert g(res.x).min() >= -1e-8
    assert 2 * res.x[4] == pytest.approx(result.objective, rel=1e-5)
    assert res.x[:3] == pytest.approx([result.design[n] for n in names], abs=2e-3)


# --- the cylinder pins ---------------------------------------------------------------------
def peak_force(p, sweep, motion):
    """The largest F_S over the continuous stroke (dense samples, refined by Brent) and where."""
    crane = Crane(p)
    return stroke_extreme(lambda th: cylinder_force(crane, motion, th)[0], *sweep, +1)


def test_cylinder_peak_force_recomputed_from_energies():
    """The reported (certified) peak cylinder force equals the peak of the Lagrange force
    computed here, to 1e-6 relative (both are exact to round-off in the model; the optimiser
    certifies its peak to 1e-8).  The parts at the peak are what the physics of a level-luffing
    crane says: the static part (mostly the jib, beak and connector: the payload barely changes
    height) dominates, the inertia part m_zS a is not negligible (the hook moves ~9 times faster
    than the rod, so the 25 t payload makes m_zS huge), the velocity part is below 0.1 %.
    The shipped pins, through the same model, need at least 25 % more force."""
    result = optimum(CYLINDER_SCENE)
    assert result.success, result.message
    p, sweep, motion, _ = with_design(CYLINDER_SCENE, result.design)
    peak, th_peak = peak_force(p, sweep, motion)
    assert peak == pytest.approx(result.objective, rel=1e-6)
    _, parts = cylinder_force(Crane(p), motion, np.array([th_peak]))
    static, inertia, velocity = (float(parts[k][0]) for k in ("static", "inertia", "velocity"))
    assert 0.75 * peak < static < 0.95 * peak
    assert 0.05 * peak < inertia < 0.25 * peak
    assert abs(velocity) < 1e-3 * peak
    assert sweep[0] < th_peak < sweep[1]  # an interior peak: the envelope is smooth in the design
    shipped = peak_force(*scene_data(SHIPPED_SCENE)[:3])[0]
    assert shipped > 1.25 * peak


def test_cylinder_active_set_is_the_physical_one():
    """What physics predicts, checked with the numpy model at the reported design:
    - the cylinder's transmission angle angle(F, S, A) is smallest at full luffing in (theta_in,
      the jib steepest), where it sits on its 40 deg limit; the force falls as the rod eye
      moves out along the jib (dP/daS < 0 at fixed F): the angle, not aS's bound, stops it;
    - with that angle held at 40 deg (aS found by a root, brentq), the optimal peak falls as the
      base F moves forward (xF) and up (yF): both sit on their upper bounds;
    - hence the optimum found again as P(8, 11, aS*) equals the reported design and peak
      (1e-8 relative), and its sensitivities to the bounds (central differences, error ~1e-7
      relative at these steps) are the reported multipliers, to 1e-5;
    - the cylinder's length ratio (1.55) and the levelness (0.44 m, fixed) are inactive.
    The result must name exactly these three as active."""
    result = optimum(CYLINDER_SCENE)
    p0, sweep, motion, constraints = scene_data(CYLINDER_SCENE)
    t_in = sweep[1]
    limit = _number(constraints["cylinder transmission angle"]["min"], {})
    box = {p.name: (p.lower, p.upper) for p in load(CYLINDER_SCENE).parameters if p.is_design}
    x_top, y_top = box["xF"][1], box["yF"][1]

    def angle_in(xF, yF, aS):
        P = Crane(dict(p0, xF=xF, yF=yF, aS=aS)).points(np.array([t_in]))
        return angle_at(P["F"], P["S"], P["A"])[0]

    def peak(xF, yF, aS):
        return peak_force(dict(p0, xF=xF, yF=yF, aS=aS), sweep, motion)[0]

    def aS_star(xF, yF, lim=limit):
        return brentq(lambda a: angle_in(xF, yF, a) - lim, *box["aS"], xtol=1e-14)

    def J(xF, yF, lim=limit):
        return peak(xF, yF, aS_star(xF, yF, lim))

    # the angle over the dense stroke: smallest at theta_in, there on its limit
    d = result.design
    P = Crane(dict(p0, **d)).points(np.linspace(*sweep, DENSE))
    at_S = angle_at(P["F"], P["S"], P["A"])
    assert int(np.argmin(at_S)) == DENSE - 1
    assert at_S[-1] == pytest.approx(limit, abs=1e-7)
    assert at_S.max() < _number(constraints["cylinder transmission angle"]["max"], {})
    # the length ratio and levelness: inactive
    L = _norm(P["S"] - P["F"])
    assert L.max() / L.min() < constraints["cylinder length ratio"]["max"] - 0.1
    y = P["T"][1]
    assert y.max() - y.min() < constraints["payload height variation"]["max"] - 0.05
    # the optimum found again from the predicted active set
    h = 1e-3
    assert (peak(d["xF"], d["yF"], d["aS"] + h) - peak(d["xF"], d["yF"], d["aS"] - h)) / (2 * h) < 0
    assert aS_star(x_top, y_top) == pytest.approx(d["aS"], rel=1e-8)
    assert (d["xF"], d["yF"]) == pytest.approx((x_top, y_top), rel=1e-8)
    assert J(x_top, y_top) == pytest.approx(result.objective, rel=1e-8)
    dJ_dxF = (J(x_top + h, y_top) - J(x_top - h, y_top)) / (2 * h)
    dJ_dyF = (J(x_top, y_top + h) - J(x_top, y_top - h)) / (2 * h)
    dJ_dlim = (J(x_top, y_top, limit + 1e-5) - J(x_top, y_top, limit - 1e-5)) / 2e-5
    assert dJ_dxF < 0 and dJ_dyF < 0 and dJ_dlim > 0
    active = {name: c["active"] for name, c in result.constraints.items() if c.get("active")}
    assert active == {"cylinder transmission angle": "lower", "bounds of xF": "upper", "bounds of yF": "upper"}
    # the reported multipliers are the optimum's sensitivities to the bounds (dJ*/d bound)
    assert result.constraints["bounds of xF"]["multiplier"] == pytest.approx(dJ_dxF, rel=1e-5)
    assert result.constraints["bounds of yF"]["multiplier"] == pytest.approx(dJ_dyF, rel=1e-5)
    assert result.constraints["cylinder transmission angle"]["multiplier"] == pytest.approx(dJ_dlim, rel=1e-5)


def test_cylinder_mass_sensitivities_show_the_level_path():
    """The masses enter neither the constraints (all geometric) nor the active set, so the
    optimum's sensitivity to a mass is the peak's partial derivative at the optimal design
    (envelope theorem): central differences of the numpy peak (F_S is linear in each mass; the
    peak moving along the stroke makes the difference err by O(delta^2), below 1e-7 here) must
    equal the reported sensitivities to 1e-5.  And the level path shows in them: a kilogram of
    payload costs the cylinder less than half what a kilogram of jib costs (the payload barely
    rises while luffing; what it costs is mostly its inertia, m (dx_T/dx)^2 a), although it
    hangs 30 m out where the jib's centre of mass is 13.5 m out."""
    result = optimum(CYLINDER_SCENE)
    p, sweep, motion, _ = with_design(CYLINDER_SCENE, result.design)
    delta = 50.0
    sens = {}
    for m in ("m_L", "m2", "m3"):
        up = peak_force(dict(p, **{m: p[m] + delta}), sweep, motion)[0]
        down = peak_force(dict(p, **{m: p[m] - delta}), sweep, motion)[0]
        sens[m] = (up - down) / (2 * delta)
        assert result.sensitivities[m] == pytest.approx(sens[m], rel=1e-5), (m, sens[m])
    assert 0 < sens["m_L"] < 0.5 * sens["m2"], sens
