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
    sub = top.add_subparsers(dest="command", required=True)
    for name in COMMANDS:
        module = importlib.import_module(f"{__package__}.{name}")
        p = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(p)
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
        args.func(args)
    except OptdesignError as exc:
        print(f"optdesign {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"\noptdesign {args.command}: interrupted ({interrupted_outcome(folder.replaced)})", file=sys.stderr)
        return 130
    return 0


def interrupted_outcome(replaced) -> str:
    """What an interrupted command left behind, truthfully: every folder it replaced was
    replaced as a whole, every other one is as it was."""
    if not replaced:
        return "nothing was written: every results folder is as it was"
    return ("the new results were written before the interrupt, each folder replaced as a whole: "
            + ", ".join(str(p) for p in replaced))


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
