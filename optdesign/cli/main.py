"""The command line: a registry of subcommands, one module each (no logic here).

Each command module imports cheaply (CasADi and numpy only inside its ``run``) and defines
``HELP``, ``add_arguments(parser)`` and ``run(args)``."""
from __future__ import annotations

import argparse
import importlib
import os
import sys

from ..errors import OptdesignError, casadi_messages_hidden
from .common import prints_to_stderr

COMMANDS = ("kinematics", "analyse", "optimise", "simulate", "study", "draw", "animate")


def parser():
    top = argparse.ArgumentParser(prog="optdesign", description="Optimisation-based design of planar mechanisms.")
    top.add_argument("--version", action=Version, nargs=0, help="show program's version number and exit")
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

    plain_warnings()
    words = sys.argv[1:] if argv is None else list(argv)
    try:
        top = parser()
        args = top.parse_args(negative_values_joined(top, words))   # the options' checks import optdesign.scene (CasADi)
    except KeyboardInterrupt:
        # a Ctrl-C while the options are read (their checks import CasADi): named like any other
        command = next((" " + w for w in words if w in COMMANDS), "")
        print(f"\noptdesign{command}: interrupted ({interrupted_outcome([])})", file=sys.stderr)
        return 130
    del folder.replaced[:]
    args.argv = words   # for a message that repeats the command
    try:
        args.to_stderr = prints_to_stderr(args)     # a file option names standard output
        with quiet(args.quiet, keep_stdout=getattr(args, "json", False) or args.to_stderr), casadi_messages_hidden():
            args.func(args)
    except OptdesignError as exc:
        print(f"optdesign {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        print(f"\noptdesign {args.command}: interrupted ({interrupted_outcome(folder.replaced, exc)})",
              file=sys.stderr)
        return 130
    except RuntimeError as exc:
        if "KeyboardInterrupt" not in str(exc):   # CasADi reports a Ctrl-C inside a call this way
            raise
        print(f"\noptdesign {args.command}: interrupted ({interrupted_outcome(folder.replaced)})", file=sys.stderr)
        return 130
    return 0


def run():
    """The program (the ``optdesign`` script, ``python -m optdesign``): :func:`main`'s exit
    status.  After a Ctrl-C (130, its message printed and nothing half-written) the process
    ends at once, without the interpreter's shutdown: a late SIGINT there (seen under load
    after CasADi/IPOPT was interrupted, cause not found) killed it by the signal, exit status
    -2 instead of 130, in 6 of 6 runs with three CPU-bound jobs beside it (os._exit: 130)."""
    code = main()
    if code == 130:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):
                pass
        os._exit(130)
    return code


def plain_warnings():
    """optdesign's own warnings (a model left on CasADi's virtual machine, ...) printed as the
    line they are, without the Python file, line number and source line of where they were
    raised; other packages' warnings as Python prints them."""
    import warnings

    default = warnings.showwarning
    if getattr(default, "optdesign", False):
        return

    def show(message, category, filename, lineno, file=None, line=None):
        if category.__module__.startswith("optdesign"):
            print(message, file=file or sys.stderr)
        else:
            default(message, category, filename, lineno, file, line)
    show.optdesign = True
    warnings.showwarning = show


def negative_values_joined(top, argv) -> list:
    """``--tolerance -1e-6`` as ``--tolerance=-1e-6``: argparse takes a value that starts with
    '-' and is not a plain decimal (-1e-6, -inf) for an option, and reports 'expected one
    argument' instead of the option's own check (a finite number > 0)."""
    import re

    takes_value = set()
    for action in top._actions:
        for sub in getattr(action, "choices", None).values() if isinstance(action, argparse._SubParsersAction) else ():
            takes_value |= {o for a in sub._actions if a.nargs != 0 and a.option_strings for o in a.option_strings}
    out, i = [], 0
    while i < len(argv):
        if argv[i] in takes_value and i + 1 < len(argv) and re.match(r"^-(\d|\.\d|inf|nan)", argv[i + 1], re.I):
            out.append(f"{argv[i]}={argv[i + 1]}")
            i += 2
            continue
        out.append(argv[i])
        i += 1
    return out


class Version(argparse.Action):
    """--version, its number read from the installed package's metadata only when asked
    (importlib.metadata costs some 0.1 s of every command's start otherwise)."""

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"optdesign {version()}")   # on standard output, as argparse's own version action
        parser.exit()


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


def interrupted_outcome(replaced, exc=None) -> str:
    """What an interrupted command left behind, truthfully: every folder it replaced was
    replaced as a whole, every other one is as it was; for optimise, how many starts had
    finished and whether the best of them was saved (``exc``: an OptimisationInterrupted); for a
    motor catalogue, which motor was interrupted and what of the catalogue was saved."""
    if getattr(exc, "catalogue", None) is not None:
        return catalogue_outcome(exc, replaced)
    finished = getattr(exc, "finished", None)
    if isinstance(finished, int):
        saved = getattr(exc, "saved", None)
        head = f"after {finished} of {exc.total} starts"
        if saved is not None and _same(saved, replaced):
            return (f"{head}; the best design of those {finished} starts was written to {saved}, replaced as "
                    "a whole and marked interrupted in result.json and summary.txt")
        if not finished or exc.result is None:
            head += ", none with a feasible optimum"
        tail = interrupted_outcome(replaced)
        return f"{head}; {tail}"
    if not replaced:
        return "nothing was written: every results folder is as it was"
    return ("the new results were written before the interrupt, each folder replaced as a whole: "
            + ", ".join(str(p) for p in replaced))


def catalogue_outcome(exc, replaced) -> str:
    """An interrupted motor catalogue: the motor interrupted after how many of its starts, and
    what was saved where (the chosen motor's design, or the outcome of the motors decided)."""
    from ..report.design_cases import motor_outcomes

    cat = exc.catalogue
    outcomes = motor_outcomes(cat)
    place = next(k for k, (name, _, _) in enumerate(outcomes) if name == cat.interrupted)
    head = f"motor catalogue: interrupted while optimising motor {cat.interrupted!r} ({place + 1} of {len(outcomes)}) " + (
        f"after {exc.finished} of {exc.total} of its starts" if exc.total else "before its starts were planned")
    saved = getattr(exc, "saved", None)
    if saved is None or not _same(saved, replaced):
        return (f"{head}{', none with a feasible design and no motor decided' if cat.best is None else ''}; "
                f"{interrupted_outcome(replaced)}")
    where = f"was written to {saved}, replaced as a whole and marked interrupted in result.json and summary.txt"
    unfit = [name for name, outcome, _ in outcomes if outcome == "does not fit"]
    unfit = f"; {', '.join(unfit)} {'does' if len(unfit) == 1 else 'do'} not fit" if unfit else ""
    if cat.chosen is not None:
        return (f"{head}{unfit}; {cat.chosen!r} fits, the smallest that does: the best design of its "
                f"{exc.finished} finished start{'s' if exc.finished != 1 else ''}, with the catalogue's outcome, "
                f"{where}")
    return (f"{head}, none with a feasible design{unfit}; no motor was found to fit: the catalogue's outcome "
            f"so far {where}")


def _same(path, replaced) -> bool:
    from pathlib import Path

    return Path(path).resolve() in {Path(p).resolve() for p in replaced}


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
