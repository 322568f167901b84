"""The command line: a registry of subcommands, one module each (no logic here).

Each command module imports cheaply (CasADi and numpy only inside its ``run``) and defines
``HELP``, ``add_arguments(parser)`` and ``run(args)``."""
from __future__ import annotations

import argparse
import importlib
import sys

from ..errors import OptdesignError

COMMANDS = ("kinematics", "analyse", "optimise", "simulate", "study", "draw", "animate")


def parser():
    top = argparse.ArgumentParser(prog="optdesign", description="Optimisation-based design of planar mechanisms.")
    top.add_argument("--version", action="version", version=f"optdesign {version()}")
    sub = top.add_subparsers(dest="command", required=True)
    for name in COMMANDS:
        module = importlib.import_module(f"{__package__}.{name}")
        p = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(p)
        p.add_argument("-q", "--quiet", action="store_true",
                       help="print nothing but errors (with --json, only the JSON document)")
        p.set_defaults(func=module.run)
    return top


def main(argv=None):
    from ..report import folder

    try:
        args = parser().parse_args(argv)   # the options' checks import optdesign.scene (CasADi)
    except KeyboardInterrupt:
        print(f"\noptdesign: interrupted ({interrupted_outcome([])})", file=sys.stderr)
        return 130
    del folder.replaced[:]
    try:
        with quiet(args.quiet, keep_stdout=getattr(args, "json", False)):
            args.func(args)
    except OptdesignError as exc:
        print(f"optdesign {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"\noptdesign {args.command}: interrupted ({interrupted_outcome(folder.replaced)})", file=sys.stderr)
        return 130
    return 0


def version() -> str:
    from importlib import metadata

    try:
        return metadata.version("optdesign")
    except metadata.PackageNotFoundError:  # pragma: no cover - a plain checkout, not installed
        return "(not installed)"


class quiet:
    """With ``on``: standard output (unless ``keep_stdout``) and standard error go nowhere while
    the command runs: no tables, summaries, 'wrote' lines or progress bars.  Errors are printed
    after it, so they still show."""

    def __init__(self, on, keep_stdout=False):
        self.on, self.keep_stdout = on, keep_stdout

    def __enter__(self):
        if self.on:
            import os

            self.saved = sys.stdout, sys.stderr
            self.null = open(os.devnull, "w")
            sys.stderr = self.null
            if not self.keep_stdout:
                sys.stdout = self.null
        return self

    def __exit__(self, *exc):
        if self.on:
            sys.stdout, sys.stderr = self.saved
            self.null.close()
        return False


def interrupted_outcome(replaced) -> str:
    """What an interrupted command left behind, truthfully: every folder it replaced was
    replaced as a whole, every other one is as it was."""
    if not replaced:
        return "nothing was written: every results folder is as it was"
    return ("the new results were written before the interrupt, each folder replaced as a whole: "
            + ", ".join(str(p) for p in replaced))


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
