"""`optdesign analyse SCENE`: the reduced one-element model over the stroke."""
from __future__ import annotations

import sys

from .common import add_scene_arguments, emit, load_scene, results_folder

HELP = "the reduced one-element model (drive torque or force) over the stroke"


def add_arguments(p):
    add_scene_arguments(p)
    p.add_argument("--plot", metavar="DIR", help="write figures (PNG) into DIR")


def run(args):
    from ..report import analysis as report
    from ..model.analysis import analyse

    if args.plot:
        results_folder(args.plot, "--plot", report.FIGURES)
    result = analyse(load_scene(args), args.samples)
    if args.plot:
        for path in report.analysis_figures(result, args.plot, label="--plot"):
            print(f"wrote {path}", file=sys.stderr)
    emit(args, lambda: report.analysis_json(result), lambda: report.analysis_table_chunks(result))
