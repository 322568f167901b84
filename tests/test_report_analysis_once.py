"""The optimum of an optimisation analysed once for its whole results folder (issue 31: the
catalogue's command analysed it four times after the solve, 2 s each): the JSON, the summary and
the figures share :func:`optdesign.report.design_cases.optimum_analysis`, and the figure process
draws with the analysis the command sends it instead of making its own."""
from __future__ import annotations

import time
from pathlib import Path
from types import SimpleNamespace

import pytest

import optdesign
from optdesign.model import analysis as analysis_module
from optdesign.report import design_cases, design_figures
from optdesign.report.figure_process import FigureProcess

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"


@pytest.fixture
def result():
    """A successful result's stand-in: what optimum_analysis reads (a scene with [[cases]])."""
    design_cases.keep_optimum_analysis(None, None)
    yield SimpleNamespace(success=True, scene=optdesign.load(PROBLEMS / "hatch_cover.toml"), design={})
    design_cases.keep_optimum_analysis(None, None)


def test_the_cases_and_the_figures_share_one_analysis(result, monkeypatch):
    made = []
    monkeypatch.setattr(analysis_module, "analyse", lambda scene: made.append(scene) or SimpleNamespace(cases="cases"))
    assert design_cases.cases_at_optimum(result) == "cases"
    assert design_cases.cases_at_optimum(result) == "cases"
    assert design_cases.optimum_analysis(result).cases == "cases"
    assert len(made) == 1
    other = SimpleNamespace(success=True, scene=result.scene, design={})   # another result: analysed anew
    design_cases.optimum_analysis(other)
    assert len(made) == 2
    assert design_cases.optimum_analysis(SimpleNamespace(success=False)) is None and len(made) == 2


def test_the_figure_process_draws_with_the_analysis_it_is_sent(result, monkeypatch, tmp_path):
    sent = SimpleNamespace(cases="the command's analysis (a stand-in)")

    def draw(result, folder, workers, animate, before_html=None):   # in the forked process: the analysis kept, none made
        monkeypatch.setattr(analysis_module, "analyse", lambda scene: pytest.fail("analysed again"))
        assert design_cases.optimum_analysis(result) == sent
        assert design_cases.cases_at_optimum(result) == sent.cases
        return [Path(folder) / "drawn.png"]

    monkeypatch.setattr(design_figures, "write_figures", draw)   # inherited by the fork
    with FigureProcess() as figures:
        assert figures.send(result, tmp_path, 1, False, sent)
        assert figures.receive() == [tmp_path / "drawn.png"]
        assert figures._proc is None


def test_a_failed_check_in_the_figure_process_reaches_the_command(result, monkeypatch, tmp_path):
    def draw(result, folder, workers, animate, before_html=None):
        assert design_cases.optimum_analysis(result) == "another analysis"
        return []

    monkeypatch.setattr(design_figures, "write_figures", draw)
    with FigureProcess() as figures:
        assert figures.send(result, tmp_path, 1, False, SimpleNamespace(cases=None))
        with pytest.raises(RuntimeError, match="(?s)drawing the figures failed.*AssertionError"):
            figures.receive()


def test_the_figure_process_writes_the_page_after_the_json(result, monkeypatch, tmp_path):
    """report.html's drive-train section reads the folder's result.json: the figure process
    waits for the command's word that it is written (the slow set once saw a page without its
    motors table: the page was written while the command still computed the JSON)."""
    def draw(result, folder, workers, animate, before_html=None):
        (Path(folder) / "figures.png").write_text("drawn")
        if before_html is not None:
            before_html()   # where write_figures writes report.html
        return [Path(folder) / ("page after the JSON" if (Path(folder) / "result.json").exists()
                                else "page before the JSON")]

    monkeypatch.setattr(design_figures, "write_figures", draw)
    with FigureProcess() as figures:
        assert figures.send(result, tmp_path, 1, False, SimpleNamespace(cases=None))
        for _ in range(3000):   # the figures drawn while the command computes the JSON (a catalogue's: slow)
            if (tmp_path / "figures.png").exists():
                break
            time.sleep(0.01)
        (tmp_path / "result.json").write_text("{}\n")
        assert figures.receive() == [tmp_path / "page after the JSON"]

