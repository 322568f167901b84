"""`optdesign simulate SCENE`: the motion in time under the scene's drive law (CLI module).

Imports cheaply (CasADi and numpy only inside :func:`run`), as ``optdesign.cli.main`` asks."""
from __future__ import annotations

import sys

HELP = "motion in time under the drive law of [drive] from the start in [simulation] (CVODES BDF/Adams, RK4)"

def add_arguments(p):
    from .common import real_number, whole_number
    from .common import samples as _samples
    from .design_option import add_design_argument

    p.add_argument("scene", help="scene file (TOML) with [drive] law and [simulation], e.g. problems/sim_slider_crank.toml")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help="override a parameter (repeatable)")
    add_design_argument(p, "simulate", ", e.g. the sized gear ratio")
    p.add_argument("--integrator", choices=("bdf", "adams", "rk4"), default=None,
                   help="bdf: CVODES BDF, Newton (implicit, stiff cases); adams: CVODES Adams, functional "
                        "iteration (non-stiff); rk4: fixed-step explicit RK4 (default: the scene's, else bdf)")
    p.add_argument("--tolerance", type=real_number(above=0.0, at_most=0.1), default=None,
                   help="relative tolerance, 0 < TOL <= 0.1 (default: the scene's, else 1e-8)")
    p.add_argument("--steps", type=whole_number(2), default=None, help="rk4 only: steps per output sample, >= 2 (default 20)")
    p.add_argument("--samples", type=_samples, default=None, help="output samples over 0 .. t_end (default: the scene's)")
    p.add_argument("--t-end", type=real_number(above=0.0), default=None, dest="t_end",
                   help="end time [s], > 0 (default: the scene's)")
    p.add_argument("--plot", metavar="DIR", help="write figures (PNG) of q, its rate and the drive load over time into DIR "
                                                 "(and, for a duty cycle of phases, cycle.png: the motor's speed and torque "
                                                 "against its limits)")
    p.add_argument("--table", action="store_true", help="print the table over every output sample before the "
                   "summary (default: the summary alone)")


def run(args):
    from .common import emit as _emit, results_folder
    from .design_option import scene_with_design
    from ..report.simulation import FIGURES, figures, simulation_json, summary_chunks
    from ..dynamics.simulator import simulate

    if args.plot:
        results_folder(args.plot, "--plot", FIGURES)
    result = simulate(scene_with_design(args), integrator=args.integrator, tolerance=args.tolerance, steps=args.steps,
                      samples=args.samples, t_end=args.t_end)
    if args.plot:
        for path in figures(result, args.plot, label="--plot"):
            print(f"wrote {path}", file=sys.stderr)
    def summary_alone():
        *_, last = summary_chunks(result)   # the rows, then the summary: keep the summary
        return last.lstrip("\n") + "\n(every output sample: --table; as JSON: --json)"

    _emit(args, lambda: simulation_json(result), lambda: summary_chunks(result) if args.table else summary_alone())
