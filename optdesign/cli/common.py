"""What every command shares: scene loading with --set, whole-number options, output, the progress
bar and deferred Ctrl-C.  Imports cheaply (nothing heavy at module level)."""
from __future__ import annotations

import argparse
import sys

from ..errors import OptdesignError, SceneError
from .progress import progress_bar  # noqa: F401  (the commands' progress)


def overrides(pairs):
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


def whole_number(minimum, maximum=None):
    """An argparse type: a whole number >= ``minimum`` (optdesign.scene.arguments.whole)."""

    def parse(text):
        from ..scene.arguments import whole

        try:
            value = int(text)
        except ValueError:
            try:
                value = float(text)          # 1e4
            except ValueError:
                value = None
        try:
            if value is None:
                raise TypeError
            return whole("", value, minimum, maximum, shown=repr(text))
        except (TypeError, ValueError):
            expected = f"a whole number >= {minimum}" + (f" and <= {maximum:,}" if maximum is not None else "")
            raise argparse.ArgumentTypeError(f"expected {expected}, found {text!r}") from None

    return parse


def real_number(above=None, below=None, at_most=None):
    """An argparse type: a finite number in the range given (optdesign.scene.arguments.real)."""

    def parse(text):
        from ..scene.arguments import real

        try:
            value = float(text)
        except ValueError:
            value = text
        try:
            return real("", value, above=above, below=below, at_most=at_most, shown=repr(text))
        except TypeError:
            raise argparse.ArgumentTypeError(f"expected a number, found {text!r}") from None
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None

    return parse


samples = whole_number(2)
workers = whole_number(1)
seed = whole_number(0)


def add_scene_arguments(p, scene_help="scene file (TOML), e.g. problems/seed1_jib.toml"):
    """The options every single-scene command takes: the scene, --json, --set, --samples."""
    p.add_argument("scene", help=scene_help)
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help="override a parameter (repeatable)")
    p.add_argument("--samples", type=samples, default=None, help="number of sweep samples, >= 2 (default: the scene's)")


def load_scene(args):
    from ..scene.file import load

    return load(args.scene, overrides(args.set))


def results_folder(path, flag, produces):
    """The folder an option names, checked before any work: it will be replaced as a whole, so it
    must be new, empty or hold only what optdesign writes there (see optdesign.report.folder)."""
    from ..report.folder import inspect

    inspect(path, produces, flag)
    return path


FILE_OPTIONS = {"analyse": ("csv",), "draw": ("out", "dxf", "svg"), "animate": ("out",)}


def output_file(path, flag):
    """A single file an option names, checked before any work (report/files.py: a folder, a path
    under a file, a read-only folder, /proc are errors now, not after the computation)."""
    from ..report.files import target

    target(path, flag)
    return path


def prints_to_stderr(args) -> bool:
    """Whether a file option of the command names standard output (``-``, ``/dev/stdout``): the
    file is then what standard output carries, and what the command prints goes to standard
    error.  Two options naming it are an error."""
    from ..report.files import names_stdout

    taken = [f"--{o}" for o in FILE_OPTIONS.get(args.command, ()) if names_stdout(getattr(args, o, None))]
    if len(taken) > 1:
        raise OptdesignError(f"{' and '.join(taken)}: only one file can go to standard output")
    return bool(taken)


def emit(args, json_part, table_part):
    """Print the --json document or the table.  Each part is a string, a dict (a JSON document,
    its :class:`~optdesign.report.output.Rows` streamed), an iterable of text pieces, or a
    function returning one (only the part printed is made); printed piece by piece."""
    part = json_part if args.json else table_part
    if callable(part):
        part = part()
    if isinstance(part, dict):
        from ..report.output import json_chunks

        part = json_chunks(part)
    elif isinstance(part, str):
        part = (part,)
    write_out(part, sys.stderr if getattr(args, "to_stderr", False) else None)


def write_out(pieces, stream=None):
    """Write text pieces and a final newline to standard output.  A reader that stops reading
    (``| head``) ends the command quietly (status 141, as SIGPIPE would); a full disk or another
    write error is an error saying the output is incomplete.  ``stream``: standard error instead."""
    import os

    if stream is not None:
        stream.write("".join(pieces) + "\n")
        return
    try:
        for piece in pieces:
            sys.stdout.write(piece)
        sys.stdout.write("\n")
        sys.stdout.flush()
    except BrokenPipeError:
        _discard_stdout(os)
        raise SystemExit(141) from None
    except OSError as exc:
        _discard_stdout(os)
        raise OptdesignError(f"standard output: {exc.strerror or exc}: the output is incomplete") from None


def _discard_stdout(os):
    """What is still buffered for standard output goes nowhere (no second error at exit)."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError):
        pass
