"""What a batch of analyse cases costs on a study's worker, stage by stage (issue 31).

    python benchmarks/bench_worker_batch.py [--sizes 256,1024] [--repeats 5] [--base REV]

writes the section ``worker_batch`` of results/scaling.md.  An analyse study of the truck crane
(problems/truck_crane.toml, boom mass mB x payload mP: leaf parameters), one batch of N cases
as a pool's process computes it (``executors.computed``: the tasks made, each case prepared,
``Analysis.run_many``, ``sweep_rms_many``, the rows and their blocks, the journal's text), then
pickled back and unpickled (the client's side of the pipe).  CPU time of the process (compiled
code from the disk cache: ``OPTDESIGN_COMPILE=wait``, after a warm-up batch), medians of
``--repeats`` rounds; each stage's CPU is its function's (inclusive), "rows and blocks, the
rest" what the batch costs besides the stages named.  The certification of extremes is shown
apart and left out of the total "without certification" (another line of work).

The process keeps freed memory as the code's pool process does (``errors.keep_freed_memory``,
where the code has it).

``--base REV``: the same measurement with the code at REV (exported with ``git archive``) in a
child process, the two codes' rounds interleaved, and the batch's journal lines (their time_s
apart) and CSV cells compared byte for byte.
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
os.environ.setdefault("OPTDESIGN_COMPILE", "wait")

# (module, class or None, function, the stage's name): wrapped where the code measured has them
STAGES = (
    ("optdesign.study.tasks", None, "_prepare", "prepare the cases"),
    ("optdesign.study.tasks", None, "prepare_all", "prepare the cases"),
    ("optdesign.study.analysed", None, "_prepare", "prepare the cases"),
    ("optdesign.study.analysed", None, "prepare_all", "prepare the cases"),
    ("optdesign.model.analysis", None, "run_cases", "run_many"),
    ("optdesign.model.runs", None, "_model_values", "model columns (compiled)"),
    ("optdesign.model.runs", None, "_certified", "certification"),
    ("optdesign.model.analysis", "Analysis", "sweep_rms_many", "sweep_rms_many"),
    ("optdesign.study.blocks", "Block", "lines", "journal text and CSV cells"),
    ("optdesign.study.blocks", "Block", "journal", "journal text and CSV cells"),   # (since it ships its lines as bytes)
)
SHOWN = ("prepare the cases", "run_many without certification", "of which model columns (compiled)",
         "sweep_rms_many", "rows and blocks, the rest", "journal text and CSV cells", "pickle out (worker)",
         "unpickle (client)", "all without certification", "certification (apart)")



def child(n, repeats):
    """One code's rounds (run with that code on PYTHONPATH): JSON lines, a round per line read
    from stdin's "go" (so that two codes' rounds interleave), the batch's text at the end."""
    import pickle
    import re

    import optdesign
    from benchfile import wrap_stages
    from optdesign import errors

    if hasattr(errors, "keep_freed_memory"):   # the memory settings of the code's pool process (since 8a9da6d)
        errors.keep_freed_memory()
    from optdesign.study import Study, executors, grid
    from optdesign.study.tasks import scene_digest

    study = Study(optdesign.load(ROOT / "problems" / "truck_crane.toml"),
                  [grid("mB", 500, 800, 8), grid("mP", 500, 3000, n // 8)], mode="analyse")
    refs, overrides, bounds = study.cases().batch(list(range(n)))
    blob, digest = pickle.dumps(study.scene), scene_digest(study.scene)
    index, ids = [r.index for r in refs], [r.id for r in refs]

    def batch():
        return executors.computed(study.tasks(overrides, bounds, None, blob, digest), index, ids)

    batch()   # warm: the model built, compiled code loaded
    spent = {}
    wrap_stages(STAGES, spent)
    for _ in range(repeats):
        sys.stdin.readline()
        spent.clear()
        t0 = time.process_time()
        made = batch()
        t1 = time.process_time()
        data = pickle.dumps(made, protocol=pickle.HIGHEST_PROTOCOL)
        t2 = time.process_time()
        back = pickle.loads(data)
        t3 = time.process_time()
        print(json.dumps({"batch": t1 - t0, "pickle": t2 - t1, "unpickle": t3 - t2, "bytes": len(data),
                          "stages": spent}), flush=True)
    timeless = re.compile(r'"time_s":[^}]*}')
    text = {"lines": [timeless.sub("", line) for b in back for line in b.lines()],
            "cells": [b.cells(k) for b in back for k in b.keys]}
    print(json.dumps(text), flush=True)


def per_stage(rounds, n) -> dict:
    """Medians over the rounds of each stage's CPU ms per case."""
    def med(f):
        return statistics.median(f(r) for r in rounds) / n * 1e3

    def stage(name):
        return lambda r: r["stages"].get(name, 0.0)

    out = {"prepare the cases": med(stage("prepare the cases")),
           "run_many without certification": med(lambda r: stage("run_many")(r) - stage("certification")(r)),
           "of which model columns (compiled)": med(stage("model columns (compiled)")),
           "sweep_rms_many": med(stage("sweep_rms_many")),
           "journal text and CSV cells": med(stage("journal text and CSV cells")),
           "rows and blocks, the rest": med(lambda r: r["batch"] - sum(r["stages"].get(s, 0.0) for s in (
               "prepare the cases", "run_many", "sweep_rms_many", "journal text and CSV cells"))),
           "pickle out (worker)": med(lambda r: r["pickle"]), "unpickle (client)": med(lambda r: r["unpickle"]),
           "all without certification": med(lambda r: r["batch"] - stage("certification")(r) + r["pickle"]
                                            + r["unpickle"]),
           "certification (apart)": med(stage("certification"))}
    out["bytes per case"] = statistics.median(r["bytes"] for r in rounds) / n
    return out


def measure(codes, n, repeats) -> dict:
    """Each code's rounds, interleaved, and its batch's text."""
    procs = {name: subprocess.Popen([sys.executable, str(Path(__file__).resolve()), "--child", str(n), str(repeats)],
                                    cwd=code, env={**os.environ, "PYTHONPATH": str(code)}, stdin=subprocess.PIPE,
                                    stdout=subprocess.PIPE, text=True) for name, code in codes.items()}
    rounds = {name: [] for name in codes}
    for _ in range(repeats):
        for name, proc in procs.items():
            proc.stdin.write("go\n")
            proc.stdin.flush()
            rounds[name].append(json.loads(proc.stdout.readline()))
    texts = {name: json.loads(proc.stdout.readline()) for name, proc in procs.items()}
    for proc in procs.values():
        proc.stdin.close()
        if proc.wait():
            raise SystemExit("a measurement failed")
    return {name: (per_stage(rounds[name], n), texts[name]) for name in codes}


def main(argv=None):
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from benchfile import SCALING_MD, cpu_model, export, git_state, write_section

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="256,1024")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--base", default=None, help="a commit to measure in the same run")
    args = ap.parse_args(argv)
    sizes = [int(s) for s in args.sizes.split(",")]
    load = os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp:
        codes = {}
        if args.base:
            codes[f"base {args.base}"] = export(args.base, tmp)
        codes["this"] = ROOT
        results = {n: measure(codes, n, args.repeats) for n in sizes}
    command = f"python benchmarks/bench_worker_batch.py --sizes {args.sizes} --repeats {args.repeats}" + (
        f" --base {args.base}" if args.base else "")
    head = " | ".join(f"{name} [ms]" for name in codes)
    lines = ["# An analyse batch on a study's worker, stage by stage (issue 31)", "",
             f"`{command}` at {git_state()}, {time.strftime('%Y-%m-%d %H:%M', time.gmtime())} UTC, {cpu_model()}, "
             f"load average {load[0]:.1f} at the start and {os.getloadavg()[0]:.1f} at the end (shared machine).  "
             "Truck crane, boom mass x payload (leaf parameters); one batch as a pool's process computes it "
             "(`executors.computed`), pickled back and unpickled; CPU per case, medians of "
             f"{args.repeats} rounds (the codes' rounds interleaved).  The certification of extremes is shown apart "
             "and not in the total.", "",
             f"| cases per batch | stage | {head} |" + (" this / base |" if args.base else ""),
             "|---|---|" + "---|" * len(codes) + ("---|" if args.base else "")]
    for n, got in results.items():
        for stage in SHOWN + ("bytes per case",):
            cells = [got[name][0][stage] for name in codes]
            ratio = f" {cells[-1] / cells[0]:.2f} |" if args.base and cells[0] > 0 else (" - |" if args.base else "")
            fmt = "{:.0f}" if stage == "bytes per case" else "{:.4f}"
            label = f"**{stage}**" if stage == "all without certification" else stage
            lines.append(f"| {n:,} | {label} | " + " | ".join(fmt.format(c) for c in cells) + " |" + ratio)
    lines.append("")
    if args.base:
        same = all(got[f"base {args.base}"][1] == got["this"][1] for got in results.values())
        lines.append("The batches' journal lines (time_s apart) and CSV cells: "
                     + ("byte-identical to the base's." if same else "DIFFERENT from the base's."))
    text = "\n".join(lines) + "\n"
    print(text)
    write_section("worker_batch", text, SCALING_MD)


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        child(int(sys.argv[2]), int(sys.argv[3]))
    else:
        main()
