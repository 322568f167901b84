"""The process that imports the drawing modules during the solve and then draws the figures
(report/figure_process.py, issue 18): the files it writes are the very files the command's own
process draws; where the process is gone, the figures are drawn in the command's process; an
error while drawing reaches the caller as it would without the process."""
from __future__ import annotations

import hashlib
from pathlib import Path

import pytest

import optdesign
from optdesign.errors import OptdesignError
from optdesign.report import design as design_report
from optdesign.report import design_figures
from optdesign.report.figure_process import FigureProcess

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"
DRAWN = ("drive_and_constraints.png", "mechanism.png", "animation.gif")


@pytest.fixture(scope="module")
def result():
    return optdesign.optimise(optdesign.load(PROBLEMS / "seed1_jib.toml"), starts=2, seed=0, workers=1)


def digests(folder):
    return {name: hashlib.sha256((folder / name).read_bytes()).hexdigest() for name in DRAWN}


def test_the_figure_process_draws_the_same_files(result, tmp_path):
    here = design_report.write_results(result, tmp_path / "here", workers=1)
    with FigureProcess() as figures:
        there = design_report.write_results(result, tmp_path / "there", workers=2, figures=figures)
    assert sorted(p.name for p in here) == sorted(p.name for p in there)
    assert digests(tmp_path / "here") == digests(tmp_path / "there")


def test_figures_are_drawn_here_when_the_process_is_gone(result, tmp_path):
    figures = FigureProcess()
    figures._proc.kill()
    figures._proc.join()
    written = design_report.write_results(result, tmp_path / "out", workers=1, figures=figures)
    names = {p.name for p in written}
    assert {"result.json", "summary.txt", "report.html", *DRAWN} <= names
    for name in names:
        assert (tmp_path / "out" / name).stat().st_size > 0, name
    assert figures._proc is None   # ended, not waited for again


def test_an_error_while_drawing_reaches_the_caller(result, tmp_path, monkeypatch):
    def broken(*args, **kwargs):
        raise OptdesignError("the disk is full (a stand-in)")

    monkeypatch.setattr(design_figures, "write_figures", broken)   # inherited by the forked process
    with FigureProcess() as figures:
        monkeypatch.undo()       # this process would draw; only the forked one fails
        with pytest.raises(OptdesignError, match="the disk is full"):
            design_report.write_results(result, tmp_path / "out", workers=1, figures=figures)
    assert not (tmp_path / "out").exists()      # nothing half-written


def test_a_bug_while_drawing_names_its_traceback(result, tmp_path, monkeypatch):
    def buggy(*args, **kwargs):
        return 1 / 0

    monkeypatch.setattr(design_figures, "write_figures", buggy)
    with FigureProcess() as figures:
        monkeypatch.undo()
        with pytest.raises(RuntimeError, match="(?s)drawing the figures failed.*ZeroDivisionError"):
            design_report.write_results(result, tmp_path / "out", workers=1, figures=figures)


def test_the_process_ends_when_nothing_is_drawn():
    with FigureProcess() as figures:
        proc = figures._proc
        assert proc.is_alive()
    assert not proc.is_alive() and proc.exitcode == 0


def test_a_result_that_cannot_be_sent_is_drawn_here(result, tmp_path):
    import copy

    odd = copy.copy(result)
    object.__setattr__(odd, "note", lambda: "a lambda cannot be pickled")
    with FigureProcess() as figures:
        proc = figures._proc
        written = design_report.write_results(odd, tmp_path / "out", workers=1, figures=figures)
    assert {"report.html", *DRAWN} <= {p.name for p in written}
    assert not proc.is_alive()
