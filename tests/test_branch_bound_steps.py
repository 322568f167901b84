"""The branch and bound's array steps (kinematics/branch_bound.py, kinematics/extrema.py)
against plain references written here: the halving pass's cuts (split), the targets' bounds
per sense (target_bound), the targets' signs (Tasks.sign) and the best located extremum per
task (Found.best, also after extrema are added)."""
from __future__ import annotations

import numpy as np

from optdesign.kinematics.branch_bound import PRESPLIT, split, target_bound
from optdesign.kinematics.extrema import Found, Tasks
from optdesign.kinematics.peaks import Request


def reference_split(task, lo, hi, left_ub, cuts):
    """Each interval cut at its cuts strictly inside it (each once), pieces in order."""
    out = []
    for k in range(len(lo)):
        edges = [lo[k]] + sorted({c for c in cuts[k] if c == c and lo[k] < c < hi[k]}) + [hi[k]]
        out += [(task[k], a, b, left_ub[k]) for a, b in zip(edges[:-1], edges[1:])]
    return tuple(np.array(a) for a in zip(*out))


def test_the_halving_split_equals_the_cuts_one_by_one():
    """The halving pass's split: intervals away from a maximum halved at their middle, those
    around one cut towards it; the same pieces, in the same order and to the bit, as cutting
    each interval at its row of cuts by hand: random intervals, maxima inside some of them, at
    their ends, outside, a middle that rounds onto an end (a tiny interval) and NaN bounds."""
    rng = np.random.default_rng(5)
    for trial in range(20):
        n = int(rng.integers(1, 60))
        lo = rng.uniform(-2, 2, n)
        width = 10.0 ** rng.uniform(-16, 0, n)
        width[rng.random(n) < 0.1] = 0.0
        hi = lo + width
        task = rng.integers(0, 5, n)
        left_ub = np.where(rng.random(n) < 0.2, np.nan, rng.normal(size=n))
        where = rng.random(n)
        centre = np.where(where < 0.4, lo + width * rng.random(n), np.where(where < 0.6, lo, hi + 1.0))
        around = (lo < centre) & (centre < hi)
        w = hi - lo
        steps = w[around, None] * 2.0 ** -np.arange(1, PRESPLIT + 1)[None, :]
        cuts = centre[around, None] + np.concatenate((-steps, np.zeros((len(steps), 1)), steps[:, ::-1]), axis=1)
        mine = split(task, lo, hi, left_ub, cuts, around, lo + w * 0.5)
        full = np.full((n, 2 * PRESPLIT + 1), np.nan)
        full[~around, 0] = lo[~around] + w[~around] * 0.5
        full[around] = cuts
        for a, b in zip(mine, reference_split(task, lo, hi, left_ub, full)):
            assert np.array_equal(a, b, equal_nan=True), trial
        for a, b in zip(split(task, lo, hi, left_ub, full), mine):   # (the general form: every row cut)
            assert np.array_equal(a, b, equal_nan=True), trial


def test_signs_target_bounds_and_the_best_extremum_per_task():
    """Tasks.sign, target_bound and Found.best against their definitions: |v| (the sign of v,
    +1 at 0 and NaN), v, -v per sense; a task's best located target (the first among equals,
    NaN-only tasks NaN, tasks without any -inf), and the same again after new extrema are added
    (not an answer kept from before)."""
    rng = np.random.default_rng(8)
    requests = [Request(0, "abs"), Request(1, "max"), Request(0, "min")]
    tasks = Tasks(requests, 4)
    values = rng.normal(size=(len(tasks), 7))
    values[0, 2], values[3, 1], values[5, 0] = 0.0, -0.0, np.nan
    sign = tasks.sign(values)
    expected = np.array([[(1.0 if not x < 0 else -1.0) if r.sense == "abs" else (1.0 if r.sense == "max" else -1.0)
                          for x in row] for row, r in zip(values, [requests[j] for j in tasks.request])])
    assert np.array_equal(sign, expected)
    L, U = np.sort(rng.normal(size=(2, len(tasks))), axis=0)
    for upper in (True, False):
        mine = target_bound(L, U, tasks.code, upper)
        for k, r in enumerate(tasks.request):
            sense = requests[r].sense
            want = {"max": U[k] if upper else L[k], "min": -L[k] if upper else -U[k],
                    "abs": max(U[k], -L[k]) if upper else max(L[k], -U[k])}[sense]
            assert mine[k] == want

    def best(found):
        out = []
        for t in range(len(tasks)):
            idx = [i for i in range(len(found.task)) if found.task[i] == t]
            sense = requests[tasks.request[t]].sense
            target = [abs(found.v[i]) if sense == "abs" else (found.v[i] if sense == "max" else -found.v[i]) for i in idx]
            finite = [x for x in target if x == x]
            out.append(max(finite) if finite else (np.nan if idx else -np.inf))
        return np.array(out)

    found = Found(len(tasks))
    found.add(np.arange(8), rng.normal(size=8), rng.normal(size=8))
    found.add([9], [0.3], [np.nan])
    first = found.best(tasks.code)[1]
    assert np.array_equal(first, best(found), equal_nan=True)
    found.add(np.arange(12), rng.normal(size=12), 5 * rng.normal(size=12))
    again = found.best(tasks.code)
    assert np.array_equal(again[1], best(found), equal_nan=True) and not np.array_equal(again[1], first, equal_nan=True)
    assert np.array_equal(target_of(found, again[0], tasks, requests), again[1], equal_nan=True)


def target_of(found, top, tasks, requests):
    """The target of each task's extremum at index ``top`` (-inf where it has none)."""
    out = []
    for t, i in enumerate(top):
        if i < 0:
            out.append(-np.inf)
            continue
        sense = requests[tasks.request[t]].sense
        v = found.v[i]
        out.append(abs(v) if sense == "abs" else (v if sense == "max" else -v))
    return np.array(out)


def test_one_case_first_intervals_are_the_many_case_arrays():
    """first_intervals of one case (its own branch: no sorting or counting by case) gives, bit
    for bit, the arrays of case 0 in a batch of two equal cases (the many-case path): the
    entries' tasks, ends and interval indices and each interval's first entry; random ascending
    and descending grids, 1-3 requests of each sense, located maxima on and off the samples."""
    from optdesign.kinematics.branch_bound import first_intervals

    rng = np.random.default_rng(11)
    for trial in range(100):
        S = int(rng.integers(2, 60))
        grid = np.sort(rng.uniform(-3, 3, S)) if trial % 3 else np.linspace(0, 2 * np.pi, S)
        if trial % 7 == 0:
            grid = grid[::-1]
        k = int(rng.integers(1, 4))
        requests = [Request(j, ("abs", "max", "min")[j % 3]) for j in range(k)]
        n_found = int(rng.integers(0, 6))
        t = rng.integers(0, k, n_found)
        s = rng.choice(grid, n_found) + rng.normal(0, 0.01, n_found) * (rng.random(n_found) < 0.5)
        v = rng.normal(0, 1, n_found)
        one, two = Tasks(requests, 1), Tasks(requests, 2)
        found_one, found_two = Found(len(one)), Found(len(two))
        found_one.add(t, s, v)
        found_two.add(np.r_[t, t + k], np.r_[s, s], np.r_[v, v])
        a = first_intervals(one, grid, found_one, found_one.best(one.code)[1].copy())
        b = first_intervals(two, grid, found_two, found_two.best(two.code)[1].copy())
        assert len(a[1]) == len(b[1]) // 2 and len(a[4]) == len(b[4]) // 2
        for x, y in zip(a, b):
            y = y[:len(x)]
            assert x.dtype == y.dtype
            assert np.array_equal(x.view(np.int64), y.view(np.int64)), trial
