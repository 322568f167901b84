"""Studies at scale, the client's side (issue 31): the journal is indexed, not loaded (a record
is read back from the file when asked for); cases.csv is written while the study runs, in case
order whatever order the cases finish in, and ends as the table of every finished row; the
memory check budgets what a case really costs (measured here with tracemalloc)."""
from __future__ import annotations

import csv
import gc
import io
import json
import random
import tracemalloc
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import optdesign
from optdesign.scene.arguments import CASE_BYTES, COLUMN_BYTES
from optdesign.study import Study, grid, values
from optdesign.study import table as study_table
from optdesign.study.journal import JOURNAL, Journal

ROOT = Path(__file__).resolve().parents[1]


def reference_csv(rows, inputs) -> str:
    """The table of ``rows`` written whole, in one go (as cases.csv was before it was written
    while the study runs)."""
    cols = study_table.columns(inputs, rows)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(cols)
    for r in rows:
        w.writerow([study_table.cell(r.get(k)) for k in cols])
    return buf.getvalue()


# --- cases.csv written as cases finish --------------------------------------------------------------
class _Case:
    def __init__(self, index):
        self.index, self.id = index, f"c{index}"


def _row(index, kind):
    base = {"case": index, "id": f"c{index}", "chain": index, "link": 0, "mC": 100.0 + index}
    if kind == "failed":
        return {**base, "status": "error: does not assemble, \"quoted\", a comma", "success": False}
    out = {**base, "status": "ok", "success": True, "peak:drive": 1e4 / (index + 1), "rms:drive": 0.1 * index}
    if kind == "wide":   # a column no row before it had
        out["constraint:extra"] = -index - 0.5
    return out


@settings(max_examples=60, deadline=None)
@given(kinds=st.lists(st.sampled_from(["failed", "ok", "wide", "missing"]), min_size=0, max_size=25),
       seed=st.integers(0, 2**32 - 1))
def test_cases_csv_written_as_cases_finish_in_any_order_is_the_whole_table(tmp_path_factory, kinds, seed):
    folder = tmp_path_factory.mktemp("csv")
    cases = [_Case(i) for i in range(len(kinds))]
    rows = {c.id: _row(c.index, k) for c, k in zip(cases, kinds) if k != "missing"}
    done = {}
    writer = study_table.CsvWriter(folder, ["mC"], cases, lambda c: done.get(c.id))
    order = [c for c in cases if c.id in rows]
    random.Random(seed).shuffle(order)
    for c in order:                          # the cases come back in any order
        done[c.id] = rows[c.id]
        writer.advance()
    path = study_table.write_tables(folder, writer)[0]
    expected = [rows[c.id] for c in cases if c.id in rows]
    assert path.read_text() == reference_csv(expected, ["mC"])
    assert writer.rows == expected
    assert sorted(p.name for p in folder.iterdir()) == ["cases.csv", "cases.parquet"]   # no temporary left


def test_a_study_whose_first_cases_fail_writes_the_same_csv_serially_and_on_the_pool(tmp_path):
    """The cylinder's base at the pivot (e = 0: a dead centre) fails: those cases are failed rows
    (2 columns of results), the next ones bring the analysis's columns; the pool finishes them in
    its own order.  The last case is the first one again (the same id)."""
    scene = optdesign.load(ROOT / "problems" / "seed1_jib.toml")
    study = Study(scene, [values("e", [0.0, -0.0] + [1.0 + 0.1 * i for i in range(10)] + [0.0])], mode="analyse")
    serial = study.run(out=tmp_path / "serial", workers=1, figures=False)
    pool = study.run(out=tmp_path / "pool", workers=2, figures=False)
    assert [r["success"] for r in serial.rows] == [False, False] + [True] * 10 + [False]
    text = (tmp_path / "serial" / "cases.csv").read_text()
    assert text == reference_csv(serial.rows, ["e"])
    assert (tmp_path / "pool" / "cases.csv").read_text() == text
    assert pool.rows == serial.rows
    assert not list((tmp_path / "pool").glob(".*"))        # the partial file was moved in


# --- the journal, indexed ---------------------------------------------------------------------
def _record(i, width=40):
    return {"id": f"{i:016x}", "case": i, "row": {f"peak:q{k}": (i + 1) * 1.0000001 ** k for k in range(width)},
            "x": None, "time_s": 0.001}


def test_the_journal_reads_back_every_record_added_before_and_after_a_quarantine(tmp_path):
    records = [_record(i, 5) for i in range(50)]
    with Journal(tmp_path) as j:
        for r in records[:30]:
            j.add(r, durable=False)
        assert j.records[records[7]["id"]] == records[7]       # added, not yet synced: read back
    lines = (tmp_path / JOURNAL).read_bytes().splitlines(keepends=True)
    lines[3] = b"not json\n"                                   # quarantined at the next open
    (tmp_path / JOURNAL).write_bytes(b"".join(lines))
    with Journal(tmp_path) as j:
        assert len(j.records) == 29 and j.quarantined[0][0] == 4
        for r in records[30:]:
            j.add(r)
        kept = [r for i, r in enumerate(records) if i != 3]
        assert {k: j.records[k] for k in j.records} == {r["id"]: r for r in kept}   # offsets in the new file


def test_opening_a_journal_keeps_its_ids_not_its_records_in_memory(tmp_path):
    """The records stay in the file: opening a journal of 3,000 records of 40 numbers each
    (about 1.9 kB of JSON) takes less than 400 bytes per record (a record as a dict: ~4 kB)."""
    n = 3000
    (tmp_path / JOURNAL).write_text("".join(json.dumps(_record(i), separators=(",", ":")) + "\n" for i in range(n)))
    gc.collect()
    tracemalloc.start()
    try:
        with Journal(tmp_path) as j:
            held = tracemalloc.get_traced_memory()[0]
            assert len(j.records) == n and j.records[f"{n - 1:016x}"] == _record(n - 1)
    finally:
        tracemalloc.stop()
    assert held / n < 400, f"{held / n:.0f} bytes per record"


# --- the memory check ---------------------------------------------------------------------------
def test_the_memory_check_budgets_at_least_what_a_finished_study_costs_per_case(tmp_path):
    """A resumed analyse study of the truck crane, every case of it in the journal (its real row
    under each id): the peak of Python's allocations during the run, per case, is within the
    estimate the study's memory check uses (CASE_BYTES + COLUMN_BYTES per column)."""
    scene = optdesign.load(ROOT / "problems" / "truck_crane.toml")
    probe = Study(scene, [values("mP", [1000.0])], mode="analyse").run(out=tmp_path / "probe", workers=1, figures=False)
    row = json.loads((tmp_path / "probe" / JOURNAL).read_text().splitlines()[0])
    n = 1500
    study = Study(scene, [grid("mB", 500, 800, 10), grid("mP", 500, 3000, n // 10)], mode="analyse")
    folder = tmp_path / "study"
    folder.mkdir()
    with open(folder / JOURNAL, "w") as fh:
        for c in study.cases():
            fh.write(json.dumps({**row, "id": c.id, "case": c.index}, separators=(",", ":")) + "\n")
    gc.collect()
    tracemalloc.start()
    try:
        result = study.run(out=folder, workers=1, figures=False)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert result.reused == n and result.computed == 0 and len(probe.rows) == 1
    columns = len(result.rows[0])
    assert abs(study.columns_estimate() - columns) <= 3, (study.columns_estimate(), columns)
    budget = CASE_BYTES + COLUMN_BYTES * study.columns_estimate()
    assert peak / n <= budget, f"{peak / n:.0f} bytes per case measured, {budget} budgeted"
    assert peak / n >= budget / 3, f"{peak / n:.0f} bytes per case measured, {budget} budgeted: a check too lax"


# --- a case as a vector of parameter values -----------------------------------------------------------
@pytest.mark.parametrize("scene_file, mode, axis", [
    ("truck_crane.toml", "analyse", values("mP", [0.1 + 0.2 + 1000.0, 2999.999999999, 3.0e3 / 7.0])),
    ("seed1_jib_design.toml", "optimise", values("mC", [1e3 / 3.0])),
])
def test_a_case_given_as_leaf_values_gives_the_numbers_of_its_rebuilt_scene(scene_file, mode, axis):
    """One parameter axis (its points validated when the study is made): the case runs as the
    built model with a vector of leaf values; the same case through its rebuilt, validated scene
    gives the very same row and optimum."""
    import dataclasses

    from optdesign.study.tasks import run_task

    study = Study(optdesign.load(ROOT / "problems" / scene_file), [axis], mode=mode, starts=1)
    for case in study.cases():
        task = study.task(case)
        assert task.checked
        fast, rebuilt = run_task(task), run_task(dataclasses.replace(task, checked=False))
        assert fast["row"] == rebuilt["row"] and fast["x"] == rebuilt["x"]
        assert fast["row"]["success"]


def test_cases_of_two_axes_are_validated_as_scenes(tmp_path):
    """Two axes: a combination of points, each valid alone, is known valid together only where
    the scene's checks see the axes' parameters in affine expressions bounded by constants
    (study/validity.py); the truck crane's boom length L enters the boom's inertia as
    mB*L^2/12, so an axis over it leaves each combination to be checked as a scene."""
    scene = optdesign.load(ROOT / "problems" / "truck_crane.toml")
    study = Study(scene, [values("mB", [600.0]), values("L", [5.0, 6.0])], mode="analyse")
    assert not study.task(study.cases()[0]).checked
    study = Study(scene, [values("mB", [600.0, 700.0]), values("mP", [500.0, 3000.0])], mode="analyse")
    assert study.task(study.cases()[0]).checked
