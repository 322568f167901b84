"""Per-start speed over the scene library (issue 18): where a start's time goes, ours against
SLSQP with finite differences, ours against IPOPT's own floor, and sqpmethod (qpOASES).

    python benchmarks/bench_per_start.py [--scene A.toml ...] [--starts 10] [--seed 0]
                                         [--out results/per_start.md]

Scenes: every ``problems/lib_*.toml`` and every shipped scene with an ``[objective]``.  On each,
the starts are ours (``draw_starts(problem, N, seed)``: the scene's start, then the screened
Sobol points), and every method starts from the same points.  In one loop over the starts, ours
and SLSQP-FD alternate start by start (a change of the shared machine's load falls on both);
times are wall and CPU (``time.process_time``: this process's CPU, which leaves out waiting for
a core; no threads run besides ours), and the ratios are of medians over the starts.

a. **ours**: ``solve_start`` (phase 1, the objective phase's IPOPT solves and exchange steps, the
   continuous check), the NLP's functions from the disk cache of compiled code
   (``OPTDESIGN_COMPILE=wait``: what every run after the first gets); instrumented by wrapping
   the problem's pieces, so that the profile table splits each start into phase 1 (IPOPT's own
   work and its NLP evaluations from ``solver.stats()``), repairs, the objective phase's IPOPT
   (own work = the call's time minus the ``t_wall_nlp_*`` entries, CPU minus ``t_proc_*``:
   CasADi's set-up of each call included, its stats carry no total with print_time off), the
   exchange's rebuilds (slots, tracking gradients, NLP parameters, row bounds), the continuous
   check, the start's own evaluations, and the Python between them (the rest).
b. **SLSQP-FD**: ``benchmarks/bench_optimise.py``'s ``slsqp_start`` (scipy SLSQP, finite
   differences, the same scaled epigraph on the scene's samples).
c. **floor**: IPOPT with our options on an NLP of the same size whose functions cost nothing
   (``bench_optimise.ipopt_size_floor``): ms per iteration, times our median iterations per
   start (phase 1 and objective phase).
d. **sqpmethod**: CasADi's ``sqpmethod`` with qpOASES against IPOPT on the objective phase's
   first solve (the NLP at the start's slots, from phase 1's feasible design): the plain SQP
   (exact Hessian, CasADi's line search, no convexification), the SQP as design/sqp.py sets it
   (the tool's re-solves), and the same with BFGS; the same NLP Function compiled for each, the
   same bounds: time per solve and how many end at the best value.  (Ours uses the tool's rule,
   IPOPT for every objective-phase solve; results/optimise_library.md compares it over the library
   with the SQP rules of design/sqp.py.)

Every design is judged by ``Solver.continuous_check`` (``bench_optimise.Judge``): "at best" =
feasible on the continuous stroke and within 0.1 % of the best value any method reached.
Not a test; it writes ``results/per_start.md`` (atomically).
"""
from __future__ import annotations

import os

os.environ.setdefault("OPTDESIGN_COMPILE", "wait")   # the cached compiled NLP, as every later run has it
# one BLAS thread: on these small problems numpy's OpenBLAS threads gain nothing, and after
# SLSQP's calls they kept spinning on the second core while the next start ran (this process's
# CPU time was twice its wall time for ours and SLSQP-FD alike, and ours' wall time 1.35x longer
# on seed1_jib); optdesign's own optimise does not start them (CPU time = wall time)
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import datetime  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import tomllib  # noqa: E402
from pathlib import Path  # noqa: E402

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks.bench_optimise import (CONSTRAINT_KINDS, Judge, SampledModel, ipopt_size_floor,  # noqa: E402
                                       slsqp_start, stroke_constraints)
from benchmarks.benchfile import cpu_model, git_state, write_section  # noqa: E402
from optdesign.design import multistart, sqp  # noqa: E402
from optdesign.design.multistart import draw_plan, solve_start  # noqa: E402
from optdesign.design.phase1 import Phase1  # noqa: E402
from optdesign.design.problem import DesignProblem  # noqa: E402
from optdesign.design.repair import Repair  # noqa: E402
from optdesign.design.solver import Solver  # noqa: E402
from optdesign.errors import OptdesignError  # noqa: E402
from optdesign.report.files import write_file  # noqa: E402
from optdesign.scene.file import load  # noqa: E402

BEST_TOL = 1e-3
GOAL_SLSQP, GOAL_SLSQP_REACH, GOAL_FLOOR = 3.0, 10.0, 3.0
SQP_OPTIONS = {"qpsol": "qpoases", "qpsol_options": {"printLevel": "none", "error_on_fail": False},
               "hessian_approximation": "exact", "max_iter": 300, "tol_pr": 1e-10, "tol_du": 1e-10,
               "print_header": False, "print_iteration": False, "print_status": False, "print_time": False,
               "error_on_fail": False, "show_eval_warnings": False}
SQP_SOLVER = sqp.sqp_solver   # design/sqp.py's (bench_scene times each one it makes)
PARTS = ("phase 1: IPOPT own", "phase 1: NLP evaluations", "phase 1: Python", "repair",
         "IPOPT own", "IPOPT NLP evaluations", "SQP own", "SQP NLP evaluations", "SQP set-up", "exchange rebuilds", "continuous check", "start evaluations", "rest (Python)")


def library_scenes() -> list:
    out = sorted((ROOT / "problems").glob("lib_*.toml"))
    for path in sorted((ROOT / "problems").glob("*.toml")):
        if path not in out and "objective" in tomllib.loads(path.read_text()):
            out.append(path)
    return out


class Clock:
    """Sums wall and CPU time per part; ``wrap(obj, name, part)`` times a method in place."""

    def __init__(self):
        self.wall, self.cpu = {}, {}

    def add(self, part, wall, cpu):
        self.wall[part] = self.wall.get(part, 0.0) + wall
        self.cpu[part] = self.cpu.get(part, 0.0) + cpu

    def wrap(self, obj, name, part):
        if name == "__call__":   # a special method is looked up on the type: swap in a timed subclass
            clock, base = self, type(obj)

            def call(me, *args, **kwargs):
                w, c = time.perf_counter(), time.process_time()
                try:
                    return base.__call__(me, *args, **kwargs)
                finally:
                    clock.add(part, time.perf_counter() - w, time.process_time() - c)
            obj.__class__ = type(f"Timed{base.__name__}", (base,), {"__call__": call})
            return
        inner = getattr(obj, name)

        def timed(*args, **kwargs):
            w, c = time.perf_counter(), time.process_time()
            try:
                return inner(*args, **kwargs)
            finally:
                self.add(part, time.perf_counter() - w, time.process_time() - c)
        setattr(obj, name, timed)


class TimedNlpsol:
    """Stands in for an nlpsol: books the solver's own work and its NLP evaluations from stats()
    (``name``: 'IPOPT' or 'SQP', the sqpmethod of design/sqp.py)."""

    def __init__(self, solver, clock, prefix="", name="IPOPT"):
        self.solver, self.clock, self.prefix, self.name = solver, clock, prefix, name
        self.iterations = self.calls = 0

    def get_function(self, name):   # (phase 1 evaluates the NLP's rows by the solver's nlp_g)
        return self.solver.get_function(name)

    def __call__(self, **kwargs):
        w, c = time.perf_counter(), time.process_time()
        out = self.solver(**kwargs)
        wall, cpu = time.perf_counter() - w, time.process_time() - c
        st = self.solver.stats()
        nlp_w = sum(v for k, v in st.items() if k.startswith("t_wall_nlp"))
        nlp_c = sum(v for k, v in st.items() if k.startswith("t_proc_nlp"))
        own_w = st.get("t_wall_total", wall) - nlp_w
        own_c = st.get("t_proc_total", cpu) - nlp_c
        self.clock.add(f"{self.prefix}{self.name} own", own_w, own_c)
        self.clock.add(f"{self.prefix}{self.name} NLP evaluations", nlp_w, nlp_c)
        self.clock.add(f"{self.prefix}{self.name} call", wall, cpu)   # the call itself (for Python between)
        self.iterations += int(st.get("iter_count", 0))
        self.calls += 1
        return out

    def stats(self):
        return self.solver.stats()


def instrument(problem, solver, repair, clock):
    """Wrap the pieces of a start in place (the numbers are the same: only clocks are added)."""
    # built once per scene on the first exchange step (the symbolic Jacobian of every row's
    # s-derivative in the parameters): built here, timed apart from the starts
    w, c = time.perf_counter(), time.process_time()
    problem.quantity_tracking
    clock.add("tracking build (once)", time.perf_counter() - w, time.process_time() - c)
    problem.solver = TimedNlpsol(problem.solver, clock)
    problem._built["warm solver"] = TimedNlpsol(problem.warm_solver, clock)
    # the SQP is made fresh for every start that re-solves (design/sqp.py): each one timed
    sqp_timed, make = TimedNlpsol(None, clock, name="SQP"), SQP_SOLVER

    def fresh_sqp(pb):
        w, c = time.perf_counter(), time.process_time()
        made = make(pb)
        clock.add("SQP set-up", time.perf_counter() - w, time.process_time() - c)
        if made is None:
            return None
        sqp_timed.solver = made
        return sqp_timed
    sqp.sqp_solver = fresh_sqp
    make(problem)   # its library compiled (or loaded) before the starts are timed
    phase1 = problem._once("phase 1", lambda: Phase1(problem))
    phase1.solver = TimedNlpsol(phase1.solver, clock, "phase 1: ")
    clock.wrap(phase1, "__call__", "phase 1 call")
    for name in ("tracking_gradient", "nlp_parameters", "row_bounds"):
        clock.wrap(problem, name, "exchange rebuilds")
    clock.wrap(solver, "_slots", "exchange rebuilds")
    clock.wrap(solver, "continuous_check", "continuous check")
    clock.wrap(solver, "_initial_w", "start evaluations")
    if getattr(repair, "ok", False):
        clock.wrap(repair, "__call__", "repair")
    return problem.solver, problem._built["warm solver"], phase1.solver, sqp_timed


def parts_of(clock, kind):
    """The profile's parts (seconds) from the clock's raw sums; 'IPOPT call' and 'phase 1 call'
    contain the finer parts, so the Python around them is their difference."""
    d = clock.wall if kind == "wall" else clock.cpu
    g = lambda k: d.get(k, 0.0)  # noqa: E731
    out = {
        "phase 1: IPOPT own": g("phase 1: IPOPT own"), "phase 1: NLP evaluations": g("phase 1: IPOPT NLP evaluations"),
        "phase 1: Python": g("phase 1 call") - g("phase 1: IPOPT call"), "repair": g("repair"),
        "IPOPT own": g("IPOPT own"), "IPOPT NLP evaluations": g("IPOPT NLP evaluations"),
        "SQP own": g("SQP own"), "SQP NLP evaluations": g("SQP NLP evaluations"), "SQP set-up": g("SQP set-up"),
        "exchange rebuilds": g("exchange rebuilds"), "continuous check": g("continuous check"),
        "start evaluations": g("start evaluations"),
    }
    # IPOPT's call overhead (argument conversion, stats) is Python between solves too
    out["rest (Python)"] = g("starts") - sum(out.values())
    return out


def comparable(problem) -> str | None:
    unknown = sorted({b.kind for b in problem.blocks} - set(CONSTRAINT_KINDS) - {"peak", "rms"})
    if unknown:
        return f"blocks of kinds {unknown} (not in the SLSQP epigraph of bench_optimise)"
    if problem.scene.cases:
        return "load cases (not in the SLSQP epigraph of bench_optimise)"
    return None


SOLVERS = ("IPOPT (ours' options)", "plain sqpmethod", "sqpmethod as the tool sets it", "the same, BFGS")


def sqp_comparison(problem, firsts):
    """IPOPT against sqpmethod+qpOASES (exact Hessian, and BFGS) on the objective phase's first
    solve from each start's feasible design, every solver's functions compiled from the disk
    cache (compiled before timing): {name: (walls, cpus, NLP objectives (None: failed))}."""
    from optdesign.model import compiled

    ipopt = problem.solver.solver if isinstance(problem.solver, TimedNlpsol) else problem.solver
    with sqp._c_output_hidden():   # qpOASES's copyright notice
        solvers = dict(zip(SOLVERS, (
            ipopt, compiled.solver("design_sqp", "sqpmethod", problem._nlp_function, SQP_OPTIONS, wait=True),
            compiled.solver("design_sqp", "sqpmethod", problem._nlp_function, sqp.OPTIONS, wait=True),
            compiled.solver("design_sqp_bfgs", "sqpmethod", problem._nlp_function,
                            dict(sqp.OPTIONS, hessian_approximation="limited-memory"), wait=True))))
    out = {name: ([], [], []) for name in SOLVERS}
    for w, p, bounds in firsts:
        for name, nlpsol in solvers.items():   # in turn, start by start
            t0, c0 = time.perf_counter(), time.process_time()
            try:
                res = nlpsol(x0=w, p=p, **bounds)
                f = float(res["f"]) if nlpsol.stats()["success"] else None
            except RuntimeError:
                f = None
            out[name][0].append(time.perf_counter() - t0)
            out[name][1].append(time.process_time() - c0)
            out[name][2].append(f)
    return out


def bench_scene(path: Path, args) -> dict:
    scene = load(path)
    problem = DesignProblem(scene)
    solver, repair = Solver(problem), Repair(problem)
    plan = draw_plan(problem, args.starts, args.seed)
    clock = Clock()
    ipopt, warm, ph1, sqp_timed = instrument(problem, solver, repair, clock)
    why_not = comparable(problem)
    judge = Judge(problem) if why_not is None else None
    model = SampledModel(problem) if why_not is None else None
    strokes = stroke_constraints(problem) if why_not is None else None
    firsts = []
    orig_start_slots = solver._start_slots

    def start_slots(x, fixed, w, s_pts):   # records the objective phase's first NLP (for sqpmethod)
        out = orig_start_slots(x, fixed, w, s_pts)
        firsts.append(out)
        return out
    solver._start_slots = start_slots
    ours, slsqp = [], []
    for i, x0 in enumerate(plan.points):
        its0 = ipopt.iterations + warm.iterations + ph1.iterations + sqp_timed.iterations
        calls0 = ipopt.calls + warm.calls + ph1.calls + sqp_timed.calls
        w, c = time.perf_counter(), time.process_time()
        report, sol = solve_start(solver, repair, i, x0, retry=lambda k, i=i: plan.retry(i, k))
        wall, cpu = time.perf_counter() - w, time.process_time() - c
        clock.add("starts", wall, cpu)
        its = ipopt.iterations + warm.iterations + ph1.iterations + sqp_timed.iterations - its0
        solves = ipopt.calls + warm.calls + ph1.calls + sqp_timed.calls - calls0
        ours.append({"wall": wall, "cpu": cpu, "iterations": its, "solves": solves, "value": report.objective if report.success else None,
                     "x": None if sol is None else sol.x})
        if why_not is None:
            w, c = time.perf_counter(), time.process_time()
            o = slsqp_start(problem, model, strokes, x0)
            wall, cpu = time.perf_counter() - w, time.process_time() - c
            v = judge.certify(o.x) if o.success else None
            slsqp.append({"wall": wall, "cpu": cpu, "value": v.objective if v is not None and v.feasible else None})
    values = [r["value"] for r in ours + slsqp if r["value"] is not None]
    best = min(values) if values else None
    # the objective phase's first NLP from each start's feasible design, as ours solved it
    fixed = solver.fixed_values()
    nlp_firsts = []
    for s_pts, x_ref, tracking, _ in firsts:
        w0 = solver._initial_w(x_ref, fixed, s_pts)
        if isinstance(w0, str):
            continue
        p = problem.nlp_parameters(fixed, s_pts, x_ref, tracking)
        lbg, ubg = problem.row_bounds(s_pts)
        nlp_firsts.append((w0, p, {"lbx": problem.lbw, "ubx": problem.ubw, "lbg": lbg, "ubg": ubg}))
    sqp = sqp_comparison(problem, nlp_firsts)
    floor = ipopt_size_floor(problem)
    print(f"[{path.name}] ours median {1e3 * statistics.median(r['wall'] for r in ours):.1f} ms"
          + (f", SLSQP-FD {1e3 * statistics.median(r['wall'] for r in slsqp):.1f} ms" if slsqp else ""), flush=True)
    return {"path": path, "problem": problem, "ours": ours, "slsqp": slsqp, "why_not": why_not, "best": best,
            "wall": parts_of(clock, "wall"), "cpu": parts_of(clock, "cpu"), "starts_wall": clock.wall["starts"],
            "starts_cpu": clock.cpu["starts"], "sqp": sqp, "floor": floor,
            "tracking_build": clock.cpu["tracking build (once)"]}


def med(xs):
    xs = [x for x in xs if x is not None]
    return statistics.median(xs) if xs else None


def at_best(values, best):
    return sum(1 for v in values if v is not None and best is not None and v <= best + BEST_TOL * abs(best))


def fmt(v, d=3):
    return "n/a" if v is None else f"{v:.{d}g}"


def name_of(res):
    return res["path"].stem


def report(results, args, git, load0) -> str:
    import scipy

    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    load1 = os.getloadavg()
    lines = ["# Per-start speed over the scene library (issue 18)", "",
             f"Written by `python benchmarks/bench_per_start.py --starts {args.starts} --seed {args.seed}` on {now}. "
             f"Machine: {platform.machine()}, {cpu_model()}, nproc {os.cpu_count()} (shared with other engineers' work), "
             f"load average (1, 5, 15 min) at the start {', '.join(f'{v:.2f}' for v in load0)} and at the end "
             f"{', '.join(f'{v:.2f}' for v in load1)}; Python {platform.python_version()}, casadi {ca.__version__}, "
             f"scipy {scipy.__version__}, numpy {np.__version__}; {git}. Compiled NLP functions from the disk cache "
             "(`OPTDESIGN_COMPILE=wait`). Times are medians over the starts; CPU = this process's CPU time "
             "(leaves out waiting for a core, which wall time includes on the loaded machine).", "",
             __doc__.split("\n\n", 2)[2].split("Not a test")[0].strip(), ""]
    # 1. ours against SLSQP-FD and the floor
    lines += ["## Ours against SLSQP-FD and IPOPT's floor", "",
              "| scene | vars, rows | ours per start [ms] wall (CPU) | SLSQP-FD per start [ms] wall (CPU) | "
              f"SLSQP-FD / ours wall (CPU) | goal >= {GOAL_SLSQP:g}x | at best: ours / SLSQP-FD | ours iterations per start "
              "(phase 1 + objective) | floor: ms per iteration x iterations [ms] | ours / floor (CPU) | "
              f"goal <= {GOAL_FLOOR:g}x |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        pb, ours, sl = r["problem"], r["ours"], r["slsqp"]
        ow, oc = med(x["wall"] for x in ours), med(x["cpu"] for x in ours)
        its = med(x["iterations"] for x in ours)
        floor = r["floor"]["ms_per_iteration"] * its
        f_ratio, f_cpu = 1e3 * ow / floor if floor else None, 1e3 * oc / floor if floor else None
        f_goal = "n/a" if f_cpu is None else ("met" if min(f_ratio, f_cpu) <= GOAL_FLOOR else "NOT met")
        if sl:
            sw, sc = med(x["wall"] for x in sl), med(x["cpu"] for x in sl)
            rw, rc = sw / ow, sc / oc
            goal = "met" if max(rw, rc) >= GOAL_SLSQP else "NOT met"
            if goal == "met":
                goal += f" (10x: {'met' if max(rw, rc) >= GOAL_SLSQP_REACH else 'not yet'})"
            sl_txt = f"{1e3 * sw:.1f} ({1e3 * sc:.1f}) | {rw:.2f}x ({rc:.2f}x) | {goal}"
            best_txt = f"{at_best([x['value'] for x in ours], r['best'])}/{len(ours)} / {at_best([x['value'] for x in sl], r['best'])}/{len(sl)}"
        else:
            sl_txt = f"n/a: {r['why_not']} | n/a | n/a"
            best_txt = f"{at_best([x['value'] for x in ours], r['best'])}/{len(ours)} / n/a"
        lines.append(f"| {name_of(r)} | {len(pb.design_names)}, {len(pb.lbg)} | {1e3 * ow:.1f} ({1e3 * oc:.1f}) | {sl_txt} | "
                     f"{best_txt} | {fmt(its)} | {r['floor']['ms_per_iteration']:.2f} x {fmt(its)} = {floor:.1f} | "
                     f"{fmt(f_ratio)}x ({fmt(f_cpu)}x) | {f_goal} |")
    # 2. the profile
    lines += ["", "## Where a start's time goes (all starts of each scene, CPU time; share of the starts' CPU)", "",
              "The tracking function (the Jacobian of every row's s-derivative in the parameters, which the exchange "
              "needs to make the slots follow their extrema) is built once per scene, before the starts here: its CPU "
              "time is the column 'tracking build (once)', not part of the starts.  'exchange rebuilds' = the slots, "
              "the tracking gradients, the NLP's parameters and row bounds of every exchange step; 'rest (Python)' = "
              "the start minus every part named (IPOPT's calls beyond its own t_proc_total included).", "",
              "| scene | tracking build (once) [s] | starts CPU [s] (wall) | " + " | ".join(PARTS) + " |",
              "|---|---|---|" + "---|" * len(PARTS)]
    total = {p: 0.0 for p in PARTS}
    for r in results:
        c = r["cpu"]
        for p in PARTS:
            total[p] += c[p]
        lines.append(f"| {name_of(r)} | {r['tracking_build']:.3f} | {r['starts_cpu']:.3f} ({r['starts_wall']:.3f}) | "
                     + " | ".join(f"{100 * c[p] / r['starts_cpu']:.0f} %" for p in PARTS) + " |")
    all_cpu = sum(r["starts_cpu"] for r in results)
    lines.append(f"| **all scenes** | {sum(r['tracking_build'] for r in results):.3f} | {all_cpu:.3f} ({sum(r['starts_wall'] for r in results):.3f}) | "
                 + " | ".join(f"**{100 * total[p] / all_cpu:.0f} %**" for p in PARTS) + " |")
    # 3. sqpmethod
    lines += ["", "## sqpmethod with qpOASES against IPOPT on the objective phase's first solve", "",
              "The same NLP Function (each solver's functions compiled from the disk cache, compiled before timing), "
              "bounds and start (phase 1's feasible design, the slots on its extrema), the solvers in turn start by "
              "start; sqpmethod with qpOASES: plain = exact Hessian, CasADi's line search (3 x 0.8), no convexification, "
              "tol_pr = tol_du = 1e-10; as the tool sets it = design/sqp.py's OPTIONS (eigen-clip, line search 20 x 0.5, "
              "tol_du 1e-8; the tool's re-solves); BFGS = the same with hessian_approximation limited-memory; 'at best' = the NLP objective within 0.1 % of the best any solver reached from any start (the "
              "sampled problem: no exchange, no continuous check).  Median CPU time per solve [ms] (wall in brackets).", "",
              "| scene | solves | " + " | ".join(f"{n}: median [ms], at best, failed" for n in SOLVERS) + " |",
              "|---|---|" + "---|" * len(SOLVERS)]
    wins = {n: [0, 0] for n in SOLVERS[1:]}
    sums = {n: 0.0 for n in SOLVERS}
    for r in results:
        sq = r["sqp"]
        fs = [v for n in SOLVERS for v in sq[n][2] if v is not None]
        b = min(fs) if fs else None
        cells = []
        for n in SOLVERS:
            walls, cpus, vals = sq[n]
            sums[n] += sum(cpus)
            cells.append(f"{fmt(1e3 * med(cpus) if cpus else None)} ({fmt(1e3 * med(walls) if walls else None)}), "
                         f"{at_best(vals, b)}/{len(vals)}, {sum(v is None for v in vals)}")
        for n in SOLVERS[1:]:
            if sq[n][1] and sq[SOLVERS[0]][1]:
                wins[n][0] += med(sq[n][1]) < med(sq[SOLVERS[0]][1])
            wins[n][1] += at_best(sq[n][2], b) >= at_best(sq[SOLVERS[0]][2], b)
        lines.append(f"| {name_of(r)} | {len(sq[SOLVERS[0]][0])} | " + " | ".join(cells) + " |")
    lines.append("")
    kept = [n for n in SOLVERS[1:] if wins[n][0] == len(results) and wins[n][1] == len(results)]
    for n in SOLVERS[1:]:
        lines.append(f"- {n}: faster than IPOPT (median CPU) on {wins[n][0]} of {len(results)} scenes, at the best as "
                     f"often as IPOPT on {wins[n][1]} of {len(results)}; CPU over every solve {sums[n]:.3f} s "
                     f"(IPOPT {sums[SOLVERS[0]]:.3f} s).")
    lines += ["", ("On the first solves " + " and ".join(kept) + " is faster and as often at the best on every scene."
                   if kept else "No sqpmethod variant is faster and as often at the best on every scene's first solves."),
              "A first solve decides which local optimum a start reaches, and a faster first solve that ends at a worse "
              "local optimum loses the start: the rules are compared over the whole library by the starts at the global "
              "optimum and the time per start in results/optimise_library.md (its rows 'objective phase: ...'; the tool "
              "keeps IPOPT, design/sqp.py says why)."]
    return "\n".join(lines) + "\n"


def summary(results, args, git) -> str:
    """The section ``per_start`` of results/bench.md: the goals' verdicts, and for a goal not
    met the measurement, what was tried and what would be needed."""
    rows, worst, floor_fail = [], [], []
    for r in results:
        ours, sl = r["ours"], r["slsqp"]
        oc = med(x["cpu"] for x in ours)
        its = med(x["iterations"] for x in ours)
        solves = med(x["solves"] for x in ours)
        own = (r["cpu"]["IPOPT own"] + r["cpu"]["phase 1: IPOPT own"] + r["cpu"]["SQP own"]) / len(ours)
        floor = r["floor"]["ms_per_iteration"] * its / 1e3
        ratio = med(x["cpu"] for x in sl) / oc if sl else None
        if ratio is not None:
            worst.append((ratio, name_of(r)))
        if floor and oc / floor > GOAL_FLOOR:
            floor_fail.append(name_of(r))
        rows.append(f"| {name_of(r)} | {1e3 * oc:.1f} | {fmt(None if not sl else 1e3 * med(x['cpu'] for x in sl))} | "
                    f"{fmt(ratio)}x | {fmt(solves)} | {1e3 * own:.1f} | {fmt(None if not sl else 1e3 * med(x['cpu'] for x in sl) / GOAL_SLSQP)} | "
                    f"{fmt(oc / floor if floor else None)}x |")
    met = [w for w in worst if w[0] >= GOAL_SLSQP]
    all_cpu = sum(r["starts_cpu"] for r in results)

    def share(*parts):
        return f"{100 * sum(r['cpu'][p] for r in results for p in parts) / all_cpu:.0f}"
    lines = ["## Per start over the scene library (`python benchmarks/bench_per_start.py`)", "",
             f"Written by `python benchmarks/bench_per_start.py --starts {args.starts}` on "
             f"{datetime.datetime.now(datetime.timezone.utc).strftime('%Y-%m-%d %H:%M UTC')}; {git}; machine {cpu_model()}, "
             f"nproc {os.cpu_count()} (shared: CPU times, medians over the starts; wall times and the profile in "
             "results/per_start.md).", "",
             "| scene | ours per start, CPU [ms] | SLSQP-FD per start, CPU [ms] | SLSQP-FD / ours | NLP solves per start "
             "(phase 1 + objective + exchange; IPOPT's and the SQP's) | IPOPT's and the SQP's own work per start [ms] | the 3x budget: SLSQP-FD / 3 [ms] | "
             "ours / IPOPT's floor (same-size NLP, our iterations) |", "|---|---|---|---|---|---|---|---|", *rows, "",
             f"Goal per start SLSQP-FD / ours >= {GOAL_SLSQP:g}x on every library scene: "
             f"{'met' if worst and len(met) == len(worst) else 'NOT met'} ({len(met)} of {len(worst)} scenes; "
             f"lowest {fmt(min(worst)[0]) if worst else 'n/a'}x on {min(worst)[1] if worst else 'n/a'}).  "
             f"Goal ours within {GOAL_FLOOR:g}x of IPOPT's floor: {'met' if not floor_fail else 'NOT met'}"
             f"{'' if not floor_fail else ' on ' + ', '.join(floor_fail)}.", "",
             "Tried in this issue (each keeps every number: the same starts, iterations, statuses and optima on every "
             "scene, compared bit for bit): the continuous check's and the exchange's evaluations (the per-sample rows, "
             "their s-derivatives, the extrema's tracking) compiled from the disk cache like the NLP (3-10x faster "
             "evaluations); the continuous check's first Newton step taken for all brackets at once (a flat row, such "
             "as a constraint on the design alone, made one coroutine per sample).  Measured and not kept: sqpmethod "
             "with qpOASES, convexified and with a longer line search (design/sqp.py; IPOPT the fallback), on the "
             "exchange's re-solves or on every solve (results/optimise_library.md: on every solve it is faster but "
             "loses a start to another local optimum; on re-solves only it gains little over the library).  "
             "What the goal would need: the table shows IPOPT's own work per start (its iterations, not our Python or "
             "our model) against the 3x budget: where it is above the budget, no removal of Python overhead can meet "
             "the goal; a start then needs fewer solves (phase 1 is one solve, every exchange step another) or a "
             "solver with cheaper iterations on these small dense problems that reaches the same optima from the same "
             "starts as IPOPT (the SQP does on re-solves, not on first solves), or SLSQP-FD's own shortcut of "
             "certifying nothing (its time has no continuous check, no phase 1, no exchange).  SLSQP-FD from these "
             "screened, feasible starts is much faster than from the unscreened uniform starts of the optimise section "
             "below (where the ratio was measured before phase 1 and the Sobol starts).", "",
             f"Ours against IPOPT's floor: the floor's NLP has functions that cost nothing, so what separates a start "
             f"from it is the rest of the start; over the library (profile in results/per_start.md) IPOPT's own work "
             f"is {share('IPOPT own', 'phase 1: IPOPT own')} % of the starts' CPU and the SQP's {share('SQP own', 'SQP set-up')} % "
             f"(its set-up included), the NLP's evaluations inside the solvers (compiled C of the exact first and second "
             f"derivatives) {share('IPOPT NLP evaluations', 'phase 1: NLP evaluations', 'SQP NLP evaluations')} %, "
             f"the continuous check {share('continuous check')} %, the exchange's rebuilds {share('exchange rebuilds')} %, "
             f"the rest of the Python {share('rest (Python)', 'phase 1: Python', 'start evaluations')} %.  Within 3x "
             "of the floor on every scene would need the evaluations made cheaper (fewer rows per solve, a cheaper "
             "Hessian that does not cost iterations) as well as the Python between the solves."]
    return "\n".join(lines) + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scene", nargs="+", default=None)
    ap.add_argument("--starts", type=int, default=10)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default=str(ROOT / "results" / "per_start.md"))
    args = ap.parse_args(argv)
    git, load0 = git_state(), os.getloadavg()
    paths = [Path(s) if Path(s).is_absolute() else ROOT / s for s in args.scene] if args.scene else library_scenes()
    results, skipped = [], []
    for p in paths:
        try:
            results.append(bench_scene(p, args))
        except OptdesignError as exc:   # a scene optimise refuses as it stands (e.g. a motor catalogue)
            print(f"[{p.name}] skipped: {exc}", flush=True)
            skipped.append((p, str(exc)))
    text = report(results, args, git, load0)
    if skipped:
        text += "\nSkipped: optimise refuses these scenes as they stand: " + "; ".join(
            f"`{p.relative_to(ROOT)}` ({why.split(': ', 1)[-1]})" for p, why in skipped) + ".\n"
    write_file(Path(args.out), text)
    if not args.scene:   # the whole library: its summary in results/bench.md
        write_section("per_start", summary(results, args, git))
    print(f"wrote {args.out}")
    return 0


assert multistart  # (imported for its solve_start; kept explicit for readers)

if __name__ == "__main__":
    sys.exit(main())
