"""A motion stated on the output: problems/ventilator_squeeze.toml, a four-bar whose rocker (the
sweep) follows a cycloidal squeeze, a modified-sine return and a rest, against an independent
numpy model written here: the laws in time from their textbook formulas (Norton's modified
sine), the four-bar's inverse kinematics (the crank from the rocker by the law of cosines),
velocities and accelerations from the loop's derivative equations, the drive torque by virtual
work, the motor's through the gearbox, and the RMS over the breath by Gauss-Legendre in time
on each smooth piece."""
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

import optdesign

SCENE = Path(__file__).parents[1] / "problems" / "ventilator_squeeze.toml"
PI = np.pi
D, MR, G, I_RATIO, J_ROTOR = 0.10, 0.4, 9.81, 10.0, 2e-5
PSI_LO, PSI_HI = np.radians(100.0), np.radians(130.0)


def cycloidal(tau):
    return tau - np.sin(2 * PI * tau) / (2 * PI), 1 - np.cos(2 * PI * tau), 2 * PI * np.sin(2 * PI * tau)


def modified_sine(tau):
    """Norton, Design of Machinery, eq. 8.21, and its derivatives."""
    tau = np.asarray(tau, float)
    k = 4 + PI
    ends = (tau <= 1 / 8) | (tau >= 7 / 8)
    shift = np.where(tau >= 7 / 8, 4.0, 0.0)
    arg = PI / 3 + 4 * PI * tau / 3
    f = np.where(ends, (shift + PI * tau - np.sin(4 * PI * tau) / 4) / k, (2 + PI * tau - 9 / 4 * np.sin(arg)) / k)
    v = np.where(ends, (PI - PI * np.cos(4 * PI * tau)) / k, (PI - 3 * PI * np.cos(arg)) / k)
    a = np.where(ends, 4 * PI**2 * np.sin(4 * PI * tau) / k, 4 * PI**2 * np.sin(arg) / k)
    return f, v, a


def drive_torque(psi, psi_d, psi_dd, a, b, c, T0, kbag):
    """(crank angle q, q', q'', drive torque) by virtual work at rocker angle psi and its rates."""
    C = np.stack([D + c * np.cos(psi), c * np.sin(psi)])
    AC = np.hypot(*C)
    gamma = np.arccos((a**2 + AC**2 - b**2) / (2 * a * AC))   # at A between A->C and A->B
    q = np.arctan2(C[1], C[0]) - gamma                           # B to the right of A->C
    B = np.stack([a * np.cos(q), a * np.sin(q)])
    beta = np.arctan2(C[1] - B[1], C[0] - B[0])
    e = lambda x: np.stack([np.cos(x), np.sin(x)])              # noqa: E731
    n = lambda x: np.stack([-np.sin(x), np.cos(x)])             # noqa: E731
    # a q' n(q) + b beta' n(beta) = c psi' n(psi): the ratios per unit psi'
    M = np.stack([np.stack([a * n(q)[0], b * n(beta)[0]], -1), np.stack([a * n(q)[1], b * n(beta)[1]], -1)], -2)
    kq, kb = np.moveaxis(np.linalg.solve(M, (c * n(psi)).T[..., None])[..., 0], -1, 0)
    q_d, b_d = kq * psi_d, kb * psi_d
    rhs = c * psi_dd * n(psi) - c * psi_d**2 * e(psi) + a * q_d**2 * e(q) + b * b_d**2 * e(beta)
    q_dd, b_dd = np.moveaxis(np.linalg.solve(M, rhs.T[..., None])[..., 0], -1, 0)
    mc = 1.5 * b
    # rocker: com D + c/2 e(psi); coupler: com B + b/2 e(beta)
    r_acc = c / 2 * (psi_dd * n(psi) - psi_d**2 * e(psi))
    r_dq = c / 2 * n(psi) / kq
    c_acc = a * (q_dd * n(q) - q_d**2 * e(q)) + b / 2 * (b_dd * n(beta) - b_d**2 * e(beta))
    c_dq = a * n(q) + b / 2 * n(beta) * kb / kq
    torque = (MR * ((r_acc * r_dq).sum(0) + G * r_dq[1]) + MR * c**2 / 12 * psi_dd / kq
              + mc * ((c_acc * c_dq).sum(0) + G * c_dq[1]) + mc * b**2 / 12 * b_dd * kb / kq
              + (T0 + kbag * (psi - PSI_LO)) / kq)
    return q, q_d, q_dd, torque


CASES = {"squeeze": (cycloidal, 1.0, 1.0, 0.6, 6.0), "return": (modified_sine, 0.8, -1.0, 0.0, 0.0)}


def case_model(name, tau, a, b, c):
    law, T, sigma, T0, kbag = CASES[name]
    L = PSI_HI - PSI_LO
    f, v, acc = law(tau)
    psi = PSI_LO + L * f if sigma > 0 else PSI_HI - L * f
    q, q_d, q_dd, torque = drive_torque(psi, sigma * L / T * v, sigma * L / T**2 * acc, a, b, c, T0, kbag)
    return psi, q, torque, torque / I_RATIO + J_ROTOR * I_RATIO * q_dd


@pytest.fixture(scope="module")
def analysed():
    return optdesign.analyse(optdesign.load(SCENE))


def test_analyse_against_the_numpy_model(analysed):
    result = analysed
    for name, (law, T, sigma, _, _) in CASES.items():
        cols = result.cases.cases[name].columns
        L = PSI_HI - PSI_LO
        x = sigma * (cols["s"] - (PSI_LO if sigma > 0 else PSI_HI))
        tau = np.array([0.0 if u <= 0 else 1.0 if u >= L else
                        brentq(lambda t: law(t)[0] - u / L, 0, 1, xtol=1e-16, rtol=8.9e-16) for u in x])
        psi, q, torque, motor = case_model(name, tau, 0.025, 0.10, 0.08)
        assert np.max(np.abs(psi - cols["s"])) < 1e-14
        assert np.max(np.abs(cols["t"] - T * tau)) < 1e-12
        assert np.max(np.abs(np.angle(np.exp(1j * (cols["q"] - q))))) < 1e-12
        assert np.max(np.abs(cols["drive"] - torque)) < 1e-9 * np.max(np.abs(torque))
        assert np.max(np.abs(cols["motor_torque"] - motor)) < 1e-9 * np.max(np.abs(motor))
    # the rest at 100 deg: the motor holds the mechanism against gravity (the return's loads)
    hold = drive_torque(np.array([PSI_LO]), 0.0, 0.0, 0.025, 0.10, 0.08, 0.0, 0.0)[3][0]
    step = result.cases.duty["steps"][2]
    assert step["kind"] == "hold" and step["load"] == pytest.approx(hold, rel=1e-12)
    assert result.cases.duty["rms_time"]["motor_torque"] == pytest.approx(reference_rms(0.025, 0.10, 0.08), rel=1e-9)


def gauss_legendre(pieces, n=64):
    nodes, weights = np.polynomial.legendre.leggauss(n)
    t = np.concatenate([(b - a) / 2 * nodes + (a + b) / 2 for a, b in pieces])
    w = np.concatenate([(b - a) / 2 * weights for a, b in pieces])
    return t, w


def reference_rms(a, b, c):
    """The motor's RMS torque over the breath: squeeze (one smooth piece), return (three pieces
    of the modified sine), and the 1.2 s rest holding the static torque."""
    total = 0.0
    for name, pieces in (("squeeze", [(0, 1)]), ("return", [(0, 1 / 8), (1 / 8, 7 / 8), (7 / 8, 1)])):
        tau, w = gauss_legendre(pieces)
        T = CASES[name][1]
        total += T * np.dot(w, case_model(name, tau, a, b, c)[3] ** 2)
    hold = drive_torque(np.array([PSI_LO]), 0.0, 0.0, a, b, c, 0.0, 0.0)[3][0] / I_RATIO
    total += hold**2 * 1.2
    return np.sqrt(total / 3.0)


def angles(psi, a, b, c):
    """(transmission angle at C, angle at B between B->A and B->C) of the numpy four-bar."""
    C = np.stack([D + c * np.cos(psi), c * np.sin(psi)])
    AC = np.hypot(*C)
    gamma = np.arccos(np.clip((a**2 + AC**2 - b**2) / (2 * a * AC), -1, 1))
    q = np.arctan2(C[1], C[0]) - gamma
    B = np.stack([a * np.cos(q), a * np.sin(q)])
    cb, cd = B - C, np.array([[D], [0.0]]) - C
    mu = np.arccos((cb * cd).sum(0) / (b * c))
    ba, bc = -B, C - B
    toggle = np.arccos(np.clip((ba * bc).sum(0) / (a * b), -1, 1))
    return mu, toggle, (a**2 + AC**2 - b**2) / (2 * a * AC)


PSI = np.linspace(PSI_LO, PSI_HI, 601)   # ends included: the constraints hold at the true stroke ends
BOX = np.array([[0.018, 0.032], [0.08, 0.12], [0.065, 0.095]])


def slack(x):
    """Every constraint's margin at the dense rocker angles (>= 0 where it holds)."""
    mu, toggle, cos_gamma = angles(PSI, *x)
    lo, hi = np.radians([40.0, 25.0]), np.radians([140.0, 155.0])
    return np.concatenate([mu - lo[0], hi[0] - mu, toggle - lo[1], hi[1] - toggle, 1 - np.abs(cos_gamma)])


def reference_optimum():
    """The global optimum of the numpy model: a 9^3 grid over the box, then SLSQP polish (finite
    differences) from the three best feasible grid points."""
    from scipy.optimize import minimize

    axes = [np.linspace(lo, hi, 9) for lo, hi in BOX]
    best = []
    for a in axes[0]:
        for b in axes[1]:
            for c in axes[2]:
                if np.min(slack((a, b, c))) >= 0:
                    best.append((reference_rms(a, b, c), (a, b, c)))
    best.sort(key=lambda item: item[0])
    found = []
    scale = BOX[:, 1] - BOX[:, 0]
    for _, x0 in best[:3]:
        res = minimize(lambda z: reference_rms(*(BOX[:, 0] + z * scale)) * 100, (np.array(x0) - BOX[:, 0]) / scale,
                       method="SLSQP", bounds=[(0, 1)] * 3,
                       constraints=[{"type": "ineq", "fun": lambda z: slack(BOX[:, 0] + z * scale)}],
                       options={"ftol": 1e-15, "maxiter": 500})
        x = BOX[:, 0] + res.x * scale
        if np.min(slack(x)) >= -1e-10:
            found.append((reference_rms(*x), x))
    return min(found, key=lambda item: item[0])


@pytest.fixture(scope="module")
def reference():
    return reference_optimum()


def check_optimum(objective, design, reference):
    f_ref, x_ref = reference
    assert objective == pytest.approx(f_ref, rel=1e-9)
    assert np.allclose([design[k] for k in "abc"], x_ref, rtol=0, atol=1e-6)
    # the crank toggle binds at both stroke ends (its min and max over the swing, ends included)
    mu, toggle, _ = angles(np.array([PSI_LO, PSI_HI]), *[design[k] for k in "abc"])
    assert np.allclose(sorted(toggle), np.radians([25.0, 155.0]), atol=1e-8)
    assert np.min(slack(np.array([design[k] for k in "abc"]))) > -1e-8


def test_optimise_reaches_the_reference_optimum(reference):
    """One start from the scene's start, with the default settings."""
    result = optdesign.optimise(optdesign.load(SCENE), starts=1)
    assert result.success
    check_optimum(result.objective, result.design, reference)


def test_shipped_results_reach_the_reference_optimum(reference):
    """results/ventilator_squeeze (optdesign optimise problems/ventilator_squeeze.toml --out
    results/ventilator_squeeze): 20 of 20 starts at the independent optimum."""
    import json

    doc = json.loads((SCENE.parents[1] / "results" / "ventilator_squeeze" / "result.json").read_text())
    assert doc["success"] and doc["starts_total"] == 20 and doc["starts_at_best"] == 20
    assert all(abs(s["objective"] / doc["objective"] - 1) < 1e-9 for s in doc["starts"])
    check_optimum(doc["objective"], doc["design"], reference)


def test_jerk_column_and_the_motion_figure(analysed, tmp_path):
    """The squeeze's jerk is the cycloid's, L/T^3 (2 pi)^2 cos(2 pi tau); motion.png is drawn."""
    from optdesign.report.cases import cases_figures

    result = analysed
    cols = result.cases.cases["squeeze"].columns
    tau = cols["t"] / 1.0
    L = PSI_HI - PSI_LO
    assert np.max(np.abs(cols["jerk"] - L * (2 * PI) ** 2 * np.cos(2 * PI * tau))) < 1e-9 * L * (2 * PI) ** 2
    assert np.max(np.abs(cols["sdd"] - L * 2 * PI * np.sin(2 * PI * tau))) < 1e-9 * L * 2 * PI
    written = cases_figures(result, tmp_path)
    assert tmp_path / "motion.png" in written and (tmp_path / "motion.png").stat().st_size > 20_000


def test_simulate_tracks_the_laws_in_time():
    """simulate's phases (a speed controller with a position loop tracking each case's law, then
    the motor holding the rest) follow the numpy model's rocker angle to the controller's
    tracking error, and its RMS motor torque over the breath agrees with the model's."""
    result = optdesign.simulate(optdesign.load(SCENE))
    t, psi = result.t, result.columns["s"]
    squeeze, back = t <= 1.0, (t >= 1.0) & (t <= 1.8)
    want = np.where(squeeze, PSI_LO + (PSI_HI - PSI_LO) * cycloidal(np.clip(t, 0, 1))[0],
                    np.where(back, PSI_HI - (PSI_HI - PSI_LO) * modified_sine(np.clip((t - 1) / 0.8, 0, 1))[0], PSI_LO))
    assert np.max(np.abs(psi - want)) < 1e-3   # rad: the tracking error, 6.1e-4 (the stroke is 0.52 rad)
    energy = sum(p["integrals"]["motor_squared"] for p in result.phases)
    assert [p["name"] for p in result.phases] == ["squeeze", "return", "rest"]
    assert np.sqrt(energy / 3.0) == pytest.approx(reference_rms(0.025, 0.10, 0.08), rel=1e-3)


def test_a_swing_past_the_crank_toggle_is_located():
    """Stated on the output, a swing the crank cannot drive (past its toggle, where dq/dpsi grows
    without bound) is refused with the located rocker angle: the numpy four-bar's, where the
    crank folds onto the coupler, |AC| = b - a (law of cosines: 132.333 deg)."""
    from optdesign.errors import OptdesignError

    text = SCENE.read_text().replace('to = "130 deg"', 'to = "136 deg"')
    with pytest.raises(OptdesignError) as info:
        optdesign.analyse(optdesign.loads(text, "far.toml"))
    cos_psi = ((0.10 - 0.025) ** 2 - D**2 - 0.08**2) / (2 * D * 0.08)
    where = np.degrees(np.arccos(cos_psi))
    assert "[points] B (dyad) cannot assemble past psi" in str(info.value)
    assert f"({where:.3f} deg)" in str(info.value)
