"""Data loss, study journals: the lock comes before anything in the folder is touched (restart
included), a damaged line is quarantined with its line number and never costs a later record,
a journal that is not a readable file is a clear error.  Hypothesis damages journals at random."""
from __future__ import annotations

import fcntl
import json
import os

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import optdesign
from optdesign.errors import OptdesignError
from optdesign.study import Study, values
from optdesign.study import journal as journal_module
from optdesign.study.journal import JOURNAL, Journal, parse_record

from .util import JIB, ROOT_USER, cli


def record(i):
    return {"id": f"id{i:03d}", "case": i, "row": {"status": "ok", "success": True, "v": i + 0.1}, "x": [i, 1e-300],
            "time_s": 0.5}


def line(i):
    return json.dumps(record(i), separators=(",", ":")).encode() + b"\n"


def write_journal(folder, lines):
    folder.mkdir(parents=True, exist_ok=True)
    (folder / JOURNAL).write_bytes(b"".join(lines))


def quarantine_files(folder):
    return sorted(folder.glob("journal.corrupt-*.jsonl"))


@pytest.fixture(scope="module")
def jib():
    return optdesign.load(JIB)


def analyse_study(scene, n=6):
    return Study(scene, [values("mC", [300 + 50 * i for i in range(n)])], mode="analyse")


# --- the lock comes first ----------------------------------------------------------------------
def test_restart_is_refused_while_another_study_holds_the_folder_and_touches_nothing(tmp_path, jib):
    study = analyse_study(jib, 3)
    study.run(out=tmp_path, workers=1, figures=False)
    before = {p.name: (p.read_bytes(), p.stat().st_ino) for p in tmp_path.iterdir()}
    with Journal(tmp_path):               # a study running in this folder
        with pytest.raises(OptdesignError, match="another study is running in this folder"):
            study.run(out=tmp_path, workers=1, figures=False, restart=True)
    after = {p.name: (p.read_bytes(), p.stat().st_ino) for p in tmp_path.iterdir()}
    assert after == before                # same files, same bytes, same inodes: nothing deleted first


def test_restart_swaps_in_a_fresh_folder_keeps_other_files_and_the_new_journal_is_locked(tmp_path, jib):
    study = analyse_study(jib, 3)
    study.run(out=tmp_path, workers=1, figures=False)
    (tmp_path / "notes.txt").write_text("mine")
    old_inode = (tmp_path / JOURNAL).stat().st_ino
    with Journal(tmp_path, restart=True, produces=("cases.csv", "cases.parquet", "summary.txt", "study.json")) as j:
        assert j.records == {}
        assert sorted(p.name for p in tmp_path.iterdir()) == [JOURNAL, "notes.txt"]
        assert (tmp_path / JOURNAL).read_bytes() == b"" and (tmp_path / JOURNAL).stat().st_ino != old_inode
        assert (tmp_path / "notes.txt").read_text() == "mine"
        with pytest.raises(OptdesignError, match="another study is running"):
            Journal(tmp_path).__enter__()
    again = study.run(out=tmp_path, workers=1, figures=False, restart=True)
    assert (again.computed, again.reused) == (3, 0)


def test_the_lock_follows_a_journal_replaced_between_open_and_lock(tmp_path, monkeypatch):
    """A run that finishes just as another starts replaces the journal's file: the starter
    must lock the file the path names now, not the one it opened first."""
    write_journal(tmp_path, [line(0)])
    real_flock, swapped = fcntl.flock, []

    def flock(fh, op):
        if not swapped:               # another run replaces the journal between our open and our lock
            swapped.append(1)
            tmp = tmp_path / "new"
            tmp.write_bytes(line(0) + line(1))
            os.replace(tmp, tmp_path / JOURNAL)
        return real_flock(fh, op)

    monkeypatch.setattr(journal_module.fcntl, "flock", flock)
    with Journal(tmp_path) as j:
        assert set(j.records) == {"id000", "id001"}
        assert os.fstat(j._fh.fileno()).st_ino == (tmp_path / JOURNAL).stat().st_ino


# --- damaged lines ---------------------------------------------------------------------------------
@pytest.mark.parametrize("bad, why", [
    (b'{"id": "x", "row": {"v": 1.', "not JSON"),
    (b"[1, 2, 3]", "JSON list, not an object"),
    (b'"a string"', "JSON str, not an object"),
    (b"null", "JSON NoneType, not an object"),
    (b"42", "JSON int, not an object"),
    (b'{"case": 3, "row": {}}', 'no "id" string'),
    (b'{"id": 7, "row": {}}', 'no "id" string'),
    (b'{"id": "x"}', 'no "row" object'),
    (b'{"id": "x", "row": [1]}', 'no "row" object'),
    (b'{"id": "x", "row": {}, "x": "abc"}', '"x" is not a list of numbers'),
    (b'{"id": "x", "row": {}, "x": [true]}', '"x" is not a list of numbers'),
    (b"", "not JSON"),
    (b"\xff\xfe\x00garbage", "not JSON"),
    (b"[" * 100_000 + b"]" * 100_000, "not JSON"),
    (b"\x00" * 64, "not JSON"),
])
def test_a_damaged_line_in_the_middle_is_quarantined_and_later_records_are_kept(tmp_path, bad, why):
    lines = [line(i) for i in range(10)]
    lines[3] = bad + b"\n"                        # line 4 of 10
    write_journal(tmp_path, lines)
    with Journal(tmp_path) as j:
        assert sorted(j.records) == [f"id{i:03d}" for i in range(10) if i != 3]
        assert j.quarantined and j.quarantined[0][0] == 4
        assert "1 damaged line (4: " + why in j.notes[0] and "the 9 valid records are kept" in j.notes[0]
        j.add(record(3))
    assert (tmp_path / JOURNAL).read_bytes() == b"".join(line(i) for i in range(10) if i != 3) + line(3)
    [q] = quarantine_files(tmp_path)
    [entry] = [json.loads(x) for x in q.read_text().splitlines()]
    assert entry["line"] == 4 and entry["why"] == why
    assert entry["text"].encode("utf-8", "surrogateescape") == bad     # the exact bytes, recoverable
    with Journal(tmp_path) as j:                  # a clean journal now: nothing more to move
        assert len(j.records) == 10 and j.notes == [] and len(quarantine_files(tmp_path)) == 1


def test_a_carriage_return_inside_a_line_does_not_cut_the_journal(tmp_path):
    """bytes.splitlines() would split at \\r and take the rest for a torn last line."""
    lines = [line(i) for i in range(5)]
    lines[1] = b'{"id":"a\rb","row":{}}\n'       # raw CR: not valid JSON (control character in a string)
    write_journal(tmp_path, lines)
    with Journal(tmp_path) as j:
        assert sorted(j.records) == ["id000", "id002", "id003", "id004"]
        assert [n for n, _ in j.quarantined] == [2]


def test_several_damaged_lines_and_a_torn_tail(tmp_path):
    lines = [line(i) for i in range(8)]
    lines[0], lines[5] = b"oops\n", b"[]\n"
    write_journal(tmp_path, lines + [b'{"id":"id999","row":{"v":'])
    with Journal(tmp_path) as j:
        assert sorted(j.records) == [f"id{i:03d}" for i in (1, 2, 3, 4, 6, 7)]
        assert [n for n, _ in j.quarantined] == [1, 6]
        assert any("line 9" in n and "cut off" in n for n in j.notes)
    assert (tmp_path / JOURNAL).read_bytes() == b"".join(lines[i] for i in (1, 2, 3, 4, 6, 7))
    assert [json.loads(x)["line"] for x in quarantine_files(tmp_path)[0].read_text().splitlines()] == [1, 6]


def test_the_torn_last_line_alone_is_cut_as_before_and_nothing_is_quarantined(tmp_path):
    write_journal(tmp_path, [line(0), line(1), b'{"id": "c", "row": {"x": 1.'])
    with Journal(tmp_path) as j:
        assert set(j.records) == {"id000", "id001"} and j.quarantined == []
    assert (tmp_path / JOURNAL).read_bytes() == line(0) + line(1)
    assert quarantine_files(tmp_path) == []


def test_a_study_resumes_every_valid_record_after_a_damaged_line_and_says_so(tmp_path, jib):
    study = analyse_study(jib, 6)
    full = study.run(out=tmp_path, workers=1, figures=False)
    reference = (tmp_path / "cases.csv").read_bytes()
    lines = (tmp_path / JOURNAL).read_bytes().splitlines(keepends=True)
    lines[2] = b"[1, 2, 3]\n"                     # the third case's record is lost to damage
    (tmp_path / JOURNAL).write_bytes(b"".join(lines))
    again = study.run(out=tmp_path, workers=1, figures=False)
    assert (again.computed, again.reused) == (1, 5)        # only the damaged case is recomputed
    assert (tmp_path / "cases.csv").read_bytes() == reference
    assert again.rows == full.rows
    assert len(quarantine_files(tmp_path)) == 1
    summary = (tmp_path / "summary.txt").read_text()
    assert "damaged line (3: JSON list, not an object) moved to journal.corrupt-" in summary


def test_the_cli_reports_a_quarantined_line_on_stderr(tmp_path):
    out = tmp_path / "study"
    args = ["study", JIB, "--mode", "analyse", "--values", "mC=300,400,500", "--workers", "1", "--no-figures",
            "--out", out]
    assert cli(*args)[0] == 0
    lines = (out / JOURNAL).read_bytes().splitlines(keepends=True)
    (out / JOURNAL).write_bytes(lines[0] + b'{"no id": 1}\n' + b"".join(lines[1:]))
    code, stdout, stderr = cli(*args)
    assert code == 0, stderr
    assert 'journal: ' in stderr and 'damaged line (2: no "id" string) moved to journal.corrupt-' in stderr
    assert "0 computed, 3 taken from the journal" in stdout


# --- journals that are not readable files -------------------------------------------------------
def test_a_journal_that_is_a_folder_is_a_clear_error(tmp_path, jib):
    (tmp_path / JOURNAL).mkdir()
    with pytest.raises(OptdesignError, match=r"journal.jsonl: the study journal is a folder, not a file"):
        analyse_study(jib, 2).run(out=tmp_path, workers=1, figures=False)
    code, _, stderr = cli("study", JIB, "--mode", "analyse", "--values", "mC=300,400", "--workers", "1",
                          "--out", tmp_path)
    assert code == 2 and "the study journal is a folder, not a file" in stderr and "Traceback" not in stderr


def test_a_study_folder_that_is_a_file_is_a_clear_error(tmp_path, jib):
    (tmp_path / "f").write_text("x")
    with pytest.raises(OptdesignError, match="is a file, not a folder"):
        analyse_study(jib, 2).run(out=tmp_path / "f", workers=1, figures=False)
    with pytest.raises(OptdesignError, match="is a file, not a folder"):
        analyse_study(jib, 2).run(out=tmp_path / "f" / "below", workers=1, figures=False)
    assert (tmp_path / "f").read_text() == "x"


@pytest.mark.skipif(ROOT_USER, reason="root reads every file")
def test_an_unreadable_journal_is_a_clear_error(tmp_path, jib):
    write_journal(tmp_path, [line(0)])
    (tmp_path / JOURNAL).chmod(0o200)
    with pytest.raises(OptdesignError, match="cannot open the study journal"):
        analyse_study(jib, 2).run(out=tmp_path, workers=1, figures=False)


def test_parse_record_accepts_what_the_study_writes():
    assert parse_record(line(3).rstrip(b"\n")) == (record(3), None)
    assert parse_record(b'{"id":"a","row":{},"x":null}')[0] == {"id": "a", "row": {}, "x": None}


# --- random damage (hypothesis) ---------------------------------------------------------------------
damage = st.lists(st.tuples(st.sampled_from(["replace", "insert", "flip", "truncate_tail", "join", "drop_newline"]),
                            st.integers(0, 11), st.binary(max_size=40)), min_size=1, max_size=5)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(damage=damage)
def test_random_damage_never_costs_an_intact_record(tmp_path_factory, damage):
    """Whatever happens to some lines, every line that is still an intact record ending in a
    newline is kept, every other complete line is quarantined with its line number and exact
    bytes, the journal afterwards holds exactly the kept lines, and it appends normally."""
    folder = tmp_path_factory.mktemp("j")
    lines = [line(i) for i in range(12)]
    for op, i, blob in damage:
        i %= len(lines) if lines else 1
        if op == "replace" and lines:
            lines[i] = blob.replace(b"\n", b"") + b"\n"
        elif op == "insert":
            lines.insert(i, blob.replace(b"\n", b"") + b"\n")
        elif op == "flip" and lines and len(lines[i]) > 1:
            j = len(blob) % (len(lines[i]) - 1)
            lines[i] = lines[i][:j] + bytes([lines[i][j] ^ 0x55]).replace(b"\n", b"?") + lines[i][j + 1:]
        elif op == "join" and i + 1 < len(lines):
            lines[i:i + 2] = [lines[i].rstrip(b"\n") + lines[i + 1]]
        elif op == "drop_newline" and lines and i == len(lines) - 1:
            lines[i] = lines[i].rstrip(b"\n")
    if damage[0][0] == "truncate_tail" and lines:
        lines[-1] = lines[-1][: max(1, len(lines[-1]) // 2)].rstrip(b"\n")
    data = b"".join(lines)
    write_journal(folder, [data])
    pieces = data.split(b"\n")
    complete, tail = pieces[:-1], pieces[-1]
    expect_good = [p for p in complete if parse_record(p)[0] is not None]
    expect_bad = [(n, p) for n, p in enumerate(complete, 1) if parse_record(p)[0] is None]
    intact = {json.dumps(record(i), separators=(",", ":")).encode() for i in range(12)}
    with Journal(folder) as j:
        for p in complete:
            if p in intact:                                # an untouched record: always kept
                assert json.loads(p)["id"] in j.records
        assert [n for n, _ in j.quarantined] == [n for n, _ in expect_bad]
        j.add(record(99))
    assert (folder / JOURNAL).read_bytes() == b"".join(p + b"\n" for p in expect_good) + line(99)
    quarantined = [json.loads(x) for q in quarantine_files(folder) for x in q.read_text().splitlines()]
    assert [(e["line"], e["text"].encode("utf-8", "surrogateescape")) for e in quarantined] == expect_bad
    assert bool(tail) == any("cut off" in n for n in j.notes)
