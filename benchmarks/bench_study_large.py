"""A large study, its client's memory, and its journal after a kill (issue 31).

    python benchmarks/bench_study_large.py [--live 10000] [--kill-after 240] [--workers 2] [--resumed 1000000]
                                           [--client 1000000]

*live*: an analyse study of the truck crane (problems/truck_crane.toml: 10 boom masses mB x
``live / 10`` payloads mP) run for real on a process pool of ``--workers``, its client (the
process running ``Study.run``, progress logged) killed with SIGKILL ``--kill-after`` seconds in, then run
again with the same folder to finish.  Measured: the records the journal holds after the kill (a
torn last line allowed), whether the second run took every one of them from the journal and
computed exactly the others (no finished case computed twice), the journal's ids unique and
complete at the end, cases.csv's rows and cases.parquet read back against cases.csv cell by cell;
cases per second of each run (``computed / wall``), and the client's peak resident memory
(``VmHWM`` of its process: imports included, the pool's processes not; the killed run's read
every 0.2 s until the kill).

*resumed*: a finished study of ``--resumed`` cases (every case in its journal, one real analyse
row under each id, as a finished study leaves it) run again in a fresh client with figures:
the journal opened, the cases listed, the rows held, cases.csv, cases.parquet, the figures and
the summary written.  Its wall time and peak resident memory: what a study of that many cases
costs its client, whatever computed the rows.

*client*: a fresh study of ``--client`` cases on the pool of 2 processes whose workers answer
every batch at once (one real analyse row, computed once, returned for every case, with the
rows' text made there as a real batch's is): everything the client does per case (the cases
listed, the batches' tasks, the answers received, the journal written with group commit,
cases.csv, cases.parquet, the rows held, the summary) and nothing else; the client's CPU time
per case is measured beside its wall rate.  Its cases per second bound what any executor can deliver through this client;
its peak resident memory is a fresh million-case study's client's, the computation aside.

Writes a section of results/scaling.md per part run (study_large, study_large_resumed,
study_large_client; benchmarks/benchfile.py)."""
from __future__ import annotations

import argparse
import csv
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from benchfile import ROOT, SCALING_MD, cpu_model, git_state, write_section  # noqa: E402

SCENE = ROOT / "problems" / "truck_crane.toml"
MASSES = 10

CLIENT = """
import json, sys, time
n, folder, workers, figures = int(sys.argv[1]), sys.argv[2], int(sys.argv[3]), sys.argv[4] == "figures"
import optdesign
from optdesign.cli.progress import progress_bar
from optdesign.study import Study, grid
study = Study(optdesign.load(%r), [grid("mB", 500, 800, %d), grid("mP", 500, 3000, n // %d)], mode="analyse")
t0 = time.perf_counter()
r = study.run(out=folder, workers=workers, figures=figures, progress=progress_bar("cases", log=True))
wall = time.perf_counter() - t0
with open("/proc/self/status") as fh:
    hwm = next(int(l.split()[1]) for l in fh if l.startswith("VmHWM:"))
print(json.dumps({"wall": wall, "computed": r.computed, "reused": r.reused, "rows": len(r.rows),
                  "complete": r.complete, "hwm_kB": hwm}))
""" % (str(SCENE), MASSES, MASSES)


def client(n, folder, workers, figures, log):
    return subprocess.Popen([sys.executable, "-c", CLIENT, str(n), str(folder), str(workers),
                             "figures" if figures else "none"], cwd=ROOT, stdout=subprocess.PIPE, stderr=log,
                            text=True, env={**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"})


def hwm_kB(pid):
    try:
        with open(f"/proc/{pid}/status") as fh:
            return next(int(line.split()[1]) for line in fh if line.startswith("VmHWM:"))
    except (OSError, StopIteration):
        return None


def journal_ids(folder):
    """The ids of the journal's complete, valid records (a torn last line left out), and the
    number of lines that are not."""
    ids, bad = [], 0
    with open(Path(folder) / "journal.jsonl", "rb") as fh:
        for raw in fh:
            if not raw.endswith(b"\n"):
                bad += 1
                continue
            try:
                ids.append(json.loads(raw)["id"])
            except (ValueError, KeyError):
                bad += 1
    return ids, bad


def parquet_equals_csv(folder) -> bool:
    """cases.parquet read back (pyarrow) holds cases.csv's every cell, column by column."""
    import pyarrow.parquet as pq

    from optdesign.study.table import cell

    with open(Path(folder) / "cases.csv", newline="") as fh:
        rows = list(csv.reader(fh))
    table = pq.read_table(Path(folder) / "cases.parquet")
    if table.column_names != rows[0] or table.num_rows != len(rows) - 1:
        return False
    for j, name in enumerate(rows[0]):
        if [cell(v) for v in table.column(name).to_pylist()] != [r[j] for r in rows[1:]]:
            return False
    return True


def live(n, kill_after, workers, tmp):
    folder, log = tmp / "live", open(tmp / "live.log", "w")
    proc = client(n, folder, workers, False, log)
    t0, hwm = time.monotonic(), 0
    while time.monotonic() - t0 < kill_after and proc.poll() is None:
        hwm = max(hwm, hwm_kB(proc.pid) or 0)
        time.sleep(0.2)
    if proc.poll() is not None:
        raise SystemExit(f"the study ended before the kill at {kill_after} s: use more cases")
    hwm = max(hwm, hwm_kB(proc.pid) or 0)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    killed_s = time.monotonic() - t0
    time.sleep(2)   # the pool's workers follow their parent
    ids, torn = journal_ids(folder)
    proc = client(n, folder, workers, False, log)
    out, _ = proc.communicate()
    if proc.returncode:
        raise SystemExit(f"the resumed study failed: see {tmp / 'live.log'}")
    again = json.loads(out.strip().splitlines()[-1])
    final, bad = journal_ids(folder)
    with open(folder / "cases.csv") as fh:
        csv_rows = sum(1 for _ in fh) - 1
    return {"n": n, "killed_s": killed_s, "hwm1_kB": hwm, "at_kill": len(ids), "torn": torn,
            "unique_at_kill": len(set(ids)), "again": again, "final": len(final), "final_unique": len(set(final)),
            "final_bad": bad, "csv_rows": csv_rows, "parquet_ok": parquet_equals_csv(folder),
            "log": (tmp / "live.log").read_text().splitlines()}


PREPARE = """
import json, sys
n, folder = int(sys.argv[1]), sys.argv[2]
import optdesign
from optdesign.study import Study, grid
from optdesign.study.executors import record
from optdesign.study.tasks import run_task
study = Study(optdesign.load(%r), [grid("mB", 500, 800, %d), grid("mP", 500, 3000, n // %d)], mode="analyse")
cases = study.cases()
out = run_task(study.task(cases[0]))
assert out["row"]["success"], out
with open(folder + "/journal.jsonl", "w") as fh:
    for c in cases:
        fh.write(json.dumps(record(c, out), separators=(",", ":")) + "\\n")
""" % (str(SCENE), MASSES, MASSES)


def resumed(n, tmp):
    folder = tmp / "resumed"
    folder.mkdir()
    subprocess.run([sys.executable, "-c", PREPARE, str(n), str(folder)], cwd=ROOT, check=True,
                   env={**os.environ, "PYTHONPATH": str(ROOT)})
    size = (folder / "journal.jsonl").stat().st_size
    with open(tmp / "resumed.log", "w") as log:
        proc = client(n, folder, 1, True, log)
        out, _ = proc.communicate()
    if proc.returncode:
        raise SystemExit(f"the resumed study failed: see {tmp / 'resumed.log'}")
    got = json.loads(out.strip().splitlines()[-1])
    return {"n": n, "journal_MB": size / 1e6, **got, "parquet_MB": (folder / "cases.parquet").stat().st_size / 1e6,
            "csv_MB": (folder / "cases.csv").stat().st_size / 1e6}


STAND_IN = """
import json, sys, time
n, folder = int(sys.argv[1]), sys.argv[2]
import optdesign
from optdesign.study import Study, grid, tasks
from optdesign.study.tasks import run_task
study = Study(optdesign.load(%r), [grid("mB", 500, 800, %d), grid("mP", 500, 3000, n // %d)], mode="analyse")
# the pool's workers (forked after this) answer every case at once with one real row, claiming
# 0.4 ms of work per case (the issue's 5,000 cases/s on 2 cores: the batches sized for that)
out = dict(run_task(study.task(study.cases()[0])), time_s=0.0004)
from optdesign.study.blocks import blocks
tasks.batch_blocks = lambda batch, index, ids: blocks(index, ids, [dict(out) for _ in batch])   # (worker.blocks_made's)
t0, c0 = time.perf_counter(), time.process_time()
r = study.run(out=folder, workers=2, figures=False)
wall, cpu = time.perf_counter() - t0, time.process_time() - c0
with open("/proc/self/status") as fh:
    hwm = next(int(l.split()[1]) for l in fh if l.startswith("VmHWM:"))
print(json.dumps({"wall": wall, "cpu": cpu, "computed": r.computed, "reused": r.reused, "rows": len(r.rows),
                  "complete": r.complete, "hwm_kB": hwm}))
""" % (str(SCENE), MASSES, MASSES)


def stand_in(n, tmp):
    folder = tmp / "client"
    done = subprocess.run([sys.executable, "-c", STAND_IN, str(n), str(folder)], cwd=ROOT, capture_output=True,
                          text=True, env={**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"})
    if done.returncode:
        raise SystemExit(f"the stand-in study failed:\n{done.stderr[-3000:]}")
    got = json.loads(done.stdout.strip().splitlines()[-1])
    ids, bad = journal_ids(folder)
    return {"n": n, **got, "journal": len(set(ids)), "bad": bad}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--live", type=int, default=10_000, help="cases of the study run for real (0: none)")
    ap.add_argument("--kill-after", type=float, default=240.0, help="seconds before its client is killed")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--resumed", type=int, default=1_000_000, help="cases of the finished study resumed (0: none)")
    ap.add_argument("--client", type=int, default=0, help="cases of the fresh study answered by a stand-in (0: none)")
    ap.add_argument("--keep", help="a folder to run in and keep (default: a temporary one)")
    args = ap.parse_args()
    load0 = os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(args.keep) if args.keep else Path(tmp)
        tmp.mkdir(parents=True, exist_ok=True)
        lv = live(args.live, args.kill_after, args.workers, tmp) if args.live else None
        if lv:
            print(json.dumps({k: v for k, v in lv.items() if k != "log"}), flush=True)
        rs = resumed(args.resumed, tmp) if args.resumed else None
        if rs:
            print(json.dumps(rs), flush=True)
        cl = stand_in(args.client, tmp) if args.client else None
        if cl:
            print(json.dumps(cl), flush=True)
    load1 = os.getloadavg()
    cmd = " ".join(["python benchmarks/bench_study_large.py", *sys.argv[1:]])
    stamp = (f"Written by `{cmd}` on {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; {git_state()}; machine "
             f"{cpu_model()}, nproc {os.cpu_count()}; load average {load0[0]:.2f} before, {load1[0]:.2f} after "
             "(shared with other sessions' work).")
    sections = {}   # each part its own section of results/scaling.md: a run of one part leaves the others
    lines = ["# A large study: its journal after a kill, its client's memory (`python benchmarks/bench_study_large.py "
             "--live N`)", "", stamp, ""]
    if lv:
        a = lv["again"]
        first_rate = lv["at_kill"] / lv["killed_s"]
        lines += [f"**Live**: an analyse study of the truck crane, {lv['n']:,} cases (10 boom masses x {lv['n'] // 10:,} "
                  f"payloads), a pool of {args.workers} processes, its client killed with SIGKILL after "
                  f"{lv['killed_s']:.0f} s, then run again with the same folder.", "",
                  "| | first run (killed) | second run (resumed) |", "|---|---|---|",
                  f"| cases finished | {lv['at_kill']:,} in the journal at the kill ({lv['torn']} torn line) | "
                  f"{a['computed']:,} computed, {a['reused']:,} taken from the journal |",
                  f"| cases per second | {first_rate:.1f} (journal records / time to the kill) | "
                  f"{a['computed'] / a['wall']:.1f} ({a['wall']:.0f} s wall, files written included) |",
                  f"| client peak resident memory | {lv['hwm1_kB'] / 1024:.0f} MB (read every 0.2 s) | "
                  f"{a['hwm_kB'] / 1024:.0f} MB |", "",
                  f"- No finished case computed twice: the second run took {a['reused']:,} cases from the journal "
                  f"(the journal held {lv['unique_at_kill']:,} distinct ids after the kill) and computed "
                  f"{a['computed']:,} = {lv['n']:,} - {a['reused']:,}: "
                  f"{'yes' if a['reused'] == lv['unique_at_kill'] and a['computed'] == lv['n'] - a['reused'] else 'NO'}.",
                  f"- The journal at the end: {lv['final']:,} records, {lv['final_unique']:,} distinct ids, "
                  f"{lv['final_bad']} damaged lines; cases.csv {lv['csv_rows']:,} rows; cases.parquet read back equals "
                  f"cases.csv cell by cell: {'yes' if lv['parquet_ok'] else 'NO'}.",
                  "- The client's progress log (every 10 s or 5 %), first and last lines of each run:", "", "```",
                  *lv["log"][:3], "...", *[ln for ln in lv["log"] if ln.startswith("cases")][-2:], "```", ""]
        rate = a["computed"] / a["wall"]
        lines += [f"At the resumed run's rate ({rate:.0f} cases/s) a 1,000,000-case study would take "
                  f"{1e6 / rate / 60:.0f} min on this machine (an extrapolation, not a measurement).", ""]
        sections["study_large"] = lines
    if rs:
        lines = ["# A finished large study resumed (`python benchmarks/bench_study_large.py --resumed N`)", "", stamp, ""]
        lines += [f"**Resumed**: a finished analyse study of the truck crane of {rs['n']:,} cases (its journal "
                  f"{rs['journal_MB']:.0f} MB: one real row under each case's id) run again in a fresh client, "
                  "figures included: the journal opened, the cases listed, the rows held, cases.csv "
                  f"({rs['csv_MB']:.0f} MB), cases.parquet ({rs['parquet_MB']:.0f} MB), figures and summary written: "
                  f"{rs['wall']:.0f} s wall, client peak resident memory {rs['hwm_kB'] / 1024:.0f} MB "
                  f"({rs['hwm_kB'] * 1024 / rs['n']:.0f} B per case, the imports included); "
                  f"{rs['reused']:,} taken from the journal, {rs['computed']} computed, complete: {rs['complete']}.", ""]
        sections["study_large_resumed"] = lines
    if cl:
        lines = ["# The client alone (`python benchmarks/bench_study_large.py --client N`)", "", stamp, ""]
        lines += [f"**Client alone**: a fresh study of {cl['n']:,} cases answered at once by a stand-in executor (one "
                  "real row for every case, from the pool's 2 processes): the client listed the cases, sent their "
                  "batches, journalled them (group commit), wrote cases.csv, cases.parquet and the summary in "
                  f"{cl['wall']:.0f} s: {cl['computed'] / cl['wall']:,.0f} cases/s through the client (a bound on any "
                  f"executor's rate here), {1e6 * cl['cpu'] / cl['computed']:.0f} us of the client's CPU per case, "
                  f"client peak resident memory {cl['hwm_kB'] / 1024:.0f} MB "
                  f"({cl['hwm_kB'] * 1024 / cl['n']:.0f} B per case, the imports included); the journal holds "
                  f"{cl['journal']:,} distinct ids, {cl['bad']} damaged lines; complete: {cl['complete']}.", ""]
        sections["study_large_client"] = lines
    for name, lines in sections.items():
        write_section(name, "\n".join(lines) + "\n", SCALING_MD)
        print("\n".join(lines))


if __name__ == "__main__":
    main()
