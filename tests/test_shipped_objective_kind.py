"""Every shipped optimisation result (results/*/result.json with summary.txt and report.html)
states its objective's kind as the code does (report/units.KIND_TEXT): a certified peak, or an
integral that is not certified (issue 29: an RMS objective was called "certified"; the shipped
results/crank_press_rms said so after the code no longer did)."""
from __future__ import annotations

import html
import json
import re
from pathlib import Path
from types import SimpleNamespace

import pytest

import optdesign
from optdesign.report.units import KIND_TEXT, objective_kind_text

RESULTS = Path(__file__).resolve().parents[1] / "results"
FOLDERS = sorted(p.parent for p in RESULTS.glob("*/result.json")
                 if (p.parent / "summary.txt").is_file() and "objective_kind" in json.loads(p.read_text())
                 and json.loads(p.read_text()).get("objective") is not None)   # (an optimum to speak of)


def test_there_are_shipped_results():
    assert len(FOLDERS) >= 10


@pytest.mark.parametrize("folder", FOLDERS, ids=[f.name for f in FOLDERS])
def test_summary_and_page_call_the_objective_certified_only_where_the_code_does(folder):
    """The objective's line of summary.txt and the best optimum's sentence of report.html say
    "certified over the continuous stroke" exactly where the code's text for its kind does (the
    wording of the other kinds may change; a claim of certification may not appear or vanish)."""
    doc = json.loads((folder / "result.json").read_text())
    scene = optdesign.load(RESULTS.parent / "problems" / f"{folder.name}.toml")
    kind = objective_kind_text(SimpleNamespace(objective_kind=doc["objective_kind"], scene=scene))
    claim = "certified over the continuous stroke"
    line = next(x for x in (folder / "summary.txt").read_text().splitlines() if x.startswith("objective = "))
    assert line.startswith(f"objective = {doc['objective']:.9g} (")
    assert (claim in line) == (claim in kind), line
    page = html.unescape((folder / "report.html").read_text())
    sentence = re.search(r"Best optimum [^<]*reached by", page).group(0)
    assert (claim in sentence) == (claim in kind), sentence


def test_an_expression_of_stroke_extremes_is_not_called_a_value_without_stroke():
    """max(y(T)) - min(y(T)) (problems/level_luffing_path.toml): each extreme is checked over the
    continuous stroke to the objective's tolerance; it read "a value of the design, no stroke in
    it".  An expression of stroke-end values has no extreme in it."""
    scene = optdesign.load(RESULTS.parent / "problems" / "level_luffing_path.toml")
    assert scene.objective.minimise == "max(y(T)) - min(y(T))"
    text = objective_kind_text(SimpleNamespace(objective_kind="expression", scene=scene))
    assert text == KIND_TEXT["extremes"] and "certified over the continuous stroke" in text
    ends = SimpleNamespace(objective_kind="expression", scene=SimpleNamespace(
        objective=SimpleNamespace(minimise="end(y(T)) - start(y(T))")))
    assert objective_kind_text(ends) == KIND_TEXT["expression"]
