"""Seed 2's three worked examples (Do Sanh & Do Dang Khoa), from their scene files.

Each answer is held to the paper's closed form and to an independent derivation written here in
plain numpy (loop equations differentiated by hand, or seed 2's own matrix formulas (1.7),
(1.12) with T, T', T'' of (1.2), (1.10), (1.16)).  The code under test supplies only the
mechanism's motion; no expected value comes from it.

Slips of the printed paper met on the way (each confirmed by a derivation below):
- (1.12): the middle sum is  sum_i phi_dot_i^2 * v'_i  (printed phi_dot_i(*) v'_i, unsquared);
  see ``seed2_acceleration`` and ``test_open_chain_printed_1_12_without_square_is_wrong``.
- (1.1): the body coordinates are (a, b, 1) (printed (a, a, 1)); (1.3) and (1.5) have (a, b, 1).
- (1.9): v_i = T_1 ... T'_i ... T_k r (printed without the trailing r, which (1.14), (1.15)
  and the examples' "v_1 = T'_1 T_2 T_3 r" carry).
- Example 2: x_B* = +2 s_2* (printed -2 s_2*; the next line places B at (2 sqrt(0.96), 0)),
  and x_B_dot* = 0.4 phi2_dot* = -0.4 omega_1 (printed 0.4 phi1_dot* = r omega_1: the crank
  turning counter-clockwise at pi/2 drives A, and with it B, towards -x).
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

import optdesign as od
from optdesign.scene.expressions import constant_value, parse

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"
# (omega1, eps1) pairs: rest, pure rate, and mixed signs
RATES = [(1.0, 0.0), (0.0, 1.0), (2.0, 3.0), (-1.5, 0.7), (0.3, -4.0)]
CLOSED_FORM = 1e-12  # closed-form answers at the paper's position (Newton closes to ~1e-15)


def state_at(scene, s_value):
    """kinematics() of ``scene`` with its stroke starting exactly at ``s_value`` (sample 0)."""
    sweep = dataclasses.replace(scene.sweep, start=float(s_value), stop=float(s_value) + 1e-3, samples=2)
    return od.kinematics(dataclasses.replace(scene, sweep=sweep))


def reference_value(scene, key, **values):
    """A [reference] entry: a number, or a formula string evaluated at ``values``."""
    ref = scene.reference[key]
    return constant_value(parse(ref, f"[reference] {key}"), values, key) if isinstance(ref, str) else ref


# ===================================================================================
# Example 2: slider-crank r = 0.4, L = 2, piston B on the horizontal through O, phi = pi/2
# ===================================================================================
R_CRANK, L_ROD = 0.4, 2.0


def slider_crank_closed_form(phi, omega1, eps1, r=R_CRANK, L=L_ROD):
    """Independent derivation, B to the right of O on y = 0, crank angle phi from +x:

        x_B = r cos(phi) + S,  S = sqrt(L^2 - r^2 sin^2 phi)
        rod angle theta (x axis from B through A) = pi - asin(r sin(phi) / L)

    differentiated twice by hand; time rates by the chain rule with phi_dot = omega1."""
    sn, cs = math.sin(phi), math.cos(phi)
    S = math.sqrt(L**2 - (r * sn) ** 2)
    dS = -(r**2) * sn * cs / S
    x = r * cs + S
    x1 = -r * sn + dS
    x2 = -r * cs - r**2 * math.cos(2 * phi) / S - (r**2 * sn * cs) ** 2 / S**3
    th = math.pi - math.asin(r * sn / L)
    th1 = -r * cs / S
    th2 = r * sn / S - r**3 * sn * cs**2 / S**3
    return {
        "xB": x, "vB": x1 * omega1, "aB": x2 * omega1**2 + x1 * eps1,
        "theta": th, "Omega2": th1 * omega1, "eps2": th2 * omega1**2 + th1 * eps1,
    }


def slider_crank_paper(omega1, eps1):
    """The paper's answers at phi = pi/2 (example 2), v_B with the corrected sign."""
    return {
        "xB": 2 * math.sqrt(0.96),
        "vB": -0.4 * omega1,  # printed +0.4 omega1 (a slip, see the module docstring)
        "aB": -0.4 * eps1 + 0.08 / math.sqrt(0.96) * omega1**2,
        "theta": math.pi / 2 + math.atan2(math.sqrt(0.96), 0.2),  # phi1 + phi2*, c2* = 0.2
        "Omega2": 0.0,
        "eps2": 0.2 / math.sqrt(0.96) * omega1**2,
    }


@pytest.fixture(scope="module")
def slider_crank():
    return od.load(PROBLEMS / "seed2_slider_crank.toml")


@pytest.mark.parametrize("omega1, eps1", RATES)
def test_paper_answers_agree_with_independent_derivation_example2(omega1, eps1):
    """The paper's numbers and the hand derivation say the same (a check of the checks)."""
    paper = slider_crank_paper(omega1, eps1)
    derived = slider_crank_closed_form(math.pi / 2, omega1, eps1)
    for key, value in paper.items():
        assert derived[key] == pytest.approx(value, abs=1e-15), key


@pytest.mark.parametrize("omega1, eps1", RATES)
def test_example2_slider_crank_at_pi_over_2(slider_crank, omega1, eps1):
    """Rod: Omega2 = 0, eps2 = 0.2/sqrt(0.96) omega1^2; piston: a_B = -0.4 eps1 + 0.08/sqrt(0.96) omega1^2."""
    res = state_at(slider_crank.with_parameters(omega1=omega1, eps1=eps1), math.pi / 2)
    paper = slider_crank_paper(omega1, eps1)
    rod, B = res.bodies["rod"], res.points["B"]
    got = {"xB": B["x"][0], "vB": B["vx"][0], "aB": B["ax"][0],
           "theta": rod["angle"][0], "Omega2": rod["omega"][0], "eps2": rod["epsilon"][0]}
    for key, value in paper.items():
        assert got[key] == pytest.approx(value, abs=CLOSED_FORM), key
    # B stays on its line: no vertical position, velocity or acceleration
    for key in ("y", "vy", "ay"):
        assert abs(B[key][0]) < CLOSED_FORM, key
    # the crank pin A = r (cos, sin)(pi/2) moves with v_A = omega1 r (-1, 0): the rod translates
    A = res.points["A"]
    assert (A["x"][0], A["y"][0]) == pytest.approx((0.0, 0.4), abs=CLOSED_FORM)
    assert (A["vx"][0], A["vy"][0]) == pytest.approx((-0.4 * omega1, 0.0), abs=CLOSED_FORM)
    assert B["vx"][0] == pytest.approx(A["vx"][0], abs=CLOSED_FORM)


def test_example2_over_the_stroke_matches_derivation(slider_crank):
    """The whole revolution against the hand derivation: B moves the way the geometry says."""
    omega1, eps1 = 1.7, -0.6
    res = od.kinematics(slider_crank.with_parameters(omega1=omega1, eps1=eps1))
    assert res.s[90] == pytest.approx(math.pi / 2, abs=1e-15)  # the stroke contains the paper's position
    for i, phi in enumerate(res.s):
        cf = slider_crank_closed_form(phi, omega1, eps1)
        B, rod = res.points["B"], res.bodies["rod"]
        assert B["x"][i] == pytest.approx(cf["xB"], abs=1e-12)
        assert B["vx"][i] == pytest.approx(cf["vB"], abs=1e-11)
        assert B["ax"][i] == pytest.approx(cf["aB"], abs=1e-11)
        assert rod["omega"][i] == pytest.approx(cf["Omega2"], abs=1e-11)
        assert rod["epsilon"][i] == pytest.approx(cf["eps2"], abs=1e-11)
        assert math.remainder(rod["angle"][i] - cf["theta"], 2 * math.pi) == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("omega1, eps1", RATES)
def test_example2_reference_table_holds_the_paper(slider_crank, omega1, eps1):
    paper = slider_crank_paper(omega1, eps1)
    ref = slider_crank.reference
    assert ref["phi"] == pytest.approx(math.pi / 2, abs=1e-15)
    assert ref["xB"] == pytest.approx(paper["xB"], abs=1e-15)
    assert ref["Omega2"] == 0
    assert ref["eps2_per_omega1_sq"] * omega1**2 == pytest.approx(paper["eps2"], abs=1e-15)
    aB = reference_value(slider_crank, "aB", omega1=omega1, eps1=eps1)
    assert aB == pytest.approx(paper["aB"], abs=1e-15)
    assert ref["aB_per_eps1"] * eps1 + ref["aB_per_omega1_sq"] * omega1**2 == pytest.approx(paper["aB"], abs=1e-15)
    assert ref["vB_per_omega1"] * omega1 == pytest.approx(paper["vB"], abs=1e-15)


# ===================================================================================
# Example 3: four-bar AB = DC = R = 0.4, BC = AD = L = 0.2, at c1 = 0.8, s1 = 0.6
# ===================================================================================
PHI1_STAR = math.atan2(0.6, 0.8)


def fourbar_closed_form(phi1, omega1, eps1, R=0.4, L=0.2):
    """Independent derivation: with absolute link angles th1 = phi1, th2, th3 and unit vectors
    e(th), the closure  R e1 + L e2 + R e3 = (L, 0)  differentiated once and twice,

        sum l_i Omega_i J e_i = 0,   sum l_i (eps_i J e_i - Omega_i^2 e_i) = 0,  J = rot(+90 deg),

    solved for (Omega2, Omega3), (eps2, eps3).  The position is the paper's branch
    (phi2 = pi/2, phi3 = pi - phi1 at phi1*), found here from C by circle intersection."""
    e = lambda th: np.array([math.cos(th), math.sin(th)])  # noqa: E731
    J = np.array([[0.0, -1.0], [1.0, 0.0]])
    B = R * e(phi1)
    D = np.array([L, 0.0])
    # C: |C - B| = L, |C - D| = R, on the right of B -> D (the paper's C = (0.2, 0.4))
    d = D - B
    d2 = d @ d
    along = d2 + L**2 - R**2
    C = B + (along * d - math.sqrt(4 * d2 * L**2 - along**2) * (J @ d)) / (2 * d2)
    th2 = math.atan2(*(C - B)[::-1])
    th3 = math.atan2(*(D - C)[::-1])
    M = np.column_stack([L * J @ e(th2), R * J @ e(th3)])
    Om2, Om3 = np.linalg.solve(M, -R * omega1 * (J @ e(phi1)))
    rhs = -(R * eps1 * (J @ e(phi1)) - R * omega1**2 * e(phi1) - L * Om2**2 * e(th2) - R * Om3**2 * e(th3))
    eps2, eps3 = np.linalg.solve(M, rhs)
    return {"B": B, "C": C, "th2": th2, "th3": th3, "Omega2": Om2, "Omega3": Om3, "eps2": eps2, "eps3": eps3}


def fourbar_paper(omega1, eps1):
    return {
        "Omega2": 8 / 3 * omega1, "Omega3": 5 / 3 * omega1,
        "eps2": 8 / 3 * eps1 - 20 / 9 * omega1**2, "eps3": 5 / 3 * eps1 - 20 / 9 * omega1**2,
    }


@pytest.fixture(scope="module")
def fourbar():
    return od.load(PROBLEMS / "seed2_fourbar.toml")


@pytest.mark.parametrize("omega1, eps1", RATES)
def test_paper_answers_agree_with_independent_derivation_example3(omega1, eps1):
    derived = fourbar_closed_form(PHI1_STAR, omega1, eps1)
    for key, value in fourbar_paper(omega1, eps1).items():
        assert derived[key] == pytest.approx(value, abs=1e-13), key
    # the paper's position: phi2 = pi/2, phi1 + phi3 = pi, so B = (0.32, 0.24), C = (0.2, 0.4)
    assert derived["th2"] == pytest.approx(PHI1_STAR + math.pi / 2, abs=1e-14)
    assert derived["C"] == pytest.approx([0.2, 0.4], abs=1e-14)


@pytest.mark.parametrize("omega1, eps1", RATES)
def test_example3_fourbar_at_paper_position(fourbar, omega1, eps1):
    """Coupler: Omega2 = 8/3 omega1, eps2 = 8/3 eps1 - 20/9 omega1^2; rocker: 5/3, 5/3, -20/9."""
    res = state_at(fourbar.with_parameters(omega1=omega1, eps1=eps1), PHI1_STAR)
    paper = fourbar_paper(omega1, eps1)
    coupler, rocker = res.bodies["coupler"], res.bodies["rocker"]
    got = {"Omega2": coupler["omega"][0], "Omega3": rocker["omega"][0],
           "eps2": coupler["epsilon"][0], "eps3": rocker["epsilon"][0]}
    for key, value in paper.items():
        assert got[key] == pytest.approx(value, abs=CLOSED_FORM), key
    # positions: the paper's branch, and D3 (link 3's end) closes on D with zero motion
    P = res.points
    assert (P["B"]["x"][0], P["B"]["y"][0]) == pytest.approx((0.32, 0.24), abs=CLOSED_FORM)
    assert (P["C"]["x"][0], P["C"]["y"][0]) == pytest.approx((0.2, 0.4), abs=CLOSED_FORM)
    for key in ("x", "y", "vx", "vy", "ax", "ay"):
        target = 0.2 if key == "x" else 0.0
        assert P["D3"][key][0] == pytest.approx(target, abs=CLOSED_FORM), key


def test_example3_over_the_stroke_matches_derivation(fourbar):
    omega1, eps1 = -0.8, 2.5
    res = od.kinematics(fourbar.with_parameters(omega1=omega1, eps1=eps1))
    for i, phi1 in enumerate(res.s):
        cf = fourbar_closed_form(phi1, omega1, eps1)
        assert (res.points["C"]["x"][i], res.points["C"]["y"][i]) == pytest.approx(tuple(cf["C"]), abs=1e-12)
        assert res.bodies["coupler"]["omega"][i] == pytest.approx(cf["Omega2"], abs=1e-11)
        assert res.bodies["rocker"]["omega"][i] == pytest.approx(cf["Omega3"], abs=1e-11)
        assert res.bodies["coupler"]["epsilon"][i] == pytest.approx(cf["eps2"], abs=1e-10)
        assert res.bodies["rocker"]["epsilon"][i] == pytest.approx(cf["eps3"], abs=1e-10)


@pytest.mark.parametrize("omega1, eps1", RATES)
def test_example3_reference_table_holds_the_paper(fourbar, omega1, eps1):
    paper = fourbar_paper(omega1, eps1)
    ref = fourbar.reference
    assert ref["phi1"] == pytest.approx(PHI1_STAR, abs=1e-15)
    assert ref["Omega2_per_omega1"] * omega1 == pytest.approx(paper["Omega2"], abs=1e-15)
    assert ref["Omega3_per_omega1"] * omega1 == pytest.approx(paper["Omega3"], abs=1e-15)
    for key in ("eps2", "eps3"):
        value = reference_value(fourbar, key, omega1=omega1, eps1=eps1)
        assert value == pytest.approx(paper[key], abs=1e-14), key


# ===================================================================================
# Example 1: the open three-link chain, point M = (a, b) in link 3
# ===================================================================================
def T(phi, L_before):
    """Seed 2, (1.2): the transmission matrix T_i."""
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[c, -s, L_before], [s, c, 0.0], [0.0, 0.0, 1.0]])


def T1p(phi):
    """Seed 2, (1.10): T'_i = dT_i/dphi_i."""
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[-s, -c, 0.0], [c, -s, 0.0], [0.0, 0.0, 0.0]])


def T2p(phi):
    """Seed 2, (1.16): T''_i = d^2 T_i/dphi_i^2."""
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[-c, s, 0.0], [-s, -c, 0.0], [0.0, 0.0, 0.0]])


def chain_product(factors, r):
    out = np.eye(3)
    for f in factors:
        out = out @ f
    return out @ r


def seed2_velocity(phi, w, lengths_before, r):
    """(1.7), (1.9): v = sum_i phi_dot_i v_i, v_i = T_1 .. T'_i .. T_k r."""
    k = len(phi)
    Ts = [T(p, Lb) for p, Lb in zip(phi, lengths_before)]
    v = np.zeros(3)
    for i in range(k):
        v += w[i] * chain_product([T1p(phi[j]) if j == i else Ts[j] for j in range(k)], r)
    return v


def seed2_acceleration(phi, w, e, lengths_before, r, square_rates=True):
    """(1.12)-(1.16): a = sum e_i v_i + sum w_i^2 v'_i + 2 sum_{i<j} w_i w_j v_ij.

    Derivation of the middle sum (the print has phi_dot_i(*) v'_i, unsquared): differentiate
    v = sum_i w_i v_i(phi) in time; dv_i/dt = sum_j w_j dv_i/dphi_j with dv_i/dphi_i =
    T_1 .. T''_i .. T_k r = v'_i (T'' = dT'/dphi, (1.16)) and dv_i/dphi_j = v_ij (j != i), so
    a = sum e_i v_i + sum_i w_i^2 v'_i + sum_{i != j} w_i w_j v_ij: the rate enters squared, as
    dimensions demand (v'_i is a length, a an acceleration).  ``square_rates=False`` gives the
    printed (unsquared) version, to show it is wrong."""
    k = len(phi)
    Ts = [T(p, Lb) for p, Lb in zip(phi, lengths_before)]

    def v_with(derivs):
        return chain_product([derivs.get(j, Ts[j]) for j in range(k)], r)

    a = np.zeros(3)
    for i in range(k):
        a += e[i] * v_with({i: T1p(phi[i])})
        a += (w[i] ** 2 if square_rates else w[i]) * v_with({i: T2p(phi[i])})
        for j in range(i + 1, k):
            a += 2 * w[i] * w[j] * v_with({i: T1p(phi[i]), j: T1p(phi[j])})
    return a


def example1_expanded(L1, L2, a, b, phi, w, e):
    """Example 1's closed forms: position and velocity as printed; the acceleration
    re-derived (the printed one has many slips), with X_i, Y_i = M - A_i in global axes."""
    p1, p12, p123 = phi[0], phi[0] + phi[1], sum(phi)
    c1, s1, c12, s12, c123, s123 = (f(t) for t in (p1, p12, p123) for f in (math.cos, math.sin))
    X3, Y3 = a * c123 - b * s123, a * s123 + b * c123
    X2, Y2 = X3 + L2 * c12, Y3 + L2 * s12
    X1, Y1 = X2 + L1 * c1, Y2 + L1 * s1
    w1, w2, w3 = w
    e1, e2, e3 = e
    return {
        "x": X1, "y": Y1,
        "vx": -Y1 * w1 - Y2 * w2 - Y3 * w3, "vy": X1 * w1 + X2 * w2 + X3 * w3,
        "ax": (-Y1 * e1 - Y2 * e2 - Y3 * e3 - X1 * w1**2 - X2 * w2**2 - X3 * w3**2
               - 2 * X2 * w1 * w2 - 2 * X3 * w1 * w3 - 2 * X3 * w2 * w3),
        "ay": (X1 * e1 + X2 * e2 + X3 * e3 - Y1 * w1**2 - Y2 * w2**2 - Y3 * w3**2
               - 2 * Y2 * w1 * w2 - 2 * Y3 * w1 * w3 - 2 * Y3 * w2 * w3),
        "vars": dict(c1=c1, s1=s1, c12=c12, s12=s12, c123=c123, s123=s123,
                     X1=X1, X2=X2, X3=X3, Y1=Y1, Y2=Y2, Y3=Y3),
    }


def random_chain_state(rng):
    return {
        "L1": rng.uniform(0.2, 1.5), "L2": rng.uniform(0.2, 1.5), "L3": rng.uniform(0.1, 1.0),
        "a": rng.uniform(-1, 1), "b": rng.uniform(-1, 1),
        **{f"phi{i}0": rng.uniform(-math.pi, math.pi) for i in (1, 2, 3)},
        **{f"w{i}": rng.uniform(-5, 5) for i in (1, 2, 3)},
        **{f"e{i}": rng.uniform(-20, 20) for i in (1, 2, 3)},
    }


@pytest.fixture(scope="module")
def open_chain():
    return od.load(PROBLEMS / "seed2_open_chain.toml")


@pytest.mark.parametrize("seed", range(12))
def test_example1_open_chain_matches_1_7_and_1_12(open_chain, seed):
    """AD velocity and acceleration of M (and Omega_3, eps_3 of link 3, (1.11), (1.17)) equal
    seed 2's matrix formulas at random lengths, angles, rates and accelerations."""
    st = random_chain_state(np.random.default_rng(1000 + seed))
    res = state_at(open_chain.with_parameters(**st), 0.0)  # t = 0: the parameters are the state
    phi = [st["phi10"], st["phi20"], st["phi30"]]
    w = [st["w1"], st["w2"], st["w3"]]
    e = [st["e1"], st["e2"], st["e3"]]
    r = np.array([st["a"], st["b"], 1.0])
    before = [0.0, st["L1"], st["L2"]]  # L_0 = 0
    pos = chain_product([T(p, Lb) for p, Lb in zip(phi, before)], r)  # (1.5)
    vel = seed2_velocity(phi, w, before, r)
    acc = seed2_acceleration(phi, w, e, before, r)
    M = res.points["M"]
    scale = 1.0 + np.abs(acc).max()  # accelerations reach ~100: 1e-12 relative to their size
    assert (M["x"][0], M["y"][0]) == pytest.approx(tuple(pos[:2]), abs=1e-12)
    assert (M["vx"][0], M["vy"][0]) == pytest.approx(tuple(vel[:2]), abs=1e-12 * (1 + np.abs(vel).max()))
    assert (M["ax"][0], M["ay"][0]) == pytest.approx(tuple(acc[:2]), abs=1e-12 * scale)
    assert vel[2] == 0.0 and acc[2] == 0.0  # homogeneous coordinate of a free vector
    link3 = res.bodies["link3"]
    assert link3["omega"][0] == pytest.approx(sum(w), abs=1e-12)  # (1.11)
    assert link3["epsilon"][0] == pytest.approx(sum(e), abs=1e-11)  # (1.17)
    # the expanded closed forms of example 1 say the same
    cf = example1_expanded(st["L1"], st["L2"], st["a"], st["b"], phi, w, e)
    for key, value in zip(("x", "y", "vx", "vy", "ax", "ay"), (*pos[:2], *vel[:2], *acc[:2])):
        assert cf[key] == pytest.approx(value, abs=1e-12 * scale), key


def test_example1_reference_table_holds_the_expanded_forms(open_chain):
    rng = np.random.default_rng(7)
    for _ in range(5):
        st = random_chain_state(rng)
        phi = [st["phi10"], st["phi20"], st["phi30"]]
        w = [st["w1"], st["w2"], st["w3"]]
        e = [st["e1"], st["e2"], st["e3"]]
        cf = example1_expanded(st["L1"], st["L2"], st["a"], st["b"], phi, w, e)
        values = {**st, **cf["vars"]}
        for key, ref_key in (("x", "xM"), ("y", "yM"), ("vx", "vxM"), ("vy", "vyM"), ("ax", "axM"), ("ay", "ayM")):
            assert reference_value(open_chain, ref_key, **values) == pytest.approx(cf[key], abs=1e-12), key
        assert reference_value(open_chain, "Omega3", **values) == pytest.approx(sum(w), abs=1e-15)
        assert reference_value(open_chain, "epsilon3", **values) == pytest.approx(sum(e), abs=1e-15)


def test_open_chain_printed_1_12_without_square_is_wrong(open_chain):
    """The slip in (1.12): with rates other than 0 and 1, the unsquared middle sum misses the
    AD acceleration by far more than rounding, while the squared one meets it."""
    st = random_chain_state(np.random.default_rng(3)) | {"w1": 2.0, "w2": -3.0, "w3": 0.5}
    res = state_at(open_chain.with_parameters(**st), 0.0)
    phi = [st["phi10"], st["phi20"], st["phi30"]]
    w = [st["w1"], st["w2"], st["w3"]]
    e = [st["e1"], st["e2"], st["e3"]]
    args = (phi, w, e, [0.0, st["L1"], st["L2"]], np.array([st["a"], st["b"], 1.0]))
    ad = np.array([res.points["M"]["ax"][0], res.points["M"]["ay"][0]])
    assert np.abs(seed2_acceleration(*args)[:2] - ad).max() < 1e-11
    assert np.abs(seed2_acceleration(*args, square_rates=False)[:2] - ad).max() > 1e-2


# ===================================================================================
# The paper's own route for examples 2 and 3: its printed matrices v_i, v'_i, v_ij at the
# given position, then (1.7) and (1.12) solved for the unknown rates (a check of the print)
# ===================================================================================
def seed2_matrices(phi, lengths_before, r):
    """v_i, v'_i and v_ij (i < j) of (1.9), (1.14), (1.15) as 2-vectors."""
    k = len(phi)
    Ts = [T(p, Lb) for p, Lb in zip(phi, lengths_before)]

    def v_with(derivs):
        return chain_product([derivs.get(j, Ts[j]) for j in range(k)], r)[:2]

    v = [v_with({i: T1p(phi[i])}) for i in range(k)]
    vp = [v_with({i: T2p(phi[i])}) for i in range(k)]
    vij = {(i, j): v_with({i: T1p(phi[i]), j: T1p(phi[j])}) for i in range(k) for j in range(i + 1, k)}
    return v, vp, vij


def test_example2_printed_matrices_and_their_solution():
    """At phi1 = pi/2, c2 = 0.2, s2 = sqrt(0.96), B = (-2, 0) in link 2: the printed v_1*, v_2*,
    v'_1*, v'_2*, v_12* (printed with the label T_1 T''_2 r; it is T'_1 T'_2 r, equal here),
    and with y_B fixed to the line: phi2_dot = -phi1_dot, phi2_ddot = -eps1 + 0.2/sqrt(0.96) w^2,
    x_B_ddot = -0.4 eps1 + 0.08/sqrt(0.96) w^2 and x_B_dot = 0.4 phi2_dot = -0.4 w."""
    q = math.sqrt(0.96)
    v, vp, vij = seed2_matrices([math.pi / 2, math.acos(0.2)], [0.0, 0.4], np.array([-2.0, 0.0, 1.0]))
    printed = {"v1": (0, 2 * q), "v2": (0.4, 2 * q), "v'1": (-2 * q, 0), "v'2": (-2 * q, 0.4), "v12": (-2 * q, 0.4)}
    for name, got in zip(printed, (v[0], v[1], vp[0], vp[1], vij[0, 1])):
        assert got == pytest.approx(printed[name], abs=1e-15), name
    for w1, e1 in RATES:
        w2 = -v[0][1] * w1 / v[1][1]  # y_B_dot = 0
        # y_B_ddot = 0 solved for phi2_ddot
        e2 = -(v[0][1] * e1 + vp[0][1] * w1**2 + vp[1][1] * w2**2 + 2 * vij[0, 1][1] * w1 * w2) / v[1][1]
        xdot = v[0][0] * w1 + v[1][0] * w2
        xddot = v[0][0] * e1 + v[1][0] * e2 + vp[0][0] * w1**2 + vp[1][0] * w2**2 + 2 * vij[0, 1][0] * w1 * w2
        assert w2 == pytest.approx(-w1, abs=1e-15)
        assert e2 == pytest.approx(-e1 + 0.2 / q * w1**2, abs=1e-14)
        assert xdot == pytest.approx(-0.4 * w1, abs=1e-15)  # printed +0.4 omega1: the sign slip
        assert xddot == pytest.approx(-0.4 * e1 + 0.08 / q * w1**2, abs=1e-14)


def test_example3_printed_matrices_and_their_solution():
    """At c1 = 0.8, s1 = 0.6, phi2 = pi/2, phi3 = pi - phi1, D = (0.4, 0) in link 3: the printed
    v_i*, v'_i*, v_ij* (several printed with garbled labels, values right), then (1.7) and
    (1.12) for the fixed point D give the paper's rates.  The printed y-equation of (1.12)
    lacks 2 v_13y w1 w3 + 2 v_23y w2 w3 = 0.8 w1 w3 + 0.8 w2 w3; as printed it would give
    eps2 = 8/3 eps1 + 15.56 w1^2, with them the paper's 8/3 eps1 - 20/9 w1^2."""
    p1 = PHI1_STAR
    v, vp, vij = seed2_matrices([p1, math.pi / 2, math.pi - p1], [0.0, 0.4, 0.2], np.array([0.4, 0.0, 1.0]))
    printed = {"v1": (0, 0.2), "v2": (0.24, -0.12), "v3": (0.4, 0), "v'1": (-0.2, 0), "v'2": (0.12, 0.24),
               "v'3": (0, 0.4), "v12": (0.12, 0.24), "v13": (0, 0.4), "v23": (0, 0.4)}
    got = (*v, *vp, vij[0, 1], vij[0, 2], vij[1, 2])
    for name, value in zip(printed, got):
        assert value == pytest.approx(printed[name], abs=1e-15), name
    V = np.column_stack([v[1], v[2]])
    for w1, e1 in RATES:
        w2, w3 = np.linalg.solve(V, -v[0] * w1)  # D at rest: (1.7) = 0
        assert (w2, w3) == pytest.approx((5 / 3 * w1, -w1), abs=1e-14)
        w = (w1, w2, w3)
        quad = sum(vp[i] * w[i] ** 2 for i in range(3)) + sum(2 * vij[i, j] * w[i] * w[j] for i, j in vij)
        e2, e3 = np.linalg.solve(V, -(v[0] * e1 + quad))  # (1.12) = 0
        paper = fourbar_paper(w1, e1)
        assert e1 + e2 == pytest.approx(paper["eps2"], abs=1e-13)
        assert e1 + e2 + e3 == pytest.approx(paper["eps3"], abs=1e-13)
        # the y-equation as printed (0.20 e1 - 0.12 e2 + 0.24 w2^2 + 0.40 w3^2 + 0.48 w1 w2 = 0)
        e2_printed = (0.20 * e1 + 0.24 * w2**2 + 0.40 * w3**2 + 0.48 * w1 * w2) / 0.12
        if w1 != 0:
            assert abs(e1 + e2_printed - paper["eps2"]) > 1.0
