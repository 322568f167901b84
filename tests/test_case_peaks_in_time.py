"""Case peaks along a law in time, certified as graphs of the law's time (model/certified.py,
CertifiedPeaks with ``time``): problems/ventilator_squeeze.toml, whose cycloidal squeeze and
modified-sine return rest at both stroke ends, where the law's inverse tau(s) has an infinite
derivative.  Enclosed through that inverse, the squeeze's drive, power and motor torque and the
return's motor speed never closed (reported "not certified", 15 s of CPU per analyse).

Reference: the independent numpy model of test_motion_output (the laws from their textbook
formulas, the four-bar's inverse kinematics, virtual work), each quantity on a dense grid in
time (20,001 points per case), its best point refined by a bounded scalar search."""
import numpy as np
import pytest
from scipy.optimize import minimize_scalar

import optdesign
from test_motion_output import CASES, I_RATIO, J_ROTOR, PSI_HI, PSI_LO, SCENE, drive_torque

DESIGN = (0.025, 0.10, 0.08)


def columns(name, tau):
    """drive, power, motor torque and motor speed of case ``name`` at the fractions ``tau`` of its time."""
    law, T, sigma, T0, kbag = CASES[name]
    L = PSI_HI - PSI_LO
    f, v, acc = law(np.atleast_1d(np.asarray(tau, float)))
    psi = PSI_LO + L * f if sigma > 0 else PSI_HI - L * f
    _, q_d, q_dd, torque = drive_torque(psi, sigma * L / T * v, sigma * L / T**2 * acc, *DESIGN, T0, kbag)
    return {"drive": torque, "power": torque * q_d, "motor_torque": torque / I_RATIO + J_ROTOR * I_RATIO * q_dd,
            "motor_speed": I_RATIO * q_d}


def reference_peak(name, key):
    tau = np.linspace(0.0, 1.0, 20001)
    v = np.abs(columns(name, tau)[key])
    i = int(np.argmax(v))
    lo, hi = tau[max(i - 1, 0)], tau[min(i + 1, len(tau) - 1)]
    best = minimize_scalar(lambda t: -abs(columns(name, t)[key][0]), bounds=(lo, hi), method="bounded",
                           options={"xatol": 1e-14})
    return max(float(v[i]), -float(best.fun))


@pytest.fixture(scope="module")
def analysed():
    return optdesign.analyse(optdesign.load(SCENE))


@pytest.mark.parametrize("name, key", [("squeeze", "drive"), ("squeeze", "power"), ("squeeze", "motor_torque"),
                                       ("return", "motor_speed"), ("squeeze", "motor_speed"), ("return", "drive"),
                                       ("return", "power"), ("return", "motor_torque")])
def test_case_peaks_at_a_rest_are_certified(analysed, name, key):
    """Every case's peaks of the ventilator (the first four govern and did not close; the others
    were "located, not certified: another case governs this peak"): certified, the located
    value and the bound within [reference, reference (1 + 1e-8)] (the located value to 1e-12
    below it: the reference's own rounding)."""
    case = analysed.cases.cases[name]
    ref = reference_peak(name, key)
    certificate = case.certificates[f"peak |{key}|"]
    assert certificate["note"] == ""
    assert ref * (1 - 1e-12) <= case.peaks[key] <= certificate["bound"] <= ref * (1 + 1e-8), (ref, case.peaks[key], certificate)


def load_inertia(psi):
    """I_zS at rocker angles ``psi`` by virtual work: the drive torque from rest with and without a
    rocker acceleration, over the crank's (no bag torque; gravity's part cancels)."""
    psi = np.atleast_1d(np.asarray(psi, float))
    accelerated = drive_torque(psi, 0.0, 1e3, *DESIGN, 0.0, 0.0)
    static = drive_torque(psi, 0.0, 0.0, *DESIGN, 0.0, 0.0)[3]
    return (accelerated[3] - static) / accelerated[2]


def test_load_inertia_is_certified_not_sampled(analysed):
    """The motor report's J_load (its inertia ratio J_load/(i^2 J_r) and optimal ratio
    sqrt(J_load/J_r)) is the largest reduced inertia over the continuous stroke, within
    [reference, reference (1 + 1e-8)] of the numpy model's on 20,001 points refined; the
    samples' (the old figure) lie 6.7e-6 below it, the maximum at 110.19 deg between samples."""
    psi = np.linspace(PSI_LO, PSI_HI, 20001)
    i = int(np.argmax(load_inertia(psi)))
    best = minimize_scalar(lambda x: -load_inertia(x)[0], bounds=(psi[i - 1], psi[i + 1]), method="bounded",
                           options={"xatol": 1e-14})
    ref = max(float(load_inertia(psi[i])[0]), -float(best.fun))
    m = next(iter(analysed.cases.train["motors"].values()))
    assert ref * (1 - 1e-12) <= m["load_inertia"] <= ref * (1 + 1e-8), (m["load_inertia"], ref)
    assert m["load_inertia_sampled"] < ref * (1 - 1e-6)   # what the samples alone give: too low
    assert m["inertia_ratio"] == pytest.approx(m["load_inertia"] / (I_RATIO**2 * m["inertia"]), rel=1e-14)
    for case in analysed.cases.cases.values():
        assert case.load_inertia["certificate"]["note"] == ""
        assert case.load_inertia["value"] <= case.load_inertia["certificate"]["bound"] <= ref * (1 + 1e-8)


@pytest.mark.slow
def test_optimise_certifies_the_case_constraints_in_time():
    """optimise's continuous check encloses a case's rows along a law in time in its time too
    (design/certify.ContinuousCheck._certified, pb.in_time): one start from the shipped optimum
    (a = 0.0181529601, b = 0.0926749018, c = 0.065), the motor's peak-torque and speed
    constraints of both cases certified (before: seven extremes "not certified: the enclosure
    did not close", e.g. the return's motor speed bound 96.99 against 38.82 located), each
    extreme equal to the numpy model's on 20,001 times refined, to 1e-8 of the column's largest
    value (the NLP's rows smooth the power-flow switch: 1.1e-9 relative on the return's motor
    torque, where analyse's exact rows agree to 1e-15).  Fast sibling:
    the analyse tests above (the same InTime certification)."""
    from optdesign.design import optimise

    global DESIGN
    design = (0.0181529601, 0.0926749018, 0.065)
    result = optimise(optdesign.load(SCENE), x_starts=[list(design)])
    assert result.success and "not certified" not in result.message, result.message
    saved, DESIGN = DESIGN, design
    try:
        for name in CASES:
            tau = np.linspace(0.0, 1.0, 20001)
            for key, column in (("motor peak torque", "motor_torque"), ("motor speed", "motor_speed")):
                c = result.constraints[f"{key} in case {name!r}"]
                for sense, sign in (("max", 1.0), ("min", -1.0)):
                    v = sign * columns(name, tau)[column]
                    i = int(np.argmax(v))
                    lo, hi = tau[max(i - 1, 0)], tau[min(i + 1, len(tau) - 1)]
                    best = minimize_scalar(lambda t: -sign * columns(name, t)[column][0], bounds=(lo, hi),
                                           method="bounded", options={"xatol": 1e-14})
                    ref = sign * max(float(v[i]), -float(best.fun))
                    # (the NLP's rows smooth the power-flow switch, design/cases.case_models: 1e-9 apart)
                    assert c[sense] == pytest.approx(ref, rel=0, abs=1e-8 * np.max(np.abs(v))), (name, key, sense)
    finally:
        DESIGN = saved


LAWS = ("harmonic", "modified-trapezoid", "polynomial-345", "polynomial-4567", "cycloidal", "modified-sine")


@pytest.mark.parametrize("law", [law if law in LAWS[:2] else pytest.param(law, marks=pytest.mark.slow) for law in LAWS])
def test_every_law_in_time_certified_against_a_dense_grid(law):
    """The ventilator with its squeeze on each motion law (and its return on the next one in the
    list): every peak of both cases certified, never below the largest of 256x denser samples
    (certify=False: the samples' own) and above them by at most 1e-6 of the peak; the harmonic
    law's acceleration jumps at both rests, the modified trapezoid has five pieces.  (Samples
    even in s are sparse in time next to a rest: 16x denser ones lay 3.5e-5 below the return's
    motor torque peak near 130 deg, which the numpy model above puts at the certified value.)"""
    other = LAWS[(LAWS.index(law) + 1) % len(LAWS)]
    text = SCENE.read_text().replace('[profiles.squeeze]\nkind = "cycloidal"', f'[profiles.squeeze]\nkind = "{law}"')
    text = text.replace('[profiles.return]\nkind = "modified-sine"', f'[profiles.return]\nkind = "{other}"')
    assert f'kind = "{law}"' in text and f'kind = "{other}"' in text
    scene = optdesign.loads(text, "laws.toml")
    coarse = optdesign.analyse(scene).cases
    dense = optdesign.analyse(scene, samples=256 * (scene.sweep.samples - 1) + 1, certify=False).cases
    for name, case in coarse.cases.items():
        for key, value in case.peaks.items():
            certificate = case.certificates[f"peak |{key}|"]
            reference = dense.cases[name].peaks[key]
            assert certificate["note"] == "", (law, name, key, certificate)
            assert reference * (1 - 1e-12) <= value <= certificate["bound"], (law, name, key, value, reference)
            assert value - reference <= 1e-6 * value, (law, name, key, value, reference)
