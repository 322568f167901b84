"""Dask against the local pool, per worker (issue 31): an analyse study of the truck crane and an
optimise study of the jib, each run on the pool of 2 processes and on a Dask cluster of 2
single-threaded workers on loopback, the scheduler and the workers each a process of their own
(``dask scheduler``, ``dask worker``), started afresh for every Dask run so that the scheduler's
peak memory is that run's.

    python benchmarks/bench_study_dask.py [--sizes 2000,20000] [--optimise 24] [--repeats 1]

Each study runs in a fresh client process (``Study.run``) that reports its wall time, its CPU
time and its peak resident memory (``VmHWM``, imports included); the scheduler's is read from
its process after the run.  Before each measured Dask run a small study warms the cluster (the
workers' helper processes started, the scene's model built), while the pool's processes start
with its study (forked, they build the model in the run): with studies of seconds this favours
Dask.  The pool and Dask runs are interleaved.

Writes its section (study_dask) of results/scaling.md (benchmarks/benchfile.py)."""
from __future__ import annotations

import argparse
import contextlib
import json
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from benchfile import ROOT, SCALING_MD, cpu_model, git_state, write_section  # noqa: E402

CLIENT = """
import json, sys, time
import optdesign
from optdesign.study import Study, grid
kind, n, out, where = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4]
if kind == "analyse":
    study = Study(optdesign.load("problems/truck_crane.toml"), [grid("mB", 500, 800, 10), grid("mP", 500, 3000, n // 10)],
                  mode="analyse")
else:   # chains of 4 warm-started cases: n // 4 chains in parallel
    study = Study(optdesign.load("problems/seed1_jib_design.toml"), [grid("mC", 300, 750, n)], starts=2, chain=4)
kw = {"workers": 2} if where == "pool" else {"scheduler": where}
t0, c0 = time.perf_counter(), time.process_time()
r = study.run(out=out, restart=True, figures=False, **kw)
wall, cpu = time.perf_counter() - t0, time.process_time() - c0
with open("/proc/self/status") as fh:
    hwm = next(int(l.split()[1]) for l in fh if l.startswith("VmHWM:"))
assert r.complete and r.computed == n, r
print(json.dumps({"wall": wall, "cpu": cpu, "hwm_kB": hwm, "ok": int(r.column("success").sum())}))
"""


def client(kind, n, where, folder):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    done = subprocess.run([sys.executable, "-c", CLIENT, kind, str(n), str(folder), where], capture_output=True,
                          text=True, cwd=ROOT, env=env)
    if done.returncode:
        raise SystemExit(f"{kind} study of {n} cases on {where} failed:\n{done.stderr[-3000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def status_kB(pid, key):
    with open(f"/proc/{pid}/status") as fh:
        return next(int(line.split()[1]) for line in fh if line.startswith(key + ":"))


@contextlib.contextmanager
def cluster(workers=2):
    """A scheduler and ``workers`` single-threaded workers, each its own process, on loopback:
    (address, the scheduler's pid)."""
    import distributed

    dask = str(Path(sys.executable).with_name("dask"))
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    procs = [subprocess.Popen([dask, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
                              stderr=subprocess.DEVNULL, env=env, cwd=ROOT)]
    try:
        time.sleep(2)
        procs += [subprocess.Popen([dask, "worker", address, "--nthreads", "1", "--nworkers", "1", "--no-dashboard",
                                    "--memory-limit", "0"], stderr=subprocess.DEVNULL, env=env, cwd=ROOT)
                  for _ in range(workers)]
        with distributed.Client(address, timeout=60) as c:
            t0 = time.monotonic()
            while len(c.nthreads()) < workers:
                if time.monotonic() - t0 > 120:
                    raise SystemExit("the Dask workers did not come up in 120 s")
                time.sleep(0.2)
        yield address, procs[0].pid
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            p.wait(timeout=60)


def measure(kind, n, tmp, k):
    pool = client(kind, n, "pool", tmp / f"{kind}-{n}-{k}-pool")
    with cluster() as (address, scheduler):
        client(kind, 40 if kind == "analyse" else 4, address, tmp / f"{kind}-{n}-{k}-warm")
        before = status_kB(scheduler, "VmRSS")
        dask = client(kind, n, address, tmp / f"{kind}-{n}-{k}-dask")
        dask["scheduler_kB"], dask["scheduler_before_kB"] = status_kB(scheduler, "VmHWM"), before
    return pool, dask


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="2000,20000", help="analyse studies' cases")
    ap.add_argument("--optimise", type=int, default=24, help="cases of the optimise study (0: none)")
    ap.add_argument("--repeats", type=int, default=1, help="runs of each (medians)")
    args = ap.parse_args()
    load0 = os.getloadavg()
    runs = [("analyse", int(s)) for s in args.sizes.split(",") if s] + ([("optimise", args.optimise)] if args.optimise else [])
    got = {}
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(args.repeats):
            for kind, n in runs:
                pool, dask = measure(kind, n, Path(tmp), k)
                got.setdefault((kind, n), []).append((pool, dask))
                print(kind, n, json.dumps(pool), json.dumps(dask), flush=True)
    load1 = os.getloadavg()
    cmd = " ".join(["python benchmarks/bench_study_dask.py", *sys.argv[1:]])
    lines = ["# Dask against the pool (`python benchmarks/bench_study_dask.py`)", "",
             f"Written by `{cmd}` on {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; {git_state()}; machine "
             f"{cpu_model()}, nproc {os.cpu_count()}; load average {load0[0]:.2f} before, {load1[0]:.2f} after "
             "(shared with other sessions' work).", "",
             "2 workers each: the local pool (2 processes) and a Dask cluster of 2 single-threaded worker processes and "
             "a scheduler process on loopback (a fresh cluster per run, warmed by a small study: its helpers "
             "started, the model built; the pool's runs include their processes' start). Analyse: the truck crane, "
             "10 boom masses x payloads; optimise: the jib (seed1_jib_design), mC on a grid, 2 starts, chains of 4. "
             f"Medians of {args.repeats} interleaved run(s). Peak memory is VmHWM (the client's imports included; "
             "the scheduler's since it started, the warm-up included).", "",
             "| study | cases | pool cases/s | Dask cases/s | Dask / pool | client peak MB pool / Dask | client CPU per "
             "case pool / Dask [us] | scheduler peak MB (at start) |", "|---|---|---|---|---|---|---|---|"]
    for (kind, n), rs in got.items():
        pool_rate = statistics.median(n / p["wall"] for p, _ in rs)
        dask_rate = statistics.median(n / d["wall"] for _, d in rs)
        p, d = rs[-1]
        lines.append(f"| {kind} | {n:,} | {pool_rate:,.1f} | {dask_rate:,.1f} | {dask_rate / pool_rate:.2f}x | "
                     f"{p['hwm_kB'] / 1024:.0f} / {d['hwm_kB'] / 1024:.0f} | {1e6 * p['cpu'] / n:,.0f} / "
                     f"{1e6 * d['cpu'] / n:,.0f} | {d['scheduler_kB'] / 1024:.0f} ({d['scheduler_before_kB'] / 1024:.0f}) |")
    lines.append("")
    lines.append("Every run's cases all finished; successful cases: " + ", ".join(
        f"{kind} {n:,}: {rs[-1][0]['ok']:,} / {rs[-1][1]['ok']:,}" for (kind, n), rs in got.items()) + ".")
    write_section("study_dask", "\n".join(lines) + "\n", SCALING_MD)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
