"""`optdesign optimise SCENE`: minimise the scene's objective over its design variables."""
from __future__ import annotations

import contextlib
import os
import sys

from ..errors import OptimisationInterrupted, SolverError
from .common import (add_scene_arguments, emit, load_scene, progress_bar, results_folder,
                     whole_number, workers)

HELP = "minimise the scene's objective over its design variables (IPOPT, multistart)"


def add_arguments(p):
    add_scene_arguments(p)
    p.add_argument("--starts", type=whole_number(1), default=20, help="number of starts, >= 1 (default 20)")
    p.add_argument("--seed", type=whole_number(0), default=0, help="seed of the random starts, >= 0 (default 0)")
    p.add_argument("--workers", type=workers, default=os.cpu_count() or 1,
                   help="processes that share the starts (default: the machine's cores; 1 = in this process)")
    p.add_argument("--out", metavar="DIR", help="results folder (default optdesign-results/<scene name>)")
    p.add_argument("--no-animation", action="store_true",
                   help="leave the optimum's animation (animation.gif, .mp4) out of the results folder")


def run(args):
    from pathlib import Path

    from ..report import design as design_report

    folder = Path(args.out or Path("optdesign-results") / Path(args.scene).stem)
    results_folder(folder, "--out", design_report.FILES)   # before the solver's imports
    from ..report.figure_process import FigureProcess

    scene = load_scene(args)
    if args.samples is not None:   # the stroke's samples: the cases' time integrals and the checks on them
        import dataclasses

        scene = dataclasses.replace(scene, sweep=dataclasses.replace(scene.sweep, samples=args.samples))
    # matplotlib and the drawing modules are imported by a forked process during the solve, and
    # the analysis of the optimum built there (what is analysed: a catalogue's every motor)
    if len(scene.motors) > 1:
        from ..design.catalogue import catalogue_scene

        analysed = catalogue_scene(scene)
    else:
        analysed = scene
    with FigureProcess(analysed) if args.workers > 1 else contextlib.nullcontext() as figures:
        solve_and_write(args, scene, folder, figures)


def solve_and_write(args, scene, folder, figures):
    """Optimise (a catalogue motor by motor), write the results folder (``figures``: the
    :class:`~optdesign.report.figure_process.FigureProcess` that draws them, or None) and print."""
    from ..design import optimise
    from ..report import design as design_report

    bar = progress_bar("starts")

    def progress(done, total):
        if bar is not None:
            bar(done, total)

    catalogue = None
    # the figure process analyses the optimum as soon as its design is known (report/figure_process.py)
    polished = None if figures is None else figures.begin
    try:
        if len(scene.motors) > 1:  # a motor catalogue: each motor in turn, the smallest that fits
            from ..design.catalogue import optimise_catalogue

            bars = {}   # one bar per motor, named

            def motor_progress(label, done, total):
                if label not in bars:
                    bars[label] = progress_bar(f"starts, {label}")
                if bars[label] is not None:
                    bars[label](done, total)
            catalogue = optimise_catalogue(scene, starts=args.starts, seed=args.seed, workers=args.workers,
                                           progress=motor_progress, polished=polished)
            result = catalogue.best
        else:
            result = optimise(scene, starts=args.starts, seed=args.seed, progress=progress, workers=args.workers,
                              polished=polished)
    except OptimisationInterrupted as stop:   # Ctrl-C: save what finished
        save_interrupted(stop, folder, args)
        raise
    if result.success:
        for path in design_report.write_results(result, folder, workers=args.workers, label="--out",
                                                 animate=not args.no_animation, catalogue=catalogue,
                                                 figures=figures):
            print(f"wrote {path}", file=sys.stderr)
    emit(args, lambda: design_report.result_json(result, catalogue),
         lambda: design_report.result_summary(result, catalogue))
    if not result.success:
        raise SolverError(f"{scene.path}: no optimum: {result.status}. {result.message} "
                          "(nothing was written to the results folder)")


def save_interrupted(stop, folder, args):
    """The best design of the starts that finished before Ctrl-C, written to the results folder
    as a whole (marked interrupted: result.json's "interrupted", the summary's headline), without
    the animation; ``stop.saved`` says where, for the final message.  A motor catalogue's
    (``stop.catalogue``) is saved with its outcome so far (the motors decided, the one
    interrupted, those not tried) once a motor was decided or the interrupted one's finished
    starts found a feasible design; with no motor found to fit, result.json and summary.txt
    alone.  A second Ctrl-C stops the writing and leaves the folder as it was."""
    from ..report import design as design_report

    stop.saved = None
    catalogue = stop.catalogue
    result = stop.result if catalogue is None else catalogue.best
    if result is None or (catalogue is None and not result.success):
        return
    design_report.write_results(result, folder, workers=1, label="--out", animate=False, catalogue=catalogue)
    stop.saved = folder
