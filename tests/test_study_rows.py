"""A study's rows held column by column (optdesign/study/rows.py, issue 31): every row reads back
as the very dict that was appended (keys in order, values of the same type), a column as the
float array the old list of dicts gave, and a row of the truck crane's 25 columns costs a tenth
of its dict (measured with tracemalloc)."""
from __future__ import annotations

import gc
import json
import math
import tracemalloc

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from optdesign.study.results import StudyResult
from optdesign.study.rows import Rows

VALUES = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-2**70, 2**70), st.booleans(),
                   st.none(), st.text(max_size=8), st.sampled_from(["ok", "error: no assembly", "1.5"]),
                   st.integers(0, 2**64 - 1).map(lambda v: f"{v:016x}"))
ROWS = st.lists(st.dictionaries(st.sampled_from(["case", "id", "status", "success", "peak:drive", "x", "y"]),
                                VALUES, max_size=7), max_size=30)


def same(a, b) -> bool:
    """Equal as the rows were: keys in the same order, values of the same type, nan as nan."""
    return list(a) == list(b) and all(
        type(a[k]) is type(b[k]) and (a[k] == b[k] or (isinstance(a[k], float) and math.isnan(a[k]) and math.isnan(b[k])))
        for k in a)


def old_column(rows, name):
    """StudyResult.column as it was, over a list of dicts."""
    def as_float(v):
        if v is None:
            return math.nan
        try:
            return float(v)
        except (TypeError, ValueError):
            return math.nan
    return np.array([as_float(r.get(name)) for r in rows], dtype=float)


@settings(max_examples=100, deadline=None)
@given(rows=ROWS)
def test_rows_read_back_as_appended_and_columns_as_before(rows):
    held = Rows(rows)
    assert len(held) == len(rows)
    assert all(same(a, b) for a, b in zip(held, rows))
    assert all(same(held[i - len(rows)], rows[i]) for i in range(len(rows)))   # negative indices
    assert [list(r) for r in held[1::2]] == [list(r) for r in rows[1::2]]
    for name in ("case", "id", "status", "success", "peak:drive", "x", "y", "absent"):
        np.testing.assert_array_equal(held.column(name), old_column(rows, name))
        assert held.has(name) == any(name in r for r in rows)
        # a column's values as the rows hold them (None where a row has none), and as doubles where
        # every row holds a float: the very same ones, bit for bit
        start = len(rows) // 3
        values = held.values(name, start)
        assert same(dict(enumerate(values)), {j: r.get(name) for j, r in enumerate(rows[start:])})
        floats = held.floats(name, start)
        pure = bool(rows) and all(type(r.get(name)) is float for r in rows)
        assert (floats is not None) == pure
        if pure:
            assert floats.tobytes() == np.array(values, dtype=float).tobytes()
    got = held[0] if rows else None
    if got:   # a row read is a new dict: changing it leaves the rows alone
        got.clear()
        assert same(held[0], rows[0])


def test_rows_compare_and_a_result_turns_a_list_into_rows(tmp_path):
    rows = [{"case": 0, "peak:drive": 1.5, "success": True}, {"case": 1, "status": "error", "success": False}]
    result = StudyResult(None, tmp_path, rows, True, 2, 0, 0.1, [])
    assert isinstance(result.rows, Rows) and result.rows == rows and rows == result.rows
    assert result.rows != rows[:1] and result.rows != [rows[1], rows[0]]
    ok, bad = result.rows
    assert ok == rows[0] and bad == rows[1]
    np.testing.assert_array_equal(result.column("peak:drive"), [1.5, math.nan])
    assert json.loads(json.dumps(result.to_dict()["rows"])) == rows


def test_a_row_of_the_truck_crane_costs_a_tenth_of_its_dict():
    """25 columns (the truck crane's analyse row: identification, two inputs, 19 numbers):
    as dicts ~2.8 kB a row; here under 300 B."""
    import random

    rng = random.Random(1)

    def row(i):
        return {"case": i, "id": f"{rng.getrandbits(64):016x}", "chain": i, "link": 0, "mB": 500.0 + i % 10,
                "mP": 500.0 + i / 7, "status": "o" + "k", "success": True,   # a new "ok" each time, as json.loads gives
                **{f"peak:q{j}": rng.random() * 1e5 for j in range(17)}}

    n = 4_000
    gc.collect()
    tracemalloc.start()
    try:
        dicts = [row(i) for i in range(n)]
        as_dicts = tracemalloc.get_traced_memory()[0]
        held = Rows(dicts)
        as_rows = tracemalloc.get_traced_memory()[0] - as_dicts
    finally:
        tracemalloc.stop()
    assert held == dicts
    assert as_dicts / n > 2000 and as_rows / n < 300, (as_dicts / n, as_rows / n)
