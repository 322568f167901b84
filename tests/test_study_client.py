"""The study's client at scale (issue 31): cases listed lazily with the ids of json.dumps, the
journal's lines made a batch at a time equal to json.dumps's, cases.csv and cases.parquet
streamed equal to the rows, a resumed study parsing each journal record once, a reported case
never lost to a kill, a bounded window of batches in flight, and a large axis validated without
a scene per point."""
from __future__ import annotations

import concurrent.futures as cf
import csv
import hashlib
import io
import json
import math
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import optdesign
from optdesign.study import Study, grid, pareto, together, values
from optdesign.study import execute as study_execute
from optdesign.study import table as study_table
from optdesign.study.blocks import Block, blocks
from optdesign.study.executors import _Futures, _Inline
from optdesign.study.journal import JOURNAL
from optdesign.study.rows import Rows, cell
from optdesign.study.tasks import case_scene

ROOT = Path(__file__).resolve().parents[1]
JIB, JIB_DESIGN, CRANE = (ROOT / "problems" / f for f in ("seed1_jib.toml", "seed1_jib_design.toml", "truck_crane.toml"))


# --- ids ---------------------------------------------------------------------------------------------
def reference_ids(study) -> list:
    """The ids as the study computed them before the lazy case list: json.dumps of each case's
    content, keys sorted, hashed."""
    from optdesign.study.tasks import scene_digest

    axes, out, prev = study.axes, [], None
    chained = study.warm and study.mode == "optimise"
    sizes = [len(a) for a in axes]
    total = math.prod(sizes)
    for index in range(total):
        idx, rest = [], index
        for n in reversed(sizes):
            idx.append(rest % n)
            rest //= n
        idx.reverse()
        link = (idx[-1] if sizes else 0) % study.chain if chained else 0
        if link == 0:
            prev = None
        overrides, bounds = [], []
        for axis, i in zip(axes, idx):
            for pair in axis.points[i]:
                (bounds.append((axis.constraint, axis.side, pair[1])) if axis.kind == "pareto" else overrides.append(pair))
        content = {"scene": scene_digest(study.scene), "mode": study.mode, "overrides": overrides, "bounds": bounds,
                   "run": study._run_settings(), "prev": prev}
        cid = hashlib.sha256(json.dumps(content, sort_keys=True).encode()).hexdigest()[:16]
        out.append(cid)
        prev = cid if chained else None
    return out


@pytest.mark.parametrize("axes, kw", [
    ([values("mC", [300, 500]), grid("l", 3.5, 4.5, 7)], {"chain": 2}),
    ([values("mC", [300, 500]), grid("l", 3.5, 4.5, 7)], {"warm": False}),
    ([pareto("cylinder stroke", [1.0, 1.2, 1.4]), together([{"mC": 400, "l": 4}, {"mC": 450, "l": 4.2}])], {"chain": 2}),
    ([], {}),
])
def test_the_lazy_case_list_has_the_ids_chains_and_contents_of_json_dumps(axes, kw):
    study = Study(optdesign.load(JIB_DESIGN), axes, **kw)
    cases = study.cases()
    assert [c.id for c in cases] == reference_ids(study)
    assert [cases.id(i) for i in range(len(cases))] == reference_ids(study)
    chains = list(cases.chains())
    assert [c.index for c in cases] == [i for ch in chains for i in ch]
    assert [(c.chain, c.link) for c in cases] == [(k, j) for k, ch in enumerate(chains) for j in range(len(ch))]
    assert cases.n_chains == len(chains)


# --- the journal's lines and cases.csv's cells, a block at a time ----------------------------------
_values = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.booleans(), st.none(),
                    st.integers(-2**70, 2**70), st.text(max_size=8), st.sampled_from(["ok", 'a "b", c', "é\n"]))


@settings(max_examples=40, deadline=None)
@given(data=st.data(), n=st.integers(1, 9))
def test_a_blocks_journal_lines_and_csv_cells_are_json_dumps_and_the_csv_modules(data, n):
    keys = data.draw(st.lists(st.text(min_size=1, max_size=6), min_size=1, max_size=5, unique=True))
    kind = data.draw(st.sampled_from(["float", "mixed", "repeated"]))
    # repeated: a column of few distinct floats (their texts made once each), 0.0 and -0.0 among them or not
    pool = data.draw(st.sampled_from([[1.5, math.nan, 1e16, -2.5e-300, math.inf], [0.0, -0.0, 7.25], [-0.0, 3.0]]))
    draw = {"float": lambda: data.draw(st.floats(allow_nan=True, allow_infinity=True)), "mixed": lambda: data.draw(_values),
            "repeated": lambda: data.draw(st.sampled_from(pool))}[kind]
    rows = [{k: draw() for k in keys} for _ in range(n)]
    outs = [{"row": r, "x": data.draw(st.none() | st.lists(st.floats(-1e3, 1e3), max_size=3)),
             "time_s": data.draw(st.floats(0, 10))} for r in rows]
    ids = [f"{random.getrandbits(64):016x}" for _ in range(n)]
    [block] = blocks(list(range(n)), ids, outs)
    expected = [json.dumps({"id": i, "case": j, "row": o["row"], "x": o["x"], "time_s": o["time_s"]},
                           separators=(",", ":")) + "\n" for j, (i, o) in enumerate(zip(ids, outs))]
    assert block.lines() == expected
    for k in keys:
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        for r in rows:
            w.writerow([cell(r[k]), ""])
        assert "".join(c + ",\n" for c in block.cells(k)) == buf.getvalue()


@settings(max_examples=40, deadline=None)
@given(rows=st.lists(st.dictionaries(st.sampled_from(["a", "b", "c", "d"]), _values, min_size=1), max_size=20))
def test_rows_extended_column_by_column_equal_rows_appended_one_by_one(rows):
    one, many = Rows(), Rows()
    for r in rows:
        one.append(r)
    start = 0
    while start < len(rows):   # runs of rows with the same keys, as blocks bring them
        end = start + 1
        while end < len(rows) and tuple(rows[end]) == tuple(rows[start]):
            end += 1
        keys = tuple(rows[start])
        many.extend(keys, [[r[k] for r in rows[start:end]] for k in keys])
        start = end
    assert repr(list(many)) == repr(list(one)) == repr(rows)   # (repr: nan, and 1 against 1.0 against True)
    for k in ("a", "b", "c", "d"):
        assert repr(many.values(k)) == repr(one.values(k))


# --- a study through a stand-in executor -----------------------------------------------------------
def synthetic_row(index) -> dict:
    """A row per case: failed ones (two columns), ones with a column no row before had, nan,
    inf, text that needs quoting."""
    r = random.Random(index)
    kind = r.choice(["ok", "ok", "ok", "failed", "wide"])
    if kind == "failed":
        return {"status": 'error: "no", it, does not assemble', "success": False}
    row = {"status": "ok", "success": True, "peak:drive": r.choice([r.uniform(-1e5, 1e5), math.nan, math.inf]),
           "rms:drive": r.random(), "smallest_motor": r.choice(["M1", "none", "a,b"])}
    if kind == "wide":
        row["constraint:extra"] = float(index)
    return row


class StandIn(_Inline):
    """Answers batches of random sizes with synthetic rows, the batches in a shuffled order."""

    def __init__(self, seed):
        super().__init__()
        self.random = random.Random(seed)

    def batch_size(self, remaining):
        return self.random.randint(1, 40)

    def room(self):
        return len(self.queue) < 6

    def ready(self):
        return bool(self.queue)

    def results(self):
        while self.queue:
            cases, tasks = self.queue.pop(self.random.randrange(len(self.queue)))
            yield cases, [{"row": synthetic_row(c.index), "x": None, "time_s": 0.001} for c in cases]


def run_stand_in(monkeypatch, study, folder, seed):
    monkeypatch.setattr(study_execute, "_executor", lambda workers, scheduler, n: StandIn(seed))
    return study.run(out=folder, workers=1, figures=False)


def reference_table(study):
    rows = [study_execute.merged_row(c, synthetic_row(c.index)) for c in study.cases()]
    cols = study_table.columns(study.input_columns, rows)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(cols)
    for r in rows:
        w.writerow([cell(r.get(k)) for k in cols])
    return rows, buf.getvalue()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cases_csv_and_parquet_streamed_in_blocks_equal_the_rows_written_whole(tmp_path, monkeypatch, seed):
    study = Study(optdesign.load(JIB), [values("mC", [100.0 + i for i in range(7)]), grid("l", 3.5, 4.5, 23)],
                  mode="analyse")
    result = run_stand_in(monkeypatch, study, tmp_path, seed)
    rows, text = reference_table(study)
    assert result.complete and repr(list(result.rows)) == repr(rows)   # (repr: nan)
    assert (tmp_path / "cases.csv").read_text() == text
    pq = pytest.importorskip("pyarrow.parquet")
    table = pq.read_table(tmp_path / "cases.parquet")
    lines = list(csv.reader(io.StringIO(text)))
    assert table.column_names == lines[0]
    for j, name in enumerate(lines[0]):
        assert [cell(v) for v in table.column(name).to_pylist()] == [r[j] for r in lines[1:]]


def test_a_resumed_study_parses_each_journal_record_once(tmp_path, monkeypatch):
    """The journal's records, read when the study resumes, go to cases.csv as they are read:
    json.loads once per record (it was twice: at the open, then for the row)."""
    study = Study(optdesign.load(JIB), [values("mC", [100.0 + i for i in range(5)]), grid("l", 3.5, 4.5, 40)],
                  mode="analyse")
    run_stand_in(monkeypatch, study, tmp_path, 3)
    first = (tmp_path / "cases.csv").read_text()
    from optdesign.study import journal as study_journal

    calls = []

    class CountingJson:
        def __getattr__(self, name):
            return getattr(json, name)

        @staticmethod
        def loads(text):
            calls.append(1)
            return json.loads(text)

    monkeypatch.setattr(study_journal, "json", CountingJson())
    result = study.run(out=tmp_path, workers=1, figures=False)
    assert result.reused == 200 and result.computed == 0
    assert len(calls) == 200
    assert (tmp_path / "cases.csv").read_text() == first


# --- a reported case is never lost -------------------------------------------------------------------
KILLED = """
import sys, time
import optdesign
from optdesign.study import Study, grid, execute
from optdesign.study.executors import _Inline
study = Study(optdesign.load(sys.argv[1]), [grid("mC", 100, 900, 100000)], mode="analyse")
row = {"status": "ok", "success": True, "peak:drive": 1.5}

class Slow(_Inline):
    def batch_size(self, remaining):
        return 64
    def results(self):
        while self.queue:
            cases, tasks = self.queue.pop(0)
            time.sleep(0.002)
            yield cases, [{"row": dict(row, n=c.index), "x": None, "time_s": 0.001} for c in cases]

execute._executor = lambda workers, scheduler, n: Slow()
def progress(done, total):
    print(done, flush=True)
study.run(out=sys.argv[2], workers=1, figures=False, progress=progress)
"""


@pytest.mark.slow
def test_a_client_killed_mid_batch_keeps_every_case_it_reported(tmp_path):
    """SIGKILL the client while batches are journalled and committed in the background: the
    journal, reopened, holds every case the client had reported finished (and no damaged line
    but a torn last one)."""
    folder = tmp_path / "s"
    proc = subprocess.Popen([sys.executable, "-c", KILLED, str(JIB), str(folder)], stdout=subprocess.PIPE,
                            text=True, cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)})
    reported = 0
    for line in proc.stdout:
        reported = int(line)
        if reported >= 3000:
            break
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    from optdesign.study.journal import Journal

    with Journal(folder) as journal:
        assert len(journal.records) >= reported > 0
        assert all(not note or "torn" in note or "cut off" in note for note in journal.notes), journal.notes
        rows = [journal.records[k]["row"]["n"] for k in journal.records]
    assert sorted(rows) == list(range(len(rows)))   # in order, none missing before the last


# --- the window of batches in flight --------------------------------------------------------------------
class Threads(_Futures):
    """_Futures (the pool's and Dask's window and queue) over a thread pool, counting the batches
    in flight."""

    def __init__(self, window):
        super().__init__()
        self.window, self.pool, self.most = window, cf.ThreadPoolExecutor(2), 0

    def _submit(self, batch):
        self.most = max(self.most, len(self.pending) + 1)
        row = {"status": "ok", "success": True}
        return self.pool.submit(lambda: [{"row": dict(row), "x": None, "time_s": 1e-4} for _ in batch.cases])

    @staticmethod
    def _wait_first(futures):
        return cf.wait(futures, return_when=cf.FIRST_COMPLETED).done

    def describe(self):
        return "threads"

    def close(self):
        self.pool.shutdown()


def test_the_scheduling_loop_keeps_at_most_the_window_in_flight(tmp_path, monkeypatch):
    executor = Threads(window=3)
    monkeypatch.setattr(study_execute, "_executor", lambda workers, scheduler, n: executor)
    study = Study(optdesign.load(JIB), [grid("mC", 100, 900, 600)], mode="analyse")
    result = study.run(out=tmp_path, workers=2, figures=False)
    assert result.computed == 600 and result.complete
    assert executor.most == 3


def test_dask_takes_analyse_batches_of_its_own_seconds_of_work_with_the_pools_tail():
    """An analyse batch is the executor's ``analyse_s`` seconds of work (Dask: 1 s, a task costing
    milliseconds of CPU in the client, the scheduler and the worker, while larger batches cost
    the helpers more per case; the pool: GROUP_S, 0.5 s), and near the end both come down to the
    window's share of what is left, not below a quarter of GROUP_S.  1 ms per case in the last
    batches; a window of 4 batches."""
    from optdesign.study.executors import _Dask, _Pool

    size = study_execute._group_size
    pool = type("PoolLike", (), {"window": 4})()
    dask = type("DaskLike", (), {"window": 4, "analyse_s": _Dask.analyse_s})()
    assert _Dask.analyse_s == 1.0 and not hasattr(_Pool, "analyse_s") and study_execute.GROUP_S == 0.5
    work = [0.001, 0.001, 0.001]
    assert [size(pool, work, left) for left in (100_000, 1_000, 400, 10)] == [500, 250, 125, 125]
    assert [size(dask, work, left) for left in (100_000, 6_000, 3_000, 1_000, 400, 10)] == [1000, 1000, 750, 250, 125,
                                                                                             125]
    assert size(dask, [], 100_000) == size(pool, [], 100_000) == study_execute.GROUP_FIRST


# --- validation of large axes ---------------------------------------------------------------------------
def count_checks(monkeypatch):
    from optdesign.scene import validate

    calls, real = [], validate.Validator.run

    def run(self):
        calls.append(1)
        return real(self)

    monkeypatch.setattr(validate.Validator, "run", run)
    return calls


def test_a_large_axis_is_validated_at_its_corners_not_a_scene_per_point(monkeypatch):
    scene = optdesign.load(CRANE)
    calls = count_checks(monkeypatch)
    study = Study(scene, [grid("mB", 500, 800, 10), grid("mP", 500, 3000, 5000)], mode="analyse")
    assert len(calls) <= 12   # one recorded check and four corners (each a scene without bounds, then with values)
    assert study.task(study.cases()[12345]).checked
    with pytest.raises(optdesign.OptdesignError, match="mass >= 0"):   # a corner outside: found
        Study(scene, [grid("mB", 500, 800, 10), grid("mP", -3000, 3000, 5000)], mode="analyse")
    calls.clear()
    # the boom length enters the boom's inertia as mB*L^2/12: each point of its axis is a scene
    Study(scene, [grid("L", 5.0, 7.0, 30), grid("mP", 500, 3000, 50)], mode="analyse")
    assert len(calls) >= 2 * 80


def test_study_json_streams_the_rows_and_prints_what_to_json_of_all_rows_gave(tmp_path, monkeypatch, capsys):
    """`optdesign study --json` writes its rows a few hundred at a time (json_chunks over a lazy
    list), the very text to_json of the whole list gave."""
    from optdesign.cli.main import main
    from optdesign.report.output import to_json

    monkeypatch.setattr(study_execute, "_executor", lambda workers, scheduler, n: StandIn(5))
    made = []
    real = Rows.__getitem__

    def getitem(self, i):
        made.append(i)
        return real(self, i)

    monkeypatch.setattr(Rows, "__getitem__", getitem)
    out = tmp_path / "s"
    assert main(["study", str(JIB), "--mode", "analyse", "--grid", "mC=100:900:1200", "--workers", "1",
                 "--no-figures", "--json", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    got = json.loads(text)
    assert len(got["rows"]) == 1200 and made[-1200:] == list(range(1200))   # one row at a time, each once
    monkeypatch.setattr(Rows, "__getitem__", real)
    rows = [study_execute.merged_row(c, synthetic_row(c.index))
            for c in Study(optdesign.load(JIB), [grid("mC", 100, 900, 1200)], mode="analyse").cases()]
    assert text == to_json({**{k: got[k] for k in got if k != "rows"}, "rows": rows}) + "\n"


def test_an_axis_in_a_check_that_is_not_a_bound_leaves_every_case_checked_as_a_scene(tmp_path):
    """The drive's speed is checked against 0 where its efficiency is below 1 (not a bound by
    constants: the speeds that pass are not an interval): an axis over it, beside one over the
    efficiency, leaves every case to be checked as a scene, and the corners of the two axes
    (speeds -0.08 and 0.08) would all pass while the speed 0 between them does not."""
    text = (CRANE.read_text().replace("speed = 0.08", 'speed = "v"').replace("efficiency = 0.9", 'efficiency = "eta"')
            .replace("[parameters]\n", "[parameters]\nv = 0.08\neta = 1.0\n"))
    path = tmp_path / "crane.toml"
    path.write_text(text)
    scene = optdesign.load(path)
    study = Study(scene, [values("eta", [1.0, 0.9]), values("v", [-0.08, 0.0, 0.08])], mode="analyse")
    assert not study.task(study.cases()[4]).checked   # eta 0.9, v 0: not a valid scene
    with pytest.raises(optdesign.OptdesignError, match="efficiency 0.9 < 1 needs the direction of power flow"):
        case_scene(scene, "analyse", dict(study.cases()[4].overrides))
