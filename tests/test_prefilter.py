"""The certification's pre-filter for a batch of cases that differ in parameters entering the
rows affinely (kinematics/linear_parts.py): the first pass skips the per-case enclosure of the
intervals whose bound from the rows' parts (v_0 + sum_k m_k v_k) is already <= the best located
value.  Checked here: it does skip on a study of masses, its bounds hold against the rows
evaluated densely inside each interval, every case's located figures are those of the analysis
without the pre-filter and without axes, and its certified bounds hold against a 16x denser
sampling; a parameter that enters the rows non-affinely disables it (read from the graph)."""
from __future__ import annotations

from pathlib import Path

import casadi as ca
import numpy as np
import pytest

import optdesign
from optdesign.kinematics import branch_bound, linear_parts
from optdesign.model.analysis import Analysis
from optdesign.scene.resolved import ResolvedScene

PROBLEMS = Path(__file__).resolve().parent.parent / "problems"


def study_analysis(*axes):
    scene = optdesign.load(PROBLEMS / "truck_crane.toml")
    return scene, Analysis(ResolvedScene(scene.without_bounds(*axes), variable=axes))


def mass_cases(analysis, n, seed=4):
    names = list(analysis.mech.parameter_names)
    rng = np.random.default_rng(seed)
    P = np.tile(analysis.mech.parameter_values, (n, 1))
    P[:, names.index("mB")] = rng.uniform(400.0, 900.0, n)
    P[:, names.index("mP")] = rng.uniform(500.0, 3000.0, n)
    return P


def test_affine_degrees_are_read_from_the_graph():
    s, p = ca.SX.sym("s"), ca.SX.sym("p", 3)   # p[0], p[1] the axes, p[2] another parameter
    rows = [p[0] * ca.sin(s) + p[1] * p[2] / ca.cos(s) + s ** 2,   # affine
            (p[0] + 2 * p[1]) / (1 + s * s) - p[2],                  # affine
            p[0] * p[0],                                             # degree 2
            ca.sqrt(p[0]) * s,                                       # not polynomial
            s / p[1],                                                # divided by an axis
            p[0] * p[1],                                             # a product of two axes
            ca.if_else(p[0] * s >= 1, p[0] / 0.9, p[0] * 0.9),       # affine in each branch
            ca.fabs(p[0] - s)]                                       # not smooth in the axis
    func = ca.Function("rows", [s, p], [ca.vertcat(*rows)])
    degree, comparisons = linear_parts.degrees(func, [0, 1])
    assert (degree <= 1).tolist() == [True, True, False, False, False, False, False, False]
    assert len(comparisons) == 1   # the if_else's p0 s >= 1
    # each outcome of that comparison forced: the if_else row affine in both
    for forced in (0.0, 1.0):
        branch = linear_parts.rebuilt(func, (s, p), {comparisons[0]: forced})
        f = ca.Function("branch", [s, p], [ca.vertcat(*branch)])
        assert linear_parts.affine_rows(f, [0, 1])[6]
        x = np.array([0.7, 1.3, 2.0])
        want = x[0] / 0.9 if forced else x[0] * 0.9
        assert float(f(0.5, x)[6]) == pytest.approx(want, rel=1e-15)


def test_the_prefilter_skips_and_every_bound_holds(monkeypatch):
    scene, analysis = study_analysis("mB", "mP")
    c = analysis.certified
    P = mass_cases(analysis, 24)
    seen = []
    keep_upper = linear_parts.Prefiltered.upper

    def upper(self, lo, hi, cases, row, where, code, best):
        ub = keep_upper(self, lo, hi, cases, row, where, code, best)
        seen.append((self.parts, lo, hi, cases, row, where, code, ub))
        return ub

    skipped = []
    keep_filter = branch_bound._prefiltered

    def prefiltered(*args):
        got = keep_filter(*args)
        skipped.append(0 if got is None else int(np.count_nonzero(~got[1])))
        return got

    monkeypatch.setattr(linear_parts.Prefiltered, "upper", upper)
    monkeypatch.setattr(branch_bound, "_prefiltered", prefiltered)
    runs = analysis.run_many(P)
    monkeypatch.undo()
    assert seen and sum(skipped) > 0, skipped
    parts = seen[0][0]
    assert parts.branches == 2   # the drive's efficiency: 1/eta or eta by the sign of the power
    assert all(parts.index[i] >= 0 for i in c.peak_rows.values())

    # 1. the pre-filter's bounds against the rows evaluated at 17 points inside each interval
    _, lo, hi, cases, row, where, code, ub = seen[0]
    finite = np.flatnonzero(np.isfinite(ub))
    pick = np.random.default_rng(1).choice(finite, size=min(400, len(finite)), replace=False)
    t = np.linspace(0.0, 1.0, 17)
    for e in pick:
        i = where[e]
        s = lo[i] + (hi[i] - lo[i]) * t
        v = np.asarray(c.values(s, np.repeat(P[cases[i]][None], len(s), axis=0))[0])[row[e]]
        target = np.abs(v) if code[e] == 0 else (v if code[e] == 1 else -v)
        assert target.max() <= ub[e], (e, target.max(), ub[e])

    # 2. the located figures are those without the pre-filter and those of the analysis without axes
    monkeypatch.setattr(linear_parts.LinearParts, "at", lambda self, enclosure, P: enclosure)
    without = analysis.run_many(P)
    monkeypatch.undo()
    joint = Analysis(scene).run_many(P)
    dense = Analysis(scene, samples=16 * (len(analysis.s_values) - 1) + 1, certify=False)
    for p, a, b, j in zip(P, runs, without, joint):
        assert a.error is None and b.error is None and j.error is None
        assert (a.peaks, a.peak_at, a.constraint_extremes, a.stroke) == (b.peaks, b.peak_at, b.constraint_extremes,
                                                                         b.stroke)
        assert (a.peaks, a.peak_at, a.constraint_extremes, a.stroke) == (j.peaks, j.peak_at, j.constraint_extremes,
                                                                         j.stroke)
        # 3. every certified bound holds against a 16x denser sampling
        sampled = dense.run(p)
        for name, peak in a.peaks.items():
            certificate = a.certificates[f"peak |{name}|"]
            assert certificate["note"] == ""
            top = float(np.max(np.abs(sampled.columns[name])))
            assert certificate["bound"] >= peak >= top - 1e-12 * top
            assert certificate["bound"] <= peak + 1e-9 * max(peak, top) + 1e-300


def test_a_parameter_entering_non_affinely_disables_it(monkeypatch):
    """A study over the boom mass and the rod eye's place b: b moves the kinematics, so no row
    is affine in the axes and the per-case enclosure does all the work, as without a pre-filter."""
    _, analysis = study_analysis("mB", "b")
    c = analysis.certified
    names = list(analysis.mech.parameter_names)
    P = np.tile(analysis.mech.parameter_values, (6, 1))
    P[:, names.index("mB")] = np.linspace(500.0, 800.0, 6)
    P[:, names.index("b")] = np.linspace(0.7, 1.2, 6)
    called = []
    keep = linear_parts.Prefiltered.upper
    monkeypatch.setattr(linear_parts.Prefiltered, "upper", lambda self, *a: called.append(1) or keep(self, *a))
    runs = analysis.run_many(P)
    assert c._linear is not None and not c._linear.any and (c._linear.index == -1).all()
    assert not called
    assert all(r.error is None for r in runs)
    # the masses alone: affine (the same scene, the same rows)
    _, masses = study_analysis("mB", "mP")
    assert masses.certified._linear.any
