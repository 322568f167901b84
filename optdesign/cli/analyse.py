"""`optdesign analyse SCENE`: the reduced one-element model over the stroke."""
from __future__ import annotations

import sys

from .common import add_scene_arguments, emit, load_scene, results_folder

HELP = "the reduced one-element model (drive torque or force) over the stroke"


EPILOG = """\
The drive load at each position is the load at the drive speed and acceleration given in
[drive] (e.g. 100 rad/s and 50 rad/s^2 at every crank angle), not the load along one motion in
time: for that, use `optdesign simulate`.  Assembly (lock-up, dead centres) is checked over
the continuous stroke, between the samples too; the peaks and constraint extremes printed (and
`peaks`, `constraint_extremes`, `constraints` in --json) are certified over the continuous
stroke, with where they lie; `peaks_sampled` and `constraints_sampled` hold the samples' own."""


def add_arguments(p):
    import argparse

    p.formatter_class = argparse.RawDescriptionHelpFormatter
    p.epilog = EPILOG
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
