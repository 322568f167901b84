"""`optdesign kinematics SCENE`: positions, velocities and accelerations over the sweep."""
from __future__ import annotations

from .common import add_scene_arguments, emit
from .design_option import add_design_argument, scene_with_design

HELP = "positions, velocities and accelerations over the sweep"


def add_arguments(p):
    add_scene_arguments(p)
    add_design_argument(p, "compute the kinematics of")
    p.add_argument("--table", action="store_true", help="print the table over every sample, then the summary "
                   "(default: the summary alone)")


def run(args):
    from ..report import analysis as report
    from ..kinematics.mechanism import kinematics

    result = kinematics(scene_with_design(args), args.samples)
    def summary():
        from ..report.checks import kinematics_summary

        return kinematics_summary(result) + "\n(every sample: --table; as JSON: --json)"

    def table():
        yield from report.kinematics_table_chunks(result)
        yield "\n\n" + summary()

    emit(args, lambda: report.kinematics_json(result), table if args.table else summary)
