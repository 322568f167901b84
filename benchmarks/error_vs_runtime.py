"""Error against run time (issue 5, part 2): the one command that writes the report.

    python benchmarks/error_vs_runtime.py [--out results/error_vs_runtime.md]

Writes ``results/error_vs_runtime.md`` and its figures ``results/error_vs_runtime/*.png``, all
measured in this one run against high-accuracy references that each section names:

  (a) derivatives of the reduced model (benchmarks/evr_derivatives.py),
  (b) the peak over the stroke (benchmarks/evr_peak.py),
  (c) motion in time (benchmarks/evr_motion.py),
  (d) optimisation (benchmarks/evr_optimise.py),
  (e) the integral over time on the sample grid of a load case (benchmarks/evr_time.py).

Each section module has ``section(out_dir) -> markdown``: it draws its figures into ``out_dir``
(whose name is ``error_vs_runtime``, so a figure is linked as ``error_vs_runtime/NAME.png``) and
returns its markdown.  Atomic: the figures go to a fresh folder that replaces the old one only
when every section has finished, and the markdown is written through a temporary file and a
rename; an interrupted run leaves the previous report as it was.  Not a test (pytest collects
only tests/).
"""
from __future__ import annotations

import argparse
import datetime
import os
import platform
import shutil
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(HERE))

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402

from benchfile import cpu_model, git_state  # noqa: E402
from optdesign.report.files import write_file  # noqa: E402

FIGURES = "error_vs_runtime"
SECTIONS = (("derivatives", "evr_derivatives"), ("peak", "evr_peak"), ("motion", "evr_motion"),
            ("optimise", "evr_optimise"), ("time", "evr_time"))


def header(started, load_start, load_end, git, durations) -> str:
    return "\n".join([
        "# Error against run time",
        "",
        f"Written by `python benchmarks/error_vs_runtime.py` on {started:%Y-%m-%d %H:%M} UTC, every number and "
        f"figure in this one run. Machine: {platform.machine()}, {cpu_model()}, nproc {os.cpu_count()}; load "
        f"average (1, 5, 15 min) at the start {', '.join(f'{v:.2f}' for v in load_start)} and at the end "
        f"{', '.join(f'{v:.2f}' for v in load_end)} (the machine may be shared: times are medians of repeats); "
        f"Python {platform.python_version()}, casadi {ca.__version__}, numpy {np.__version__}; {git}. "
        "Section run times: " + ", ".join(f"{k} {v:.0f} s" for k, v in durations.items()) + ".",
        "",
        "Every curve is error against run time: each point is (wall time of one evaluation, its error "
        "against the section's reference), both measured here. Figures are log-log.",
        "",
        "",
    ])


def run_sections(out_dir: Path):
    """Markdown of every section (in order) and the time each took."""
    import importlib

    parts, durations = [], {}
    for name, module in SECTIONS:
        t0 = time.perf_counter()
        try:
            mod = importlib.import_module(module)
        except ModuleNotFoundError as exc:
            if exc.name != module:
                raise
            parts.append(f"## ({'abcde'[[s for s, _ in SECTIONS].index(name)]}) {name}\n\nNot measured: "
                         f"benchmarks/{module}.py does not exist in this checkout.\n")
            print(f"warning: benchmarks/{module}.py not found; section '{name}' left out", file=sys.stderr)
            continue
        print(f"section {name} ...", file=sys.stderr, flush=True)
        parts.append(mod.section(out_dir).rstrip() + "\n")
        durations[name] = time.perf_counter() - t0
        print(f"section {name}: {durations[name]:.1f} s", file=sys.stderr, flush=True)
    return parts, durations


def replace_folder(new: Path, final: Path):
    """Put ``new`` in the place of ``final`` (renames; the old folder is removed afterwards)."""
    old = None
    if final.exists():
        old = final.with_name(f".{final.name}.old.{os.getpid()}")
        os.replace(final, old)
    os.replace(new, final)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=str(ROOT / "results" / "error_vs_runtime.md"))
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    started = datetime.datetime.now(datetime.timezone.utc)
    load_start = os.getloadavg()
    git = git_state(("optdesign", "benchmarks"))
    staging = Path(tempfile.mkdtemp(prefix=".evr.", dir=out.parent))
    try:
        figures = staging / FIGURES  # the folder's final name, so that links are right
        figures.mkdir()
        parts, durations = run_sections(figures)
        text = header(started, load_start, os.getloadavg(), git, durations) + "\n".join(parts)
        replace_folder(figures, out.parent / FIGURES)
        write_file(out, text)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    print(f"wrote {out} and {out.parent / FIGURES}/", file=sys.stderr)


if __name__ == "__main__":
    main()
