"""The branch and bound's first pass (kinematics/branch_bound.first_intervals): the stroke in
blocks of samples, cut around each located maximum towards it, so that the Taylor form closes
there in one evaluation of the interval program.  A faster certificate must be the same
certificate.

References: the stroke itself (the first pass's intervals of every request must tile it, none
lost, and every block edge and located maximum an edge), dense numpy samples of generated
functions written here from their parameters (the bound must hold each of them), and the same
branch and bound without the cuts (branch_bound.PRESPLIT = 0): the same located maximum, both
bounds within the tolerance of it."""
from __future__ import annotations

import casadi as ca
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from optdesign.kinematics import branch_bound, peaks
from optdesign.kinematics.extrema import Found, Tasks
from optdesign.kinematics.enclosure import Enclosures
from optdesign.kinematics.peaks import CERTIFY_TOL, Extremum, Request, continuous_maxima_rows


@settings(max_examples=60, deadline=None)
@given(st.integers(2, 40), st.booleans(), st.lists(st.floats(0, 1), min_size=1, max_size=6),
       st.lists(st.sampled_from(["abs", "max", "min"]), min_size=1, max_size=3), st.integers(0, 2 ** 32 - 1))
def test_the_first_pass_tiles_the_stroke(samples, descending, where, senses, seed):
    """Per request, the first pass's intervals tile [min s, max s]: sorted, each ends where the
    next begins, none crosses a sample, whatever the located maxima (at samples, between
    them, at the ends, several in one interval)."""
    rng = np.random.default_rng(seed)
    grid = np.sort(rng.uniform(-2, 3, samples)) if seed % 2 else np.linspace(-2, 3, samples)
    grid = np.unique(grid)
    if len(grid) < 2:
        return
    if descending:
        grid = grid[::-1]
    a, b = float(grid.min()), float(grid.max())
    s_at = [a + (b - a) * w for w in where] + [float(grid[len(grid) // 2])]
    requests = [Request(0, sense) for sense in senses]
    found = [[Extremum(s, 1.0 + 1e-4 * k) for k, s in enumerate(s_at)] for _ in requests]
    tasks = Tasks(requests, 1)
    flat = Found(len(requests))
    for k, f in enumerate(found):
        flat.add([k] * len(f), [e.s for e in f], [e.value for e in f])
    _, best = flat.best(tasks.code)
    req, lo, hi, where, first = branch_bound.first_intervals(tasks, grid, flat, best)
    assert np.array_equal(lo[first][where], lo) and np.array_equal(hi[first][where], hi)
    samples_sorted = np.sort(grid)
    blocks = samples_sorted[::branch_bound.BLOCK]
    for k in range(len(requests)):
        mine = req == k
        order = np.argsort(lo[mine], kind="stable")
        x, y = lo[mine][order], hi[mine][order]
        assert np.all(x < y)
        assert x[0] == a and y[-1] == b and np.array_equal(y[:-1], x[1:])
        edges = set(x) | set(y)
        assert set(blocks) <= edges   # the blocks' edges, whatever else is cut
        for s in s_at:   # every located maximum inside the stroke is an edge, its pieces shrinking to it
            if a < s < b:
                assert s in edges
                closest = min(abs(e - s) for e in edges if e != s)
                h = (samples_sorted[1:] - samples_sorted[:-1]).max()
                assert closest <= h * 2.0 ** (1 - branch_bound.PRESPLIT) * (1 + 1e-9)


def _bumps(params):
    """v(s) = sum A exp(-((s - c)/w)^2) + B sin(f s + g), as CasADi (v, dv, d2v) and as numpy."""
    s, p = ca.SX.sym("s"), ca.SX.sym("p", 1)
    bumps, (B, f, g) = params
    v = B * ca.sin(f * s + g)
    for A, c, w in bumps:
        v += A * ca.exp(-((s - c) / w) ** 2)
    dv = ca.jacobian(v, s)
    F = ca.Function("f", [s, p], [v, dv, ca.jacobian(dv, s)], ["s", "p"], ["v", "dv", "d2v"], {"cse": True})

    def numpy_v(x):
        out = B * np.sin(f * x + g)
        for A, c, w in bumps:
            out = out + A * np.exp(-((x - c) / w) ** 2)
        return out
    return F, numpy_v


BUMP = st.tuples(st.floats(-5, 5), st.floats(0, 2), st.floats(0.005, 0.6))
WAVE = st.tuples(st.floats(-2, 2), st.floats(0.5, 6), st.floats(-3, 3))


@settings(max_examples=25, deadline=None)
@given(st.lists(BUMP, min_size=1, max_size=3), WAVE, st.integers(3, 41), st.sampled_from(["abs", "max", "min"]),
       st.booleans())
def test_generated_functions_are_certified_as_without_the_cuts(bumps, wave, samples, sense, descending):
    """Bumps narrower than the sample spacing at random places, on a wave, swept up or down:
    the certified maximum with the first pass's cuts is the one without them (within the
    tolerance), both bounds lie within the tolerance above it, and no value of a dense numpy
    sample (20,001 points) exceeds a bound."""
    F, numpy_v = _bumps((bumps, wave))
    grid = np.linspace(0.0, 2.0, samples)
    if descending:
        grid = grid[::-1]

    def ev(x):
        return [np.asarray(a) for a in F.map(len(x))(np.asarray(x, float)[None, :], [0.0])]

    V = ev(grid)[0]

    def certified():
        return continuous_maxima_rows(ev, grid, V, [Request(0, sense, ends=True)],
                                      enclosure=Enclosures(F).at([0.0]))[0][0]

    fast = certified()
    saved = branch_bound.PRESPLIT
    branch_bound.PRESPLIT = 0
    try:
        plain = certified()
    finally:
        branch_bound.PRESPLIT = saved
    sign = {"abs": None, "max": 1.0, "min": -1.0}[sense]
    dense = numpy_v(np.linspace(0.0, 2.0, 20001))
    target = np.abs(dense) if sign is None else sign * dense
    tol = CERTIFY_TOL * max(float(np.max(np.abs(V))), abs(fast.value)) + 1e-12
    for top in (fast, plain):
        assert top.note == "", top.note
        value = abs(top.value) if sign is None else sign * top.value
        assert value <= top.bound <= value + tol
        assert float(np.max(target)) <= top.bound + 1e-12 * max(1.0, top.bound)
    f_value = abs(fast.value) if sign is None else sign * fast.value
    p_value = abs(plain.value) if sign is None else sign * plain.value
    assert abs(f_value - p_value) <= tol


def test_a_sweep_that_runs_down_is_certified():
    """Issue 27's minimal bump, v(s) = -0.2 s + 5 exp(-((s - 1.4)/0.3)^2), sampled on [2, 1, 0]
    (a sweep from 2 to 0): its maximum is 4.720 at s = 1.398, as on [0, 1, 2].  The sample
    intervals were taken as [lo, hi] = [2, 1], [1, 0], which the interval operations read
    wrongly (sin's and exp's extremes inside are tested for lo <= hi): the code before certified
    4.174 at s = 1.5 with the bound 4.174."""
    s, p = ca.SX.sym("s"), ca.SX.sym("p", 1)
    v = -0.2 * s + 5 * ca.exp(-((s - 1.4) / 0.3) ** 2)
    dv = ca.jacobian(v, s)
    F = ca.Function("f", [s, p], [v, dv, ca.jacobian(dv, s)], ["s", "p"], ["v", "dv", "d2v"], {"cse": True})

    def ev(x):
        return [np.asarray(a) for a in F.map(len(x))(np.asarray(x, float)[None, :], [0.0])]

    saved = branch_bound.PRESPLIT
    try:
        for cuts in (saved, 0):
            branch_bound.PRESPLIT = cuts
            for grid in (np.array([2.0, 1.0, 0.0]), np.array([0.0, 1.0, 2.0])):
                top = continuous_maxima_rows(ev, grid, ev(grid)[0], [Request(0, "abs", ends=True)],
                                             enclosure=Enclosures(F).at([0.0]))[0][0]
                assert top.note == "" and round(top.value, 3) == 4.720 and round(top.s, 3) == 1.398, (cuts, grid, top)
                assert top.value <= top.bound <= top.value * (1 + CERTIFY_TOL)
    finally:
        branch_bound.PRESPLIT = saved
