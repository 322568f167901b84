"""Studies at scale (issue 31): cases per second and the client's peak memory of an analyse
study of the truck crane (problems/truck_crane.toml, boom mass mB x payload mP: leaf
parameters) against its
size, on the local pool of 2 processes and on a Dask LocalCluster of 2 worker processes
(loopback; the cluster runs in another process, so the client's memory is the client's alone),
and the journal's throughput with group commit against one fsync per case.

    python benchmarks/bench_study_scale.py [--sizes 2000,20000]
    python benchmarks/bench_study_scale.py --batched 2000 [--repeats 3] [--batch 256]

``--batched N``: one study of N cases one case at a time and in batches of ``--batch`` cases
(``Analysis.run_many``: every stage over the batch's cases at once) in one process, on the pool
and on Dask (2 processes each), interleaved, medians of cases/s and client CPU per case, and
whether the cases.csv files are identical; then the CPU per case of ``Analysis.run_many`` (its
certification apart) and ``sweep_rms_many`` in this process at N = 1, 32, 256, 1024 (section
study_batched).

Each study runs in a fresh Python process (``optdesign.study`` from a script) that reports its
wall time and its peak resident memory (``ru_maxrss``: imports included, so the growth between
two sizes is what the cases cost); the pool's processes are its children and not counted.
Journal: ``Journal.add`` of N records of an analyse row's size, each made durable at once
(``durable=True``, the old way) or committed in groups (``durable=False`` and a ``sync`` every
``--group`` records, as a study's scheduling loop does for the cases that come back together),
on this machine's disk.

writes its section of results/scaling.md (benchmarks/benchfile.py)."""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from benchfile import ROOT, SCALING_MD, cpu_model, git_state, write_section  # noqa: E402

CHILD = """
import json, resource, sys, time
import optdesign
from optdesign.study import Study, grid
n, out, where = int(sys.argv[1]), sys.argv[2], sys.argv[3]
masses = 10   # boom mass x payload: leaf parameters, one build serves every case
study = Study(optdesign.load(sys.argv[4]), [grid("mB", 500, 800, masses), grid("mP", 500, 3000, n // masses)],
              mode="analyse")
kw = {"workers": 2} if where == "pool" else {"scheduler": where}
t0 = time.perf_counter()
result = study.run(out=out, restart=True, figures=False, **kw)
wall = time.perf_counter() - t0
assert result.complete and result.computed == n, result
ok = sum(1 for r in result.rows if r.get("success"))
print(json.dumps({"wall": wall, "maxrss_kB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, "ok": ok}))
"""


BATCHED_CHILD = """
import hashlib, json, sys, time
import optdesign
from optdesign.study import Study, grid
from optdesign.study import execute
n, out, where, batch = int(sys.argv[1]), sys.argv[2], sys.argv[3], int(sys.argv[5])
execute.BATCH_MAX = 1 if where == "one by one" else batch   # 1: each case's analysis alone (tasks.run_task)
masses = 10
study = Study(optdesign.load(sys.argv[4]), [grid("mB", 500, 800, masses), grid("mP", 500, 3000, n // masses)],
              mode="analyse")
kw = {"workers": 2} if where == "pool" else {"workers": 1} if where in ("one by one", "batches") else {"scheduler": where}
t0, c0 = time.perf_counter(), time.process_time()
result = study.run(out=out, restart=True, figures=False, **kw)
wall, cpu = time.perf_counter() - t0, time.process_time() - c0
assert result.complete and result.computed == n, result
digest = hashlib.sha256(open(out + "/cases.csv", "rb").read()).hexdigest()[:16]
print(json.dumps({"wall": wall, "cpu": cpu, "csv": digest}))
"""


def run_batched(n, where, folder, batch):
    """One study of ``n`` cases in a fresh process: wall and client CPU seconds, cases.csv's digest."""
    done = subprocess.run([sys.executable, "-c", BATCHED_CHILD, str(n), str(folder), where,
                           str(ROOT / "problems" / "truck_crane.toml"), str(batch)],
                          capture_output=True, text=True, cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)})
    if done.returncode:
        raise SystemExit(f"study of {n} cases ({where}) failed:\n{done.stderr[-3000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def run_many_costs(sizes=(1, 32, 256, 1024), repeats=3) -> list:
    """CPU ms per case of Analysis.run_many (and of its certification) and sweep_rms_many on
    the truck crane at each batch size, warm, medians of ``repeats``: random boom and payload
    masses (leaf parameters)."""
    import statistics

    import numpy as np

    import optdesign
    from optdesign.model.analysis import Analysis
    from optdesign.model import runs as runs_module
    from optdesign.scene.resolved import ResolvedScene

    scene = optdesign.load(ROOT / "problems" / "truck_crane.toml")
    varied = ["mB", "mP"]
    analysis = Analysis(ResolvedScene(scene.without_bounds(*varied), variable=varied))
    names = analysis.mech.parameter_names
    certified = runs_module._certified
    spent = []

    def timed(*args):
        c0 = time.process_time()
        try:
            return certified(*args)
        finally:
            spent.append(time.process_time() - c0)

    runs_module._certified = timed
    rows = []
    try:
        for n in sizes:
            rng = np.random.default_rng(n)
            P = np.tile(np.asarray(analysis.mech.parameter_values, float), (n, 1))
            P[:, names.index("mB")] = rng.uniform(500, 800, n)
            P[:, names.index("mP")] = rng.uniform(500, 3000, n)
            analysis.run_many(P)
            analysis.sweep_rms_many(P)   # warm: every mapped Function made
            run, cert, rms = [], [], []
            for _ in range(repeats):
                spent.clear()
                c0 = time.process_time()
                runs = analysis.run_many(P)
                run.append(time.process_time() - c0)
                cert.append(sum(spent))
                c0 = time.process_time()
                analysis.sweep_rms_many(P)
                rms.append(time.process_time() - c0)
                assert all(r.error is None for r in runs)
            rows.append((n, *(1e3 * statistics.median(x) / n for x in (run, cert, rms))))
            print("run_many", rows[-1], flush=True)
    finally:
        runs_module._certified = certified
    return rows


def batched_section(n, repeats, tmp, batch) -> str:
    """Cases/s of one study of ``n`` cases one by one and in batches in this process, on the pool
    and on a Dask LocalCluster (2 processes each), the four interleaved ``repeats`` times
    (medians), whether their cases.csv are identical, and :func:`run_many_costs`."""
    import statistics

    import distributed

    load0 = os.getloadavg()
    runs = {}
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        wheres = {"in process, one case at a time": "one by one", "in process, run_many batches": "batches",
                  "pool, 2 processes": "pool", "Dask LocalCluster, 2 workers": cluster.scheduler_address}
        run_batched(min(n, 40), cluster.scheduler_address, Path(tmp) / "warm", batch)   # helpers started
        for k in range(repeats):
            for label, where in wheres.items():
                r = run_batched(n, where, Path(tmp) / f"b{k}-{label[:6]}", batch)
                runs.setdefault(label, []).append(r)
                print(n, label, r, flush=True)
    costs = run_many_costs()
    load1 = os.getloadavg()
    rate = {label: statistics.median(n / r["wall"] for r in rs) for label, rs in runs.items()}
    cpu = {label: statistics.median(1e3 * r["cpu"] / n for r in rs) for label, rs in runs.items()}
    digests = {r["csv"] for rs in runs.values() for r in rs}
    base = rate["in process, one case at a time"]
    lines = ["## Analyse cases in batches (`python benchmarks/bench_study_scale.py --batched N`)", "",
             f"Written by `python benchmarks/bench_study_scale.py --batched {n} --repeats {repeats} --batch {batch}` "
             f"on {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; {git_state()}; machine {cpu_model()}, nproc "
             f"{os.cpu_count()}; load average {load0[0]:.2f} before, {load1[0]:.2f} after (shared).", "",
             f"An analyse study of the truck crane ({n:,} cases: 10 boom masses x {n // 10} payloads), each run in a "
             f"fresh process, the four ways interleaved {repeats} times; medians.  One case at a time is each "
             f"case's own `Analysis.run`; in batches (about 0.5 s of work each, `execute.GROUP_S`, at most {batch} "
             "cases, `execute.BATCH_MAX`) the cases go through one `Analysis.run_many` and one `sweep_rms_many` "
             "(optdesign/model/runs.py: every stage over the batch's cases at once, each case's figures its own); "
             "the pool and Dask run such batches.  Client CPU is the study's own process (the pool's and Dask's "
             "processes not counted).", "",
             "| where | cases/s | x one at a time | client CPU per case [ms] |", "|---|---|---|---|"]
    for label in runs:
        lines.append(f"| {label} | {rate[label]:.1f} | {rate[label] / base:.2f}x | {cpu[label]:.2f} |")
    lines += ["", f"cases.csv of all {sum(len(rs) for rs in runs.values())} runs: "
              + ("byte-identical." if len(digests) == 1 else f"{len(digests)} different files (NOT identical)."), "",
              "CPU per case in this process (warm; random boom and payload masses; medians of 3): "
              "`Analysis.run_many` with its certification (`CertifiedExtremes.many`) shown apart, and "
              "`Analysis.sweep_rms_many`.", "",
              "| cases per call | run_many [ms] | of which certification [ms] | run_many without it [ms] | "
              "sweep_rms_many [ms] |", "|---|---|---|---|---|"]
    for size, run, cert, rms in costs:
        lines.append(f"| {size:,} | {run:.3f} | {cert:.3f} | {run - cert:.3f} | {rms:.3f} |")
    return "\n".join(lines) + "\n"


def run_study(n, where, folder):
    done = subprocess.run([sys.executable, "-c", CHILD, str(n), str(folder), where, str(ROOT / "problems" /
                                                                                    "truck_crane.toml")],
                          capture_output=True, text=True, cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)})
    if done.returncode:
        raise SystemExit(f"study of {n} cases on {where} failed:\n{done.stderr[-3000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def journal_rate(n, group, folder):
    """Records per second into a fresh journal: group 1 = an fsync per record."""
    from optdesign.study.journal import Journal

    row = {f"peak:{k}": 12345.678901234 + i for i, k in enumerate(["drive", "power", "static", "velocity"])}
    row.update({f"constraint:c{i}:min": 0.1234567 * i for i in range(12)}, status="ok", success=True)
    with Journal(folder, restart=True) as journal:
        t0 = time.perf_counter()
        for i in range(n):
            journal.add({"id": f"{i:016x}", "case": i, "row": row, "x": None, "time_s": 0.0025},
                        durable=group == 1)
            if group > 1 and (i + 1) % group == 0:
                journal.sync()
        journal.sync()
        return n / (time.perf_counter() - t0), journal.path.stat().st_size / n


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="2000,20000")
    ap.add_argument("--journal", type=int, default=20000, help="records written per journal run")
    ap.add_argument("--group", type=int, default=50, help="records per fsync with group commit")
    ap.add_argument("--batched", type=int, default=0,
                    help="only the batches' comparison, on a study of this many cases (section study_batched)")
    ap.add_argument("--batch", type=int, default=256, help="cases per batch at most for --batched")
    ap.add_argument("--repeats", type=int, default=3, help="runs of each way for --batched (medians)")
    args = ap.parse_args()
    if args.batched:
        with tempfile.TemporaryDirectory() as tmp:
            text = batched_section(args.batched, args.repeats, tmp, args.batch)
        write_section("study_batched", text, SCALING_MD)
        print(text)
        return
    sizes = [int(s) for s in args.sizes.split(",")]
    load0 = os.getloadavg()
    import distributed

    rows = []
    with tempfile.TemporaryDirectory() as tmp, \
            distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                     dashboard_address=None) as cluster:
        run_study(min(sizes), cluster.scheduler_address, Path(tmp) / "warm")   # helpers started, code compiled
        for n in sizes:
            for label, where in (("pool, 2 processes", "pool"), ("Dask LocalCluster, 2 workers", cluster.scheduler_address)):
                r = run_study(n, where, Path(tmp) / f"{n}-{label[:4]}")
                rows.append((n, label, r))
                print(n, label, r, flush=True)
        rates = {g: journal_rate(args.journal, g, Path(tmp) / f"journal-{g}") for g in (1, args.group)}
    load1 = os.getloadavg()
    lines = ["# Studies at scale (`python benchmarks/bench_study_scale.py`)", "",
             f"Written by `python benchmarks/bench_study_scale.py --sizes {args.sizes}` on "
             f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; {git_state()}; machine {cpu_model()}, nproc "
             f"{os.cpu_count()}; load average {load0[0]:.2f} before, {load1[0]:.2f} after (shared).", "",
             "An analyse study of the truck crane (10 boom masses x payloads), each run in a fresh process; the "
             "client's peak memory is its `ru_maxrss` (imports included; the pool's processes and the Dask "
             "cluster are not counted).", "",
             "| cases | where | wall [s] | cases/s | client peak memory [MB] | successful |", "|---|---|---|---|---|---|"]
    for n, label, r in rows:
        lines.append(f"| {n:,} | {label} | {r['wall']:.1f} | {n / r['wall']:.0f} | {r['maxrss_kB'] / 1024:.0f} | "
                     f"{r['ok']:,} |")
    lines.append("")
    for label in dict.fromkeys(lb for _, lb, _ in rows):
        mine = [(n, r) for n, lb, r in rows if lb == label]
        if len(mine) >= 2:
            (n0, r0), (n1, r1) = mine[0], mine[-1]
            per_case = (r1["maxrss_kB"] - r0["maxrss_kB"]) * 1024 / (n1 - n0)
            lines.append(f"- {label}: the client's peak grows by {per_case / 1000:.2f} kB per case from {n0:,} to "
                         f"{n1:,} cases.")
    for n in sizes:
        pool = next(r for m, lb, r in rows if m == n and lb.startswith("pool"))
        dask = next(r for m, lb, r in rows if m == n and lb.startswith("Dask"))
        lines.append(f"- {n:,} cases: Dask / pool throughput {pool['wall'] / dask['wall']:.2f}x.")
    lines += ["", f"Journal ({args.journal:,} records of an analyse row, {rates[1][1]:.0f} bytes each, this "
              "machine's disk):", "",
              "| commit | records/s |", "|---|---|",
              f"| an fsync per record | {rates[1][0]:,.0f} |",
              f"| group commit, an fsync per {args.group} records | {rates[args.group][0]:,.0f} |", "",
              f"Group commit / per-record fsync: {rates[args.group][0] / rates[1][0]:.1f}x."]
    write_section("study_scale", "\n".join(lines) + "\n", SCALING_MD)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
