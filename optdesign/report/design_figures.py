"""The figures of an optimisation's folder and its report.html: the load figure (start and
optimum over the stroke), the engineering drawing (PNG and SVG), the optimum's animation (GIF,
MP4 where ffmpeg is on PATH), and report.html with all of them inlined.

The start's and the optimum's analyses are made once and shared.  With ``workers`` > 1 the
drawing and the animation are made by forked processes while this one draws the load figure
(each takes a second or more of rasterising); the page is written last, from the files."""
from __future__ import annotations

import multiprocessing
import os
from pathlib import Path

FIGURES = ("drive_and_constraints.png", "mechanism.png", "mechanism.svg", "animation.gif", "animation.mp4",
           "cases.png", "torque_speed.png", "cylinder.png", "report.html")


def analyses(result) -> list:
    """[('start', AnalysisResult), ('optimum', AnalysisResult)] of ``result``'s scene."""
    from ..model.analysis import Analysis

    scene = result.scene
    return [("start", Analysis(scene).run()), ("optimum", Analysis(scene.with_parameters(**result.design)).run())]


def load_figure(result, folder, runs=None) -> Path:
    """Drive load and per-sample constraints over the stroke, start and optimum on one figure, in
    the units the scene wrote (:mod:`.stroke_plots`): bounds drawn with the feasible side
    shaded, violations red, the peaks and their positions marked."""
    from .stroke_plots import stroke_figure

    scene = result.scene
    path = Path(folder) / "drive_and_constraints.png"
    nominal = " (the nominal [drive] state; the load cases: cases.png)" if scene.cases else ""
    stroke_figure(runs or analyses(result), path,
                  title=f"{scene.title}\n{scene.objective.minimise}: start and optimum{nominal}")
    return path


def mechanism_figure(result, folder, runs=None) -> list:
    """The engineering drawing of the start and the optimum side by side at one scale
    (mechanism.png and mechanism.svg); a design that breaks a constraint (``runs``: the
    analyses) says which in its title."""
    from .checks import violations
    from .mechanism import mechanism_figure as draw

    scene = result.scene
    folder = Path(folder)
    labels = []
    for label, analysis in runs or (("start", None), ("optimum", None)):
        broken = sorted({v["name"] for v in violations(analysis)}) if analysis is not None else []
        labels.append(f"{label} (infeasible: {', '.join(broken)})" if broken else label)
    return draw([(labels[0], scene), (labels[1], scene.with_parameters(**result.design))],
                [folder / "mechanism.png", folder / "mechanism.svg"], suptitle=scene.title)


def animation(result, folder, analysis=None) -> list:
    """The optimum moving over its stroke: animation.gif (and animation.mp4 with ffmpeg)."""
    from .animate import animate

    scene = result.scene.with_parameters(**result.design)
    folder = Path(folder)
    return animate(scene, [folder / "animation.gif", folder / "animation.mp4"], frames=30, analysis=analysis,
                   title=f"{scene.title} (optimum)")


def sized_figures(result, folder) -> list:
    """With [[cases]]: the load figure per case at the optimum (cases.png) and the figures of
    what was sized (torque_speed.png, cylinder.png: report/sized.py)."""
    from .cases import case_load_figure
    from .design_cases import cases_at_optimum
    from .sized import sized_figures as draw

    cases = cases_at_optimum(result)
    if cases is None:
        return []
    folder = Path(folder)
    return [case_load_figure(cases, result.scene, folder / "cases.png", "load cases at the optimum")] + draw(
        cases, folder, "the optimum")


SIZED = ("cases.png", "torque_speed.png", "cylinder.png")   # sized_figures' files


def write_figures(result, folder, workers=1, animate=True, before_html=None) -> list:
    """Every figure and report.html into ``folder``; returns the paths written.  With
    ``workers`` > 1 the animation (the longest) and the figures of what was sized are forked as
    soon as the optimum's analysis is made, the drawing once the start's is, and this process
    draws the load figure (on 2 cores: the three forks' and this one's ~4 s of CPU in ~2 s).
    ``before_html``: called (if given) once the figures are drawn, before report.html is
    written from the folder's result.json (the figure process waits there for the JSON)."""
    from .design_cases import optimum_analysis
    from .drive_train import start_analysis
    from .html import write_html
    from .joint_arrows import build_ahead

    folder = Path(folder)
    scene = result.scene
    fork = workers > 1 and "fork" in multiprocessing.get_all_start_methods()
    if fork:
        _import_for_children()
        context = multiprocessing.get_context("fork")
    children, jobs = [], []

    def job(target, *args):
        jobs.append((target, args))
        if fork:
            children.append(context.Process(target=_quietly, args=(os.getpid(), target, *args)))
            children[-1].start()

    optimum = optimum_analysis(result)   # the one the JSON and the summary use (report/design_cases.py)
    if fork and animate:   # the drawing's and the animation's pin forces: one build, before they fork
        build_ahead(scene)
    if animate:
        job(animation, result, folder, optimum)
    if fork and scene.cases:   # (in this process they are drawn after the load figure, as the files are listed)
        job(sized_figures, result, folder)
    runs = [("start", start_analysis(scene)), ("optimum", optimum)]   # (the cases: at the optimum)
    job(mechanism_figure, result, folder, runs)
    load = load_figure(result, folder, runs)
    if not (fork and scene.cases):
        sized_figures(result, folder)
    finish(children, jobs)
    written = [load] + [folder / n for n in SIZED + ("mechanism.png", "mechanism.svg", "animation.gif",
                                                       "animation.mp4") if (folder / n).exists()]
    if before_html is not None:
        before_html()
    written.append(write_html(result, folder, runs, [p.name for p in written]))
    return written


def finish(children, jobs):
    """Each job (target, args) that its forked process (``children``, in the same order; none
    when nothing was forked) did not finish, done here: it failed there, or it ran for
    forked.WAIT seconds from here on (it hangs, a lock held at the fork, say) and was killed.  A
    child writes atomically, so a figure it did not finish is drawn here whole.  On any error or
    Ctrl-C here the children left are killed."""
    from .forked import WAIT

    try:
        for k, (target, args) in enumerate(jobs):
            if children:
                children[k].join(WAIT)
                if children[k].exitcode == 0:
                    continue
                children[k].kill()
                children[k].join()
            target(*args)
    finally:
        for child in children:
            if child.is_alive():
                child.kill()
                child.join()


def _quietly(parent, target, *args):
    """A forked drawing process: ``target(*args)``; an error ends it with status 1 and no
    traceback (the parent draws that figure itself and meets the error there; or it has failed
    already and removed the folder being written: transfer_arm's animation printed a traceback
    then).  As the optimiser's workers (errors.worker_process): Ctrl-C is the parent's, and it
    dies with its parent (``parent``: its process id), also one killed by SIGKILL."""
    try:
        from ..errors import worker_process

        worker_process(parent)
        target(*args)
    except BaseException:   # noqa: BLE001 - said by the parent, which draws it again
        os._exit(1)


def _import_for_children():
    """Everything the forked figure processes use, imported once before the fork (else each
    process imports matplotlib.figure and the drawing modules again: 0.2 s of CPU each)."""
    from .forked import prepare

    prepare()   # matplotlib first (report/mpl_import.py)
    from . import animate as _animate, checks, mechanism, stroke_plots  # noqa: F401
