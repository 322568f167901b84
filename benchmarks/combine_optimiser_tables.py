"""The optimiser table put together from several runs of bench_optimiser_table.py (each a JSON beside
its .md; a later file wins for a scene), each row naming the commit its new side ran at:

    python benchmarks/combine_optimiser_tables.py results/optimiser_table.md RUN1.json RUN2.json ...
"""
import json, sys, os
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bench_optimiser_table as b
runs = [json.load(open(f)) for f in sys.argv[2:]]   # later files win for a scene
scenes, where = {}, {}
for d in runs:
    for k, v in d["scenes"].items():
        scenes[k] = v; where[k] = d["new"]
order = [p.stem for p in b.scenes()]
rows = []
for k in order:
    if k not in scenes: continue
    v = scenes[k]
    marked = " (best of the two runs)" if v["source"] == "runs" else ""
    target = v["known_optimum"]
    w = " (issue 27)" if k in b.ISSUE27 else ""
    rows.append(f"| {k}{w} | {'-' if target is None else f'{target:.10g}{marked}'} | {b.cell(v['old'])} | {b.cell(v['new'])} | {where[k]} |")
commits = sorted(set(where.values()))
lines = ["# The optimiser, old against new (issue 27)", "",
 "Old = e832500 (this session's start; its runs: `python benchmarks/bench_optimiser_table.py --old /tmp/old --old-only --no-warm`, "
 f"{runs[0]['old_when']}, nice 19 beside other work). New = main during the session's end, each row at the commit in its last column: "
 "`python benchmarks/bench_optimiser_table.py --old /tmp/old --new /tmp/NEW --old-runs OLD.json [--no-warm] [--parallel N] --scenes ...` "
 "from a fresh clone of that commit (" + ", ".join(f"{d['new']} at {d['when']}" for d in runs) + "; a later run replaces an "
 "earlier one's rows for the scenes it ran: the commit message says which and why). "
 "Every optimisation scene in problems/ and issue 27's two scenes, `optimise(scene, 20, 0)` with the default settings, workers=1 "
 "(a motor catalogue motor by motor, as the command does), each version in its own process, the compile cache shared. "
 "The rows were put together from the runs' JSON files by `python benchmarks/combine_optimiser_tables.py`.", "",
 f"*At optimum*: starts whose certified objective is within {b.AT:g} (relative) of the known optimum: the independent reference "
 "(results/optimise_library.json; issue 27's scenes: their tests' numpy references), or where none exists the best certified value of "
 "the two runs (marked; press_servo_cycle, hatch_cover, transfer_arm and ventilator_squeeze also have independent optima in their tests: "
 "tests/test_press_servo_optimum.py 83.80882329, tests/test_hatch_cover_optimum.py 57458.6297947, tests/test_transfer_arm_optimum.py "
 "2.3889192099, the ventilator's 0.0273883941 in tests/test_motion_output.py). *Per start*: the optimisation's CPU time / 20 in ms "
 "(wall time in brackets: the machine was shared with other work, so wall times are noisy; the CPU times are the comparison).", "",
 "| scene | known optimum | old: at optimum | old: failed starts | old: ms per start CPU (wall) | old: best | new: at optimum | new: failed starts | new: ms per start CPU (wall) | new: best | new at |",
 "|---|---|---|---|---|---|---|---|---|---|---|", *rows]
out = sys.argv[1]
open(out + ".tmp", "w").write("\n".join(lines) + "\n"); os.replace(out + ".tmp", out)
js = {"old": "e832500", "old_when": runs[0]["old_when"], "new_at": where, "scenes": scenes}
open(out[:-3] + ".json.tmp", "w").write(json.dumps(js, indent=1)); os.replace(out[:-3] + ".json.tmp", out[:-3] + ".json")
