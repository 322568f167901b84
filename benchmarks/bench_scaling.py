"""How the time per analyse and per optimise start grows with the problem (issue 18).

    python benchmarks/bench_scaling.py [--starts 6] [--repeats 5] [--out results/scaling.md]

A parametric family of scenes, written by this script: the jib of problems/seed1_jib_design.toml
(cylinder base e and rod eye b free, the transmission-angle, length-ratio and stroke
constraints, minimise peak(drive)), with

* **samples**: the sweep's samples, 101, 1,001 and 10,001;
* **design variables**: 2 + k, k extra masses m_1 .. m_k (each in [0, 200] kg) hung at fixed
  points along the jib (r_i from 0.5 m to 3.5 m), with the design constraint that together they
  carry at least 50 k kg (where they hang is what the optimiser decides: the peak force wants
  them near the pivot); 2, 4, 6, 8, 10 and 12 variables;
* **load cases**: 1, 2, 4 and 8 ``[[cases]]``, case j lifting a tip mass of 500 (1 + j/4) kg,
  forward and reverse in turn (the objective peak(drive) over every case).

Each axis varies from the base (201 samples, 2 variables, no cases; on the cases axis one case
and up).  The family's scenes are not nested (the added masses must carry 50 k kg, the cases
lift heavier loads), so each point is its own problem: its optimum, iterations and active set
differ, and the time per start carries that scatter.  Per scene: *analyse* =
``Analysis(scene).run()`` after its build (median of ``--repeats`` runs); *optimise start* =
``solve_start`` (phase 1, objective phase, exchange, continuous check) from each of ``--starts``
planned starts (``draw_plan``), median per start, with IPOPT's iterations per start (phase 1 and
objective phase).  Each is built twice, the first build untimed (it compiles, or loads from the
disk cache); the builds' columns are the second's.  Compiled functions come
from the disk cache (``OPTDESIGN_COMPILE=wait``: compiled before timing, as every later run
has them).  Wall and CPU (``time.process_time``) times; the growth exponent of each is the slope
of log(time) against log(size) by least squares (CPU time: the machine is shared).  Goal: no
worse than linear (exponent <= 1) in samples and in cases.  Not a test; it writes
its section of ``results/scaling.md`` (benchmarks/benchfile.py; atomically).
"""
from __future__ import annotations

import os

os.environ.setdefault("OPTDESIGN_COMPILE", "wait")

import argparse  # noqa: E402
import datetime  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks.benchfile import cpu_model, git_state, write_section  # noqa: E402
from optdesign.design.multistart import draw_plan, solve_start  # noqa: E402
from optdesign.design.problem import DesignProblem  # noqa: E402
from optdesign.design.repair import Repair  # noqa: E402
from optdesign.design.solver import Solver  # noqa: E402
from optdesign.model.analysis import Analysis  # noqa: E402
from optdesign.scene.file import load  # noqa: E402

SAMPLES = (101, 1001, 10001)
VARIABLES = (2, 4, 6, 8, 10, 12)
CASES = (1, 2, 4, 8)
BASE = {"samples": 201, "extra": 0, "cases": 0}


def scene_text(samples: int, extra: int, cases: int) -> str:
    """The family's scene: the seed-1 jib with ``extra`` free masses and ``cases`` load cases."""
    r = np.linspace(0.5, 3.5, extra) if extra > 1 else [2.0] * extra
    lines = [
        'title = "Scaling family (benchmarks/bench_scaling.py)"', "", "[parameters]", "l = 4.0",
        "e = { value = 1.6, min = 0.5, max = 3.0 }", "b = { value = 2.4, min = 0.5, max = 4.0 }",
        'psi = "-60 deg"', "mC = 500.0",
    ]
    lines += [f"m{i + 1} = {{ value = 60.0, min = 0.0, max = 200.0 }}" for i in range(extra)]
    lines += ["", "[sweep]", 'name = "theta"', "from = 0.053331010512329025", "to = 0.776279030740378",
              f"samples = {samples}", "", "[points]", "A = { fixed = [0, 0] }",
              'D = { fixed = ["e*cos(psi)", "e*sin(psi)"] }', 'B = { polar = ["A", "b", "theta"] }',
              'C = { polar = ["A", "l", "theta"] }', "", "[[bodies]]", 'name = "load"', 'frame = ["A", "B"]',
              'mass = "mC"', 'com = ["l", 0]']
    for i in range(extra):
        lines += ["", "[[bodies]]", f'name = "mass {i + 1}"', 'frame = ["A", "B"]', f'mass = "m{i + 1}"',
                  f"com = [{float(r[i])!r}, 0]"]
    lines += ["", "[gravity]", "g = 9.81", "", "[drive]", 'type = "linear"', 'between = ["D", "B"]', "speed = 0.1",
              "acceleration = 0.2", "", "[[constraints]]", 'name = "transmission angle"', 'expr = "angle(D, B, A)"',
              'min = "35 deg"', 'max = "145 deg"', "", "[[constraints]]", 'name = "cylinder length ratio"',
              'expr = "max(length(D, B)) / min(length(D, B))"', "max = 1.6", "", "[[constraints]]",
              'name = "cylinder stroke"', 'expr = "max(length(D, B)) - min(length(D, B))"', "max = 1.2"]
    if extra:
        lines += ["", "[[constraints]]", 'name = "added mass"', f'expr = "{" + ".join(f"m{i + 1}" for i in range(extra))}"',
                  f"min = {50.0 * extra}"]
    for j in range(cases):
        lines += ["", "[[cases]]", f'name = "load {j + 1}"', f'direction = "{"forward" if j % 2 == 0 else "reverse"}"',
                  f"set = {{ mC = {500.0 * (1 + j / 4)} }}"]
    lines += ["", "[objective]", 'minimise = "peak(drive)"', ""]
    return "\n".join(lines)


def timed(f):
    w, c = time.perf_counter(), time.process_time()
    out = f()
    return out, time.perf_counter() - w, time.process_time() - c


def measure(folder: Path, config: dict, args) -> dict:
    path = folder / f"scaling_{config['samples']}_{config['extra']}_{config['cases']}.toml"
    path.write_text(scene_text(**config))
    scene = load(path)
    Analysis(scene)            # compiles (wait) on a miss: not timed
    analysis, build_w, build_c = timed(lambda: Analysis(scene))
    runs = [timed(analysis.run)[1:] for _ in range(args.repeats)]
    DesignProblem(scene)       # compiles the NLP (wait) on a miss: not timed
    problem, pb_w, pb_c = timed(lambda: DesignProblem(scene))
    solver, repair = Solver(problem), Repair(problem)
    plan = draw_plan(problem, args.starts, args.seed)
    starts, values, iterations = [], [], []
    for i, x0 in enumerate(plan.points):
        (report, _), w, c = timed(lambda: solve_start(solver, repair, i, x0, retry=lambda k, i=i: plan.retry(i, k)))
        starts.append((w, c))
        iterations.append(report.iterations + report.phase1_iterations)
        values.append(report.objective if report.success else None)
    ok = [v for v in values if v is not None]
    best = min(ok) if ok else None
    at_best = sum(1 for v in ok if v <= best * (1 + 1e-3))
    out = {"config": config, "variables": len(problem.design_names), "rows": len(problem.lbg),
           "analyse_w": statistics.median(w for w, _ in runs), "analyse_c": statistics.median(c for _, c in runs),
           "analysis_build_w": build_w, "analysis_build_c": build_c, "problem_build_w": pb_w, "problem_build_c": pb_c,
           "start_w": statistics.median(w for w, _ in starts), "start_c": statistics.median(c for _, c in starts),
           "best": best, "at_best": at_best, "iterations": statistics.median(iterations), "converged": len(ok), "starts": len(values)}
    print(f"{config}: analyse {1e3 * out['analyse_c']:.1f} ms CPU, start {1e3 * out['start_c']:.1f} ms CPU, "
          f"{at_best}/{len(values)} at best", flush=True)
    return out


def exponent(xs, ts) -> float:
    """The slope of log t against log x (least squares)."""
    return float(np.polyfit(np.log(xs), np.log(ts), 1)[0])


def axis_table(title, label, rows, xs, goal) -> list:
    lines = [f"## {title}", "",
             f"| {label} | NLP rows | analyse [ms] CPU (wall) | Analysis build (second) [ms] CPU | optimise start [ms] CPU "
             "(wall) | IPOPT iterations per start | DesignProblem build (second) [ms] CPU | starts converged, at best | "
             "best peak(drive) [N] |",
             "|---|---|---|---|---|---|---|---|---|"]
    for x, r in zip(xs, rows):
        best = "n/a" if r["best"] is None else f"{r['best']:.6g}"
        lines.append(f"| {x:,} | {r['rows']} | {1e3 * r['analyse_c']:.2f} ({1e3 * r['analyse_w']:.2f}) | "
                     f"{1e3 * r['analysis_build_c']:.0f} | {1e3 * r['start_c']:.1f} ({1e3 * r['start_w']:.1f}) | {r['iterations']:g} | "
                     f"{1e3 * r['problem_build_c']:.0f} | {r['converged']}/{r['starts']}, {r['at_best']} | "
                     f"{best} |")
    ea, es = exponent(xs, [r["analyse_c"] for r in rows]), exponent(xs, [r["start_c"] for r in rows])
    ea_w, es_w = exponent(xs, [r["analyse_w"] for r in rows]), exponent(xs, [r["start_w"] for r in rows])
    # the starts' iterations differ from point to point (each is its own problem): per iteration too
    ei = exponent(xs, [r["start_c"] / max(r["iterations"], 1) for r in rows])
    verdict = lambda e: "" if goal is None else (": met" if e <= goal else ": NOT met")  # noqa: E731
    lines += ["", f"Growth exponent (log-log least squares, CPU time; wall in brackets): analyse **{ea:.2f}** ({ea_w:.2f})"
              f"{'' if goal is None else f', goal <= {goal:g}'}{verdict(ea)}; optimise start **{es:.2f}** ({es_w:.2f})"
              f"{'' if goal is None else f', goal <= {goal:g}'}{verdict(es)}; optimise start per IPOPT iteration "
              f"(the problems' iterations differ) **{ei:.2f}**.", ""]
    return lines


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--starts", type=int, default=6)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--out", default=str(ROOT / "results" / "scaling.md"))
    args = ap.parse_args(argv)
    git, load0 = git_state(), os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        by_samples = [measure(folder, dict(BASE, samples=n), args) for n in SAMPLES]
        by_vars = [measure(folder, dict(BASE, extra=n - 2), args) for n in VARIABLES]
        by_cases = [measure(folder, dict(BASE, cases=n), args) for n in CASES]
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    lines = ["# Scaling: time per analyse and per optimise start (issue 18)", "",
             f"Written by `python benchmarks/bench_scaling.py --starts {args.starts} --repeats {args.repeats}` on {now}. "
             f"Machine: {platform.machine()}, {cpu_model()}, nproc {os.cpu_count()} (shared), load average at the start "
             f"{', '.join(f'{v:.2f}' for v in load0)} and at the end {', '.join(f'{v:.2f}' for v in os.getloadavg())}; "
             f"Python {platform.python_version()}; {git}.", "", __doc__.split("\n\n", 1)[1].split("Not a test")[0].strip(), ""]
    lines += axis_table("Samples (2 design variables, no cases)", "samples", by_samples, list(SAMPLES), 1.0)
    lines += axis_table("Design variables (201 samples, no cases)", "design variables", by_vars, list(VARIABLES), None)
    lines += axis_table("Load cases (201 samples, 2 design variables)", "cases", by_cases, list(CASES), 1.0)
    write_section("problem_size", "\n".join(lines).rstrip() + "\n", Path(args.out))
    print(f"wrote its section of {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
