"""Certified extremes of many cases at once (model/certified.CertifiedExtremes.many): each case's
result is exactly its own one-case result, whatever the other cases of the batch and its
position in it (a study's rows must not depend on how its cases were batched)."""
from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import qmc

import optdesign
from optdesign.model.analysis import Analysis

PROBLEMS = Path(__file__).resolve().parent.parent / "problems"
VARIED = {"mB": (400.0, 900.0), "mP": (500.0, 3000.0), "xD": (-0.1, 0.6), "yD": (-1.8, -0.9), "b": (0.7, 1.6)}


def sampled(analysis, p):
    """The sampled columns and per-sample constraints of one case, as Analysis.run hands them on."""
    raw = analysis.vectorised(analysis.s_values, p)
    n = len(analysis.s_values)
    values = {k: np.broadcast_to(np.asarray(v, float).ravel(), (n,)).copy() for k, v in raw.items()}
    columns = {k: v for k, v in values.items() if ":" not in k}
    if analysis.scene.drive.kind == "rotary":
        columns["q"] = np.unwrap(columns["q"])
    constraints = {k.split(":", 1)[1]: v for k, v in values.items() if k.startswith("constraint:")}
    return columns, constraints


def stacked(analysis, P):
    """Every case's sampled columns and constraints stacked (name -> N x S)."""
    each = [sampled(analysis, p) for p in P]
    return ({k: np.array([c[k] for c, _ in each]) for k in each[0][0]},
            {k: np.array([c[k] for _, c in each]) for k in each[0][1]})


@pytest.fixture(scope="module")
def crane():
    return Analysis(optdesign.load(PROBLEMS / "truck_crane.toml"))


def crane_parameters(analysis, n, seed, varied=VARIED):
    mech = analysis.mech
    names = list(mech.parameter_names)
    unit = qmc.Sobol(len(varied), seed=seed).random(n)
    P = np.tile(mech.parameter_values, (n, 1))
    for j, (name, (lo, hi)) in enumerate(varied.items()):
        P[:, names.index(name)] = lo + (hi - lo) * unit[:, j]
    return P


def test_a_batch_gives_each_case_its_own_result(crane):
    analysis = crane
    P = crane_parameters(analysis, 8, 3)
    columns, constraints = stacked(analysis, P)
    s = analysis.s_values
    together = analysis.certified.many(s, P, columns, constraints)
    alone = [analysis.certified(s, P[i], {k: v[i] for k, v in columns.items()},
                                {k: v[i] for k, v in constraints.items()}) for i in range(len(P))]
    assert together == alone   # bit-identical, certificates included
    # another composition and order: the reversed batch, and a batch of three
    order = [5, 2, 7]
    part = analysis.certified.many(s, P[order], {k: v[order] for k, v in columns.items()},
                                   {k: v[order] for k, v in constraints.items()})
    assert part == [alone[i] for i in order]
    backwards = analysis.certified.many(s, P[::-1], {k: v[::-1] for k, v in columns.items()},
                                        {k: v[::-1] for k, v in constraints.items()})
    assert backwards == alone[::-1]
    for found in alone:   # every one certified
        assert all(c["note"] == "" for c in found["certificates"].values()), found["certificates"]


def test_many_checks_its_arguments(crane):
    analysis = crane
    P = crane_parameters(analysis, 2, 1)
    columns, constraints = stacked(analysis, P)
    with pytest.raises(ValueError, match="narrow"):
        analysis.certified.many(analysis.s_values, P, columns, constraints, narrow=[()])



def test_rows_no_axis_moves_are_certified_once_per_batch_and_each_case_keeps_its_own(crane, monkeypatch):
    """A study of masses alone (axes mB, mP): the rows whose graphs read neither (the transmission
    angle, the cylinder's length ratio: found from the graphs' structure) are certified once for
    a batch whose cases are equal in what they read, apart from the rows the masses move; each
    case still gets exactly its own one-case result, and every bound holds: at or above the
    located extreme and the samples, within the tolerance of what the analysis without axes
    (one branch and bound for all rows) certifies for the same case."""
    from optdesign.model import certified as certified_module
    from optdesign.scene.resolved import ResolvedScene

    scene = optdesign.load(PROBLEMS / "truck_crane.toml")
    analysis = Analysis(ResolvedScene(scene.without_bounds("mB", "mP"), variable=("mB", "mP")))
    c = analysis.certified
    assert c.fixed_rows == {c.constraint_rows["transmission angle"], *(i for _, _, i in c.aggregate_rows)}
    geometry = Analysis(ResolvedScene(scene.without_bounds("mB", "xD"), variable=("mB", "xD")))
    assert geometry.certified.fixed_rows == frozenset()   # xD moves every row
    assert crane.certified.fixed_rows == frozenset()       # no axes: as before
    P = crane_parameters(analysis, 8, 5, {k: VARIED[k] for k in ("mB", "mP")})
    columns, constraints = stacked(analysis, P)
    s = analysis.s_values
    calls = []
    keep = certified_module.maxima_of_cases
    monkeypatch.setattr(certified_module, "maxima_of_cases", lambda f, grid, V, requests, **kw: calls.append(
        (len(V), sorted({r.row for r in requests}))) or keep(f, grid, V, requests, **kw))
    together = c.many(s, P, columns, constraints)
    assert calls == [(8, sorted(c.peak_rows.values())), (1, sorted(c.fixed_rows))]
    monkeypatch.setattr(certified_module, "maxima_of_cases", keep)
    alone = [c(s, P[i], {k: v[i] for k, v in columns.items()}, {k: v[i] for k, v in constraints.items()})
             for i in range(len(P))]
    assert together == alone   # bit-identical, certificates included
    assert c.many(s, P[::-1], {k: v[::-1] for k, v in columns.items()},
                  {k: v[::-1] for k, v in constraints.items()}) == alone[::-1]
    # cases that differ in a parameter those rows read (not a study's batch: an axis of another
    # study): one branch and bound of them per group of equal values, each case still its own
    mixed = P.copy()
    mixed[::2, analysis.mech.parameter_names.index("xD")] += 0.05
    m_columns, m_constraints = stacked(analysis, mixed)
    monkeypatch.setattr(certified_module, "maxima_of_cases", lambda f, grid, V, requests, **kw: calls.append(
        (len(V), sorted({r.row for r in requests}))) or keep(f, grid, V, requests, **kw))
    calls.clear()
    got = c.many(s, mixed, m_columns, m_constraints)
    monkeypatch.setattr(certified_module, "maxima_of_cases", keep)
    assert calls == [(8, sorted(c.peak_rows.values())), (2, sorted(c.fixed_rows))]
    assert got == [c(s, mixed[i], {k: v[i] for k, v in m_columns.items()}, {k: v[i] for k, v in m_constraints.items()})
                   for i in range(len(P))]
    joint = crane.certified.many(s, P, columns, constraints)   # (the same scene's rows, one branch and bound)
    for i, (f, g) in enumerate(zip(together, joint)):
        assert f["peaks"] == g["peaks"] and f["peak_at"] == g["peak_at"]
        for name, e in f["constraint_extremes"].items():
            row = constraints[name][i]
            scale = float(np.max(np.abs(row)))
            high, low = f["certificates"][f"{name} max"], f["certificates"][f"{name} min"]
            assert high["note"] == low["note"] == ""
            assert high["bound"] >= e["max"] >= float(np.max(row)) and low["bound"] <= e["min"] <= float(np.min(row))
            assert e["max"] == g["constraint_extremes"][name]["max"] and e["min"] == g["constraint_extremes"][name]["min"]
            for key in (f"{name} max", f"{name} min"):
                assert abs(f["certificates"][key]["bound"] - g["certificates"][key]["bound"]) <= 1e-9 * scale
        assert f["aggregates"] == g["aggregates"]



def test_four_bars_studied_over_masses_hold_their_rows_certified_apart_against_a_denser_sampling():
    """Generated four-bars (Sobol) with a transmission angle and a rocker swing's max()/min(),
    each studied over its masses and load (axes m2, m3, T0): the rows those do not move are
    certified apart (their extremes inside the stroke); every bound holds against a 16x denser
    sampling of its case, and the peaks, located extremes and per-stroke values are those of the
    analysis without axes (bounds within the tolerance: their last digits may move, the
    intervals being the rows' own)."""
    from optdesign.scene.resolved import ResolvedScene
    from test_analysis_many import CONSTRAINTS
    from test_enclosure_fourbars import G, M2, M3, OMEGA, SCENE, designs

    axes = ("m2", "m3", "T0")
    for g, d in enumerate(designs(8, seed=21)[1:3]):
        text = SCENE.format(side="left", m2=M2, m3=M3, g=G, omega=OMEGA, **{k: float(v) for k, v in d.items()})
        scene = optdesign.loads(text + CONSTRAINTS, "four-bar over masses")
        split, joint = Analysis(ResolvedScene(scene.without_bounds(*axes), variable=axes)), Analysis(scene)
        dense = Analysis(scene, samples=16 * (len(split.s_values) - 1) + 1, certify=False)
        assert split.certified.fixed_rows == {split.certified.constraint_rows["transmission"],
                                              *(i for _, _, i in split.certified.aggregate_rows)}
        names = split.mech.parameter_names
        P = np.tile(split.mech.parameter_values, (4, 1))
        for k, (lo, hi) in zip(axes, ((1.0, 6.0), (1.0, 5.0), (0.0, 30.0))):
            P[:, names.index(k)] = lo + (hi - lo) * qmc.Sobol(1, seed=g).random(4)[:, 0]
        for p, a, b in zip(P, split.run_many(P), joint.run_many(P)):
            assert a.error is None and b.error is None
            assert (a.peaks, a.peak_at, a.constraint_extremes, a.stroke) == (b.peaks, b.peak_at, b.constraint_extremes,
                                                                             b.stroke)
            sampled = dense.run(p).constraints
            for name, e in a.constraint_extremes.items():
                high, low = a.certificates[f"{name} max"], a.certificates[f"{name} min"]
                assert high["note"] == low["note"] == ""
                scale = max(abs(e["max"]), abs(e["min"]))
                top, bottom = float(np.max(sampled[name])), float(np.min(sampled[name]))
                assert high["bound"] >= e["max"] >= e["max_sampled"] and e["max"] >= top - 1e-12 * scale
                assert low["bound"] <= e["min"] <= e["min_sampled"] and e["min"] <= bottom + 1e-12 * scale
                assert high["bound"] >= top and low["bound"] <= bottom   # (the bounds hold between the samples)
                for key in (f"{name} max", f"{name} min"):
                    assert abs(a.certificates[key]["bound"] - b.certificates[key]["bound"]) <= 1e-9 * scale


# --- generated families: each case of a batch against an independent reference ---

def four_bar_batch(n, seed, count=None):
    """Crank-rockers with a torque bump between two samples (tests/test_enclosure_fourbars.py's
    family) as one built analysis and a parameter row per four-bar."""
    from test_enclosure_fourbars import G, M2, M3, OMEGA, SCENE, designs

    points = designs(n, seed)[:count]
    text = SCENE.format(side="left", m2=M2, m3=M3, g=G, omega=OMEGA, **{k: float(v) for k, v in points[0].items()})
    analysis = Analysis(optdesign.loads(text, "four-bar family"))
    names = list(analysis.mech.parameter_names)
    P = np.tile(analysis.mech.parameter_values, (len(points), 1))
    for i, params in enumerate(points):
        for k, v in params.items():
            P[i, names.index(k)] = v
    return analysis, points, P


def check_four_bars(n, seed, count=None):
    from test_enclosure_fourbars import reference_peak, torque

    analysis, points, P = four_bar_batch(n, seed, count)
    columns, constraints = stacked(analysis, P)
    found = analysis.certified.many(analysis.s_values, P, columns, constraints)
    wrong, missed = [], 0
    for params, f, sampled in zip(points, found, columns["drive"]):
        branch = min((1.0, -1.0), key=lambda br: float(np.max(np.abs(torque(analysis.s_values, branch=br, **params)
                                                                      - sampled))))
        ref = reference_peak(params, branch)   # numpy on 20,001 angles, refined by scipy
        peak, cert = f["peaks"]["drive"], f["certificates"]["peak |drive|"]
        missed += float(np.max(np.abs(sampled))) < 0.9 * ref   # the samples do not see the bump
        if not (ref * (1 - 1e-9) <= peak <= ref * (1 + 2e-9) and cert["note"] == "" and peak <= cert["bound"]
                <= peak * (1 + 1e-9)):
            wrong.append(f"{params}: certified {peak!r} (bound {cert['bound']}, {cert['note']!r}) against {ref!r}")
    assert not wrong, "\n".join(wrong)
    assert missed >= len(points) // 2   # the family exercises the certificate
    # and one alone gives the same numbers
    for i in (len(points) - 1,):
        alone = analysis.certified(analysis.s_values, P[i], {k: v[i] for k, v in columns.items()},
                                   {k: v[i] for k, v in constraints.items()})
        assert alone == found[i]


def test_a_batch_of_four_bars_with_narrow_torque_bumps():
    """The fast sibling: 4 generated four-bars in one batch."""
    check_four_bars(8, 4, 4)


@pytest.mark.slow
def test_a_family_of_four_bars_with_narrow_torque_bumps_in_one_batch():
    check_four_bars(64, 44)


def test_a_batch_of_truck_cranes_holds_a_denser_sampling():
    """16 Sobol truck cranes (mB, mP, xD, yD, b) in one batch: every certified peak and constraint
    extreme lies at or beyond every sample of a 16x denser sampling of its case, and its bound
    beyond those too (the bound holds between the samples)."""
    analysis = Analysis(optdesign.load(PROBLEMS / "truck_crane.toml"))
    dense = Analysis(optdesign.load(PROBLEMS / "truck_crane.toml"), samples=16 * (len(analysis.s_values) - 1) + 1,
                     certify=False)
    P = crane_parameters(analysis, 16, 11)
    columns, constraints = stacked(analysis, P)
    found = analysis.certified.many(analysis.s_values, P, columns, constraints)
    d_columns, d_constraints = stacked(dense, P)
    for i, f in enumerate(found):
        for name, peak in f["peaks"].items():
            top = float(np.max(np.abs(d_columns[name][i])))
            bound = f["certificates"][f"peak |{name}|"]["bound"]
            assert top <= bound and top <= peak * (1 + 1e-12), (i, name, top, peak, bound)
            assert peak <= bound <= peak + 1e-9 * max(peak, float(np.max(np.abs(columns[name][i])))) * 1.000001
        for name, e in f["constraint_extremes"].items():
            hi, lo = float(np.max(d_constraints[name][i])), float(np.min(d_constraints[name][i]))
            assert hi <= e["max"] + 1e-12 * abs(e["max"]) and lo >= e["min"] - 1e-12 * abs(e["min"]), (i, name)
            assert hi <= f["certificates"][f"{name} max"]["bound"] and lo >= f["certificates"][f"{name} min"]["bound"]


@pytest.mark.skipif(shutil.which(os.environ.get("CC", "gcc")) is None,
                    reason="no C compiler on this machine: nothing compiled to compare")
@pytest.mark.slow
def test_a_batch_gives_each_case_its_own_result_with_the_compiled_programs(tmp_path, monkeypatch):
    """The same with the interval program and the rows compiled to C (this file's other tests run
    numpy's intervals and CasADi's virtual machine: tests/conftest.py): each interval and each
    point is computed on its own in the C as well, whatever its place in the call."""
    from optdesign.model import compiled
    from optdesign.model.intervals_compiled import CompiledProgram

    monkeypatch.delenv("OPTDESIGN_NO_COMPILE", raising=False)
    monkeypatch.delenv("OPTDESIGN_INTERVALS", raising=False)
    monkeypatch.setenv("OPTDESIGN_COMPILE", "wait")
    monkeypatch.setenv("OPTDESIGN_CACHE_DIR", str(tmp_path))
    compiled._compiler.clear()
    try:
        analysis = Analysis(optdesign.load(PROBLEMS / "truck_crane.toml"))
        program = analysis.certified.enclosures.program
        assert isinstance(program, CompiledProgram) and program.subsets_pay   # the C, not numpy
        P = crane_parameters(analysis, 40, 9)
        columns, constraints = stacked(analysis, P)
        s = analysis.s_values
        together = analysis.certified.many(s, P, columns, constraints)
        alone = [analysis.certified(s, P[i], {k: v[i] for k, v in columns.items()},
                                    {k: v[i] for k, v in constraints.items()}) for i in range(len(P))]
        assert together == alone
        order = np.random.default_rng(2).permutation(len(P))[:13]
        assert analysis.certified.many(s, P[order], {k: v[order] for k, v in columns.items()},
                                       {k: v[order] for k, v in constraints.items()}) == [alone[i] for i in order]
        # cases differing in their masses alone: the kinematics' interval work shared by the
        # cases (CompiledProgram._shared) and the aggregates' rows evaluated once; the same bits
        shared = []
        keep = CompiledProgram._shared
        monkeypatch.setattr(CompiledProgram, "_shared", lambda self, *a: shared.append(keep(self, *a)) or shared[-1])
        P = crane_parameters(analysis, 40, 8, {k: VARIED[k] for k in ("mB", "mP")})
        columns, constraints = stacked(analysis, P)
        together = analysis.certified.many(s, P, columns, constraints)
        assert sum(x is not None for x in shared) >= 3
        monkeypatch.setattr(CompiledProgram, "_shared", keep)
        for i in (0, 17, 39):
            assert together[i] == analysis.certified(s, P[i], {k: v[i] for k, v in columns.items()},
                                                     {k: v[i] for k, v in constraints.items()})
    finally:
        compiled._compiler.clear()
