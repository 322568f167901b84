"""`optdesign analyse SCENE`: the reduced one-element model over the stroke."""
from __future__ import annotations

import sys

from .common import add_scene_arguments, emit, output_file, results_folder
from .design_option import add_design_argument, scene_with_design

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
    add_design_argument(p, "analyse")
    p.add_argument("--plot", metavar="DIR", help="write figures (PNG) into DIR")
    p.add_argument("--table", action="store_true", help="print the table over every sample (after which the "
                   "peaks and constraints in SI, then the summary in the scene's units); without it, the summary")
    p.add_argument("--csv", metavar="FILE", help="write every sample as CSV, each header 'name [unit]' (- : to "
                   "standard output, the summary then to standard error; with [[cases]], also FILE-STEM_case-NAME.csv "
                   "per case and FILE-STEM_cycle.csv for the duty cycle)")
    p.add_argument("--joints", action="store_true", help="the force at every pin and slider too (pin_force(P), "
                   "its components, slider_normal(P), slider_moment(P)), their peaks certified")


def run(args):
    from ..report import analysis as report
    from ..model.analysis import analyse

    if args.plot:
        results_folder(args.plot, "--plot", report.FIGURES)
    if args.csv:
        output_file(args.csv, "--csv")
    result = analyse(scene_with_design(args), args.samples, joints=args.joints)
    if args.plot:
        for path in report.analysis_figures(result, args.plot, label="--plot"):
            print(f"wrote {path}", file=sys.stderr)
    if args.csv:
        from ..report.checks import csv_text
        from ..report.files import write_file

        print(f"wrote {write_file(args.csv, csv_text(result), '--csv')}", file=sys.stderr)
        if args.csv != "-":
            from ..report.cases import cases_csv

            for path in cases_csv(result, args.csv):   # with [[cases]]: one per case and the duty cycle's
                print(f"wrote {path}", file=sys.stderr)
    emit(args, lambda: report.analysis_json(result),
         lambda: table_chunks(report, result) if args.table else summary_chunks(report, result))


def table_chunks(report, result):
    """--table: the table over every sample, then the summary (it keeps the summary)."""
    yield from report.analysis_table_chunks(result)
    yield "\n\n"
    from ..report.checks import summary_lines

    yield "\n".join(summary_lines(result))


def summary_chunks(report, result):
    """The summary in the scene's units (report/checks.py), then the peaks and constraints in SI."""
    from ..report.checks import summary_lines

    yield "\n".join(summary_lines(result)) + "\n\nin SI, over the continuous stroke:"
    for chunk in report.analysis_peaks_chunks(result, case_samples=False):   # (the violations are in the summary already)
        yield "\n".join(line for line in chunk.split("\n") if not line.startswith("violated: "))
    yield "\n(every sample: --table; as CSV with units: --csv FILE; as JSON: --json)"
