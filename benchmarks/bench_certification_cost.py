"""What the interval-enclosure certificate (issue 27: kinematics/enclosure.py, peaks.certify)
costs, against the code before it.

    python benchmarks/bench_certification_cost.py [--baseline REV|numpy] [--label TEXT] [--repeats N] [--starts N] [--runs N]

writes results/certification_cost.md.  The baseline is the code at REV (default a267455, the
last commit before the enclosure; ``--label`` says what it is), exported with ``git archive`` into
a temporary folder, or ``numpy``: this tree with its interval programs run by numpy
(``OPTDESIGN_INTERVALS=numpy``) instead of compiled C.  Every run compiles what it misses at once
(``OPTDESIGN_COMPILE=wait``; the warm-up runs fill the cache); every
measurement runs in a fresh Python process with one tree as its working directory and on its
path, baseline and current interleaved, so that the shared machine's load falls on both alike.
Times are medians of ``--repeats`` runs.

Measured per scene: the whole command ``optdesign analyse SCENE`` (start-up included, wall
time); inside one process, ``Analysis.run()`` (CPU time: less hostage to the machine's load) with the peaks certified against the same run with
``certify=False`` (assembly and dead centres still checked), after a warm-up run, on each
tree (the two analyses' runs in turn; the ratio the median of the pairs' ratios; ``--repeats``
processes per tree, the trees in turn); and ``optdesign optimise SCENE --starts N --workers 1 --no-animation`` (one process, so
that the time is the work, not the pool's scheduling).
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ANALYSE = ["problems/seed1_slider_crank.toml", "problems/lib_excavator_boom.toml", "problems/crank_press_peak.toml",
           "problems/lib_toggle_press.toml", "tests/data/issue27/knuckle_press.toml"]
OPTIMISE = ["problems/crank_press_peak.toml", "problems/lib_excavator_boom.toml"]
RUN = """
import json, sys, time, statistics
import optdesign
from optdesign.model.analysis import Analysis
scene = optdesign.load(sys.argv[1])
out, times, runs = {}, {True: [], False: []}, {}
for certify in (True, False):
    runs[certify] = Analysis(scene, certify=certify)
    runs[certify].run()
for _ in range(int(sys.argv[2])):   # certified and not in turn: the machine's load falls on both alike
    for certify, a in runs.items():
        t0 = time.process_time(); r = a.run(); times[certify].append(time.process_time() - t0)
        out["peak_" + str(certify)] = r.peaks["drive"]
for certify in (True, False):
    out[str(certify)] = statistics.median(times[certify])
out["ratio"] = statistics.median(c / u for c, u in zip(times[True], times[False]))
print(json.dumps(out))
"""


def _env(tree) -> dict:
    path, extra = tree
    return {"PYTHONPATH": str(path), "MPLBACKEND": "Agg", "PATH": "/usr/bin:/bin", "OPTDESIGN_COMPILE": "wait",
            **{k: os.environ[k] for k in ("HOME", "OPTDESIGN_CACHE_DIR") if k in os.environ}, **extra}


def timed(cmd, tree) -> float:
    t0 = time.perf_counter()
    subprocess.run(cmd, cwd=tree[0], env=_env(tree), check=True, capture_output=True)
    return time.perf_counter() - t0


def inside(tree, scene, repeats) -> dict:
    out = subprocess.run([sys.executable, "-c", RUN, str(ROOT / scene), str(repeats)], cwd=tree[0], check=True,
                         capture_output=True, text=True, env=_env(tree))
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--baseline", default="a267455")
    ap.add_argument("--label", default="the last commit before the enclosure", help="what the baseline is")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--starts", type=int, default=4)
    ap.add_argument("--runs", type=int, default=15, help="Analysis.run() calls timed per tree and scene (median)")
    args = ap.parse_args(argv)
    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp:
        if args.baseline == "numpy":
            trees = {"before": (ROOT, {"OPTDESIGN_INTERVALS": "numpy"}), "after": (ROOT, {})}
        else:
            sys.path.insert(0, str(ROOT / "benchmarks"))
            from benchfile import export

            base = export(args.baseline, Path(tmp) / "baseline", ("optdesign",))
            trees = {"before": (base, {}), "after": (ROOT, {})}
        rows_a, rows_i, rows_o = [], [], []
        for scene in ANALYSE:
            cmd = [sys.executable, "-m", "optdesign", "analyse", str(ROOT / scene)]
            for tree in trees.values():   # warm the compile cache
                timed(cmd, tree)
            t = {k: [] for k in trees}
            for _ in range(args.repeats):
                for k, tree in trees.items():
                    t[k].append(timed(cmd, tree))
            med = {k: statistics.median(v) for k, v in t.items()}
            rows_a.append((scene, med["before"], med["after"]))
            got = {k: [] for k in trees}
            for _ in range(args.repeats):   # the two trees in turn, each in a fresh process
                for k, tree in trees.items():
                    got[k].append(inside(tree, scene, args.runs))
            ins = {k: {**v[0], **{key: statistics.median(x[key] for x in v) for key in ("True", "False", "ratio")}}
                   for k, v in got.items()}
            rows_i.append((scene, ins))
        for scene in OPTIMISE:
            t = {k: [] for k in trees}
            for r in range(args.repeats + 1):
                for k, tree in trees.items():
                    out = Path(tmp) / f"out_{k}_{r}"
                    dt = timed([sys.executable, "-m", "optdesign", "optimise", str(ROOT / scene), "--starts",
                                str(args.starts), "--workers", "1", "--no-animation", "--out", str(out)], tree)
                    if r:   # the first round warms the compile cache
                        t[k].append(dt)
            med = {k: statistics.median(v) for k, v in t.items()}
            rows_o.append((scene, med["before"], med["after"]))
    load_after = os.getloadavg()
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout.strip()
    lines = ["# The cost of the enclosure certificate (issue 27)", "",
             f"`python benchmarks/bench_certification_cost.py --baseline {args.baseline} --label '{args.label}' "
             f"--repeats {args.repeats} --starts {args.starts} "
             f"--runs {args.runs}` at "
             f"{commit} (after) against {args.baseline} (before: {args.label}), "
             f"{datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC, on a shared 2-core machine (other jobs running, load "
             f"average {load_before[0]:.1f} at the start and {load_after[0]:.1f} at the end: the ratios, measured "
             "interleaved, mean more than the times).  Medians.", "",
             "## `optdesign analyse SCENE` (whole command)", "",
             "| scene | before [s] | after [s] | after / before |", "|---|---|---|---|"]
    lines += [f"| {s} | {b:.2f} | {a:.2f} | {a / b:.2f} |" for s, b, a in rows_a]
    lines += ["", f"## `Analysis.run()` inside one process (after a warm-up run; CPU time of the process, median of "
              f"{args.runs} runs, certified and certify=False in turn; the ratio the median of the {args.runs} "
              f"pairs' ratios; each figure the median of {args.repeats} processes per tree, the trees in turn)", "",
              "| scene | before: certify=False [ms] | before: certified [ms] | after: certify=False [ms] | "
              "after: certified [ms] | certified after / before | certified / certify=False, before -> after | "
              "peak |drive| before -> after |",
              "|---|---|---|---|---|---|---|---|"]
    for s, ins in rows_i:
        b, a = ins["before"], ins["after"]
        lines.append(f"| {s} | {1e3 * b['False']:.2f} | {1e3 * b['True']:.2f} | {1e3 * a['False']:.2f} | {1e3 * a['True']:.2f} | "
                     f"{a['True'] / b['True']:.2f} | {b['ratio']:.2f} -> {a['ratio']:.2f} | "
                     f"{b['peak_True']:.10g} -> {a['peak_True']:.10g} |")
    lines += ["", f"## `optdesign optimise SCENE --starts {args.starts} --workers 1 --no-animation`", "",
              "| scene | before [s] | after [s] | after / before |", "|---|---|---|---|"]
    lines += [f"| {s} | {b:.2f} | {a:.2f} | {a / b:.2f} |" for s, b, a in rows_o]
    from optdesign.report.files import write_file   # atomic: never half-written

    path = write_file(ROOT / "results" / "certification_cost.md", "\n".join(lines) + "\n")
    print("\n".join(lines))
    return path


if __name__ == "__main__":
    main()
