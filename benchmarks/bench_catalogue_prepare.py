"""Each motor's problem prepared as the motor catalogue prepares it (issue 31), this code against
an older commit, in one run: :func:`optdesign.design.multistart.prepare` (the problem, its solver,
the screened start plan and, when a start point fits, what the workers would otherwise build) of
problems/crane_luffing_drive.toml's 5.5 kW motor and then its 7.5 kW motor in one process (the
two the catalogue prepares: the 4 kW motor is proved not to fit first, the 11 kW never tried).

    python benchmarks/bench_catalogue_prepare.py --base REV [--repeats 5]

Each version runs in its own child with PYTHONPATH set to its tree (``--base``: that commit's
optdesign/ and problems/ exported with ``git archive``), old and new in turn per round, after one
warm-up run of each (compiled libraries and eliminated graphs in the cache folder); per motor the
child's CPU (``time.process_time``) and wall time of the prepare, and a digest of what it made
(the start plan's points, reserve and fitting count, the problem's start quantities), which must
be the same in every run.  Writes the section ``catalogue_prepare`` of results/scaling.md.
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

sys.path.insert(0, str(Path(__file__).resolve().parent))
from benchfile import ROOT, SCALING_MD, against, cpu_model, export, write_section  # noqa: E402

SCENE = "problems/crane_luffing_drive.toml"
CHILD = r"""
import hashlib, json, sys, time
from optdesign.scene.file import load
from optdesign.design.catalogue import motor_order, with_motor
from optdesign.design.multistart import prepare
scene = load(sys.argv[1])
out = {}
for motor in motor_order(scene)[1:3]:
    c, w = time.process_time(), time.perf_counter()
    made = prepare(with_motor(scene, motor), 20, 0)
    c, w = time.process_time() - c, time.perf_counter() - w
    plan = made.plan
    digest = hashlib.sha256(plan.points.tobytes() + plan.reserve.tobytes() + str(plan.fitting).encode()
                            + made.problem.start_quantities.tobytes()).hexdigest()
    out[motor.name] = {"cpu": c, "wall": w, "digest": digest}
print(json.dumps(out))
"""


def child(tree: Path, env: dict) -> dict:
    proc = subprocess.run([sys.executable, "-c", CHILD, str(ROOT / SCENE)], cwd=tree, capture_output=True, text=True,
                          env=dict(env, PYTHONPATH=str(tree), MPLBACKEND="Agg"))
    if proc.returncode != 0:
        raise SystemExit(f"the child in {tree} failed ({proc.returncode}): {proc.stderr[-800:]}")
    return json.loads(proc.stdout.splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", required=True, help="a commit whose code is exported (git archive) and run as the old code")
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args(argv)
    runs = {"old": [], "new": []}
    with tempfile.TemporaryDirectory() as tmp:
        (old, _, git, env) = against(export(args.base, Path(tmp) / "base"))
        new, load0 = ROOT, os.getloadavg()
        for tree in (old, new):   # warm-up: the cache folder's entries made
            child(tree, dict(env, OPTDESIGN_COMPILE="wait"))
        for r in range(args.repeats):
            for name, tree in (("old", old), ("new", new)):
                out = child(tree, env)
                runs[name].append(out)
                print(f"round {r + 1} {name}: " + ", ".join(f"{m} {v['cpu']:.2f} s CPU {v['wall']:.2f} s wall"
                                                         for m, v in out.items()), flush=True)
    load1 = os.getloadavg()
    motors = list(runs["old"][0])
    every = runs["old"] + runs["new"]
    same = all(o[m]["digest"] == every[0][m]["digest"] for o in every for m in motors)

    def total(o, key):
        return sum(o[m][key] for m in motors)
    cpu = statistics.median(total(o, "cpu") / total(n, "cpu") for o, n in zip(runs["old"], runs["new"]))
    wall = statistics.median(total(o, "wall") / total(n, "wall") for o, n in zip(runs["old"], runs["new"]))
    lines = [
        "# catalogue_prepare", "",
        f"`python benchmarks/bench_catalogue_prepare.py --base {args.base} --repeats {args.repeats}` "
        f"({time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; {cpu_model()}, {os.cpu_count()} cores; "
        f"load {load0[0]:.1f} -> {load1[0]:.1f}): `prepare` of {SCENE}'s {' and '.join(motors)} motors in turn in "
        f"one child process (as the catalogue prepares them), old = {args.base}, new = {git}; rounds interleaved "
        "(old, new); CPU and wall seconds of each prepare.", "",
        "| round | " + " | ".join(f"old {m} CPU s | new {m} CPU s" for m in motors) + " | old wall s | new wall s |",
        "|---|" + "---|---|" * len(motors) + "---|---|",
    ]
    for r, (o, n) in enumerate(zip(runs["old"], runs["new"])):
        lines.append(f"| {r + 1} | " + " | ".join(f"{o[m]['cpu']:.2f} | {n[m]['cpu']:.2f}" for m in motors)
                     + f" | {total(o, 'wall'):.2f} | {total(n, 'wall'):.2f} |")
    lines += [
        "", f"Median over the rounds of old / new (both motors): CPU {cpu:.2f}x, wall {wall:.2f}x.  Medians of the "
        "CPU per motor old -> new: " + ", ".join(
            f"{m} {statistics.median(o[m]['cpu'] for o in runs['old']):.2f} -> "
            f"{statistics.median(n[m]['cpu'] for n in runs['new']):.2f} s" for m in motors) + ".", "",
        f"Same output: each motor's start plan (points, reserve, fitting) and start quantities bit-identical in every "
        f"run: {same}.",
    ]
    text = "\n".join(lines) + "\n"
    print(text)
    write_section("catalogue_prepare", text, SCALING_MD)
    (ROOT / "results" / "catalogue_prepare_bench.json").write_text(json.dumps(
        {"old": args.base, "new": git, "runs": runs, "cpu_ratio": cpu, "wall_ratio": wall,
         "load": [load0[0], load1[0]]}, indent=1) + "\n")


if __name__ == "__main__":
    main()
