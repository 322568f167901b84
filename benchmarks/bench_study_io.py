"""Studies at scale, the client's side (issue 31): what opening a study's journal, listing its
cases and writing its results cost against the study's size, for this code and for a base
commit, measured in one run.

    python benchmarks/bench_study_io.py [--sizes 20000,100000] [--base REF]

A study of the truck crane (problems/truck_crane.toml, analyse mode, boom mass mB x payload mP)
whose every case is already in its journal: one real analyse row (computed here, once) under
each case's id, as a finished study leaves it.  Each measurement runs in a fresh Python process
importing either this worktree's optdesign or the base commit's (``git archive REF``):

* *journal open*: ``Journal(folder)`` entered (what a resumed study does first): wall time, and
  in a second run of the step the peak of Python's allocations (tracemalloc) and the growth of
  the process's peak resident memory (``VmHWM`` after, reset by ``/proc/self/clear_refs`` once
  the imports are done and the Study made, minus the resident memory then);
* *cases()*: ``Study.cases()``: wall time;
* *resume*: ``study.run(out=folder, workers=1, figures=False)`` with every case finished (the
  journal read, the rows merged, cases.csv and the other files written): wall time and peak
  resident memory growth, as above; its per-case growth is
  what the study's memory check budgets (``CASE_BYTES``: optdesign/scene/arguments.py).

Both versions' cases.csv are compared byte for byte.  Writes its section of results/scaling.md
(benchmarks/benchfile.py)."""
from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from benchfile import ROOT, SCALING_MD, cpu_model, export, git_state, write_section  # noqa: E402

SCENE = ROOT / "problems" / "truck_crane.toml"
MASSES = 10

CHILD = """
import json, sys, time
what, n, folder, scene_path, trace = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4], sys.argv[5] == "trace"
import optdesign
from optdesign.study import Study, grid
from optdesign.study.journal import Journal
study = Study(optdesign.load(scene_path), [grid("mB", 500, 800, %d), grid("mP", 500, 3000, n // %d)], mode="analyse")

def status_kB(key):
    with open("/proc/self/status") as fh:
        return next(int(l.split()[1]) for l in fh if l.startswith(key + ":"))

with open("/proc/self/clear_refs", "w") as fh:   # the peak (VmHWM) from now on, not the imports'
    fh.write("5")
base = status_kB("VmRSS")
if trace:
    import tracemalloc
    tracemalloc.start()
t0 = time.perf_counter()
if what == "journal":
    with Journal(folder) as j:
        count = len(j.records)
elif what == "cases":
    count = len(study.cases())
else:
    r = study.run(out=folder, workers=1, figures=False)
    assert r.complete and r.reused == n and r.computed == 0, r
    count = len(r.rows)
wall = time.perf_counter() - t0
traced = tracemalloc.get_traced_memory()[1] if trace else None
print(json.dumps({"wall": wall, "grow_kB": status_kB("VmHWM") - base, "traced": traced, "count": count}))
""" % (MASSES, MASSES)


def prepare(n, folder):
    """A finished study of ``n`` cases: its journal, one real row under every case's id."""
    import optdesign
    from optdesign.study import Study, grid
    from optdesign.study.executors import record
    from optdesign.study.tasks import run_task

    study = Study(optdesign.load(SCENE), [grid("mB", 500, 800, MASSES), grid("mP", 500, 3000, n // MASSES)],
                  mode="analyse")
    cases = study.cases()
    out = run_task(study.task(cases[0]))
    assert out["row"]["success"], out
    folder.mkdir(parents=True)
    with open(folder / "journal.jsonl", "w") as fh:
        for c in cases:
            fh.write(json.dumps(record(c, out), separators=(",", ":")) + "\n")
    return (folder / "journal.jsonl").stat().st_size


def measure(code, what, n, folder, trace=False):
    done = subprocess.run([sys.executable, "-c", CHILD, what, str(n), str(folder), str(SCENE), "trace" if trace else "time"], capture_output=True,
                          text=True, cwd=code, env={**os.environ, "PYTHONPATH": str(code)})   # cwd: first on sys.path
    if done.returncode:
        raise SystemExit(f"{what} of {n} cases with {code} failed:\n{done.stderr[-3000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="20000,100000")
    ap.add_argument("--base", default="a60aa27", help="the commit compared against (before issue 31's I/O work)")
    args = ap.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    load0 = os.getloadavg()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        base = export(args.base, tmp / "base", ("optdesign",))
        for n in sizes:
            size = prepare(n, tmp / f"study-{n}")
            for label, code in (("base", base), ("this", ROOT)):
                got = {}
                for what in ("journal", "cases", "resume"):
                    for trace in (False, True):
                        folder = tmp / f"{label}-{n}"
                        shutil.rmtree(folder, ignore_errors=True)
                        shutil.copytree(tmp / f"study-{n}", folder)
                        got[what + "_traced" * trace] = measure(code, what, n, folder, trace)
                    if what == "resume":
                        got["csv"] = (folder / "cases.csv").read_bytes()
                rows.append((n, label, size, got))
                print(n, label, {k: v for k, v in got.items() if k != "csv"}, flush=True)
    load1 = os.getloadavg()
    lines = ["# Studies at scale, the client's side (`python benchmarks/bench_study_io.py`)", "",
             f"Written by `python benchmarks/bench_study_io.py --sizes {args.sizes} --base {args.base}` on "
             f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; {git_state()}; machine {cpu_model()}, nproc "
             f"{os.cpu_count()}; load average {load0[0]:.2f} before, {load1[0]:.2f} after (shared).", "",
             "A finished analyse study of the truck crane (every case in its journal, one real row each); each "
             "measurement in a fresh process, with the base commit's optdesign and with this one's. Memory: the peak "
             "of Python's allocations during the step (tracemalloc, in a second run of the step: the times are of "
             "the first, untraced); in brackets the growth of the peak resident memory over the resident memory "
             "before the step (an understatement: the step reuses memory the Study's construction freed).", "",
             "| cases | journal [MB] | code | journal open [s] | journal open [MB] | cases() [s] | cases() [MB] | "
             "resume, files written [s] | resume [MB] | resume per case [kB] |", "|---|---|---|---|---|---|---|---|---|---|"]

    def mb(got, what):
        return f"{got[what + '_traced']['traced'] / 2**20:.0f} ({got[what]['grow_kB'] / 1024:.0f})"

    for n, label, size, got in rows:
        lines.append(f"| {n:,} | {size / 1e6:.0f} | {label} | {got['journal']['wall']:.2f} | {mb(got, 'journal')} | "
                     f"{got['cases']['wall']:.2f} | {mb(got, 'cases')} | {got['resume']['wall']:.2f} | {mb(got, 'resume')} | "
                     f"{got['resume_traced']['traced'] / 1000 / n:.2f} |")
    lines.append("")
    for n in sizes:
        b = next(g for m, lb, _, g in rows if m == n and lb == "base")
        t = next(g for m, lb, _, g in rows if m == n and lb == "this")
        traced = {w: b[w + "_traced"]["traced"] / t[w + "_traced"]["traced"] for w in ("journal", "cases", "resume")}
        lines.append(f"- {n:,} cases, base / this: journal open {b['journal']['wall'] / t['journal']['wall']:.1f}x the "
                     f"time, {traced['journal']:.1f}x the memory; cases() {b['cases']['wall'] / t['cases']['wall']:.1f}x "
                     f"the time, {traced['cases']:.1f}x the memory; resume {b['resume']['wall'] / t['resume']['wall']:.1f}x "
                     f"the time, {traced['resume']:.1f}x the memory; cases.csv "
                     f"{'identical' if b['csv'] == t['csv'] else 'DIFFERENT'} ({len(t['csv']) / 1e6:.1f} MB).")
    write_section("study_io", "\n".join(lines) + "\n", SCALING_MD)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
