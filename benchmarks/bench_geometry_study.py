"""Analyse studies whose axes are geometry: what each stage of ``Analysis.run_many`` costs per case
(issue 31).

    python benchmarks/bench_geometry_study.py [--cases 256] [--load-cases 16] [--batch 256]
        [--repeats 3] [--base REV]

writes the section ``geometry_study`` of results/scaling.md.  Three studies of Sobol points over
pivot coordinates, so that every case is a distinct geometry:

* the truck crane (problems/truck_crane.toml) over its cylinder base xD, yD and rod eye b
  (``--cases`` cases; some do not assemble, or reach a dead centre, part of the stroke);
* the hatch cover (problems/hatch_cover.toml, three load cases: open, close, open with snow)
  over its cylinder base xD, yD and rod eye b (``--load-cases`` cases);
* the ventilator (problems/ventilator_squeeze.toml: a four-bar, two load cases on laws in time)
  over its crank, coupler and rocker lengths a, b, c (``--load-cases`` cases; most do not
  assemble part of the stroke: the assembly check's errors are much of its work).

Timed: ``Analysis.run_many`` over the cases in batches of ``--batch``, CPU time of the process
(compiled intervals and rows: ``OPTDESIGN_COMPILE=wait``, after a warm-up batch), medians of
``--repeats`` rounds; each stage's CPU is measured by wrapping its function (inclusive: the load
cases' CPU holds their peaks' and integrals').  ``--base REV``: the same measurement with the code
at REV (exported with ``git archive``) in a child process, run in the same run (rounds
interleaved), and every case's figures compared with this code's (==).
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

STUDIES = {
    "truck_crane": ("problems/truck_crane.toml", {"xD": (-0.1, 0.6), "yD": (-1.8, -0.9), "b": (0.7, 1.6)}),
    "hatch_cover": ("problems/hatch_cover.toml", {"xD": (-0.2, 0.8), "yD": (-1.2, -0.3), "b": (0.25, 1.2)}),
    "ventilator_squeeze": ("problems/ventilator_squeeze.toml", {"a": (0.018, 0.032), "b": (0.08, 0.12), "c": (0.065, 0.095)}),
}
# (module, class or None, function, the stage's name): wrapped when the code measured has them
STAGES = (
    ("optdesign.kinematics.assembly", "AssemblyCheck", "many", "assembly check"),
    ("optdesign.model.reduction", "ReducedModel", "dead_centres", "dead centres"),
    ("optdesign.model.runs", None, "_model_values", "model"),
    ("optdesign.model.certified", "CertifiedExtremes", "many", "certified extremes"),
    ("optdesign.model.cases", "CaseAnalysis", "run", "load cases"),
    ("optdesign.model.cases", "CaseAnalysis", "run_many", "load cases"),
)


def parameters(analysis, axes, n, seed=1):
    """``n`` parameter vectors: the scene's, with ``axes`` (name -> (low, high)) at Sobol points."""
    import numpy as np
    from scipy.stats import qmc

    names = list(analysis.mech.parameter_names)
    unit = qmc.Sobol(len(axes), seed=seed).random(n)
    P = np.tile(analysis.mech.parameter_values, (n, 1))
    for j, (name, (lo, hi)) in enumerate(axes.items()):
        P[:, names.index(name)] = lo + (hi - lo) * unit[:, j]
    return P



def summary(run) -> dict:
    """What a case's figures are, for comparing two codes' cases: its error or its peaks,
    constraints and load cases' peaks."""
    if run.error is not None:
        return {"error": type(run.error).__name__}
    out = {"peaks": run.peaks, "stroke": run.stroke, "extremes": run.constraint_extremes}
    if run.cases is not None:
        out["cases"] = {k: r.peaks for k, r in run.cases.cases.items()}
        out["governing"] = run.cases.governing
    return out


def child(study, n, batch, repeats):
    """One code's measurement (run with that code on PYTHONPATH): JSON on the last line."""
    import optdesign
    from benchfile import wrap_stages
    from optdesign.model.analysis import Analysis

    scene, axes = STUDIES[study]
    analysis = Analysis(optdesign.load(ROOT / scene))
    P = parameters(analysis, axes, n)
    analysis.run_many(P[:min(batch, 8)])   # warm-up: libraries loaded, functions built
    spent = {}
    wrap_stages(STAGES, spent)
    rounds, found = [], None
    for _ in range(repeats):
        spent.clear()
        t = time.process_time()
        found = []
        for a in range(0, n, batch):
            found += analysis.run_many(P[a:a + batch])
        rounds.append((time.process_time() - t, dict(spent)))
    print(json.dumps({"rounds": rounds, "cases": [summary(r) for r in found],
                      "failed": sum(r.error is not None for r in found)}, default=float))


def measure(code, study, n, batch, repeats):
    env = {**os.environ, "PYTHONPATH": str(code)}
    out = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--child", study, str(n), str(batch),
                          str(repeats)], cwd=code, env=env, check=True, capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def stage_table(name, n, runs) -> list:
    """Rows: per stage, each code's median CPU per case (and the base's / this's)."""
    stages = list(dict.fromkeys(s for *_, s in STAGES))
    lines = []
    for stage in ["all of run_many"] + stages:
        cells = []
        for got in runs.values():
            if stage == "all of run_many":
                cells.append(statistics.median(r[0] for r in got["rounds"]) / n * 1e3)
            else:
                cells.append(statistics.median(r[1].get(stage, 0.0) for r in got["rounds"]) / n * 1e3)
        ratio = f"{cells[0] / cells[-1]:.2f}" if len(cells) > 1 and cells[-1] > 0 else "-"
        lines.append(f"| {name} | {stage} | " + " | ".join(f"{c:.3f}" for c in cells) + (f" | {ratio}" if len(cells) > 1 else "") + " |")
    return lines


def main(argv=None):
    sys.path.insert(0, str(ROOT))
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from benchfile import SCALING_MD, cpu_model, export, git_state, write_section

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=256)
    ap.add_argument("--load-cases", type=int, default=16)
    ap.add_argument("--batch", type=int, default=256)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--base", default=None, help="a commit to measure in the same run")
    args = ap.parse_args(argv)
    load = os.getloadavg()
    sizes = {"truck_crane": args.cases, "hatch_cover": args.load_cases, "ventilator_squeeze": args.load_cases}
    with tempfile.TemporaryDirectory() as tmp:
        codes = {}
        if args.base:
            codes[f"base {args.base}"] = export(args.base, tmp)
        codes["this"] = ROOT
        results = {study: {name: measure(code, study, n, args.batch, args.repeats) for name, code in codes.items()}
                   for study, n in sizes.items()}
    command = (f"python benchmarks/bench_geometry_study.py --cases {args.cases} --load-cases {args.load_cases} "
               f"--batch {args.batch} --repeats {args.repeats}" + (f" --base {args.base}" if args.base else ""))
    head = " | ".join(f"{name} CPU per case [ms]" for name in codes)
    lines = ["# Analyse studies over geometry, stage by stage (issue 31)", "",
             f"`{command}` at {git_state()}, {time.strftime('%Y-%m-%d %H:%M', time.gmtime())} UTC, {cpu_model()}, "
             f"load average {load[0]:.1f} at the start and {os.getloadavg()[0]:.1f} at the end.  Sobol points over the "
             "cylinder base (xD, yD) and rod eye (b): every case a distinct geometry.  `Analysis.run_many` in batches of "
             f"{args.batch}, CPU time of the process (compiled: OPTDESIGN_COMPILE=wait, warm), medians of "
             f"{args.repeats} rounds; a stage's CPU is its function's, inclusive (load cases: their peaks and "
             "integrals too).", "",
             f"| study | stage | {head} |" + (" base / this |" if args.base else ""),
             "|---|---|" + "---|" * len(codes) + ("---|" if args.base else "")]
    for study, runs in results.items():
        lines += stage_table(f"{study} ({sizes[study]} cases)", sizes[study], runs)
    lines.append("")
    for study, runs in results.items():
        this = runs["this"]
        cps = sizes[study] / statistics.median(r[0] for r in this["rounds"])
        text = f"{study}: {cps:.0f} cases/s per core (this code), {this['failed']} of {sizes[study]} cases fail"
        if args.base:
            base = runs[f"base {args.base}"]
            text += (f"; base {sizes[study] / statistics.median(r[0] for r in base['rounds']):.0f} cases/s; every case's "
                     f"figures {'identical (==)' if base['cases'] == this['cases'] else 'DIFFERENT'} to the base's")
        lines.append(text + ".  ")
    text = "\n".join(lines) + "\n"
    print(text)
    write_section("geometry_study", text, SCALING_MD)


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        child(sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5]))
    else:
        main()
