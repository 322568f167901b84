"""The motor catalogue's optimisation (issue 31): ``optdesign optimise`` of a scene with
[[motors]] (default problems/crane_luffing_drive.toml: 4 motors, 20 starts, the default
workers), this code against an older commit, in one run.

    python benchmarks/bench_catalogue.py (--old /tmp/old | --base REV) [--repeats 3] [--scene ...]

``--old`` is a checkout of the older code (e.g. ``git worktree add --detach /tmp/old e832500``);
``--base REV`` exports that commit's optdesign/ and problems/ into a temporary folder
(``benchfile.export``: ``git archive``) and runs it as the old code.
Each version runs from its own folder with PYTHONPATH set to it (a child started in a
worktree would otherwise import that worktree's optdesign).  Warm: each version runs once
before timing with ``OPTDESIGN_COMPILE=wait`` (its compiled libraries in the disk cache, the
files in the page cache); then ``--repeats`` rounds, old and new in turn in each round (the
shared machine's load falls on both); per round the ratio old / new of wall time and of the
child's CPU time (user + system, ``resource.getrusage(RUSAGE_CHILDREN)``, forked workers
included), and the median of those ratios.  Every run's answer is compared: the chosen motor,
its objective (relative difference) and how many starts reached it.  Writes the section
``catalogue`` of results/scaling.md.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_commands import run as run_command  # noqa: E402
from benchfile import ROOT, SCALING_MD, against, cpu_model, export, write_section  # noqa: E402


NOT_WARMED = ("the compile cache not warmed by this run (--no-warm: what earlier runs left in it; a library "
              "missing is compiled in the background while that run evaluates on CasADi's virtual machine)")


def run(tree: Path, scene: str, out: Path, env: dict, starts: int):
    """(wall, child CPU, answer) of ``optdesign optimise`` with the code of ``tree``."""
    env = dict(env, PYTHONPATH=str(tree), MPLBACKEND="Agg")
    cmd = [sys.executable, "-m", "optdesign", "optimise", str(ROOT / scene), "--out", str(out), "--no-animation", "-q",
           "--starts", str(starts)]
    wall, cpu = run_command(cmd, env, cwd=tree)
    result = json.loads((out / "result.json").read_text())
    answer = {"motor": result.get("chosen_motor"), "objective": result["objective"],
              "starts_at_best": result["starts_at_best"], "starts": result["starts_total"]}
    return wall, cpu, answer


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    old_code = ap.add_mutually_exclusive_group(required=True)
    old_code.add_argument("--old", help="a checkout of the older code")
    old_code.add_argument("--base", help="a commit whose code is exported (git archive) and run as the old code")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--scene", default="problems/crane_luffing_drive.toml")
    ap.add_argument("--starts", type=int, default=20)
    ap.add_argument("--no-warm", action="store_true", help="skip the warm-up runs (the cache is known to be warm)")
    ap.add_argument("--section", default="catalogue",
                    help="the section of results/scaling.md written (and results/<section>_bench.json)")
    args = ap.parse_args(argv)
    times = {"old": [], "new": []}
    answers = {"old": [], "new": []}
    with tempfile.TemporaryDirectory() as tmp:
        if args.base:
            (old, _, git, env), old_commit = against(export(args.base, Path(tmp) / "base")), args.base
        else:
            old, old_commit, git, env = against(args.old)
        new, load0 = ROOT, os.getloadavg()
        for name, tree in () if args.no_warm else (("old", old), ("new", new)):   # compiled libraries in the cache
            print(f"warm-up {name} ...", flush=True)
            run(tree, args.scene, Path(tmp) / f"warm_{name}", dict(env, OPTDESIGN_COMPILE="wait"), args.starts)
        for r in range(args.repeats):
            for name, tree in (("old", old), ("new", new)):
                wall, cpu, answer = run(tree, args.scene, Path(tmp) / f"{name}_{r}", env, args.starts)
                times[name].append((wall, cpu))
                answers[name].append(answer)
                print(f"round {r + 1} {name}: {wall:.1f} s wall, {cpu:.1f} s CPU, {answer}", flush=True)
    load1 = os.getloadavg()
    wall_ratio = statistics.median(o[0] / n[0] for o, n in zip(times["old"], times["new"]))
    cpu_ratio = statistics.median(o[1] / n[1] for o, n in zip(times["old"], times["new"]))
    ref = answers["old"][0]
    diffs = [abs(a["objective"] - ref["objective"]) / abs(ref["objective"]) for a in answers["old"] + answers["new"]]
    same_motor = all(a["motor"] == ref["motor"] for a in answers["old"] + answers["new"])
    lines = [
        f"# {args.section}",
        "",
        f"`python benchmarks/bench_catalogue.py {'--base ' + args.base if args.base else '--old ' + args.old} "
        f"--repeats {args.repeats} --scene {args.scene} "
        f"--starts {args.starts}{' --no-warm' if args.no_warm else ''}"
        f"{'' if args.section == 'catalogue' else ' --section ' + args.section}` "
        f"({time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; {cpu_model()}, {os.cpu_count()} cores; "
        f"load {load0[0]:.1f} -> {load1[0]:.1f}): `optdesign optimise {args.scene} --no-animation --starts "
        f"{args.starts}` with the default workers (the machine's cores), "
        f"{NOT_WARMED if args.no_warm else 'warm compile cache'}; old = {old_commit}, "
        f"new = {git}; rounds interleaved (old, new).",
        "",
        "| round | old wall s | new wall s | old CPU s | new CPU s |",
        "|---|---|---|---|---|",
    ]
    for r, (o, n) in enumerate(zip(times["old"], times["new"])):
        lines.append(f"| {r + 1} | {o[0]:.1f} | {n[0]:.1f} | {o[1]:.1f} | {n[1]:.1f} |")
    lines += [
        "",
        f"Median over the rounds of old / new: wall {wall_ratio:.2f}x, CPU {cpu_ratio:.2f}x.  Median new: wall "
        f"{statistics.median(t[0] for t in times['new']):.1f} s, CPU {statistics.median(t[1] for t in times['new']):.1f} s "
        "(the issue's goal: under 10 s wall warm on 2 cores).",
        "",
        f"Answers: chosen motor {ref['motor']!r} in every run: {same_motor}; objective old {ref['objective']:.9g}, "
        f"largest relative difference of any run from it {max(diffs):.1e}; starts at the best: old "
        f"{[a['starts_at_best'] for a in answers['old']]}, new {[a['starts_at_best'] for a in answers['new']]} "
        f"of {ref['starts']}.",
    ]
    text = "\n".join(lines) + "\n"
    print(text)
    write_section(args.section, text, SCALING_MD)
    (ROOT / "results" / f"{args.section}_bench.json").write_text(json.dumps(
        {"old": old_commit, "new": git, "times": times, "answers": answers, "wall_ratio": wall_ratio,
         "cpu_ratio": cpu_ratio, "load": [load0[0], load1[0]]}, indent=1) + "\n")


if __name__ == "__main__":
    main()
