"""What the benchmark scripts share: the machine and commit they ran on, and
``results/bench.md``, which holds one section per benchmark script; each script rewrites only its own
section (between ``<!-- begin NAME -->`` and ``<!-- end NAME -->``) and leaves the others as
they were, atomically (the file is never half-written)."""
from __future__ import annotations

import os
import platform
import re
import statistics
import subprocess
import time
from pathlib import Path

from optdesign.report.files import write_file

ROOT = Path(__file__).resolve().parents[1]
BENCH_MD = ROOT / "results" / "bench.md"
ORDER = ("reduced_model", "optimise", "per_start", "study", "commands")   # the order of the sections in the file
TITLE = "# Benchmarks\n\nEach section is written by the script it names, in one run of that script; ratios are measured within one run.\n"


SCALING_MD = ROOT / "results" / "scaling.md"
TITLES = {SCALING_MD: "# Scaling\n\nEach section is written by the script it names, in one run of that script.\n"}
ORDERS = {SCALING_MD: ("problem_size", "study_scale", "study_io", "study_large", "study_large_resumed", "study_large_client",
                      "study_dask")}


def write_section(name: str, markdown: str, path: Path = BENCH_MD) -> Path:
    """Replace (or add) section ``name`` of ``path`` with ``markdown`` (its headings one level
    down, under the file's title: results/bench.md's, or results/scaling.md's)."""
    path = Path(path)
    title = TITLES.get(path.resolve(), TITLE)
    order = ORDERS.get(path.resolve(), ORDER)
    markdown = re.sub(r"^#", "##", markdown, flags=re.M)
    text = path.read_text() if path.exists() else ""
    sections = {m.group(1): m.group(0) for m in
                re.finditer(r"<!-- begin (\w+) -->\n.*?<!-- end \1 -->\n", text, flags=re.S)}
    sections[name] = f"<!-- begin {name} -->\n{markdown.rstrip()}\n<!-- end {name} -->\n"
    names = [n for n in order if n in sections] + sorted(n for n in sections if n not in order)
    write_file(path, title + "\n" + "\n".join(sections[n] for n in names))
    return path


def git_state(paths=("optdesign",)) -> str:
    """The commit measured, and whether ``paths`` had uncommitted changes (other people may
    work in the same tree)."""
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                              text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--", *paths], cwd=ROOT,
                               capture_output=True, text=True).stdout.rstrip()
    except (OSError, subprocess.CalledProcessError):
        return "git state unknown"
    if not dirty:
        return f"commit {head}"
    return f"commit {head} with uncommitted changes in " + ", ".join(line[3:] for line in dirty.splitlines())


def against(old) -> tuple:
    """(the older checkout ``old`` resolved, its short commit, this tree's :func:`git_state`, the
    environment for the children: without PYTHONPATH and OPTDESIGN_COMPILE) of a benchmark that
    runs an older commit beside this code."""
    old = Path(old).resolve()
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=old, capture_output=True,
                            text=True).stdout.strip()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "OPTDESIGN_COMPILE")}
    return old, commit, git_state(), env


def export(rev: str, folder, paths=("optdesign", "problems")) -> Path:
    """The files ``paths`` of commit ``rev`` written into ``folder`` (made if missing) with
    ``git archive``: an older code for a benchmark to run beside this one.  Returns the folder."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    archive = subprocess.run(["git", "archive", rev, *paths], cwd=ROOT, check=True, capture_output=True)
    subprocess.run(["tar", "-x", "-C", str(folder)], input=archive.stdout, check=True)
    return folder


def cpu_model() -> str:
    """The processor's model name (Linux), else what platform knows."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def wrap_stages(stages, spent):
    """Wrap each stage's function to add its CPU time to ``spent`` (outermost call only):
    ``stages`` holds (module, class or None, function, the stage's name); a module or function
    the code measured does not have is left out (an older commit's code)."""
    import importlib

    depth = {}
    for module, cls, func, stage in stages:
        try:
            owner = importlib.import_module(module)
        except ImportError:
            continue
        owner = getattr(owner, cls) if cls else owner
        if not hasattr(owner, func):
            continue
        original = getattr(owner, func)

        def timed(*args, _original=original, _stage=stage, **kwargs):
            depth[_stage] = depth.get(_stage, 0) + 1
            t = time.process_time()
            try:
                return _original(*args, **kwargs)
            finally:
                depth[_stage] -= 1
                if not depth[_stage]:
                    spent[_stage] = spent.get(_stage, 0.0) + time.process_time() - t

        setattr(owner, func, timed)


def median_time(f, repeats):
    """Median wall time of ``repeats`` calls of f() and the last call's value."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        value = f()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), value
