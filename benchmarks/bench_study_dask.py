"""Dask against the local pool, per worker (issue 31): an analyse study of the truck crane and an
optimise study of the jib, each run on the pool of 2 processes and on a Dask cluster of 2
single-threaded workers on loopback, the scheduler and the workers each a process of their own
(``dask scheduler``, ``dask worker``), started afresh for every Dask run so that the scheduler's
peak memory is that run's.

    python benchmarks/bench_study_dask.py [--sizes 2000,20000] [--optimise 24] [--repeats 1] [--base REV] [--section NAME]

Each study runs in a fresh client process (``Study.run``) that reports its wall time, its CPU
time and its peak resident memory (``VmHWM``, imports included); the scheduler's is read from
its process after the run.  Before each measured Dask run a small study warms the cluster (the
workers' helper processes started, the scene's model built), while the pool's processes start
with its study (forked, they build the model in the run): with studies of seconds this favours
Dask.  The pool and Dask runs are interleaved.

Start-up.  The wall time of a study counts from ``Study.run`` to its return: the client's
connection to the cluster (and ``import distributed``) or the pool's processes' start, the
study's preparation, every case, the folder's files.  A user pays it, so the table's cases/s and
Dask / pool are those of the whole run; the steady state beside it counts only the cases after the
first durable one (``progress`` calls: cases done and times), from that moment to the last: the
rate once both are running.  The time to the first durable result is given too, and the
client's start-up in it (to the moment the study starts feeding cases: connection, preparation).

Fair per worker: 2 pool processes against 2 single-threaded Dask workers, the same study (the
same cases, batched by the same code) in every run; each run's cases.csv is hashed (SHA-256) and
compared with the pool's run of the same round: the line under the tables says whether all were
byte-identical.

Fixed costs.  A Dask client pays ``import distributed`` (0.3-0.6 s of CPU; the pool's client
does not import it) and its connection before the first batch, while the cluster's helpers wait:
at 20,000 truck-crane cases (~3.5 s of wall on the quiet machine) that alone is ~10 % of the
whole run, at 96 jib optimisations (~3 s) ~12 %.  The steady rate leaves it out; larger sizes
(``--sizes 20000,200000``, ``--optimise 480``) show the whole run's ratio where it is diluted.

Dask's settings.  Each round runs this code's Dask twice: on a cluster started with the settings
README.md recommends for a study's cluster (optdesign/study/cluster.py: Dask's event-loop check,
system monitor and worker profiler less often or off) and on the same cluster with Dask's defaults.

``--base REV``: Dask runs also with the code at REV (``git archive`` of optdesign and problems;
its own cluster with Dask's defaults, its workers and helpers importing that code), interleaved
with this code's runs, against the same pool runs (this code): Dask / pool before and after in
one run.

Writes its section (study_dask, or ``--section``) of results/scaling.md (benchmarks/benchfile.py)."""
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
from benchfile import ROOT, SCALING_MD, cpu_model, export, git_state, write_section  # noqa: E402
from optdesign.study.cluster import environ  # noqa: E402

CLIENT = """
import json, resource, sys, time
import optdesign
from optdesign.study import Study, grid
kind, n, out, where = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4]
if kind == "analyse":
    study = Study(optdesign.load("problems/truck_crane.toml"), [grid("mB", 500, 800, 10), grid("mP", 500, 3000, n // 10)],
                  mode="analyse")
else:   # chains of 4 warm-started cases: n // 4 chains in parallel
    study = Study(optdesign.load("problems/seed1_jib_design.toml"), [grid("mC", 300, 750, n)], starts=2, chain=4)
kw = {"workers": 2} if where == "pool" else {"scheduler": where}
seen = []   # (time, cases done) at each progress call
t0, c0 = time.perf_counter(), time.process_time()
r = study.run(out=out, restart=True, figures=False, progress=lambda done, total: seen.append((time.perf_counter(), done)),
              **kw)
wall, cpu = time.perf_counter() - t0, time.process_time() - c0
start = seen[0][0] - t0   # the first call, before any case: the client's start-up (connection, preparation)
came = [(t, d) for t, d in seen if d > 0]
(t1, d1), (t2, d2) = came[0], came[-1]
steady = (d2 - d1) / (t2 - t1) if t2 > t1 and d2 > d1 else float("nan")
with open("/proc/self/status") as fh:
    hwm = next(int(l.split()[1]) for l in fh if l.startswith("VmHWM:"))
assert r.complete and r.computed == n, r
kids = resource.getrusage(resource.RUSAGE_CHILDREN)   # the pool's processes, waited for when it ended
import hashlib
csv = hashlib.sha256(open(out + "/cases.csv", "rb").read()).hexdigest()   # the answers, compared between runs
print(json.dumps({"csv": csv, "wall": wall, "cpu": cpu, "children_cpu": kids.ru_utime + kids.ru_stime, "hwm_kB": hwm, "ok": int(r.column("success").sum()), "start_s": start, "first_s": t1 - t0,
                  "steady": steady}))
"""


def client(kind, n, where, folder, code=ROOT):
    env = {**os.environ, "PYTHONPATH": str(code), "MPLBACKEND": "Agg"}
    done = subprocess.run([sys.executable, "-c", CLIENT, kind, str(n), str(folder), where], capture_output=True,
                          text=True, cwd=code, env=env)
    if done.returncode:
        raise SystemExit(f"{kind} study of {n} cases on {where} failed:\n{done.stderr[-3000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def cpu_s(pid) -> float:
    """A process's CPU time so far (user + system), seconds."""
    with open(f"/proc/{pid}/stat") as fh:
        fields = fh.read().rpartition(")")[2].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def roles(scheduler, nannies) -> dict:
    """The cluster's processes by role: pid -> 'scheduler', 'nanny', 'worker' (the nanny's worker
    process) or 'helper' (the study's helper processes of a worker)."""
    children = {}
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                with open(f"/proc/{d}/stat") as fh:
                    children.setdefault(int(fh.read().rpartition(")")[2].split()[1]), []).append(int(d))
            except OSError:
                pass

    def cmd(pid):
        with open(f"/proc/{pid}/cmdline") as fh:
            return fh.read()

    out = {scheduler: "scheduler"}
    for nanny in nannies:
        out[nanny] = "nanny"
        for w in children.get(nanny, []):
            if "multiprocessing-fork" in cmd(w):
                out[w] = "worker"
                out.update({h: "helper" for h in children.get(w, []) if "optdesign.study.worker" in cmd(h)})
    return out


def status_kB(pid, key):
    with open(f"/proc/{pid}/status") as fh:
        return next(int(line.split()[1]) for line in fh if line.startswith(key + ":"))


@contextlib.contextmanager
def cluster(workers=2, code=ROOT, settings=None):
    """A scheduler and ``workers`` single-threaded workers, each its own process, on loopback:
    (address, the scheduler's pid); ``settings``: Dask's environment variables for them
    (optdesign.study.cluster.environ(), the ones README.md recommends), else Dask's defaults."""
    import distributed

    dask = str(Path(sys.executable).with_name("dask"))
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    env = {**os.environ, "PYTHONPATH": str(code), **(settings or {})}
    procs = [subprocess.Popen([dask, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
                              stderr=subprocess.DEVNULL, env=env, cwd=code)]
    try:
        time.sleep(2)
        procs += [subprocess.Popen([dask, "worker", address, "--nthreads", "1", "--nworkers", "1", "--no-dashboard",
                                    "--memory-limit", "0"], stderr=subprocess.DEVNULL, env=env, cwd=code)
                  for _ in range(workers)]
        with distributed.Client(address, timeout=60) as c:
            t0 = time.monotonic()
            while len(c.nthreads()) < workers:
                if time.monotonic() - t0 > 120:
                    raise SystemExit("the Dask workers did not come up in 120 s")
                time.sleep(0.2)
        yield address, [p.pid for p in procs]   # the scheduler's, then the workers' (nannies)
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            p.wait(timeout=60)


def on_dask(kind, n, folder, code=ROOT, settings=None):
    with cluster(code=code, settings=settings) as (address, (scheduler, *nannies)):
        client(kind, 40 if kind == "analyse" else 4, address, folder.with_name(folder.name + "-warm"), code)
        before = status_kB(scheduler, "VmRSS")
        who = roles(scheduler, nannies)   # the helpers the warm-up started (a batch may start more)
        cpu0 = {pid: cpu_s(pid) for pid in who}
        dask = client(kind, n, address, folder, code)
        who.update(roles(scheduler, nannies))
        dask["scheduler_kB"], dask["scheduler_before_kB"] = status_kB(scheduler, "VmHWM"), before
        dask["cpu_by_role"] = {}
        for pid, role in who.items():
            try:
                used = cpu_s(pid) - cpu0.get(pid, 0.0)
            except OSError:   # a helper that ended (not the case here: they live as long as their worker)
                continue
            dask["cpu_by_role"][role] = dask["cpu_by_role"].get(role, 0.0) + used
    return dask


def on_pool(kind, n, folder):
    """The pool's run, with its processes' CPU (the client's children, waited for when the pool ends)."""
    pool = client(kind, n, "pool", folder)
    pool["cpu_by_role"] = {"pool processes": pool["children_cpu"]}
    return pool


def variants(base):
    """The Dask runs of a round: (label, code, the cluster's settings)."""
    runs = [("this", ROOT, environ()), ("this, Dask's defaults", ROOT, None)]
    return runs + ([(f"base {base[0]}, Dask's defaults", base[1], None)] if base else [])


def measure(kind, n, tmp, k, runs):
    """(pool, then each Dask run of ``runs``), interleaved: the Dask runs in turn in a rotated
    order (round ``k``), so that a load that rises or falls during a round does not always favour
    the same one."""
    pool = on_pool(kind, n, tmp / f"{kind}-{n}-{k}-pool")
    got = {}
    for j in [(k + i) % len(runs) for i in range(len(runs))]:
        label, code, settings = runs[j]
        got[j] = on_dask(kind, n, tmp / f"{kind}-{n}-{k}-{j}", code, settings)
    return [pool] + [got[j] for j in range(len(runs))]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="2000,20000", help="analyse studies' cases")
    ap.add_argument("--optimise", type=int, default=24, help="cases of the optimise study (0: none)")
    ap.add_argument("--repeats", type=int, default=1, help="runs of each (medians)")
    ap.add_argument("--base", default=None, help="a commit whose Dask runs are measured in the same run")
    ap.add_argument("--section", default="study_dask", help="the section of results/scaling.md written (letters, "
                    "digits, _): another run's figures kept beside")
    args = ap.parse_args()
    load0 = os.getloadavg()
    runs = [("analyse", int(s)) for s in args.sizes.split(",") if s] + ([("optimise", args.optimise)] if args.optimise else [])
    got = {}
    with tempfile.TemporaryDirectory() as tmp:
        base = (args.base, export(args.base, Path(tmp) / "base")) if args.base else None
        dask_runs = variants(base)
        for k in range(args.repeats):
            for kind, n in runs:
                measured = measure(kind, n, Path(tmp), k, dask_runs)
                got.setdefault((kind, n), []).append(measured)
                print(kind, n, *(json.dumps(m) for m in measured), flush=True)
            report(args, got, load0, k + 1, [label for label, _, _ in dask_runs])   # after every round


def same_answers(got) -> str:
    """Whether every run of a study wrote the same cases.csv, byte for byte (its SHA-256), as the
    pool's run of the same round: the same cases and the same answers."""
    differ = [f"{kind} {n:,} round {k + 1} run {j}" for (kind, n), rs in got.items() for k, r in enumerate(rs)
              for j, m in enumerate(r) if m.get("csv") != r[0].get("csv")]
    runs = sum(len(r) for rs in got.values() for r in rs)
    if not differ:
        return f"cases.csv byte-identical (SHA-256) to the pool's of the same study in all {runs} runs."
    return f"cases.csv DIFFERS from the pool's of the same study in {len(differ)} of {runs} runs: {', '.join(differ)}."


def report(args, got, load0, rounds, labels):
    load1 = os.getloadavg()
    cmd = " ".join(["python benchmarks/bench_study_dask.py", *sys.argv[1:]])
    lines = ["# Dask against the pool (`python benchmarks/bench_study_dask.py`)", "",
             f"Written by `{cmd}` on {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; {git_state()}; machine "
             f"{cpu_model()}, nproc {os.cpu_count()}; load average {load0[0]:.2f} before, {load1[0]:.2f} after "
             f"(shared with other sessions' work); {rounds} of {args.repeats} round(s) done.", "",
             "2 workers each: the local pool (2 processes) and a Dask cluster of 2 single-threaded worker processes and "
             "a scheduler process on loopback (a fresh cluster per run, warmed by a small study: its helpers "
             "started, the model built; the pool's runs include their processes' start). Analyse: the truck crane, "
             "10 boom masses x payloads; optimise: the jib (seed1_jib_design), mC on a grid, 2 starts, chains of 4. "
             f"Medians of {rounds} interleaved run(s) (the pool, then the Dask runs in a rotated order). Dask runs: "
             f"'this': this code, its cluster started with the settings README.md recommends for a study's cluster "
             f"({', '.join(f'{k}={v}' for k, v in environ().items())}: optdesign/study/cluster.py); 'Dask's defaults': "
             "the same cluster with Dask's own settings" + (", 'base': the code at the base commit" if args.base else "")
             + ". "
             "Whole run: wall time from Study.run to its return, start-up included (the client's connection or the "
             "pool's start, the first case's wait); steady: the cases after the first durable one over the time from "
             "it to the last. Peak memory is VmHWM (the client's imports included; the scheduler's since it "
             "started, the warm-up included).", ""]
    cols = [(name, j + 1) for j, name in enumerate(labels)]
    head = " | ".join(f"Dask / pool whole ({name}) | Dask / pool steady ({name})" for name, _ in cols)
    lines += [f"| study | cases | pool cases/s whole / steady | Dask cases/s whole / steady | {head} | first result s "
              "pool / Dask (client start-up) | client CPU per case pool / Dask [us] | client peak MB pool / Dask | scheduler peak MB (at "
              "start) |", "|---|---|---|---|" + "---|---|" * len(cols) + "---|---|---|---|"]

    def med(rs, j, key):
        return statistics.median((n / r[j]["wall"]) if key == "whole" else r[j][key] for r in rs)

    for (kind, n), rs in got.items():
        ratios = " | ".join(f"{med(rs, j, 'whole') / med(rs, 0, 'whole'):.2f}x | "
                            f"{med(rs, j, 'steady') / med(rs, 0, 'steady'):.2f}x" for _, j in cols)
        p, d = rs[-1][0], rs[-1][1]
        lines.append(f"| {kind} | {n:,} | {med(rs, 0, 'whole'):,.1f} / {med(rs, 0, 'steady'):,.1f} | "
                     f"{med(rs, 1, 'whole'):,.1f} / {med(rs, 1, 'steady'):,.1f} | {ratios} | "
                     f"{statistics.median(r[0]['first_s'] for r in rs):.1f} / "
                     f"{statistics.median(r[1]['first_s'] for r in rs):.1f} (start-up {statistics.median(r[0]['start_s'] for r in rs):.1f} / "
                     f"{statistics.median(r[1]['start_s'] for r in rs):.1f}) | "
                     f"{statistics.median(1e6 * r[0]['cpu'] / n for r in rs):,.0f} / "
                     f"{statistics.median(1e6 * r[1]['cpu'] / n for r in rs):,.0f} | "
                     f"{p['hwm_kB'] / 1024:.0f} / {d['hwm_kB'] / 1024:.0f} | "
                     f"{d['scheduler_kB'] / 1024:.0f} ({d['scheduler_before_kB'] / 1024:.0f}) |")
    lines += ["", "Where the CPU went, per case (medians over the rounds, microseconds; each process's user + system time "
              "from the study's start to its end: the client's from Study.run, the pool's processes (forked by it, "
              "building the model in the run), and the Dask cluster's processes read from /proc before and after "
              "the measured run): the cluster's own processes take their CPU from the cores the helpers compute on.", "",
              "| study | cases | run | client | pool processes / helpers | Dask worker processes | nannies | scheduler | all | "
              "cores busy (all CPU / wall) |", "|---|---|---|---|---|---|---|---|---|---|"]
    for (kind, n), rs in got.items():
        for j, name in [(0, "pool"), *((j, f"Dask ({name})") for name, j in cols)]:
            def per(role):
                return statistics.median(1e6 * (r[j]["cpu"] if role == "client" else r[j]["cpu_by_role"].get(role, 0.0)) / n
                                         for r in rs)
            compute = per("pool processes") if j == 0 else per("helper")
            parts = [per("client"), compute] + ([per("worker"), per("nanny"), per("scheduler")] if j else [0.0, 0.0, 0.0])
            busy = statistics.median((r[j]["cpu"] + sum(r[j]["cpu_by_role"].values())) / r[j]["wall"] for r in rs)
            cells = " | ".join(f"{v:,.0f}" if (v or not j == 0) else "-" for v in parts)
            lines.append(f"| {kind} | {n:,} | {name} | {cells} | {sum(parts):,.0f} | {busy:.2f} |")
    lines += ["", "Per round (the Dask runs rotate their order each round): the machine's speed drifts between "
              "minutes, so a ratio moves from round to round; CPU per case is the steadier measure.", "",
              "| study | round | pool wall s | Dask wall s (" + " / ".join(labels) + ") | Dask / pool whole | "
              "CPU per case all processes, us (pool / " + " / ".join(labels) + ") |", "|---|---|---|---|---|---|"]
    for (kind, n), rs in got.items():
        for k, r in enumerate(rs):
            every = [1e6 * (m["cpu"] + sum(m["cpu_by_role"].values())) / n for m in r]
            lines.append(f"| {kind} {n:,} | {k + 1} | {r[0]['wall']:.2f} | "
                         + " / ".join(f"{m['wall']:.2f}" for m in r[1:]) + " | "
                         + " / ".join(f"{r[0]['wall'] / m['wall']:.2f}x" for m in r[1:]) + " | "
                         + " / ".join(f"{v:,.0f}" for v in every) + " |")
    lines.append("")
    lines.append("Every run's cases all finished; successful cases (pool / " + " / ".join(labels) + "): "
                 + ", ".join(f"{kind} {n:,}: " + " / ".join(f"{r['ok']:,}" for r in rs[-1] if r) for (kind, n), rs in got.items())
                 + ". " + same_answers(got))
    write_section(args.section, "\n".join(lines) + "\n", SCALING_MD)
    print("\n".join(lines), flush=True)


if __name__ == "__main__":
    main()
