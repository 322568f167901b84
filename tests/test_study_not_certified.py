"""An analyse study's row says which of its case's figures are not certified (poolmass's finding,
issue 31: the bounds and notes were dropped, so a case whose enclosure did not close looked, in
cases.csv, like a certified one).

The scene: seed1_slider_crank with a constraint -sqrt((alpha - 1.005) (alpha - 1.010)), undefined
for alpha in (1.005, 1.010), between two samples: its extremes are never certified
(tests/test_undefined_between_samples.py).  The reference is the function's domain itself, worked
out here: the hole lies inside the stroke for every crank radius and force, so every case's row
must name the constraint's min and max as not certified, and only them; the same study without
the constraint has no such column at all (cases.csv stays as it was)."""
from __future__ import annotations

import csv
from pathlib import Path

import pytest

import optdesign
from optdesign.study import Study, grid

ROOT = Path(__file__).resolve().parents[1]
HOLE = '''
[[constraints]]
name = "hole"
expr = "-sqrt((alpha - 1.005)*(alpha - 1.010))"
max = 1
'''


def _scene(hole: bool):
    text = (ROOT / "problems" / "seed1_slider_crank.toml").read_text() + (HOLE if hole else "")
    return optdesign.loads(text, "hole.toml" if hole else "crank.toml")


@pytest.mark.parametrize("workers", [1, 2])
def test_an_analyse_studys_rows_name_the_figures_that_are_not_certified(tmp_path, workers):
    study = Study(_scene(True), [grid("FC", 1000.0, 3000.0, 3), grid("mC", 8.0, 16.0, 2)], mode="analyse")
    result = study.run(out=tmp_path / "hole", workers=workers, figures=False)
    assert result.complete and len(result.rows) == 6
    with open(tmp_path / "hole" / "cases.csv", newline="") as fh:
        table = list(csv.DictReader(fh))
    for row, written in zip(result.rows, table):
        assert row["status"] == "ok" and row["success"]
        why = row["not_certified"]
        named = sorted(part.split(":", 1)[0] for part in why.split("; "))
        assert named == ["hole max", "hole min"], why
        assert all(part.split(": ", 1)[1].startswith("not certified") for part in why.split("; ")), why
        assert written["not_certified"] == why
    # the same case analysed alone says the same
    alone = optdesign.analyse(_scene(True))
    assert {k for k, c in alone.certificates.items() if c["note"]} == {"hole max", "hole min"}


def test_a_study_whose_figures_are_all_certified_has_no_not_certified_column(tmp_path):
    study = Study(_scene(False), [grid("FC", 1000.0, 3000.0, 3)], mode="analyse")
    result = study.run(out=tmp_path / "crank", workers=1, figures=False)
    assert result.complete and all("not_certified" not in row for row in result.rows)
    header = (tmp_path / "crank" / "cases.csv").read_text().splitlines()[0].split(",")
    assert "not_certified" not in header and "peak:drive" in header
