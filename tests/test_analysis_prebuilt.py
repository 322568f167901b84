"""The optimum's analysis run on a build made before the design was known (issue 31: the motor
catalogue's results folder analysed the 4-motor scene at the chosen design after the solve,
~1.3 s on the command's critical path, half of it the build).  The figure process builds the
analysis while the command builds its first problem (report/drive_train.prebuild) and runs it at
the design when asked (FigureProcess.analysis, report/drive_train.analyse_at).

The reference is what the command did before: ``analyse(scene.with_parameters(**design))``, made
apart; every number the same (timings aside), over a family of designs.  The scene is
tests/test_cases_optimise.py's crank with a gearbox and its catalogue of three motors."""
from __future__ import annotations

import dataclasses

import pytest

from optdesign.design.catalogue import catalogue_scene, motor_order
from optdesign.model import analysis as analysis_module
from optdesign.report import design_cases, drive_train
from optdesign.report.figure_process import FigureProcess

from test_catalogue_analysis import _catalogue, same
from test_catalogue_retries import crank


@pytest.fixture
def clean():
    drive_train._BUILT[:], drive_train._LAST[:], design_cases._LAST[:] = [], [None, None], [None, None]
    yield
    drive_train._BUILT[:], drive_train._LAST[:], design_cases._LAST[:] = [], [None, None], [None, None]


@pytest.fixture(scope="module")
def built():
    """The catalogue scene's build (report/drive_train.prebuild), made once for the tests that run it."""
    scene = catalogue_scene(crank())
    drive_train.prebuild(scene)
    build, drive_train._BUILT[:] = drive_train._BUILT[0], []
    return scene, build


def _use(built):
    scene, build = built
    drive_train._BUILT[:], drive_train._RAN[:] = [build], []
    return scene


def _not_analysed_again(monkeypatch):
    monkeypatch.setattr(analysis_module, "analyse", lambda *a, **k: pytest.fail("analysed from scratch"))


def test_the_catalogue_scene_has_every_motor_in_the_order_tried():
    scene = crank()
    whole = catalogue_scene(scene)
    assert [m.name for m in whole.motors] == [m.name for m in motor_order(scene)] == ["tiny", "small", "large"]
    assert dataclasses.replace(whole, motors=scene.motors) == scene


def _prebuilt_against_apart(ratios, built, monkeypatch) -> list:
    """For each ratio, what differs between the prebuilt build's run and the scene analysed at
    that ratio from scratch (the scene, then :func:`same`'s differences): empty lists when equal."""
    scene = _use(built)
    apart = [analysis_module.analyse(scene.with_parameters(i=float(i))) for i in ratios]
    _not_analysed_again(monkeypatch)
    differences = []
    for i, reference in zip(ratios, apart):
        made = drive_train.analyse_at(scene, {"i": float(i)})
        differences.append(([] if made.scene == reference.scene else ["scene"]) + same(made, reference))
    return differences


def test_the_prebuilt_analysis_is_the_one_made_apart(clean, built, monkeypatch):
    """At the upper bound of the ratio, after the build's own run at the scene's values: the
    run of the build equals the scene analysed at that ratio from scratch."""
    assert _prebuilt_against_apart([200.0], built, monkeypatch) == [[]]


@pytest.mark.slow   # three analyses from scratch; the test above is the fast sibling
def test_the_prebuilt_analysis_is_the_one_made_apart_over_the_box(clean, built, monkeypatch):
    """Ratios over the design box (its bounds and one between), one after the other on one build."""
    assert _prebuilt_against_apart([2.0, 23.7, 200.0], built, monkeypatch) == [[], [], []]


def test_a_build_of_another_scene_is_not_used(clean, built, monkeypatch):
    """The scene with the small motor alone is not the catalogue's (every motor), whose build is there."""
    result, _ = _catalogue(40.0)
    scene = result.scene
    _use(built)   # the catalogue scene's: every motor
    made = []
    monkeypatch.setattr(analysis_module, "analyse", lambda s: made.append(s) or "made apart")
    assert drive_train.analyse_at(scene, {"i": 40.0}) == "made apart"
    assert made == [scene.with_parameters(i=40.0)]


def test_the_figure_process_answers_with_its_build(clean, monkeypatch):
    """The catalogue's analysis at the chosen design, made in the figure process from the build
    it made on start (begun when the design was told), is the one made apart, and the command
    keeps it for the JSON."""
    result, catalogue = _catalogue(40.0)
    scene = catalogue_scene(crank())
    whole = analysis_module.analyse(scene.with_parameters(i=40.0))
    _not_analysed_again(monkeypatch)   # (inherited by the fork: the process must use its build)
    with FigureProcess(scene) as figures:
        figures.begin({"i": 40.0})   # (the design once polished: made ahead there)
        made = figures.analysis(result, catalogue)
    assert made is not None and same(made, whole) == []
    drive_train.keep_catalogue_analysis(catalogue, made)
    assert drive_train.catalogue_analysis(catalogue) is made


def test_without_the_figure_process_the_analysis_is_made_here(clean):
    figures = FigureProcess()
    figures.close()
    result, catalogue = _catalogue(40.0)
    assert figures.analysis(result, catalogue) is None


def test_the_analysis_made_ahead_is_the_one_asked_for(clean, built, monkeypatch):
    """analyse_ahead at the optimum's design (told by optimise's ``polished`` while the command
    still certifies the optimum): the later analyse_at of that design is that analysis, not run
    again; another design is run anew."""
    scene = _use(built)
    drive_train.analyse_ahead({"i": 40.0})
    made = drive_train._RAN[2]
    build = drive_train._BUILT[0]
    monkeypatch.setattr(build, "run", lambda *a: pytest.fail("run again"))
    assert drive_train.analyse_at(scene, {"i": 40.0}) is made
    monkeypatch.undo()
    _not_analysed_again(monkeypatch)
    other = drive_train.analyse_at(scene, {"i": 41.0})
    assert other is not made and other.scene == scene.with_parameters(i=41.0)


def test_optimise_tells_the_polished_design():
    """optimise's ``polished`` is told the result's design, once, before the result is made (the
    command sends it to the figure process: FigureProcess.begin)."""
    from optdesign.design.catalogue import with_motor
    from optdesign.design.multistart import optimise

    sc = crank()
    small = with_motor(sc, next(m for m in sc.motors if m.name == "small"))
    told = []
    result = optimise(small, starts=1, polished=told.append)
    assert result.success and told == [result.design]
