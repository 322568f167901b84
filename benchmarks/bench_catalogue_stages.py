"""The motor catalogue's stages that do not depend on the solves (issue 31), this code against an
older commit, in one run: the build and screening of each motor's problem (DesignProblem, its
Screen and the start plan) and the results folder of one catalogue result (result.json,
summary.txt, the figures; in one process, no animation).

    python benchmarks/bench_catalogue_stages.py --old /tmp/old [--repeats 2] [--result cat.pkl]

A whole `optdesign optimise` of the catalogue (benchmarks/bench_catalogue.py) spends most of its
CPU in the solves, and on a loaded machine their noise hides a few seconds; here each stage runs
alone.  ``--result``: a pickled CatalogueResult of problems/crane_luffing_drive.toml (made by
this code with 20 starts and 2 workers when the file is not there); both versions write the
folder of the same result.  Each version runs in its own child with PYTHONPATH set to its tree,
old and new in turn per round; per stage the child's CPU (``time.process_time``) and what it
made: each motor's start plan (points and reserve) must be bit-identical, and the folders'
result.json, summary.txt and PNG files byte-identical.  Writes the section
``catalogue_stages`` of results/scaling.md.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from benchfile import ROOT, SCALING_MD, against, cpu_model, write_section  # noqa: E402

SCENE = "problems/crane_luffing_drive.toml"
CHILD = r"""
import hashlib, json, pickle, sys, time
from pathlib import Path
import numpy as np
from optdesign.scene.file import load
from optdesign.design.catalogue import with_motor
from optdesign.design.problem import DesignProblem
from optdesign.design import starts
from optdesign.report import design
scene_path, result_path, folder = sys.argv[1:4]
scene, out = load(scene_path), {"screen": [], "plans": []}
for motor in scene.motors[:3]:   # the motors crane_luffing_drive's catalogue builds (the 11 kW is not tried)
    t = time.process_time()
    pb = DesignProblem(with_motor(scene, motor))
    plan = starts.plan_starts(pb, 20, 0)
    out["screen"].append(time.process_time() - t)
    out["plans"].append(hashlib.sha256(plan.points.tobytes() + plan.reserve.tobytes()).hexdigest())
catalogue = pickle.loads(Path(result_path).read_bytes())
t = time.process_time()
design.write_results(catalogue.best, Path(folder), workers=1, animate=False, catalogue=catalogue)
out["folder"] = time.process_time() - t
print(json.dumps(out))
"""
MAKE = r"""
import pickle, sys
from pathlib import Path
from optdesign.scene.file import load
from optdesign.design.catalogue import optimise_catalogue
Path(sys.argv[2]).write_bytes(pickle.dumps(optimise_catalogue(load(sys.argv[1]), starts=20, workers=2)))
"""


def child(tree: Path, code: str, args: list, env: dict) -> str:
    proc = subprocess.run([sys.executable, "-c", code, *args], cwd=tree, capture_output=True, text=True,
                          env=dict(env, PYTHONPATH=str(tree), MPLBACKEND="Agg"))
    if proc.returncode != 0:
        raise SystemExit(f"the child in {tree} failed ({proc.returncode}): {proc.stderr[-800:]}")
    return proc.stdout


def digests(folder: Path) -> dict:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir())
            if p.suffix == ".png" or p.name in ("summary.txt",)} | {"result.json": _json_digest(folder / "result.json")}


def _json_digest(path: Path) -> str:
    """result.json without its timings (wall seconds of this run)."""
    def strip(d):
        if isinstance(d, dict):
            return {k: strip(v) for k, v in d.items() if k not in ("timings", "time_s")}
        return [strip(v) for v in d] if isinstance(d, list) else d
    return hashlib.sha256(json.dumps(strip(json.loads(path.read_text())), sort_keys=True).encode()).hexdigest()


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", required=True, help="a checkout of the older code")
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--result", default=None, help="a pickled CatalogueResult of the scene (made when missing)")
    args = ap.parse_args(argv)
    (old, old_commit, git, env), new, load0 = against(args.old), ROOT, os.getloadavg()
    runs = {"old": [], "new": []}
    with tempfile.TemporaryDirectory() as tmp:
        result = Path(args.result or Path(tmp) / "catalogue.pkl")
        if not result.exists():
            print("the catalogue result ...", flush=True)
            child(new, MAKE, [str(ROOT / SCENE), str(result)], env)
        for r in range(args.repeats):
            for name, tree in (("old", old), ("new", new)):
                folder = Path(tmp) / f"{name}_{r}"
                out = json.loads(child(tree, CHILD, [str(ROOT / SCENE), str(result), str(folder)], env).splitlines()[-1])
                out["files"] = digests(folder)
                runs[name].append(out)
                print(f"round {r + 1} {name}: screening {sum(out['screen']):.2f} s CPU, folder {out['folder']:.2f} s CPU",
                      flush=True)
    load1 = os.getloadavg()
    every = runs["old"] + runs["new"]
    same_plans = all(o["plans"] == every[0]["plans"] for o in every)
    same_files = all(o["files"] == every[0]["files"] for o in every)

    def med(name, key):
        return statistics.median(sum(o[key]) if isinstance(o[key], list) else o[key] for o in runs[name])
    lines = [
        "# catalogue_stages", "",
        f"`python benchmarks/bench_catalogue_stages.py --old {args.old} --repeats {args.repeats}` "
        f"({time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; {cpu_model()}, {os.cpu_count()} cores; "
        f"load {load0[0]:.1f} -> {load1[0]:.1f}): {SCENE}'s catalogue stages that do not depend on the solves, each "
        f"in a child process: the problem build, screening and start plan of the 4, 5.5 and 7.5 kW motors, and the "
        f"results folder of one catalogue result (write_results in one process, no animation); old = {old_commit}, "
        f"new = {git}; rounds interleaved (old, new); CPU seconds of the child.", "",
        "| round | old build + screening s | new build + screening s | old folder s | new folder s |",
        "|---|---|---|---|---|",
    ]
    for r, (o, n) in enumerate(zip(runs["old"], runs["new"])):
        lines.append(f"| {r + 1} | {sum(o['screen']):.2f} | {sum(n['screen']):.2f} | {o['folder']:.2f} | {n['folder']:.2f} |")
    lines += [
        "", f"Medians old -> new: build + screening {med('old', 'screen'):.2f} -> {med('new', 'screen'):.2f} s CPU, "
        f"results folder {med('old', 'folder'):.2f} -> {med('new', 'folder'):.2f} s CPU.", "",
        f"Same output: every motor's start plan (points and reserve) bit-identical in every run: {same_plans}; "
        f"result.json (timings aside), summary.txt and the PNG files byte-identical in every run: {same_files}.",
    ]
    text = "\n".join(lines) + "\n"
    print(text)
    write_section("catalogue_stages", text, SCALING_MD)
    (ROOT / "results" / "catalogue_stages_bench.json").write_text(json.dumps(
        {"old": old_commit, "new": git, "runs": runs, "load": [load0[0], load1[0]]}, indent=1) + "\n")


if __name__ == "__main__":
    main()
