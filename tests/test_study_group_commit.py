"""Group commit: the journal's cases share fsyncs, and a case is reported finished (the progress
callback) only once its line is durable: at every report, the last fsync of the journal covered
at least that many lines.  Checked in this process and on the pool (the
commit is the scheduling loop's, whatever runs the cases)."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

import optdesign
from optdesign.study import Study, values

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("where", ["inline", "pool"])
def test_every_reported_case_was_fsynced_first(tmp_path, monkeypatch, where):
    n = 60
    study = Study(optdesign.load(ROOT / "problems" / "seed1_jib.toml"),
                  [values("mC", [100.0 + 5 * i for i in range(n)])], mode="analyse")
    journal = tmp_path / "journal.jsonl"
    synced = [0]          # lines of the journal at its last fsync
    real = os.fsync

    def fsync(fd):
        real(fd)
        try:
            if os.path.samefile(f"/proc/self/fd/{fd}", journal):
                synced[0] = journal.read_bytes().count(b"\n")
        except OSError:
            pass

    monkeypatch.setattr(os, "fsync", fsync)
    reports = []

    def progress(done, total):
        reports.append((done, synced[0]))

    result = study.run(out=tmp_path, progress=progress, figures=False, workers=1 if where == "inline" else 2)
    assert result.complete and result.computed == n
    assert reports[-1][0] == n
    assert all(done <= lines for done, lines in reports), reports   # reported => durable
    assert len(journal.read_text().splitlines()) == n
