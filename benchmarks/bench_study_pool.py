"""An analyse study of the truck crane on the local pool of 2 processes, this code against an
older commit in one run (issue 31: ">= 5,000 cases/s on 2 cores").

    python benchmarks/bench_study_pool.py [--cases 20000] [--repeats 3] [--base REV]

writes the section ``study_pool`` of results/scaling.md.  The study: problems/truck_crane.toml,
10 boom masses x cases/10 payloads (leaf parameters), ``Study.run(workers=2, figures=False)``
from a fresh Python process per run (``OPTDESIGN_COMPILE=wait``: compiled code from the disk
cache), the two codes' runs interleaved ``--repeats`` times.  Per run: wall time (cases/s), the
client's processor time (its own process: scheduling, journal, cases.csv and Parquet, progress,
unpickling) and the pool's processes' (``RUSAGE_CHILDREN`` once the pool is shut down: the
workers' whole lives, start-up and the model's build included), each per case, and the digest
of cases.csv (the two codes' files compared byte for byte).  Medians; on a shared machine the
processor times are the steadier figures (cases/s depends on what else runs)."""
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
from benchfile import ROOT, SCALING_MD, cpu_model, export, git_state, write_section  # noqa: E402

STUDY = """
import hashlib, json, os, resource, sys, time
os.environ.setdefault("OPTDESIGN_COMPILE", "wait")
import optdesign
from optdesign.study import Study, grid
n, out = int(sys.argv[1]), sys.argv[2]
study = Study(optdesign.load("problems/truck_crane.toml"), [grid("mB", 500, 800, 10), grid("mP", 500, 3000, n // 10)],
              mode="analyse")
t0, c0 = time.perf_counter(), time.process_time()
result = study.run(out=out, restart=True, figures=False, workers=2)
wall, cpu = time.perf_counter() - t0, time.process_time() - c0
assert result.complete and result.computed == n, result
pool = resource.getrusage(resource.RUSAGE_CHILDREN)
print(json.dumps({"wall": wall, "client": cpu, "pool": pool.ru_utime + pool.ru_stime,
                  "csv": hashlib.sha256(open(out + "/cases.csv", "rb").read()).hexdigest()[:16]}))
"""


def run(code: Path, n: int, folder: Path) -> dict:
    done = subprocess.run([sys.executable, "-c", STUDY, str(n), str(folder)], cwd=code, capture_output=True,
                          text=True, env={**os.environ, "PYTHONPATH": str(code)})
    if done.returncode:
        raise SystemExit(f"the study at {code} failed:\n{done.stderr[-3000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=20000)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--base", default=None, help="a commit to measure in the same run")
    args = ap.parse_args(argv)
    n = args.cases
    load0 = os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp:
        codes = {}
        if args.base:
            codes[f"base {args.base}"] = export(args.base, Path(tmp) / "base")
        codes["this"] = ROOT
        for name, code in codes.items():   # warm: compiled code in the disk cache
            run(code, 200, Path(tmp) / f"warm-{len(name)}")
        runs = {name: [] for name in codes}
        for k in range(args.repeats):
            for j, (name, code) in enumerate(codes.items()):
                runs[name].append(run(code, n, Path(tmp) / f"run-{k}-{j}"))
                print(name, runs[name][-1], flush=True)
    load1 = os.getloadavg()

    def med(name, f):
        return statistics.median(f(r) for r in runs[name])

    figures = {name: {"cases/s": med(name, lambda r: n / r["wall"]),
                      "client CPU per case [ms]": med(name, lambda r: 1e3 * r["client"] / n),
                      "pool's processes' CPU per case [ms]": med(name, lambda r: 1e3 * r["pool"] / n),
                      "client + pool CPU per case [ms]": med(name, lambda r: 1e3 * (r["client"] + r["pool"]) / n)}
               for name in codes}
    command = f"python benchmarks/bench_study_pool.py --cases {n} --repeats {args.repeats}" + (
        f" --base {args.base}" if args.base else "")
    lines = ["# An analyse study on the pool of 2 processes, old and new code (issue 31)", "",
             f"`{command}` at {git_state()}, {time.strftime('%Y-%m-%d %H:%M', time.gmtime())} UTC, {cpu_model()}, "
             f"nproc {os.cpu_count()}, load average {load0[0]:.1f} at the start and {load1[0]:.1f} at the end "
             f"(shared machine).  Truck crane, {n:,} cases (10 boom masses x {n // 10:,} payloads), "
             "`Study.run(workers=2)` in a fresh process per run, the codes' runs interleaved; medians of "
             f"{args.repeats}.  The pool's CPU is its processes' whole lives (start-up and the model's build "
             "included).", "",
             "| figure | " + " | ".join(codes) + " |" + (" this / base |" if args.base else ""),
             "|---|" + "---|" * len(codes) + ("---|" if args.base else "")]
    for figure in next(iter(figures.values())):
        cells = [figures[name][figure] for name in codes]
        fmt = "{:,.0f}" if figure == "cases/s" else "{:.3f}"
        lines.append(f"| {figure} | " + " | ".join(fmt.format(c) for c in cells) + " |"
                     + (f" {cells[-1] / cells[0]:.2f} |" if args.base else ""))
    digests = {r["csv"] for rs in runs.values() for r in rs}
    lines += ["", f"cases.csv of all {sum(len(rs) for rs in runs.values())} runs: "
              + ("byte-identical." if len(digests) == 1 else f"{len(digests)} different files (NOT identical).")]
    text = "\n".join(lines) + "\n"
    print(text)
    write_section("study_pool", text, SCALING_MD)


if __name__ == "__main__":
    main()
