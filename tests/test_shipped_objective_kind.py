"""Every shipped optimisation result (results/*/result.json with summary.txt and report.html)
states its objective's kind as the code does (report/units.KIND_TEXT): a certified peak, or an
integral that is not certified (issue 29: an RMS objective was called "certified"; the shipped
results/crank_press_rms said so after the code no longer did)."""
from __future__ import annotations

import html
import json
from pathlib import Path
from types import SimpleNamespace

import pytest

import optdesign
from optdesign.report.units import KIND_TEXT, objective_kind_text

RESULTS = Path(__file__).resolve().parents[1] / "results"
FOLDERS = sorted(p.parent for p in RESULTS.glob("*/result.json")
                 if (p.parent / "summary.txt").is_file() and "objective_kind" in json.loads(p.read_text()))


def test_there_are_shipped_results():
    assert len(FOLDERS) >= 10


@pytest.mark.parametrize("folder", FOLDERS, ids=[f.name for f in FOLDERS])
def test_summary_and_page_state_the_objective_kind(folder):
    doc = json.loads((folder / "result.json").read_text())
    if doc.get("objective") is None:
        pytest.skip("no optimum")
    scene = optdesign.load(RESULTS.parent / "problems" / f"{folder.name}.toml")
    kind = objective_kind_text(SimpleNamespace(objective_kind=doc["objective_kind"], scene=scene))
    summary = (folder / "summary.txt").read_text()
    assert f"objective = {doc['objective']:.9g} ({kind}" in summary
    page = html.unescape((folder / "report.html").read_text())
    assert kind in page
    if doc["objective_kind"] not in ("peak", "expression"):
        assert "certified over the continuous stroke" not in summary.split("objective = ", 1)[1].split("\n")[0]


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
