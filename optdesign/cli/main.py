"""The command line: a thin registry of subcommands over the front doors (no logic here)."""
from __future__ import annotations

import argparse
import importlib
import os
import sys

from ..errors import OptdesignError, SceneError, SolverError


def _overrides(pairs):
    out = {}
    for pair in pairs or ():
        name, sep, value = pair.partition("=")
        if not sep or not name.strip():
            raise SceneError(f"--set {pair!r}: expected NAME=VALUE, e.g. --set mC=750 or --set psi='-55 deg'")
        try:
            out[name.strip()] = float(value)
        except ValueError:
            out[name.strip()] = value.strip()
    return out


def _whole_number(minimum):
    """An argparse type: a whole number >= ``minimum``, or an error naming the bound."""

    def parse(text):
        try:
            n = int(text)
        except ValueError:
            n = minimum - 1
        if n < minimum:
            raise argparse.ArgumentTypeError(f"expected a whole number >= {minimum}, found {text!r}")
        return n

    return parse


_samples = _whole_number(2)
_workers = _whole_number(1)


def _load(args):
    from ..scene.file import load

    return load(args.scene, _overrides(args.set))


def _emit(args, json_text, table_text):
    sys.stdout.write((json_text if args.json else table_text) + "\n")


def cmd_kinematics(args):
    from ..report import common as report
    from ..kinematics.mechanism import kinematics

    result = kinematics(_load(args), args.samples)
    _emit(args, report.to_json(report.kinematics_json(result)) if args.json else "", report.kinematics_table(result))


def cmd_analyse(args):
    from ..report import common as report
    from ..model.analysis import analyse

    result = analyse(_load(args), args.samples)
    if args.plot:
        for path in report.analysis_figures(result, args.plot):
            print(f"wrote {path}", file=sys.stderr)
    _emit(args, report.to_json(report.analysis_json(result)) if args.json else "", report.analysis_table(result))


def cmd_optimise(args):
    from pathlib import Path

    from ..report import design as design_report
    from ..report import common as report
    from ..design.optimise import optimise

    scene = _load(args)
    bar = _progress("starts")

    def progress(done, total):
        if bar is not None:
            bar(done, total)
        interrupted.check()

    with deferred_interrupt() as interrupted:
        result = optimise(scene, starts=args.starts, seed=args.seed, progress=progress, workers=args.workers)
    if result.success:
        folder = Path(args.out or Path("results") / Path(args.scene).stem)
        for path in design_report.write_results(result, folder, workers=args.workers):
            print(f"wrote {path}", file=sys.stderr)
    _emit(args, report.to_json(design_report.optimisation_json(result)) if args.json else "",
          design_report.summary(result))
    if not result.success:
        raise SolverError(f"{scene.path}: no optimum: {result.status}. {result.message} "
                          "(nothing was written to the results folder)")


class deferred_interrupt:
    """Ctrl-C while a long loop runs takes effect at the loop's next ``check()`` (after a start,
    a case): inside IPOPT, CasADi would catch the KeyboardInterrupt and report a failed solve,
    and the loop would go on.  A second Ctrl-C interrupts at once."""

    def __enter__(self):
        import signal
        import threading

        self.pending, self.previous = False, None
        if threading.current_thread() is threading.main_thread():
            self.previous = signal.signal(signal.SIGINT, self._handler)
        return self

    def _handler(self, signum, frame):
        if self.pending:
            raise KeyboardInterrupt
        self.pending = True

    def check(self):
        if self.pending:
            raise KeyboardInterrupt

    def __exit__(self, *exc):
        import signal

        if self.previous is not None:
            signal.signal(signal.SIGINT, self.previous)
        return False


def _progress(what):
    """A progress bar on standard error when it is a terminal."""
    if not sys.stderr.isatty():
        return None

    def show(done, total):
        bar = "#" * round(30 * done / total)
        end = "\n" if done == total else ""
        sys.stderr.write(f"\r{what} {done:>4}/{total} [{bar:<30}]{end}")
        sys.stderr.flush()

    return show


COMMANDS = {
    "kinematics": (cmd_kinematics, "positions, velocities and accelerations over the sweep"),
    "analyse": (cmd_analyse, "the reduced one-element model (drive torque or force) over the stroke"),
    "optimise": (cmd_optimise, "minimise the scene's objective over its design variables (IPOPT, multistart)"),
}

# Commands with many options of their own live in their own module, which must import cheaply
# (no CasADi at import time) and define HELP, add_arguments(parser) and run(args).
COMMAND_MODULES = {
    "simulate": "optdesign.cli.simulate",
    "study": "optdesign.cli.study",
}


def parser():
    top = argparse.ArgumentParser(prog="optdesign", description="Optimisation-based design of planar mechanisms.")
    sub = top.add_subparsers(dest="command", required=True)
    for name, (func, help_text) in COMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        p.add_argument("scene", help="scene file (TOML), e.g. problems/seed1_jib.toml")
        p.add_argument("--json", action="store_true", help="print JSON instead of a table")
        p.add_argument("--set", action="append", metavar="NAME=VALUE", help="override a parameter (repeatable)")
        p.add_argument("--samples", type=_samples, default=None, help="number of sweep samples, >= 2 (default: the scene's)")
        if name == "analyse":
            p.add_argument("--plot", metavar="DIR", help="write figures (PNG) into DIR")
        if name == "optimise":
            p.add_argument("--starts", type=_whole_number(1), default=20, help="number of starts, >= 1 (default 20)")
            p.add_argument("--seed", type=int, default=0, help="seed of the random starts (default 0)")
            p.add_argument("--workers", type=_workers, default=os.cpu_count() or 1,
                           help="processes that share the starts (default: the machine's cores; 1 = in this process)")
            p.add_argument("--out", metavar="DIR", help="results folder (default results/<scene name>)")
        p.set_defaults(func=func)
    for name, module_name in COMMAND_MODULES.items():
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as exc:
            if exc.name != module_name:
                raise
            continue  # not built yet
        p = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(p)
        p.set_defaults(func=module.run)
    return top


def main(argv=None):
    args = parser().parse_args(argv)
    try:
        args.func(args)
    except OptdesignError as exc:
        print(f"optdesign {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"\noptdesign {args.command}: interrupted (no result file was written or changed)", file=sys.stderr)
        return 130
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
