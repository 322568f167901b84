"""A scene's load cases at many geometries at once (model/case_runs.py, CaseAnalysis.run_many, and
CertifiedPeaks.many under it): each geometry's load cases give exactly what they give alone, in any
batch, and their certified peaks hold against independent numpy models.

* The hatch cover (three load cases on a trapezoid) over a Sobol family of its cylinder base and
  rod eye, with geometries that pass a dead centre (an error) mid-batch: every load case's peak
  drive force against tests/ref_hatch_cover.py (virtual work in closed form, each phase sampled
  and its local maxima refined by bounded scalar searches).
* The ventilator (two laws in time, peaks certified in the law's time: InTime) over its crank,
  coupler and rocker lengths: each load case's peak drive torque against
  tests/test_motion_output.py's four-bar (a dense grid in time, refined)."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.optimize import minimize_scalar
from scipy.stats import qmc

import optdesign
from optdesign.model.analysis import Analysis

import ref_hatch_cover as hatch
from test_motion_output import CASES as VENT_CASES, PSI_HI, PSI_LO, SCENE as VENT_SCENE, drive_torque


def _text(found) -> str:
    """A CasesResult (or an error) as text, every float to its last digit."""
    if isinstance(found, Exception):
        return f"error: {type(found).__name__}: {found}"

    def plain(x):
        if isinstance(x, np.ndarray):
            return x.tolist()
        if isinstance(x, (np.floating, np.integer, np.bool_)):
            return x.item()
        return repr(x)

    cases = {name: {k: getattr(r, k) for k in r.__dataclass_fields__} for name, r in found.cases.items()}
    return json.dumps([cases, found.governing, found.duty, found.train], sort_keys=True, default=plain)


def _alone(analysis, p):
    """The load cases of ``analysis.run(p)`` (its assembly and dead-centre checks first), or its error."""
    try:
        return analysis.run(p).cases
    except optdesign.OptdesignError as exc:
        return exc


def _many(analysis, P):
    """The load cases of each case of ``analysis.run_many(P)``, or its error."""
    return [r.cases if r.error is None else r.error for r in analysis.run_many(P)]


def _sobol(analysis, box, n, seed):
    names = list(analysis.mech.parameter_names)
    unit = qmc.Sobol(len(box), seed=seed).random(n)
    P = np.tile(analysis.mech.parameter_values, (n, 1))
    for j, (name, (lo, hi)) in enumerate(box.items()):
        P[:, names.index(name)] = lo + (hi - lo) * unit[:, j]
    return P


def _hatch_dead_centre(analysis, theta=40 * hatch.DEG):
    """The hatch cover's parameters with D placed where k = dq/dtheta = 0 at ``theta``: on the
    line through B along B's velocity's normal (B - D parallel to B's normal to dB/dtheta)."""
    names = list(analysis.mech.parameter_names)
    p = np.asarray(analysis.mech.parameter_values, float).copy()
    b = 0.6
    Bx, By, Bpx, Bpy = hatch.rod_eye(b, theta)
    r = 0.7 / math.hypot(Bpx, Bpy)   # D = B + r (dB' rotated by 90 deg): (B - D).B' = 0
    p[names.index("b")], p[names.index("xD")], p[names.index("yD")] = b, Bx + r * Bpy, By - r * Bpx
    return p


def _hatch_family(n, seed):
    """The hatch cover's analysis and ``n`` Sobol geometries with the dead centre third."""
    analysis = Analysis(optdesign.load(hatch.SCENE))
    P = np.insert(_sobol(analysis, hatch.BOX, n, seed=seed), 2, _hatch_dead_centre(analysis), axis=0)
    return analysis, P


def _reference_case_peak(xD, yD, b, direction, msnow, n=2001):
    """The largest |F_S| of one hatch-cover case over its continuous stroke (ref_hatch_cover's
    force: each phase sampled, every local maximum refined)."""
    x1 = hatch.V ** 2 / (2 * hatch.ACC)
    best = -1.0
    for lo, hi, a in ((0, x1, hatch.ACC), (x1, hatch.L - x1, 0.0), (hatch.L - x1, hatch.L, -hatch.ACC)):
        xs = np.linspace(lo, hi, n)
        f = np.abs(hatch.force(xD, yD, b, xs, a, direction, msnow))
        best = max(best, float(np.max(f)))
        for i in np.flatnonzero((f[1:-1] >= f[:-2]) & (f[1:-1] >= f[2:])) + 1:
            r = minimize_scalar(lambda t: -abs(float(hatch.force(xD, yD, b, t, a, direction, msnow))),
                                bounds=(xs[i - 1], xs[i + 1]), method="bounded", options={"xatol": 1e-13})
            best = max(best, -float(r.fun))
    return best


def check_hatch_family(n, seed, more=True):
    """Each geometry's load cases in a batch (``more``: also in another composition, and in the
    load cases' own batch) as alone; every certified peak drive force against virtual work."""
    analysis, P = _hatch_family(n, seed)
    together = _many(analysis, P)
    alone = [_alone(analysis, p) for p in P]
    assert isinstance(alone[2], optdesign.OptdesignError) and "dead centre" in str(alone[2])   # mid-batch
    assert [_text(x) for x in together] == [_text(x) for x in alone]
    ok = [i for i, a in enumerate(alone) if not isinstance(a, Exception)]
    assert len(ok) >= n - n // 4
    if more:
        order = [len(P) - 1, 2, 0]   # another composition and order
        assert [_text(x) for x in _many(analysis, P[order])] == [_text(alone[i]) for i in order]
        # the load cases' own batch, without the analysis's checks first: the same for those that pass them
        assert [_text(x) for x in analysis.case_analysis.run_many(P[ok[::-1]])] == [_text(alone[i]) for i in ok[::-1]]
    names = list(analysis.mech.parameter_names)
    for i in ok:
        xD, yD, b = (P[i, names.index(k)] for k in ("xD", "yD", "b"))
        for name, direction, msnow in hatch.CASES:
            case = together[i].cases[name]
            ref = _reference_case_peak(xD, yD, b, direction, msnow)
            certificate = case.certificates["peak |drive|"]
            assert certificate["note"] == "", (name, certificate)
            # located to the reference's own rounding (1e-11 measured), the bound above it within the tolerance
            assert ref * (1 - 1e-9) <= case.peaks["drive"] <= certificate["bound"] <= ref * (1 + 1e-6), (
                name, ref, case.peaks["drive"], certificate)


def test_hatch_cover_batch_gives_each_geometry_its_own_load_cases():
    check_hatch_family(2, seed=5, more=False)


@pytest.mark.slow
def test_a_sobol_family_of_hatch_covers_in_one_batch():
    check_hatch_family(8, seed=5)


VENT_BOX = {"a": (0.018, 0.032), "b": (0.08, 0.12), "c": (0.065, 0.095)}


def _vent_reference(name, a, b, c):
    """The ventilator case's largest |drive torque| over its law's time (a dense grid, refined)."""
    law, T, sigma, T0, kbag = VENT_CASES[name]
    L = PSI_HI - PSI_LO

    def torque(tau):
        f, v, acc = law(np.atleast_1d(np.asarray(tau, float)))
        psi = PSI_LO + L * f if sigma > 0 else PSI_HI - L * f
        return drive_torque(psi, sigma * L / T * v, sigma * L / T ** 2 * acc, a, b, c, T0, kbag)[3]

    tau = np.linspace(0.0, 1.0, 20001)
    v = np.abs(torque(tau))
    i = int(np.argmax(v))
    r = minimize_scalar(lambda t: -abs(torque(t)[0]), bounds=(tau[max(i - 1, 0)], tau[min(i + 1, len(tau) - 1)]),
                        method="bounded", options={"xatol": 1e-14})
    return max(float(v[i]), -float(r.fun))


def test_ventilator_laws_in_time_batch_against_alone_and_the_four_bar():
    analysis = Analysis(optdesign.load(VENT_SCENE))
    P = _sobol(analysis, VENT_BOX, 4, seed=2)   # the third does not assemble part of the stroke
    together = _many(analysis, P)
    alone = [_alone(analysis, p) for p in P]
    assert [_text(x) for x in together] == [_text(x) for x in alone]
    assert isinstance(together[2], optdesign.AssemblyError)
    names = list(analysis.mech.parameter_names)
    for p, found in zip(P, together):
        if isinstance(found, Exception):
            continue
        a, b, c = (p[names.index(k)] for k in ("a", "b", "c"))
        for name in VENT_CASES:
            case = found.cases[name]
            ref = _vent_reference(name, a, b, c)
            certificate = case.certificates["peak |drive|"]
            assert certificate["note"] == ""
            assert ref * (1 - 1e-12) <= case.peaks["drive"] <= certificate["bound"] <= ref * (1 + 1e-8), (
                name, ref, case.peaks["drive"], certificate)
