"""enclosure.distinct_ends: the distinct (case, value) ends of many intervals, found in one pass
where each case's intervals are ascending and do not overlap, must be the arrays the stable sort
by (case, value) gives (the reference below, written out here): the same ends in the same order,
each group's first end in the order lo then hi (+0.0 and -0.0 are one end: its bits are the first
one's), each end's index and case."""
import numpy as np
import pytest

from optdesign.kinematics.enclosure import distinct_ends


def reference(lo, hi, cases):
    n = len(lo)
    s = np.concatenate((lo, hi))
    c = np.zeros(2 * n, int) if cases is None else np.concatenate((cases, cases))
    order = sorted(range(2 * n), key=lambda k: (c[k], s[k], k))   # stable: ties by index
    ends, case, where = [], [], [0] * (2 * n)
    for k in order:
        if not ends or c[k] != case[-1] or s[k] - ends[-1] != 0:
            ends.append(s[k])
            case.append(c[k])
        where[k] = len(ends) - 1
    return np.array(ends), np.array(where), (None if cases is None else np.array(case))


def intervals(rng, k, sorted_cases):
    per = rng.integers(1, 8, k)
    cases = np.repeat(np.arange(k), per) if sorted_cases else rng.permutation(np.repeat(np.arange(k), per))
    lo, hi = np.empty(len(cases)), np.empty(len(cases))
    for c in range(k):
        m = np.count_nonzero(cases == c)
        pool = np.array([-1.0, -0.0, 0.0, 0.5, 1.0]) if rng.random() < 0.4 else rng.uniform(-1, 1, 12)
        edges = np.sort(rng.choice(pool, m + 1))
        a, b = edges[:-1].copy(), edges[1:].copy()
        if rng.random() < 0.2:   # overlapping intervals: the sort
            b = b + rng.uniform(0, 0.5, m)
        zero = (a == 0) & (rng.random(m) < 0.5)
        a[zero] = rng.choice([-0.0, 0.0])
        lo[cases == c], hi[cases == c] = a, b
    return lo, hi, cases


@pytest.mark.parametrize("seed", range(4))
def test_distinct_ends_match_the_stable_sort(seed):
    rng = np.random.default_rng(seed)
    one_pass = 0
    for _ in range(400):
        lo, hi, cases = intervals(rng, int(rng.integers(1, 5)), rng.random() < 0.8)
        if rng.random() < 0.2:
            cases = None
        got, want = distinct_ends(lo, hi, cases), reference(lo, hi, cases)
        assert got[0].view(np.int64).tolist() == want[0].view(np.int64).tolist()   # by the bits
        assert got[1].tolist() == want[1].tolist()
        assert (got[2] is None) == (want[2] is None)
        if got[2] is not None:
            assert got[2].tolist() == want[2].tolist()
        ends, case = np.empty(2 * len(lo)), np.repeat(np.zeros(len(lo), int) if cases is None else cases, 2)
        ends[0::2], ends[1::2] = lo, hi
        one_pass += bool(np.all((case[1:] > case[:-1]) | ((case[1:] == case[:-1]) & (ends[1:] >= ends[:-1]))))
    assert one_pass > 100   # (the one-pass path was taken)


def test_distinct_ends_of_touching_intervals():
    lo, hi = np.array([0.0, 1.0, 2.0, -0.0, 0.5]), np.array([1.0, 2.0, 3.0, 0.5, 1.0])
    ends, where, case = distinct_ends(lo, hi, np.array([0, 0, 0, 1, 1]))
    assert ends.tolist() == [0.0, 1.0, 2.0, 3.0, 0.0, 0.5, 1.0]
    assert np.signbit(ends[4])   # case 1's first end is -0.0
    assert where.tolist() == [0, 1, 2, 4, 5, 1, 2, 3, 5, 6]
    assert case.tolist() == [0, 0, 0, 0, 1, 1, 1]
