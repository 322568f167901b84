"""`optdesign study SCENE ...`: many analyses or optimisations of one scene (see optdesign.study.study).

Imports nothing heavy at module level: the CLI registers this module on every start."""
from __future__ import annotations

import argparse
import sys

HELP = "many optimisations or analyses of one scene: grids, lists, Pareto fronts; resumable, parallel or on Dask"

EPILOG = """\
axes (repeatable, in the order given; the last varies fastest and carries the warm starts):
  --grid NAME=START:STOP:N       N evenly spaced values, ends included, e.g. --grid mP=500:3000:6
  --values NAME=V1,V2,...        listed values, e.g. --values L=5,6,7.5 or --values "psi=-60 deg,-50 deg"
  --pareto CONSTRAINT[.min|.max]=START:STOP:N  or  =V1,V2,...
                                 sweep a constraint's bound (epsilon-constraint Pareto front),
                                 e.g. --pareto "cylinder length ratio=1.4:1.9:6"
                                      --pareto "transmission angle.min=15 deg:35 deg:5"
examples:
  optdesign study problems/truck_crane.toml --grid mP=500:3000:6 --values L=5,6,7
  optdesign study problems/truck_crane.toml --pareto "cylinder length ratio=1.4:2.0:7"
  optdesign study problems/seed1_jib.toml --mode analyse --grid mC=250:1000:4 --workers 1
  optdesign study problems/truck_crane.toml --grid mP=500:3000:26 --scheduler tcp://10.0.0.5:8786
Interrupted (Ctrl-C, a killed process)?  Run the same command again: finished cases are kept
in OUT/journal.jsonl and are not redone.  --restart forgets them."""


class _AxisAction(argparse.Action):
    """Collects --grid/--values/--pareto in the order given."""

    def __call__(self, parser, namespace, value, option_string=None):
        axes = list(getattr(namespace, "axes", None) or [])
        axes.append((option_string.lstrip("-"), value))
        namespace.axes = axes


def add_arguments(p):
    from .common import whole_number as _whole_number

    p.formatter_class = argparse.RawDescriptionHelpFormatter
    p.epilog = EPILOG
    p.add_argument("scene", help="scene file (TOML), e.g. problems/truck_crane.toml")
    p.add_argument("--mode", choices=("optimise", "analyse"), default="optimise",
                   help="optimise each case (default) or analyse it (peaks over the stroke)")
    for flag, meta, text in (("--grid", "NAME=START:STOP:N", "an axis: N evenly spaced values of a parameter"),
                             ("--values", "NAME=V1,V2,...", "an axis: listed values of a parameter"),
                             ("--pareto", "CONSTRAINT[.min|.max]=START:STOP:N",
                              "an axis: a constraint's bound (Pareto front; or =V1,V2,...)")):
        p.add_argument(flag, action=_AxisAction, dest="axes", metavar=meta, default=[], help=text + " (repeatable; see below)")
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help="override a parameter for every case (repeatable)")
    p.add_argument("--starts", type=_whole_number(1), default=8, help="starts of a cold optimisation case (default 8)")
    p.add_argument("--seed", type=_whole_number(0), default=0, help="seed of the random starts, >= 0 (default 0)")
    p.add_argument("--warm-starts", type=_whole_number(1), default=1,
                   help="starts of a warm case: the previous optimum, then the first cold ones (default 1)")
    p.add_argument("--no-warm", action="store_true", help="no warm starts: every case starts cold (all run in parallel)")
    p.add_argument("--chain", type=_whole_number(1), default=25, help="at most this many cases per warm-started chain (default 25)")
    p.add_argument("--workers", type=_whole_number(1), default=None, help="processes on this machine (default: its cores; 1 = in process)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="run on a Dask cluster, e.g. tcp://127.0.0.1:8786")
    p.add_argument("--out", metavar="DIR", help="results folder (default optdesign-results/<scene>_study-<axes>-<digest>: one folder per "
                   "study, named from the scene and the study's axes)")
    p.add_argument("--restart", action="store_true", help="forget the cases finished by an earlier run in DIR")
    p.add_argument("--no-figures", action="store_true", help="write no figures")
    p.add_argument("--json", action="store_true", help="print the run's summary and rows as JSON")


def parse_axis(kind, text):
    """An Axis from the text of --grid, --values or --pareto."""
    from ..errors import SceneError
    from ..scene.arguments import study_cases
    from ..study.axes import evenly_spaced
    from ..study.study import grid, pareto, values

    name, sep, spec = text.rpartition("=")
    name = name.strip()
    if not sep or not name or not spec.strip():
        raise SceneError(f"--{kind} {text!r}: expected NAME=START:STOP:N or NAME=V1,V2,...")
    if kind == "grid" or (kind == "pareto" and ":" in spec):
        parts = spec.split(":")
        if len(parts) != 3:
            raise SceneError(f"--{kind} {text!r}: expected START:STOP:N, e.g. {name}=500:3000:6")
        try:
            n = int(parts[2])
        except ValueError:
            raise SceneError(f"--{kind} {text!r}: N must be a whole number, found {parts[2]!r}") from None
        if n < 1:
            raise SceneError(f"--{kind} {text!r}: N must be at least 1")
        study_cases(f"--{kind} {text!r}: N", n)
        lo, hi = (_constant(v, f"--{kind} {text!r}") for v in parts[:2])
        items = evenly_spaced(lo, hi, n)
        if kind == "grid":
            return grid(name, lo, hi, n)
    else:
        items = [v.strip() for v in spec.split(",") if v.strip()]
        if not items:
            raise SceneError(f"--{kind} {text!r}: no values")
        if kind == "values":
            return values(name, items)
    side = None
    for suffix in (".min", ".max"):
        if name.endswith(suffix):
            name, side = name[: -len(suffix)], suffix[1:]
    return pareto(name, items, side)


def _constant(text, where):
    from ..scene.expressions import constant_value, parse

    return constant_value(parse(text.strip(), where), {}, where)


def run(args):
    from . import common as cli
    from ..errors import OptdesignError
    from ..study.results import ClusterLost
    from ..study.study import Study, StudyInterrupted

    scene = cli.load_scene(args)
    axes = [parse_axis(kind, text) for kind, text in args.axes]
    study = Study(scene, axes, mode=args.mode, starts=args.starts, seed=args.seed, warm=not args.no_warm,
                  warm_starts=args.warm_starts, chain=args.chain)
    out = args.out or study.default_folder()
    try:
        result = study.run(out=out, workers=args.workers, scheduler=args.scheduler,
                           progress=cli.progress_bar("cases", log=True), restart=args.restart, figures=not args.no_figures)
    except ClusterLost as exc:   # one line: what the journal kept and the command that resumes
        raise OptdesignError(f"{str(exc).split('; run the same study')[0]}; resume with: "
                             f"{resume_command(args)}") from None
    except StudyInterrupted as exc:
        for note in exc.result.notes:
            print(f"optdesign study: {note}", file=sys.stderr)
        print(f"\noptdesign study: {exc}", file=sys.stderr)
        raise SystemExit(130) from None
    for note in result.notes:
        print(f"optdesign study: {note}", file=sys.stderr)
    for path in result.paths:
        print(f"wrote {path}", file=sys.stderr)
    if args.json:   # the rows streamed a few hundred at a time: a million cases never all dicts at once
        from ..report.output import Rows, json_chunks

        rows = result.rows
        for chunk in json_chunks({"schema": "optdesign/1", "kind": "study", "folder": str(result.folder),
                                  "complete": result.complete, "computed": result.computed, "reused": result.reused,
                                  "wall_s": result.wall_s, "files": [str(p) for p in result.paths],
                                  "rows": Rows(len(rows), rows.__getitem__)}):
            sys.stdout.write(chunk)
        sys.stdout.write("\n")
    else:
        sys.stdout.write((result.folder / "summary.txt").read_text())


def resume_command(args) -> str:
    """The command that resumes this study: the same one, without --restart (which would
    throw the journal away)."""
    import shlex

    argv = [a for a in (getattr(args, "argv", None) or sys.argv[1:]) if a != "--restart"]
    return shlex.join(["optdesign", *argv])

