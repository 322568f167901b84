"""What the results folder's figures share instead of making again (issue 31: the end of
`optdesign optimise`): the pin forces' graphs built once for a scene and its designs
(report/joint_arrows._built), the start's analysis taken from the figure process's prebuilt run
(report/drive_train.start_analysis), and the figures of what was sized drawn in a forked
process.  Each gives the numbers, and the files, that making them anew gives."""
from __future__ import annotations

import dataclasses
import hashlib
import os
import time
from pathlib import Path

import numpy as np
import pytest

import optdesign
from optdesign.model.analysis import Analysis
from optdesign.report import design as design_report
from optdesign.report import drive_train, joint_arrows
from optdesign.report.figure_process import FigureProcess
from optdesign.scene import ResolvedScene
from processes import kill_once_forked  # tests/ is on sys.path under pytest

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"


def _fresh(scene, s):
    joint_arrows._BUILT.clear()
    return joint_arrows.governing_pin_forces(scene, s)


def _same_forces(a, b):
    return a[1] == b[1] and list(a[0]) == list(b[0]) and all(np.array_equal(a[0][k], b[0][k], equal_nan=True) for k in a[0])


@pytest.mark.parametrize("name", ["seed1_jib.toml", "hatch_cover.toml"])
def test_pin_forces_of_another_design_from_one_build(name):
    scene = optdesign.load(PROBLEMS / name)
    values = ResolvedScene(scene).values
    s = ResolvedScene(scene).stroke(7)
    design = {p.name: 1.05 * values[p.name] for p in scene.parameters if p.is_design}
    other = scene.with_parameters(**design)
    _fresh(scene, s)                                   # the start's build ...
    shared = joint_arrows.governing_pin_forces(other, s)   # ... evaluated at the other design
    assert joint_arrows._BUILT[0] is scene             # (not built again)
    own = _fresh(other, s)                             # its own build
    assert shared[0] and _same_forces(shared, own)
    # a change other than a design variable's value is built anew, and gives its own forces
    fixed = next(p.name for p in scene.parameters if not p.is_design and not p.value.names())
    heavier = scene.with_parameters(**{fixed: 1.5 * values[fixed]})
    _fresh(scene, s)
    rebuilt = joint_arrows.governing_pin_forces(heavier, s)
    assert joint_arrows._BUILT[0] is heavier
    assert _same_forces(rebuilt, _fresh(heavier, s))


def test_start_analysis_from_the_prebuilt_run():
    scene = optdesign.load(PROBLEMS / "crane_luffing_drive.toml")   # a catalogue: built with every motor
    one = dataclasses.replace(scene, motors=scene.motors[:1])
    drive_train.prebuild(scene)
    taken = drive_train.start_analysis(one)
    made = Analysis(one, cases=False).run()
    assert taken.scene is one and taken.cases is None
    for f in dataclasses.fields(made):
        if f.name in ("timings", "scene"):
            continue
        a, b = getattr(taken, f.name), getattr(made, f.name)
        assert repr(a) == repr(b), f.name   # arrays and dicts of floats: the same digits
    for k, v in made.columns.items():
        assert np.array_equal(taken.columns[k], v), k
    other = one.with_parameters(**{next(p.name for p in one.parameters if p.is_design): 2.0})
    assert drive_train.start_analysis(other).columns["drive"].tobytes() == \
        Analysis(other, cases=False).run().columns["drive"].tobytes()   # another scene: made anew


def test_start_analysis_of_a_catalogue_whose_simulation_names_another_motor():
    """transfer_arm's [simulation] names its 1.5 kW motor; the result's scene has the chosen one
    alone, its simulation that one's (design/catalogue.with_motor): the start's analysis is that
    scene's (it raised "unknown motor 'servo 1.5 kW'" and `optdesign optimise` failed)."""
    from optdesign.design.catalogue import with_motor

    scene = optdesign.load(PROBLEMS / "transfer_arm.toml")
    assert scene.simulation.motor not in {m.name for m in scene.motors[:1]}
    one = with_motor(scene, scene.motors[0])
    drive_train.prebuild(scene)
    taken = drive_train.start_analysis(one)
    made = Analysis(one, cases=False).run()
    assert taken.scene == one
    for k, v in made.columns.items():
        assert np.array_equal(taken.columns[k], v), k


@pytest.fixture(scope="module")
def hatch():
    return optdesign.optimise(optdesign.load(PROBLEMS / "hatch_cover.toml"), starts=2, seed=0, workers=1)


def test_the_folder_drawn_in_processes_is_the_folder_drawn_here(hatch, tmp_path):
    here = design_report.write_results(hatch, tmp_path / "here", workers=1, animate=False)
    with FigureProcess(hatch.scene) as figures:
        figures.begin(dict(hatch.design))
        there = design_report.write_results(hatch, tmp_path / "there", workers=2, animate=False, figures=figures)
    names = [p.name for p in here]
    assert names == [p.name for p in there]
    assert {"cases.png", "drive_and_constraints.png", "mechanism.png"} <= set(names)
    for name in names:
        if name.endswith(".png"):
            digests = [hashlib.sha256((tmp_path / w / name).read_bytes()).hexdigest() for w in ("here", "there")]
            assert digests[0] == digests[1], name


def test_a_drawing_process_that_fails_ends_quietly(capfd):
    """A forked drawing process whose figure fails (its folder gone: the command failed) ends
    with status 1 and prints no traceback; the parent, if it is still there, draws the figure
    itself and meets the error (design_figures.write_figures)."""
    import multiprocessing

    from optdesign.report.design_figures import _quietly

    def fail():
        raise OSError("the folder is gone")
    child = multiprocessing.get_context("fork").Process(target=_quietly, args=(os.getpid(), fail))
    child.start()
    child.join()
    assert child.exitcode == 1
    assert "Traceback" not in capfd.readouterr().err


def test_a_drawing_process_dies_with_a_parent_killed_by_sigkill():
    """A forked drawing process whose parent (the figure process) is killed stops drawing at
    once instead of drawing on into a folder nobody will read (here its figure takes 2 minutes)."""
    children, left = kill_once_forked(
        "import multiprocessing, os, time\nfrom optdesign.report.design_figures import _quietly\n"
        "child = multiprocessing.get_context('fork').Process(target=_quietly, args=(os.getpid(), time.sleep, 120))\n"
        "child.start()\ntime.sleep(120)\n")
    assert children, "no drawing process seen"
    assert left == [], "the drawing process outlived its parent"


def test_a_drawing_process_that_hangs_is_ended_and_its_figure_drawn_here(tmp_path, monkeypatch):
    """write_figures' forked processes are waited for forked.WAIT seconds each (here 1 s), then
    killed, their figure drawn by this process: a child that hangs (a minute here) cannot hang
    the command."""
    import multiprocessing

    from optdesign.report import forked
    from optdesign.report.design_figures import _quietly, finish

    monkeypatch.setattr(forked, "WAIT", 1.0)
    here = os.getpid()
    path = tmp_path / "figure.png"

    def draw():
        if os.getpid() != here:
            time.sleep(60)
        path.write_text(str(os.getpid()))
    child = multiprocessing.get_context("fork").Process(target=_quietly, args=(here, draw))
    child.start()
    t0 = time.monotonic()
    finish([child], [(draw, ())])
    assert time.monotonic() - t0 < 30
    assert path.read_text() == str(here) and not child.is_alive()


def test_the_figure_process_dies_with_a_command_killed_by_sigkill():
    """The figure process, busy (here its prebuild takes 2 minutes) when the command is killed
    with SIGKILL, ends at once (and so do the drawing processes it forks: above)."""
    children, left = kill_once_forked("import time\nfrom optdesign.report import figure_process\n"
                                      "figure_process._prebuild = lambda scene: time.sleep(120)\n"
                                      "with figure_process.FigureProcess(scene='a scene'):\n    time.sleep(120)\n",
                                      settle=1.0)   # (it is in its prebuild then)
    assert children, "no figure process seen"
    assert left == [], "the figure process outlived the command"


@pytest.mark.slow
def test_the_animation_and_drawing_forked_after_one_pin_force_build_are_those_drawn_here(hatch, tmp_path):
    """With the animation, the pin forces' graphs are built before the drawing processes fork
    (joint_arrows.build_ahead): mechanism.png and animation.gif are the bytes drawn in one process."""
    joint_arrows._BUILT.clear()
    here = design_report.write_results(hatch, tmp_path / "here", workers=1, animate=True)
    joint_arrows._BUILT.clear()
    there = design_report.write_results(hatch, tmp_path / "there", workers=2, animate=True)
    assert joint_arrows._BUILT and joint_arrows._BUILT[0] is hatch.scene   # built here, before the forks
    assert [p.name for p in here] == [p.name for p in there]
    for name in ("mechanism.png", "animation.gif", "drive_and_constraints.png", "cases.png"):
        assert (tmp_path / "here" / name).read_bytes() == (tmp_path / "there" / name).read_bytes(), name


def test_a_pin_force_build_ahead_that_fails_is_left_to_the_drawing(monkeypatch):
    """build_ahead swallows an error of the build and keeps no build; the drawing that asks for
    the forces then meets the error itself, and no earlier scene's build is served."""
    scene = optdesign.load(PROBLEMS / "hatch_cover.toml")
    s = ResolvedScene(scene).stroke(7)
    _fresh(scene, s)
    other = optdesign.load(PROBLEMS / "seed1_jib.toml")

    def broken(model):
        raise RuntimeError("a stand-in for a failing build")
    monkeypatch.setattr(joint_arrows, "JointForces", broken)
    joint_arrows.build_ahead(other)
    assert joint_arrows._BUILT == []
    with pytest.raises(RuntimeError, match="stand-in"):
        joint_arrows.governing_pin_forces(other, ResolvedScene(other).stroke(7))
