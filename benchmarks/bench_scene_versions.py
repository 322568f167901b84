"""One optimisation scene's CPU per start on several versions of the code, run interleaved.

Did a version make it slower, or was it the machine's load?  (On this shared 2-core machine a
process's CPU time itself grows with the load: results/optimiser_knuckle.md.)

    git worktree add --detach /tmp/v1 COMMIT1   (and so on)
    python benchmarks/bench_scene_versions.py --scene knuckle_press --versions /tmp/v1 /tmp/v2 ... \\
        [--rounds 3] [--out results/optimiser_knuckle_versions.md]

Each round runs every version once, in turn, each in its own process with
bench_optimiser_table.py's run (``optimise(scene, 20, 0)``, workers=1, ``OPTDESIGN_COMPILE=wait``,
the compile cache shared; the first round warms the cache with one untimed start), the order
rotated by one version per round so that none always runs first or last.  Per run: the load
average when it started, CPU (wall) ms per start, the best objective, and how many of the
compile cache's look-ups found a library (a look-up that found none ran on CasADi's virtual
machine).  Writes ``--out`` (markdown) and the runs as JSON beside it, after every run.  Not a
test."""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_optimiser_table import ROOT, run, scenes  # noqa: E402

from optdesign.report.files import write_file  # noqa: E402


def commit(version: Path) -> str:
    return subprocess.run(["git", "-C", str(version), "rev-parse", "--short", "HEAD"], capture_output=True,
                          text=True).stdout.strip() or str(version)


def table(args, names, runs) -> str:
    lines = [f"# {args.scene}: CPU per start on {len(names)} versions, interleaved", "",
             f"`python benchmarks/bench_scene_versions.py --scene {args.scene} --versions "
             f"{' '.join(names)} --rounds {args.rounds}` (worktrees of those commits; started "
             f"{runs[0]['when'] if runs else '-'}): `optimise(scene, 20, 0)`, workers=1, `OPTDESIGN_COMPILE=wait`, "
             "each run its own process, the compile cache shared, each round every version once in a rotated order.",
             "", "| round | version | load (1 min) | ms per start CPU (wall) | best objective | compiled libraries found |",
             "|---|---|---|---|---|---|"]
    for r in runs:
        res = r["result"]
        if "cpu_s" not in res:
            lines.append(f"| {r['round']} | {r['version']} | {r['load']:.1f} | {res} | | |")
            continue
        n = len(res["starts"])
        libs = res.get("libraries")
        lines.append(f"| {r['round']} | {r['version']} | {r['load']:.1f} | {1e3 * res['cpu_s'] / n:.0f} "
                     f"({1e3 * res['wall_s'] / n:.0f}) | {res['objective']!r} | "
                     f"{'-' if libs is None else f'{libs[0]} of {libs[1]}'} |")
    lines += ["", "| version | median ms per start CPU | runs |", "|---|---|---|"]
    for name in names:
        cpu = [1e3 * r["result"]["cpu_s"] / len(r["result"]["starts"]) for r in runs
               if r["version"] == name and "cpu_s" in r["result"]]
        if cpu:
            lines.append(f"| {name} | {statistics.median(cpu):.0f} | {', '.join(f'{c:.0f}' for c in cpu)} |")
    return "\n".join(lines) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", required=True, help="a scene's name (problems/ or tests/data/issue27/)")
    ap.add_argument("--versions", type=Path, nargs="+", required=True, help="checkouts of the code (git worktree add)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "scene_versions.md")
    args = ap.parse_args()
    found = [p for p in scenes() if p.stem == args.scene]
    if not found:
        ap.error(f"--scene {args.scene}: no optimisation scene of that name in problems/ or tests/data/issue27/")
    names = [commit(v) for v in args.versions]
    runs = []
    for k in range(args.rounds):
        shift = k % len(args.versions)
        for version, name in list(zip(args.versions, names))[shift:] + list(zip(args.versions, names))[:shift]:
            load = os.getloadavg()[0]
            when = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
            runs.append({"round": k + 1, "version": name, "load": load, "when": when,
                         "result": run(version, found[0], warm=k == 0)})
            print(table(args, names, runs).splitlines()[len(runs) + 5], flush=True)
            write_file(args.out, table(args, names, runs))
            write_file(args.out.with_suffix(".json"), json.dumps(runs, indent=1))


if __name__ == "__main__":
    main()
