"""Analysis.run_many: many cases that differ in leaf parameters, each stage over all of them at
once (optdesign/model/runs.py), give each case exactly the figures of its own Analysis.run (which
is the one case of the same code) and of its own sweep_rms, whatever batch it is in: the truck
crane over boom and payload masses and its geometry (one case with a dead centre mid-batch), a
four-bar with per-sample and per-stroke constraints and an RMS, and a Sobol family of
crank-rocker four-bars (with one that does not assemble mid-batch) against an independent numpy
model written in tests/test_enclosure_fourbars.py (virtual work on a dense grid)."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import optdesign
from optdesign.model.analysis import Analysis
from optdesign.scene.resolved import ResolvedScene

from test_enclosure_fourbars import DEG, G, M2, M3, OMEGA, SCENE, designs, reference_peak, torque

ROOT = Path(__file__).resolve().parents[1]
CRANE = ["mB", "mP", "b", "xD", "yD"]
FOURBAR = ["a", "b", "c", "T0", "pc", "w"]
CONSTRAINTS = """
[[constraints]]
name = "transmission"
expr = "angle(B, C, D)"
min = "10 deg"
[[constraints]]
name = "rocker swing"
expr = "max(angle(D, C)) - min(angle(D, C))"
max = 3.0
[[constraints]]
name = "load change"
expr = "end(static_load) - start(static_load) + 0*T0"
max = 1e9
"""


def _analysis(scene, varied):
    return Analysis(ResolvedScene(scene.without_bounds(*varied), variable=varied))


def _figures(run):
    """A case's figures as text (floats to their last digit)."""
    return json.dumps([run.peaks, run.peak_at, run.peaks_sampled, run.constraint_extremes, run.stroke,
                       run.stroke_sampled, run.certificates], sort_keys=True)


def _alone(analysis, p):
    """The figures of ``analysis.run(p)``, or its error's text."""
    try:
        res = analysis.run(p)
    except optdesign.OptdesignError as exc:
        return f"error: {exc}"
    stroke = {k: v for k, v in res.constraints.items() if not np.ndim(v)}
    return json.dumps([res.peaks, res.peak_at, res.peaks_sampled, res.constraint_extremes, stroke,
                       res.constraints_sampled, res.certificates], sort_keys=True)


def _batch(analysis, P):
    return [f"error: {r.error}" if r.error is not None else _figures(r) for r in analysis.run_many(P)]


def _crane_cases(n, seed):
    scene = optdesign.load(ROOT / "problems" / "truck_crane.toml")
    analysis = _analysis(scene, CRANE)
    names = analysis.mech.parameter_names
    u = np.random.default_rng(seed).random((n, 5))
    P = np.tile(np.asarray(analysis.mech.parameter_values, float), (n, 1))
    for k, (name, lo, hi) in enumerate((("mB", 400, 900), ("mP", 300, 3300), ("b", 0.6, 2.1), ("xD", -0.1, 0.5),
                                        ("yD", -1.8, -0.6))):
        P[:, names.index(name)] = lo + (hi - lo) * u[:, k]
    return analysis, P


def _dead_centre_row(analysis, theta=30 * DEG):
    """Leaf values with the cylinder's base D on the line A-B at theta: dq/dtheta = 0 there."""
    names = analysis.mech.parameter_names
    p = np.asarray(analysis.mech.parameter_values, float).copy()
    b, f = p[names.index("b")], p[names.index("f")]
    bx, by = b * math.cos(theta) + f * math.sin(theta), b * math.sin(theta) - f * math.cos(theta)
    r = 1.6 / math.hypot(bx, by)
    p[names.index("xD")], p[names.index("yD")] = -r * bx, -r * by
    return p


def test_truck_crane_batches_give_each_case_its_own_run():
    analysis, P = _crane_cases(4, seed=3)
    P = np.insert(P, 2, _dead_centre_row(analysis), axis=0)   # a dead centre mid-batch
    alone = [_alone(analysis, p) for p in P]
    assert alone[2].startswith("error:") and "dead centre" in alone[2]
    assert sum(not a.startswith("error") for a in alone) == 4
    assert _batch(analysis, P) == alone
    # another composition: reversed, in two batches of other sizes
    order = np.arange(len(P))[::-1]
    parts = _batch(analysis, P[order[:3]]) + _batch(analysis, P[order[3:]])
    assert parts == [alone[i] for i in order]
    ok = [i for i, a in enumerate(alone) if not a.startswith("error")]
    many = analysis.sweep_rms_many(P[ok])
    assert many == [analysis.sweep_rms(P[i]) for i in ok]
    assert analysis.sweep_rms_many(P[ok][::-1]) == many[::-1]


def test_masses_alone_share_the_geometry_checks_and_keep_each_cases_numbers():
    """Cases that differ in masses only: the assembly and dead-centre checks run once for them
    (kinematics/batches.py), every figure still the case's own."""
    analysis, P = _crane_cases(6, seed=8)
    names = analysis.mech.parameter_names
    for name in ("b", "xD", "yD"):
        P[:, names.index(name)] = P[0, names.index(name)]
    calls = []   # the cases whose k is checked between the samples (all groups' at once)
    check = analysis.model._dead_centre_between
    analysis.model._dead_centre_between = lambda s, K, *args: calls.append(len(K)) or check(s, K, *args)
    try:
        together = _batch(analysis, P)
    finally:
        del analysis.model._dead_centre_between
    assert calls == [1]
    assert together == [_alone(analysis, p) for p in P]


def test_a_geometry_checked_before_is_not_checked_again_and_keeps_each_cases_numbers():
    """A study's later batches of the same geometry (masses varied): the dead-centre check
    between the samples is not run again (its result kept per geometry), and every case's
    figures are still those of its own run in a fresh analysis; a new geometry is checked."""
    analysis, P = _crane_cases(6, seed=9)
    names = analysis.mech.parameter_names
    for name in ("b", "xD", "yD"):
        P[:, names.index(name)] = P[0, names.index(name)]
    moved = P[:2].copy()
    moved[:, names.index("b")] += 0.05   # another geometry
    calls = []
    check = analysis.model._dead_centre_between
    analysis.model._dead_centre_between = lambda s, K, *args: calls.append(len(K)) or check(s, K, *args)
    try:
        first, again, other = _batch(analysis, P[:3]), _batch(analysis, P[3:]), _batch(analysis, moved)
    finally:
        del analysis.model._dead_centre_between
    assert calls == [1, 1]   # the first batch's geometry, then the moved one: not the second batch's
    fresh = _crane_cases(6, seed=9)[0]
    assert first + again == [_alone(fresh, p) for p in P]
    fresh = _crane_cases(6, seed=9)[0]
    assert other == [_alone(fresh, p) for p in moved]


def _fourbar(params, extra=""):
    text = SCENE.format(side="left", m2=M2, m3=M3, g=G, omega=OMEGA, **{k: float(v) for k, v in params.items()})
    return optdesign.loads(text + extra, "four-bars")


def test_per_stroke_constraints_and_rms_of_a_four_bar_batch_are_each_cases_own():
    points = designs(8, seed=11)[:2]
    analysis = _analysis(_fourbar(points[0], CONSTRAINTS), FOURBAR)
    names = analysis.mech.parameter_names
    P = np.array([[p.get(n, v) for n, v in zip(names, analysis.mech.parameter_values)] for p in points], float)
    runs = analysis.run_many(P)
    assert all(r.error is None for r in runs)
    assert set(runs[0].stroke) == {"rocker swing", "load change"} and "transmission" in runs[0].constraint_extremes
    assert [_figures(r) for r in runs] == [_alone(analysis, p) for p in P]
    assert analysis.sweep_rms_many(P) == [analysis.sweep_rms(p) for p in P]
    # the per-stroke constraints against their definitions, on the four-bar's own geometry
    s = analysis.s_values
    for params, p, r in zip(points, P, runs):
        res = analysis.run(p)
        branch = min((1.0, -1.0), key=lambda br: float(np.max(np.abs(torque(s, branch=br, **params)
                                                                       - res.columns["drive"]))))
        cx, cy = _rocker_pin(s, params["a"], params["b"], params["c"], branch)
        assert r.stroke_sampled["rocker swing"] == pytest.approx(np.ptp(np.arctan2(cy, cx - 1.0)), rel=1e-12)
        assert r.stroke["rocker swing"] >= r.stroke_sampled["rocker swing"]
        load = res.columns["static_load"]
        assert r.stroke["load change"] == pytest.approx(load[-1] - load[0], rel=1e-12, abs=1e-12)


def _rocker_pin(phi, a, b, c, branch, d=1.0):
    """The rocker's pin C at the crank angles ``phi`` (circle intersection, as the reference model)."""
    bx, by = a * np.cos(phi), a * np.sin(phi)
    ex, ey = d - bx, -by
    e = np.hypot(ex, ey)
    along = (b * b - c * c + e * e) / (2 * e)
    across = branch * np.sqrt(b * b - along * along)
    return bx + (along * ex - across * ey) / e, by + (along * ey + across * ex) / e


def test_two_four_bars_and_one_that_does_not_assemble_in_one_batch_against_virtual_work():
    """The fast sibling of the family below: two four-bars around one that does not assemble."""
    check_family_batch(designs(8, seed=23)[:2])


@pytest.mark.slow
def test_a_sobol_family_of_four_bars_in_one_batch_against_virtual_work():
    check_family_batch(designs(32, seed=29)[:10])


def check_family_batch(points):
    """Each four-bar's certified peak drive torque and its RMS over the sweep against the numpy
    model (virtual work on 20,001 points); the one that does not assemble, mid-batch, says so
    and leaves the others as they are alone."""
    bad = dict(points[0], a=4.0)   # not a crank-rocker: does not assemble over the sweep
    cases = points[:1] + [bad] + points[1:]
    analysis = _analysis(_fourbar(points[0]), FOURBAR)
    names = analysis.mech.parameter_names
    P = np.array([[c.get(n, v) for n, v in zip(names, analysis.mech.parameter_values)] for c in cases], float)
    runs = analysis.run_many(P)
    assert runs[1].error is not None and "assemble" in str(runs[1].error)
    assert [_figures(r) if r.error is None else f"error: {r.error}" for r in runs] == [_alone(analysis, p) for p in P]
    ok = [i for i in range(len(cases)) if i != 1]
    rms = dict(zip(ok, analysis.sweep_rms_many(P[ok])))
    phi = np.linspace(20 * DEG, 160 * DEG, 20001)
    for i in ok:
        params = cases[i]
        sampled = np.asarray(analysis.run(P[i]).columns["drive"])
        s = analysis.s_values
        branch = min((1.0, -1.0), key=lambda br: float(np.max(np.abs(torque(s, branch=br, **params) - sampled))))
        ref = reference_peak(params, branch)
        assert ref * (1 - 1e-9) <= runs[i].peaks["drive"] <= ref * (1 + 2e-9)
        T = torque(phi, branch=branch, **params)
        h = phi[1] - phi[0]
        simpson = h / 3 * (T[0] ** 2 + T[-1] ** 2 + 4 * np.sum(T[1:-1:2] ** 2) + 2 * np.sum(T[2:-1:2] ** 2))
        ref_rms = math.sqrt(simpson / (phi[-1] - phi[0]))
        assert rms[i]["drive"][0] == pytest.approx(ref_rms, rel=1e-7)


LOOP = """
title = "four-bar closed by Newton's method"
[parameters]
a = 0.2
b = 0.9
c = 0.7
d = 1.0
m = 2.0
[sweep]
name = "theta"
from = "20 deg"
to = "160 deg"
samples = 29
[points]
A = { fixed = [0, 0] }
D = { fixed = ["d", 0] }
[points.chain]
loop = "A"
lengths = ["a", "b", "c"]
angles = ["theta", "phi2", "phi3"]
joints = ["B", "C", "D3"]
unknowns = { phi2 = "60 deg - theta", phi3 = "-100 deg" }
closure = { point = "D3", fixed = "D" }
[[bodies]]
name = "rocker"
frame = ["D", "C"]
mass = "m"
com = ["c/2", 0]
inertia = "m*c^2/12"
[gravity]
g = 9.81
[drive]
type = "rotary"
crank = ["A", "B"]
speed = 2.0
acceleration = 0.0
[[constraints]]
name = "rise"
expr = "max(y(C)) - min(y(C)) + 0*m"
max = 5
[[constraints]]
name = "transmission"
expr = "angle(B, C, D)"
min = "10 deg"
"""


def test_a_loop_closed_by_newton_mx_graphs_gives_each_case_its_own_run():
    """A four-bar closed by Newton's method (MX graphs: CasADi's map with a parameter row per
    point, no blocks) with a per-stroke constraint: each case as alone."""
    analysis = _analysis(optdesign.loads(LOOP, "loop"), ["a", "m"])
    assert analysis.vectorised is None   # the MX path
    names = analysis.mech.parameter_names
    P = np.tile(np.asarray(analysis.mech.parameter_values, float), (3, 1))
    P[:, names.index("a")], P[:, names.index("m")] = [0.18, 0.2, 0.22], [1.0, 2.0, 3.0]
    assert _batch(analysis, P) == [_alone(analysis, p) for p in P]
    assert _batch(analysis, P[::-1]) == [_alone(analysis, p) for p in P[::-1]]
    assert analysis.sweep_rms_many(P) == [analysis.sweep_rms(p) for p in P]


def test_per_stroke_values_with_located_extrema_are_those_of_the_samples_and_the_located_together():
    """StrokeConstraints.values(columns, P, extra): each case's located values (a different number
    per case, none, or NaN) count in its max(...)/min(...) as if they were samples: the values of
    the columns with each case's located values appended (padded with its first sample)."""
    scene = optdesign.load(ROOT / "problems" / "truck_crane.toml")
    analysis = Analysis(ResolvedScene(scene, variable=CRANE))
    stroke = analysis.stroke
    assert {f for calls in stroke.calls for f, _ in calls} == {"max", "min"}
    rng = np.random.default_rng(4)
    n, samples = 7, 9
    P = np.repeat(np.asarray(analysis.mech.parameter_values, float)[None, :], n, axis=0)
    columns = {key: rng.uniform(-1, 1, (n, samples)) + 2.0 for key in stroke.keys}
    extra = [rng.uniform(-2, 2, (len(stroke.keys), k)) + 2.0 if k is not None else None
             for k in (3, None, 0, 1, 5, 2, 4)]
    extra[5][0, 1] = math.nan
    longest = max(e.shape[1] for e in extra if e is not None)
    joined = {}
    for row, key in enumerate(stroke.keys):
        joined[key] = np.column_stack([columns[key], np.empty((n, longest))])
        for case in range(n):
            more = extra[case][row] if extra[case] is not None else np.zeros(0)
            joined[key][case, samples:] = np.r_[more, np.full(longest - len(more), columns[key][case, 0])]
    got, expected = stroke.values(columns, P, extra), stroke.values(joined, P)
    assert np.isnan(got[5]).any() and np.array_equal(got, expected, equal_nan=True)
    assert not np.array_equal(got, stroke.values(columns, P), equal_nan=True)   # the located values count


@pytest.mark.parametrize("n", [1, 5, 256, 300, 700])
def test_per_stroke_values_through_the_buffer_are_casadis_ordinary_call(n):
    """The per-stroke constraints' Function over n cases through CasADi's buffer interface (calls
    of CHUNK cases, the last padded) gives each case the numbers of CasADi's ordinary mapped call
    (==, NaN where an aggregate is 0: 0/0), whatever the number of cases."""
    from optdesign.model.per_stroke import CHUNK

    scene = optdesign.load(ROOT / "problems" / "truck_crane.toml")
    stroke = Analysis(ResolvedScene(scene, variable=CRANE), certify=False).stroke
    rng = np.random.default_rng(n)
    P = np.asarray(Analysis(scene, certify=False).mech.parameter_values, float) * rng.uniform(0.5, 2, (n, 7))
    A = rng.uniform(-3, 3, (len(stroke.keys), n))
    A[:, ::7] = 0.0
    got = stroke._call(A, P)
    assert stroke._maps["buffer"] is not None and (n <= CHUNK or n % CHUNK)
    expected = np.asarray(stroke.function.map(n)(A, P.T), float).reshape(len(stroke.names), n).T
    assert np.isnan(got).any() and np.array_equal(got, expected, equal_nan=True)


def test_a_per_stroke_value_that_is_not_finite_stops_its_case_alone_and_large_finite_ones_pass():
    """A per-stroke constraint that divides by zero for one case of a batch (mP = 1000): that case
    carries the ResultError naming the constraint, the others their figures; two per-stroke
    values near the largest double (their sum overflows) are finite and pass."""
    from optdesign.errors import ResultError

    text = (ROOT / "problems" / "truck_crane.toml").read_text()
    text = text.replace("[objective]", """[[constraints]]
name = "per payload"
expr = "max(drive) / (mP - 1000)"
max = 1e300

[[constraints]]
name = "huge one"
expr = "max(drive) * 0 + 1.5e308"
max = 1.7e308

[[constraints]]
name = "huge two"
expr = "min(drive) * 0 + 1.5e308"
max = 1.7e308

[objective]""", 1)
    scene = optdesign.loads(text, "truck_crane_checks.toml")
    analysis = Analysis(ResolvedScene(scene.without_bounds("mP"), variable=["mP"]))
    names = analysis.mech.parameter_names
    P = np.repeat(np.asarray(analysis.mech.parameter_values, float)[None, :], 3, axis=0)
    P[:, names.index("mP")] = [900.0, 1000.0, 1100.0]
    runs = analysis.run_many(P)
    assert isinstance(runs[1].error, ResultError) and "'per payload'" in str(runs[1].error)
    for r in (runs[0], runs[2]):
        assert r.error is None and r.stroke["huge one"] == r.stroke["huge two"] == 1.5e308
        assert math.isfinite(r.stroke["per payload"])
