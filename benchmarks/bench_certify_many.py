"""What the certified extremes of an analysis cost per case, one case at a time against batches
(issue 31: model/certified.CertifiedExtremes.many, kinematics/extrema.py, branch_bound.py).

    python benchmarks/bench_certify_many.py [--scene problems/truck_crane.toml] [--cases 1024]
        [--batches 1,32,256,1024] [--repeats 3] [--base REV] [--varied mB,mP,xD,yD,b]

writes the section ``certify_many`` of results/scaling.md.  The cases: Sobol points over the
truck crane's mB, mP, xD, yD and b (tests/test_certified_many.VARIED), each case's sampled
columns and constraints computed first (not timed).  Timed (CPU time of this process, medians of
``--repeats`` rounds, compiled intervals and rows: ``OPTDESIGN_COMPILE=wait``, after a warm-up
round): the certification of every case one at a time (``CertifiedExtremes.__call__``), and in
batches of each size (``many``); every batch's results are compared with the one-at-a-time
results (equal: ==, bounds and notes included).  ``--base REV``: the same one-at-a-time
certification with the code at REV (exported with ``git archive``, run in a child process from
its own folder) on the same cases, its results compared with this code's (peaks, located s and
constraint extremes: ==; bounds: the largest relative difference).
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
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))
os.environ.setdefault("OPTDESIGN_COMPILE", "wait")

CHILD = """
import json, pickle, sys, time, statistics
import numpy as np
import optdesign
from optdesign.model.analysis import Analysis
scene, data, repeats = sys.argv[1], sys.argv[2], int(sys.argv[3])
P, columns, constraints = pickle.load(open(data, "rb"))
a = Analysis(optdesign.load(scene))
s = a.s_values
def one(i):
    return a.certified(s, P[i], {k: v[i] for k, v in columns.items()}, {k: v[i] for k, v in constraints.items()})
[one(i) for i in range(min(8, len(P)))]
times = []
for _ in range(repeats):
    t = time.process_time(); out = [one(i) for i in range(len(P))]; times.append(time.process_time() - t)
print(json.dumps({"cpu": statistics.median(times), "results": out}))
"""


def cases(analysis, n, varied):
    from test_certified_many import VARIED, crane_parameters, stacked

    P = crane_parameters(analysis, n, 5, {k: VARIED[k] for k in varied})
    columns, constraints = stacked(analysis, P)
    return P, columns, constraints


def one_at_a_time(analysis, P, columns, constraints):
    s = analysis.s_values
    return [analysis.certified(s, P[i], {k: v[i] for k, v in columns.items()}, {k: v[i] for k, v in constraints.items()})
            for i in range(len(P))]


def batched(analysis, P, columns, constraints, size):
    s, out = analysis.s_values, []
    for a in range(0, len(P), size):
        b = min(a + size, len(P))
        out += analysis.certified.many(s, P[a:b], {k: v[a:b] for k, v in columns.items()},
                                       {k: v[a:b] for k, v in constraints.items()})
    return out


def cpu(f, repeats):
    times, out = [], None
    for _ in range(repeats):
        t = time.process_time()
        out = f()
        times.append(time.process_time() - t)
    return statistics.median(times), out


def base_run(rev, scene, data, repeats):
    """The one-at-a-time certification at ``rev`` in a child process run from its own folder."""
    with tempfile.TemporaryDirectory() as tmp:
        sys.path.insert(0, str(ROOT / "benchmarks"))
        from benchfile import export

        export(rev, tmp, ("optdesign",))
        env = {**os.environ, "PYTHONPATH": tmp}
        out = subprocess.run([sys.executable, "-c", CHILD, str(ROOT / scene), data, str(repeats)], cwd=tmp, env=env,
                             check=True, capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def compare(old, new):
    """(peaks, s and constraint extremes all ==, the largest relative difference of the bounds)."""
    same, worst = True, 0.0
    for a, b in zip(old, new):
        same &= a["peaks"] == b["peaks"] and a["constraint_extremes"] == b["constraint_extremes"]
        same &= all(a["peak_at"][k]["s"] == b["peak_at"][k]["s"] for k in a["peak_at"])
        for k, c in a["certificates"].items():
            x, y = c["bound"], b["certificates"][k]["bound"]
            if x is not None and y is not None:
                worst = max(worst, abs(x - y) / max(abs(x), 1e-300))
    return same, worst


def main(argv=None):
    import optdesign
    from optdesign.model.analysis import Analysis

    from benchfile import SCALING_MD, cpu_model, git_state, write_section

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default="problems/truck_crane.toml")
    ap.add_argument("--cases", type=int, default=1024)
    ap.add_argument("--batches", default="1,32,256,1024")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--base", default=None, help="a commit whose one-at-a-time certification to compare")
    ap.add_argument("--varied", default="mB,mP,xD,yD,b", help="the parameters the cases vary (of mB,mP,xD,yD,b)")
    args = ap.parse_args(argv)
    load = os.getloadavg()
    analysis = Analysis(optdesign.load(ROOT / args.scene))
    varied = args.varied.split(",")
    P, columns, constraints = cases(analysis, args.cases, varied)
    sizes = [int(x) for x in args.batches.split(",")]
    one_at_a_time(analysis, P[:8], *(dict((k, v[:8]) for k, v in d.items()) for d in (columns, constraints)))
    for size in sizes:   # warm-up: the mapped functions of each size built, the libraries loaded
        batched(analysis, P[:size], *(dict((k, v[:size]) for k, v in d.items()) for d in (columns, constraints)), size)
    t_one, alone = cpu(lambda: one_at_a_time(analysis, P, columns, constraints), args.repeats)
    rows = [("one at a time (`__call__`)", t_one, True)]
    for size in sizes:
        t, found = cpu(lambda: batched(analysis, P, columns, constraints, size), args.repeats)
        rows.append((f"batches of {size} (`many`)", t, found == alone))
    base = None
    if args.base:
        with tempfile.TemporaryDirectory() as tmp:
            import pickle

            data = Path(tmp) / "cases.pickle"
            data.write_bytes(pickle.dumps((P, columns, constraints)))
            base = base_run(args.base, args.scene, str(data), args.repeats)
        same, worst = compare(base["results"], alone)
    n = args.cases
    lines = ["# Certified extremes of many cases (issue 31)", "",
             f"`python benchmarks/bench_certify_many.py --scene {args.scene} --cases {n} --batches {args.batches} "
             f"--repeats {args.repeats}" + (f" --base {args.base}" if args.base else "")
             + (f" --varied {args.varied}" if args.varied != "mB,mP,xD,yD,b" else "") + f"` at {git_state()}, "
             f"{time.strftime('%Y-%m-%d %H:%M', time.gmtime())} UTC, {cpu_model()}, load average {load[0]:.1f} at the "
             f"start and {os.getloadavg()[0]:.1f} at the end.  {n} cases (Sobol {', '.join(varied)}), each case's "
             "sampled columns computed first (not timed); CPU time of the certification alone "
             "(`CertifiedExtremes`), compiled intervals and rows, median of the rounds.", "",
             "| run | CPU per case [ms] | one at a time's CPU / this | " + (f"base's CPU / this | " if base else "")
             + "results equal one at a time's (==) |", "|---|---|---|" + ("---|" if base else "") + "---|"]
    if base is not None:
        lines.append(f"| base {args.base}, one at a time | {base['cpu'] / n * 1e3:.3f} | {t_one / base['cpu']:.2f} | 1.00 | "
                     f"peaks, s, constraint extremes: {'identical' if same else 'DIFFERENT'}; bounds within {worst:.1e} "
                     "(relative) |")
    lines += [f"| {name} | {t / n * 1e3:.3f} | {t_one / t:.2f} | " + (f"{base['cpu'] / t:.2f} | " if base else "")
              + f"{'yes' if eq else 'NO'} |" for name, t, eq in rows]
    text = "\n".join(lines) + "\n"
    print(text)
    write_section("certify_many", text, SCALING_MD)


if __name__ == "__main__":
    main()
