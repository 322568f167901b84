"""The optimiser old against new (issue 27): every optimisation scene in problems/ (and issue
27's two scenes in tests/data/issue27), the default ``optimise(scene, 20, 0)`` (one process,
workers=1; a motor catalogue motor by motor, as the command does), each version in its own
Python process:

    git worktree add /tmp/old a267455
    python benchmarks/bench_optimiser_table.py --old /tmp/old [--new /tmp/new] [--out results/optimiser_table.md]

Per scene and version: the starts that reached the known optimum (certified objective within
1e-6 relative of it), the failed starts by status, the CPU and wall time per start (the whole
optimisation's process time / 20: screening and the summary included), the best objective.
The known optimum: the independent reference of results/optimise_library.json (dense grid +
polished SLSQP, rechecked on 20,001 samples, written apart from optdesign: tests/library and
benchmarks/bench_library.py), issue 27's own references (tests/knuckle_reference.py,
tests/test_aggregate_design_variables.py), else (marked) the best certified value of the two
runs.  Both versions share the compile cache, compiled before the timing (OPTDESIGN_COMPILE=wait:
a first run of one start compiles, and is not timed).  Writes ``--out`` (markdown) and the numbers as JSON
beside it.  Not a test."""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
AT = 1e-6
STARTS, SEED = 20, 0
ISSUE27 = {   # independent references (see the module's doc)
    "knuckle_press": 13643.138036,          # tests/knuckle_reference.py: SLSQP + located peak, 20,001 samples
    "crank_rocker_mu": -0.6585636834,       # tests/test_aggregate_design_variables.py: grid + bounded search
}

RUN = r"""
import json, sys, time, os
import optdesign
from optdesign.errors import OptdesignError
scene = optdesign.load(sys.argv[1])
libraries = []   # the compile cache's answers: True where a library was found (else the virtual machine)
try:
    from optdesign.model import compiled
    def library(*args, _found=compiled.library, **kw):
        path = _found(*args, **kw)
        libraries.append(path is not None)
        return path
    compiled.library = library
except (ImportError, AttributeError):
    pass
def go(starts=20):
    if len(scene.motors) > 1:
        from optdesign.design.catalogue import optimise_catalogue
        return optimise_catalogue(scene, starts=starts, seed=0, workers=1).best
    return optdesign.optimise(scene, starts, 0, workers=1)
if sys.argv[2] == "warm":
    try:
        go(1)   # one start: compiles what the cache lacks
    except OptdesignError:
        pass
    print("{}")
    raise SystemExit
t0, c0 = time.perf_counter(), time.process_time()
try:
    res = go()
except OptdesignError as exc:
    print(json.dumps({"refused": str(exc).splitlines()[0][:200]}))
    raise SystemExit
out = {"wall_s": time.perf_counter() - t0, "cpu_s": time.process_time() - c0, "success": res.success,
       "objective": res.objective, "libraries": [sum(libraries), len(libraries)], "starts": [[s.success, s.status, s.objective, s.time_s] for s in res.starts]}
print(json.dumps(out))
"""


def scenes() -> list:
    sys.path.insert(0, str(ROOT))
    import optdesign

    out = [p for p in sorted((ROOT / "problems").glob("*.toml")) if optdesign.load(p).objective is not None]
    # the long ones first (issue 27's knuckle press), a motor catalogue (many optimisations) last
    out.sort(key=lambda p: len(optdesign.load(p).motors) > 1)
    return sorted((ROOT / "tests" / "data" / "issue27").glob("*.toml"), reverse=True) + out


def run(version: Path, scene: Path, warm=True) -> dict:
    env = dict(os.environ, PYTHONPATH=str(version), MPLBACKEND="Agg", OPTDESIGN_COMPILE="wait")
    for mode in ("warm", "timed") if warm else ("timed",):
        done = subprocess.run([sys.executable, "-c", RUN, str(scene), mode], capture_output=True, text=True,
                              env=env, cwd=str(version))
        if done.returncode != 0:
            return {"error": done.stderr.strip().splitlines()[-1][:200] if done.stderr.strip() else "failed"}
    return json.loads(done.stdout.strip().splitlines()[-1])


def references() -> dict:
    lib = json.loads((ROOT / "results" / "optimise_library.json").read_text())["scenes"]
    out = {k: v["reference"]["value"] for k, v in lib.items() if v.get("reference", {}).get("value") is not None}
    out.update(ISSUE27)
    return out


def summary(r: dict, target) -> dict:
    if "starts" not in r:
        return {"note": r.get("refused") or r.get("error")}
    ok = [s for s in r["starts"] if s[0] and s[2] is not None]
    at = sum(1 for s in ok if target is not None and abs(s[2] - target) <= AT * abs(target))
    failed = {}
    for s in r["starts"]:
        if not s[0]:
            key = s[1].split(" (recheck")[0] if "recheck" not in s[1] else "recheck failed"
            failed[key] = failed.get(key, 0) + 1
    n = len(r["starts"])
    return {"at": at, "n": n, "failed": failed, "cpu_per_start_s": r["cpu_s"] / n, "wall_per_start_s": r["wall_s"] / n,
            "best": r["objective"]}


def cell(d) -> str:
    if "note" in d:
        return f"refused: {d['note']} | | | "
    failed = ", ".join(f"{v} {k}" for k, v in sorted(d["failed"].items())) or "none"
    best = "-" if d["best"] is None else f"{d['best']:.10g}"
    return f"{d['at']}/{d['n']} | {failed} | {d['cpu_per_start_s'] * 1e3:.0f} ({d['wall_per_start_s'] * 1e3:.0f}) | {best}"


def both(args, scene):
    """The old and the new run of one scene, one after the other (so that both see about the same
    load of the machine); the old one taken from --old-runs where given, the new one left out with
    --old-only."""
    if args.old_runs is not None and scene.stem in args.old_runs:
        old = args.old_runs[scene.stem]
    else:
        old = run(args.old, scene, not args.no_warm)
    return scene, {"old": old, "new": old if args.old_only else run(args.new, scene, not args.no_warm)}


def main():
    from concurrent.futures import ThreadPoolExecutor, as_completed

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", type=Path, required=True, help="a checkout of the old code (git worktree add)")
    ap.add_argument("--new", type=Path, default=ROOT, help="a checkout of the new code (default: this one)")
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "optimiser_table.md")
    ap.add_argument("--scenes", nargs="*", help="only these scene names")
    ap.add_argument("--parallel", type=int, default=1, help="scenes run at once (each: old, then new)")
    ap.add_argument("--no-warm", action="store_true", help="no one-start run before the timed one (a warm cache)")
    ap.add_argument("--old-runs", type=Path, help="the old runs of an earlier table's .json (its 'runs'), not rerun")
    ap.add_argument("--old-only", action="store_true", help="run the old code only (to be reused by --old-runs)")
    args = ap.parse_args()
    if args.old_runs is not None:
        earlier = json.loads(args.old_runs.read_text())
        if earlier.get("old") != subprocess.run(["git", "-C", str(args.old), "rev-parse", "--short", "HEAD"],
                                                capture_output=True, text=True).stdout.strip():
            ap.error(f"--old-runs {args.old_runs} was run on {earlier.get('old')}, not on --old's HEAD")
        args.old_runs = {k: v["runs"]["old"] for k, v in earlier["scenes"].items() if "runs" in v}
    old_when = (earlier.get("when") or earlier.get("old_when")) if args.old_runs is not None else None  # a combined table keeps old_when
    refs = references()
    heads = {k: subprocess.run(["git", "-C", str(getattr(args, k)), "rev-parse", "--short", "HEAD"], capture_output=True,
                               text=True).stdout.strip() for k in ("old", "new")}
    data = {**heads, "when": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "old_when": old_when, "scenes": {}}
    todo = [p for p in scenes() if not args.scenes or p.stem in args.scenes]
    t0 = time.perf_counter()
    rows = {}
    with ThreadPoolExecutor(max(1, args.parallel)) as pool:
        for future in as_completed([pool.submit(both, args, scene) for scene in todo]):
            scene, runs = future.result()
            target, marked = refs.get(scene.stem), ""
            if target is None:
                values = [r["objective"] for r in runs.values() if r.get("objective") is not None and r.get("success")]
                target, marked = (min(values) if values else None), " (best of the two runs)"
            out = {k: summary(r, target) for k, r in runs.items()}
            data["scenes"][scene.stem] = {"known_optimum": target, "source": "runs" if marked else "reference", **out,
                                          "runs": runs}
            where = "" if scene.parent.name == "problems" else " (issue 27)"
            known = "-" if target is None else f"{target:.10g}{marked}"
            rows[scene] = f"| {scene.stem}{where} | {known} | {cell(out['old'])} | {cell(out['new'])} |"
            print(rows[scene], flush=True)
            write(args, data, [rows[p] for p in todo if p in rows], len(todo), time.perf_counter() - t0)


def write(args, data, rows, total, seconds):
    """The table so far (a scene's row once both of its runs finished), atomically."""
    done = "" if len(rows) == total else f" **{len(rows)} of {total} scenes so far.**"
    lines = [
        "# The optimiser, old against new (issue 27)",
        "",
        f"`python benchmarks/bench_optimiser_table.py --old /tmp/old --new /tmp/new"
        f"{' --parallel %d' % args.parallel if args.parallel > 1 else ''}{' --no-warm' if args.no_warm else ''}"
        f"{' --old-runs OLD.json (the old runs of ' + data['old_when'] + ')' if data.get('old_when') else ''}` "
        f"({data['when']}, {seconds:.0f} s): old = {data['old']}, new = {data['new']}; every optimisation scene in "
        f"problems/ and issue 27's two scenes, `optimise(scene, {STARTS}, {SEED})` with the default settings, "
        "workers=1 (a motor catalogue motor by motor, as the command does), each version in its own process, "
        f"the compile cache shared.{done}",
        "",
        f"*At optimum*: starts whose certified objective is within {AT:g} (relative) of the known optimum: the "
        "independent reference (results/optimise_library.json; issue 27's scenes: their tests' numpy references), "
        "or where none exists the best certified value of the two runs (marked). *Per start*: the optimisation's "
        "CPU time / 20 in ms (wall time in brackets: the machine was shared with other work, so wall times are "
        "noisy; the CPU times are the comparison).",
        "",
        "| scene | known optimum | old: at optimum | old: failed starts | old: ms per start CPU (wall) | old: best | "
        "new: at optimum | new: failed starts | new: ms per start CPU (wall) | new: best |",
        "|---|---|---|---|---|---|---|---|---|---|",
        *rows,
    ]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_suffix(".md.tmp")
    tmp.write_text("\n".join(lines) + "\n")
    os.replace(tmp, args.out)
    js = args.out.with_suffix(".json")
    tmp = js.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(data, indent=1))
    os.replace(tmp, js)


if __name__ == "__main__":
    main()
