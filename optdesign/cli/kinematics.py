"""`optdesign kinematics SCENE`: positions, velocities and accelerations over the sweep."""
from __future__ import annotations

from .common import add_scene_arguments, emit, load_scene

HELP = "positions, velocities and accelerations over the sweep"


def add_arguments(p):
    add_scene_arguments(p)
    p.add_argument("--table", action="store_true", help="print the table over every sample (default: a summary)")


def run(args):
    from ..report import analysis as report
    from ..kinematics.mechanism import kinematics

    result = kinematics(load_scene(args), args.samples)
    def summary():
        from ..report.checks import kinematics_summary

        return kinematics_summary(result) + "\n(every sample: --table; as JSON: --json)"

    emit(args, lambda: report.kinematics_json(result),
         lambda: report.kinematics_table_chunks(result) if args.table else summary())
