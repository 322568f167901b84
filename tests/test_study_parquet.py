"""cases.parquet (issue 31): a study's rows streamed to Parquet beside cases.csv, in row groups as
the rows are written, in case order.  Read back with pyarrow, it holds cases.csv's every cell
(a missing value as null, the empty cell), whatever order the cases finished in and however the
columns grew; without pyarrow the study writes cases.csv and says why there is no Parquet file."""
from __future__ import annotations

import csv
import io
import random
import sys
from pathlib import Path
from unittest import mock

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import optdesign
from optdesign.study import Study, values
from optdesign.study import parquet as study_parquet
from optdesign.study import table as study_table

pq = pytest.importorskip("pyarrow.parquet")
ROOT = Path(__file__).resolve().parents[1]


def parquet_as_csv(path) -> str:
    """cases.parquet read back by pyarrow and written out with cases.csv's cells."""
    table = pq.read_table(path)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(table.column_names)
    for row in table.to_pylist():
        w.writerow([study_table.cell(row[k]) for k in table.column_names])
    return buf.getvalue()


def csv_text(path) -> str:
    """cases.csv as written (newline="": a "\\r" in a cell kept)."""
    with open(path, newline="") as fh:
        return fh.read()


class _Case:
    def __init__(self, index):
        self.index, self.id = index, f"c{index}"


VALUE = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-2**70, 2**70), st.booleans(), st.none(),
                  st.text(max_size=5))


def _row(index, kind, extra):
    base = {"case": index, "id": f"c{index}", "chain": index, "link": 0, "mC": 100.0 + index}
    if kind == "failed":
        return {**base, "status": "error: \"quoted\", a comma", "success": False}
    out = {**base, "status": "ok", "success": True, "peak:drive": 1e4 / (index + 1), "iterations": index}
    if kind == "wide":   # a column no row before it had, of any type
        out["constraint:extra"] = extra
    return out


@settings(max_examples=40, deadline=None)
@given(kinds=st.lists(st.tuples(st.sampled_from(["failed", "ok", "wide", "missing"]), VALUE), max_size=25),
       seed=st.integers(0, 2**32 - 1), group=st.integers(1, 4))
def test_cases_parquet_holds_the_cells_of_cases_csv_in_any_finish_order(tmp_path_factory, kinds, seed, group):
    folder = tmp_path_factory.mktemp("pq")
    cases = [_Case(i) for i in range(len(kinds))]
    rows = {c.id: _row(c.index, k, x) for c, (k, x) in zip(cases, kinds) if k != "missing"}
    done = {}
    with mock.patch.object(study_parquet, "GROUP", group):
        writer = study_table.CsvWriter(folder, ["mC"], cases, lambda c: done.get(c.id))
        order = [c for c in cases if c.id in rows]
        random.Random(seed).shuffle(order)
        for c in order:
            done[c.id] = rows[c.id]
            writer.advance()
        paths = study_table.write_tables(folder, writer)
    assert [p.name for p in paths] == ["cases.csv", "cases.parquet"] and writer.parquet.note is None
    assert parquet_as_csv(paths[1]) == csv_text(paths[0])
    groups = pq.ParquetFile(paths[1]).metadata.num_row_groups
    assert groups >= min(len(rows), 1) and (len(rows) <= group or groups > 1)
    assert sorted(p.name for p in folder.iterdir()) == ["cases.csv", "cases.parquet"]


def test_a_study_writes_cases_parquet_beside_cases_csv_serially_and_on_the_pool(tmp_path):
    """The jib's cylinder base at the pivot (e = 0: a dead centre): the first cases fail (no
    analysis columns), the later ones bring them (the Parquet file widened); serial and pool give
    the same table, and the Parquet file reads back as cases.csv."""
    scene = optdesign.load(ROOT / "problems" / "seed1_jib.toml")
    study = Study(scene, [values("e", [0.0, -0.0, 1.0, 1.1, 1.2, 1.3, 0.0])], mode="analyse")
    with mock.patch.object(study_parquet, "GROUP", 2):
        serial = study.run(out=tmp_path / "serial", workers=1, figures=False)
        pool = study.run(out=tmp_path / "pool", workers=2, figures=False)
    for result in (serial, pool):
        assert (result.folder / "cases.parquet") in result.paths and not result.notes
        assert parquet_as_csv(result.folder / "cases.parquet") == csv_text(result.folder / "cases.csv")
    assert pq.read_table(serial.folder / "cases.parquet").equals(pq.read_table(pool.folder / "cases.parquet"))
    assert [r["success"] for r in pq.read_table(serial.folder / "cases.parquet").to_pylist()] == \
        [r["success"] for r in serial.rows]


def test_without_pyarrow_a_study_writes_cases_csv_and_says_why_there_is_no_parquet(tmp_path, monkeypatch):
    for name in [m for m in sys.modules if m == "pyarrow" or m.startswith("pyarrow.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "pyarrow", None)   # import pyarrow raises ImportError
    scene = optdesign.load(ROOT / "problems" / "seed1_jib.toml")
    result = Study(scene, [values("mC", [300.0, 400.0])], mode="analyse").run(out=tmp_path, workers=1, figures=False)
    assert result.complete and not (tmp_path / "cases.parquet").exists()
    assert result.notes == (study_parquet.MISSING_NOTE,)
    assert study_parquet.MISSING_NOTE in (tmp_path / "summary.txt").read_text()
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == []
