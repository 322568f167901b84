"""The transfer arm's reduced inertia (problems/transfer_arm.toml) against kinetic energy from its
geometry, and why its figure jumps.

Reference (nothing of optdesign): the positions of tests/ref_transfer_arm.py (the dyad's circles'
intersection), their d/dphi by fourth-order central differences here, the kinetic energy's
coefficient M_q = sum m |dr/dphi|^2 + I (dtheta/dphi)^2 over the arm (mass at La/2 on Q -> B,
inertia mA La^2/12), the part (point at La) and the coupler (mass 2.5 c at the middle of A B,
inertia mC c^2/12); and the sign of the crank's ideal power (ref_transfer_arm.ideal_torque at the
[drive] state: 10 rad/s, no acceleration).

Seed 1's reduced inertia is I_zS = c M_q with the efficiency factor c = 1/eta while the drive
delivers power and eta while power flows back (eqs. 12, 33): it jumps by 1/eta^2 where the power
changes sign (near 105 and 337 deg in the shipped design's figure), and so does its derivative.
The jumps are the model's, not a fault; reduced_inertia.png draws them as gaps and M_q beside
them."""
from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq, minimize_scalar

import optdesign
from optdesign.report.stroke_plots import inertia_figure

sys.path.insert(0, str(Path(__file__).resolve().parent))
import ref_transfer_arm as ref  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
DESIGNS = {"scene start": {"r": 0.12, "c": 0.45, "xQ": 0.45, "i": 20.0},
           "shipped optimum": json.loads((ROOT / "results" / "transfer_arm" / "result.json").read_text())["design"]}


def nominal(design):
    """analyse's [drive] state of the scene at ``design`` (its load cases, duty and motors left
    out: they do not change that state, and cost seconds)."""
    scene = optdesign.load(ref.SCENE).with_parameters(**design)
    scene = dataclasses.replace(scene, cases=type(scene.cases)(), duty=None, motors=type(scene.motors)(), simulation=None)
    return optdesign.analyse(scene, certify=False)


def kinetic_coefficient(r, c, xQ, phi, mP=8.0, h=1e-4):
    """M_q(phi) = 2 T / phid^2 from the positions, d/dphi by central differences (O(h^4))."""
    def points(x):
        A, B = ref.positions(r, c, xQ, x)
        Q = xQ + 1j * ref.YQ
        e = (B - Q) / ref.R
        return {"arm": Q + ref.LA / 2 * e, "part": Q + ref.LA * e, "coupler": (A + B) / 2, "rocker": B - Q,
                "coupler angle": B - A}

    ps = [points(phi + k * h) for k in (-2, -1, 1, 2)]
    d = {n: (ps[0][n] - 8 * ps[1][n] + 8 * ps[2][n] - ps[3][n]) / (12 * h) for n in ps[0]}
    here = points(phi)

    def turning(n):   # dtheta/dphi of the direction of vector n
        return (np.conj(here[n]) * d[n]).imag / np.abs(here[n]) ** 2

    mC = 2.5 * c
    return (ref.MA * np.abs(d["arm"]) ** 2 + ref.MA * ref.LA ** 2 / 12 * turning("rocker") ** 2
            + mP * np.abs(d["part"]) ** 2 + mC * np.abs(d["coupler"]) ** 2 + mC * c ** 2 / 12 * turning("coupler angle") ** 2)


@pytest.mark.parametrize("which", sorted(DESIGNS))
def test_reduced_inertia_is_the_efficiency_factor_times_the_kinetic_energy(which):
    """At the [drive] state: I_zS / c equals the numpy M_q (1e-9 of its peak), c is 1/eta
    where the ideal power is positive and eta where it is negative (eta = 0.95, the [drive]'s),
    so that I_zS jumps by 1/eta^2 exactly where the power changes sign, and nowhere else."""
    design = DESIGNS[which]
    res = nominal(design)
    s = np.asarray(res.columns["s"], float)
    inertia, c = np.asarray(res.columns["reduced_inertia"]), np.asarray(res.columns["efficiency_factor"])
    M = kinetic_coefficient(design["r"], design["c"], design["xQ"], s)
    assert np.max(np.abs(inertia / c - M)) <= 1e-9 * np.max(M)
    base, part = ref.ideal_torque(design["r"], design["c"], design["xQ"], s, 10.0, 0.0)
    power = (base + 8.0 * part) * 10.0
    clear = np.abs(power) > 1e-9 * np.max(np.abs(power))
    assert np.array_equal(c[clear], np.where(power[clear] > 0, 1 / ref.ETA_M, ref.ETA_M))
    jumps = np.flatnonzero(np.diff(c) != 0)
    assert len(jumps) >= 2 and np.all(np.sign(power[jumps]) != np.sign(power[jumps + 1]))
    ratio = inertia[jumps + 1] / inertia[jumps] / (M[jumps + 1] / M[jumps])
    assert np.allclose(np.maximum(ratio, 1 / ratio), 1 / ref.ETA_M ** 2, rtol=1e-9)


def test_the_figure_draws_the_jumps_as_the_models_and_the_ideal_inertia_beside_them(tmp_path):
    """reduced_inertia.png of the shipped design: I_zS and its derivative broken (a gap) at each
    power reversal with a dotted line there, M_q = I_zS / c drawn (equal to the numpy M_q), and
    the title saying why I_zS jumps; without an efficiency none of it."""
    design = DESIGNS["shipped optimum"]
    res = nominal(design)
    figures = []
    import optdesign.report.stroke_plots as plots

    saved = plots.save_figure
    try:
        plots.save_figure = lambda fig, path: figures.append(fig)
        inertia_figure(res, tmp_path / "a.png")
        plain = dataclasses.replace(res, columns={k: v for k, v in res.columns.items() if k != "efficiency_factor"})
        inertia_figure(plain, tmp_path / "b.png")
    finally:
        plots.save_figure = saved
    ax = figures[0].axes[0]
    lines = {line.get_label(): line for line in ax.get_lines()}
    ideal = next(line for label, line in lines.items() if label.startswith("M_q"))
    x, y = (np.asarray(a, float) for a in ideal.get_data())
    assert np.max(np.abs(y - kinetic_coefficient(design["r"], design["c"], design["xQ"], np.radians(x)))) <= 1e-9
    switches = np.flatnonzero(np.diff(np.asarray(res.columns["efficiency_factor"])) != 0)
    verticals = [line for line in ax.get_lines() if line.get_xdata()[0] == line.get_xdata()[-1] and len(line.get_xdata()) == 2]
    assert len(verticals) == len(switches) >= 2
    for line in (lines[next(k for k in lines if k.startswith("I_zS"))], figures[0].axes[1].get_lines()[0]):
        assert np.isnan(np.asarray(line.get_ydata(), float)).sum() == len(switches)   # a gap at each
    assert "power changes sign" in ax.get_title(loc="left")
    plain = figures[1].axes[0]
    assert not any(line.get_label().startswith("M_q") for line in plain.get_lines())
    assert "power" not in plain.get_title(loc="left")


def numpy_peak(design, speed=10.0, n=20001):
    """The largest I_zS = c M_q over the stroke at the [drive] state (``speed``, no acceleration)
    by the numpy model: on each stretch between sign changes of the ideal power (roots by
    brentq), c is 1/eta or eta and c M_q is smooth; its maximum there over a dense grid, refined
    by a bounded search, and the stretch's ends (the sup at a switch, c there 1/eta: power 0
    counts as delivered, as in analyse)."""
    r, c, xQ = design["r"], design["c"], design["xQ"]

    def power(phi):
        base, part = ref.ideal_torque(r, c, xQ, phi, speed, 0.0)
        return (base + 8.0 * part) * speed

    def M(phi):
        return float(kinetic_coefficient(r, c, xQ, np.array([phi]))[0])

    grid = np.linspace(0, 2 * np.pi, n)
    P = power(grid)
    roots = [brentq(power, grid[k], grid[k + 1], xtol=1e-15) for k in np.flatnonzero(np.sign(P[:-1]) != np.sign(P[1:]))]
    edges = [0.0, *roots, 2 * np.pi]
    best = -np.inf
    for a, b in zip(edges[:-1], edges[1:]):
        factor = 1 / ref.ETA_M if power(0.5 * (a + b)) > 0 else ref.ETA_M
        candidates = [(1 / ref.ETA_M if a in roots else factor) * M(a), (1 / ref.ETA_M if b in roots else factor) * M(b)]
        inside = grid[(grid > a) & (grid < b)]
        if len(inside):
            values = factor * kinetic_coefficient(r, c, xQ, inside)
            k = int(np.argmax(values))
            lo, hi = max(a, inside[max(k - 1, 0)]), min(b, inside[min(k + 1, len(inside) - 1)])
            found = minimize_scalar(lambda x: -factor * M(x), bounds=(lo, hi), method="bounded", options={"xatol": 1e-13})
            candidates += [float(values[k]), -found.fun]
        best = max(best, *candidates)
    return best, roots


CASES = {"shipped optimum at 40 rad/s": ("shipped optimum", 40.0),   # its peak at a power reversal
         "shipped optimum": ("shipped optimum", 10.0), "scene start": ("scene start", 10.0)}   # (smooth peaks)


@pytest.mark.parametrize("which", [pytest.param(k, marks=[pytest.mark.slow] if i else []) for i, k in enumerate(CASES)])
def test_the_certified_peak_of_the_jumping_inertia_is_the_numpy_models(which):
    """analyse's certified peak |I_zS| at the [drive] state (enclosed across the power reversals,
    where I_zS jumps) against the numpy model's largest c M_q (numpy_peak): the value within
    1e-9, the certified bound within [ref (1 - 3e-11), ref (1 + 1e-8)] (the reference's own
    accuracy).  At 40 rad/s the peak lies at a reversal (1/eta M_q there, M_q still rising: the
    inertia term's power changes sign near M_q's own maximum), the maximum of a discontinuous
    function; at the scene's 10 rad/s it is a smooth maximum (the slow cases)."""
    name, speed = CASES[which]
    design = DESIGNS[name]
    scene = optdesign.load(ref.SCENE).with_parameters(**design)
    scene = dataclasses.replace(scene, cases=type(scene.cases)(), duty=None, motors=type(scene.motors)(), simulation=None,
                                drive=dataclasses.replace(scene.drive, speed=speed))
    res = optdesign.analyse(scene)
    expected, roots = numpy_peak(design, speed)
    certificate = res.certificates["peak |reduced_inertia|"]
    assert certificate["note"] == ""
    assert res.peaks["reduced_inertia"] == pytest.approx(expected, rel=1e-9)
    # (the numpy model's own accuracy: M_q by central differences of positions carries rounding
    # of ~eps/h; at the scene start's smooth peak its value with h = 1e-4 ... 1e-3 spans
    # 0.9029434836150 ... 0.9029434836286, 1.5e-11 relative, so the bound cannot be held
    # to it more tightly than that: it was 1e-12, and the certified bound 0.9029434836169447,
    # above the located value 0.9029434836163861, lay 1.3e-12 below this reference)
    assert expected * (1 - 3e-11) <= certificate["bound"] <= expected * (1 + 1e-8)
    at = res.peak_at["reduced_inertia"]["s"]
    assert (min(abs(at - x) for x in roots) < 1e-6) == (speed == 40.0)
