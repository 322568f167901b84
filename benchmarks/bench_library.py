"""Benchmark of the optimiser over the whole scene library (issue 14): does the default
``optimise(scene, 20, 0)`` reach the independent global optimum from (nearly) every start, on
every scene, shipped and new, with one setting for all?

    python benchmarks/bench_library.py [--level full|small] [--no-variants] [--scenes NAME ...]
                                       [--out results/optimise_library.md]

For every scene in problems/ with an [objective]:

* the independent global optimum: for a library scene (problems/lib_*.toml) its numpy reference
  in tests/library (``global_optimum(level)``: a dense grid over the whole design box, polished
  SLSQP minimax solves, every constraint rechecked on 20,001 samples; written without
  optdesign); for a shipped scene a dense grid plus polish written here on the independent
  evaluator of tests/test_optimisation_scenes.py (it shares only the scene's model with the
  optimiser: no DesignProblem, no exchange, no certification): the grid's best feasible local
  minima, each polished by SLSQP on 2,001 stroke samples with every extreme refined between
  samples, the result judged on 20,001 samples;
* the default run: best found, starts at the global optimum (certified objective within 1e-6
  relative), distinct local optima (``result.optima``), failed starts by status, median time per
  start; the certified peak against the peak of 20,001 samples at the optimum.

Then the option table: the same library under one change each (an IPOPT option of the
objective phase set back to IPOPT's default or to an alternative, phase 1's barrier strategy,
phase 1 left out, the starts drawn otherwise).  Every option the tool sets is justified by a row
of it; none is chosen per scene.  Not a test; writes ``--out`` (markdown) and the same numbers as
JSON beside it, atomically.
"""
from __future__ import annotations

import argparse
import contextlib
import importlib
import json
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests"), str(ROOT / "tests" / "library"), str(ROOT / "benchmarks")]

import optdesign  # noqa: E402
from optdesign.design import multistart, nlp, phase1, problem, solver, sqp, starts  # noqa: E402
from optdesign.errors import OptdesignError  # noqa: E402
from optdesign.report.files import write_file  # noqa: E402

STARTS, SEED = 20, 0
AT_GLOBAL = 1e-6       # a start reached the global optimum: certified objective within this, relative
DENSE = 20001


# --- the scenes and their independent optima -------------------------------------------------
def scenes(names=None) -> list:
    out = []
    for p in sorted((ROOT / "problems").glob("*.toml")):
        if names and p.stem not in names:
            continue
        try:
            scene = optdesign.load(p)
            # a motor catalogue is optimised once per motor (design/catalogue.py; checked by
            # tests/test_cases_scenes.py): not one multistart
            if scene.objective is not None and len(scene.motors) <= 1:
                out.append(p)
        except OptdesignError:
            continue
    return out


def library_reference(path: Path, level: str):
    """The numpy reference module of a library scene and its global optimum (value, design)."""
    for ref in sorted((ROOT / "tests" / "library").glob("ref_*.py")):
        if path.stem.removeprefix("lib_") in ref.stem or path.stem in ref.read_text():
            module = importlib.import_module(f"tests.library.{ref.stem}")
            if Path(getattr(module, "SCENE", "")).resolve() == path.resolve():
                res = module.global_optimum(level)
                value = res["value"] if "value" in res else res["peak"]
                return float(value), {k: float(v) for k, v in res["design"].items()}, f"tests/library/{ref.stem}.py ({level})"
    return None


def shipped_reference(path: Path):
    """Dense grid plus polish on the independent evaluator of tests/test_optimisation_scenes.py."""
    import test_optimisation_scenes as ind

    scene = optdesign.load(path)
    if scene.cases:   # an objective over load cases: the evaluator has no cases (tests/test_cases_*.py check those)
        return None
    grid, n, total, assembling = ind.grid_search(scene)
    fine = ind.Stroke(scene, max(2001, scene.sweep.samples), refine=True)
    dense = ind.Stroke(scene, DENSE)
    best, best_x = math.inf, None
    for _, x0 in grid[:ind.POLISH_STARTS]:
        x = ind.polish(fine, x0)
        obj, viol = dense.value(x)
        if viol <= ind.BOUND_TOL and obj < best:
            best, best_x = obj, x
    names = [p.name for p in scene.parameters if p.is_design]
    design = None if best_x is None else dict(zip(names, map(float, best_x)))
    return best, design, f"grid {n}/variable + SLSQP on 2,001 samples (tests/test_optimisation_scenes.py evaluator)"


def dense_peak(path, design):
    """The peak |objective quantity| over 20,001 samples at ``design`` (peak objectives only)."""
    import test_optimisation_scenes as ind

    scene = optdesign.load(path)
    if scene.cases:   # an objective over load cases: the evaluator has no cases
        return None
    st = ind.Stroke(scene, DENSE)
    if st.kind != "peak":
        return None
    x = np.array([design[p.name] for p in scene.parameters if p.is_design])
    return float(st.evaluate(x)[0][0])


# --- the variants ----------------------------------------------------------------------------
def ipopt_change(**change):
    """The objective phase's IPOPT options (and phase 1's, which start from them) changed:
    a value sets the option, None removes it (IPOPT's default)."""
    @contextlib.contextmanager
    def patch():
        original = nlp.ipopt_options

        def options(st, kind):
            opts = original(st, kind)
            for k, v in change.items():
                if v is None:
                    opts.pop(f"ipopt.{k}", None)
                else:
                    opts[f"ipopt.{k}"] = v
            return opts
        nlp.ipopt_options = options
        try:
            yield
        finally:
            nlp.ipopt_options = original
    return patch


@contextlib.contextmanager
def setting(module, name, value):
    old = getattr(module, name)
    setattr(module, name, value)
    try:
        yield
    finally:
        setattr(module, name, old)


def start_method(method):
    @contextlib.contextmanager
    def patch():
        original = starts.unit_sample
        with setting(starts, "unit_sample", lambda d, n, rng, _m="sobol": original(d, n, rng, method)):
            yield
    return patch


def unscreened(method="sobol"):
    """Starts in the order drawn (no ranking, no zoom), optionally by another method."""
    @contextlib.contextmanager
    def patch():
        with setting(starts, "rank", lambda f, viol: np.arange(len(f))), setting(starts, "ZOOM", ()), \
                start_method(method)():
            yield
    return patch


def no_phase1():
    """Phase 1 left out: a start that assembles goes to the objective phase as it is (one that
    does not is repaired, as before issue 14)."""
    @contextlib.contextmanager
    def patch():
        def as_is(solver, repair, x0, fixed):
            pb = solver.pb
            x0 = np.clip(np.asarray(x0, float), pb.lower, pb.upper)
            q = pb.evaluate_grid(x0, fixed, np.r_[pb.base_points, pb.initial_slots])
            repaired = False
            if not np.all(np.isfinite(q)):
                x0 = repair(x0, fixed)
                if x0 is None:
                    return None, False
                repaired = True
            return phase1.Phase1Result(x0, 0.0, "left out", 0), repaired
        with setting(multistart, "feasible_start", as_is):
            yield
    return patch


def cold_exchange():
    """Exchange steps solved cold (the warm solver's options left out)."""
    @contextlib.contextmanager
    def patch():
        with setting(nlp, "warm_solver", lambda pb: pb.solver):
            yield
    return patch


def phase1_options(options):
    @contextlib.contextmanager
    def patch():
        with setting(phase1, "OPTIONS", options):
            yield
    return patch


def max_exchanges(n):
    """SolverSettings' default number of exchange steps set to n."""
    @contextlib.contextmanager
    def patch():
        old_init = problem.SolverSettings.__init__.__defaults__
        defaults = list(old_init)
        names = [f for f in problem.SolverSettings.__dataclass_fields__]
        defaults[names.index("max_exchanges")] = n
        problem.SolverSettings.__init__.__defaults__ = tuple(defaults)
        try:
            yield
        finally:
            problem.SolverSettings.__init__.__defaults__ = old_init
    return patch


def none():
    return contextlib.nullcontext


VARIANTS = [
    ("default", "the shipped setting", none()),
    ("objective phase: sqpmethod on re-solves", "every re-solve after an exchange step (and the polish) by sqpmethod + "
     "qpOASES first (design/sqp.py), IPOPT from the same point when the SQP's result is not accepted; a start's first "
     "solve by IPOPT (the tool: IPOPT for every objective-phase solve)", lambda: setting(sqp, "SOLVER", "sqpmethod on re-solves")),
    ("objective phase: sqpmethod for every solve", "the same on a start's first solve too",
     lambda: setting(sqp, "SOLVER", "sqpmethod")),
    ("expect_infeasible_problem yes", "the setting before issue 14 (the tool leaves IPOPT's default, no)",
     ipopt_change(expect_infeasible_problem="yes")),
    ("mu_strategy monotone", "objective phase (the tool sets adaptive)", ipopt_change(mu_strategy="monotone")),
    ("alpha_for_y primal", "IPOPT's default (the tool sets min-dual-infeas)", ipopt_change(alpha_for_y=None)),
    ("constr_mult_init_max 1000", "IPOPT's default (the tool sets 0)", ipopt_change(constr_mult_init_max=None)),
    ("mumps scaling on", "IPOPT's default (the tool sets mumps_scaling 0, mumps_permuting_scaling 0)",
     ipopt_change(mumps_scaling=None, mumps_permuting_scaling=None)),
    ("min_refinement_steps 1", "IPOPT's default (the tool sets 0)", ipopt_change(min_refinement_steps=None)),
    ("hessian limited-memory", "every objective (the tool uses it for rms only)",
     ipopt_change(hessian_approximation="limited-memory")),
    ("hessian exact for rms", "the rms objective too (the tool uses limited-memory there)",
     ipopt_change(hessian_approximation=None)),
    ("exchange steps cold", "no warm-start options on an exchange step", cold_exchange()),
    ("exchange: no step limit", "an exchange step may move the design anywhere in the box (the tool limits it to 0.1 "
     "of each range, halved or doubled)", lambda: setting(solver, "STEP_START", 1e9)),
    ("exchange: 12 steps", "at most 12 exchange steps per solve (the tool allows 20)", max_exchanges(12)),
    ("phase 1: mu_strategy adaptive", "phase 1 with the objective phase's barrier strategy (the tool sets monotone)",
     phase1_options({})),
    ("phase 1 left out", "IPOPT from the start as drawn (repair only), as before issue 14", no_phase1()),
    ("starts: Latin hypercube", "screened and zoomed as the default, LHS instead of Sobol", start_method("lhs")),
    ("starts: uniform", "screened and zoomed as the default, independent uniform draws", start_method("uniform")),
    ("starts: no zoom", "screened Sobol candidates, no zoom levels", lambda: setting(starts, "ZOOM", ())),
    ("starts: unscreened Sobol", "the first Sobol points in order", unscreened("sobol")),
    ("starts: unscreened uniform", "uniform draws in order (the starts before issue 14)", unscreened("uniform")),
]


# --- one run -----------------------------------------------------------------------------------
@contextlib.contextmanager
def start_cpu(times: list):
    """Each start's CPU time (this process's, ``time.process_time``) appended to ``times``."""
    original = multistart.solve_start

    def timed(*args, **kwargs):
        c0 = time.process_time()
        try:
            return original(*args, **kwargs)
        finally:
            times.append(time.process_time() - c0)
    with setting(multistart, "solve_start", timed):
        yield


def run(path: Path, glob: float | None) -> dict:
    scene = optdesign.load(path)
    t0, c0, cpus = time.perf_counter(), time.process_time(), []
    try:
        with start_cpu(cpus):
            res = optdesign.optimise(scene, STARTS, SEED)
    except OptdesignError as exc:
        return {"refused": str(exc).splitlines()[0][:200]}
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    ok = [s for s in res.starts if s.success and s.objective is not None]
    target = glob if glob is not None and math.isfinite(glob) else res.objective
    at = sum(1 for s in ok if target is not None and abs(s.objective - target) <= AT_GLOBAL * abs(target))
    failed = {}
    for s in res.starts:
        if not s.success:
            key = s.status.split(":")[0]
            failed[key] = failed.get(key, 0) + 1
    return {"success": res.success, "best": res.objective, "design": res.design, "at_global": at,
            "optima": len(res.optima), "failed": failed, "retries": sum(max(len(s.tried) - 1, 0) for s in res.starts),
            "median_start_s": statistics.median(s.time_s for s in res.starts), "wall_s": wall, "cpu_s": cpu,
            "median_start_cpu_s": statistics.median(cpus) if cpus else None,
            "screen_s": res.timings.get("screen_s"), "peak_certified": res.peak_certified,
            "iterations": sum(s.iterations + s.phase1_iterations for s in res.starts)}


# --- the report ----------------------------------------------------------------------------------
def fmt(v, digits=9):
    return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:,.{digits}g}"


def cpu_ms(run) -> str:
    v = run.get("median_start_cpu_s")
    return "-" if v is None else f"{v * 1e3:.0f}"


SOLVER_ROWS = ("default", "objective phase: sqpmethod on re-solves", "objective phase: sqpmethod for every solve")


def solver_table(data) -> list:
    """The objective phase's solver, scene by scene: the rules of SOLVER_ROWS (the default,
    IPOPT only; the SQP on re-solves; the SQP on every solve), starts at the global optimum
    and the median CPU time per start, each against IPOPT only."""
    labels = {"default": "default (IPOPT only)", "objective phase: sqpmethod on re-solves": "sqpmethod on re-solves",
              "objective phase: sqpmethod for every solve": "sqpmethod for every solve"}
    base = SOLVER_ROWS[0]
    rows, ratios = [], {k: [] for k in SOLVER_ROWS if k != base}
    for name, row in data["scenes"].items():
        runs = {k: row["runs"].get(k) for k in SOLVER_ROWS}
        if any(r is None or "refused" in r for r in runs.values()):
            continue
        cells = []
        for k in SOLVER_ROWS:
            r = runs[k]
            cell = f"{r['at_global']}/{STARTS}, {r['median_start_s'] * 1e3:.0f} ({cpu_ms(r)}), {r['iterations']}"
            if k != base and r.get("median_start_cpu_s") and runs[base].get("median_start_cpu_s"):
                ratio = runs[base]["median_start_cpu_s"] / r["median_start_cpu_s"]
                ratios[k].append(ratio)
                cell += f", {ratio:.2f}x"
            cells.append(cell)
        rows.append(f"| `{name}` | " + " | ".join(cells) + " |")
    if not rows:
        return []
    out = ["## The objective phase's solver, scene by scene", "",
           "The solver rows of the option table above (each scene runs them one after the other). Each cell: starts at "
           "the global optimum, median time per start wall (CPU) [ms], iterations of all starts (phase 1's, IPOPT's and "
           "the SQP's), and the median CPU per start of IPOPT only divided by this rule's (> 1: this rule is faster).", "",
           "| scene | " + " | ".join(labels[k] for k in SOLVER_ROWS) + " |", "|---|" + "---|" * len(SOLVER_ROWS), *rows, ""]
    for k, rs in ratios.items():
        if rs:
            gm = math.exp(statistics.fmean(math.log(r) for r in rs))
            out.append(f"- {labels[k]}: CPU per start, IPOPT only / this rule: geometric mean over the scenes {gm:.2f}x "
                       f"(lowest {min(rs):.2f}x, highest {max(rs):.2f}x); starts at the global optimum "
                       f"{sum(data['scenes'][n]['runs'][k]['at_global'] for n in data['scenes'] if k in data['scenes'][n]['runs'] and 'at_global' in data['scenes'][n]['runs'][k])}"
                       f" (IPOPT only {sum(data['scenes'][n]['runs'][base]['at_global'] for n in data['scenes'] if base in data['scenes'][n]['runs'] and 'at_global' in data['scenes'][n]['runs'][base])}).")
    kept = [k for k, rs in ratios.items() if rs and all(
        data["scenes"][n]["runs"][k]["at_global"] >= data["scenes"][n]["runs"][base]["at_global"]
        for n in data["scenes"] if k in data["scenes"][n]["runs"] and "at_global" in data["scenes"][n]["runs"][k])
        and math.exp(statistics.fmean(math.log(r) for r in rs)) > 1.1]
    same = [n for n, row in data["scenes"].items()
            if len({row["runs"].get(k, {}).get("iterations") for k in SOLVER_ROWS}) == 1]
    if same:
        out.append(f"- The same iterations under every rule (no SQP solve: its compiled library is not in the cache, "
                   f"e.g. gcc exceeded its memory bound, and without it the solves are IPOPT's): "
                   f"{', '.join(f'`{n}`' for n in same)}; their time ratios are the machine's noise.")
    out += ["", "A rule replaces the default only if it loses no start on any scene and is faster per start over the "
            "library (geometric mean of IPOPT only / the rule above 1.1x: a scene's median CPU per start under the same "
            "setting varied by up to 75 % between two runs this evening on the shared machine: level-luffing cylinder 37 and 65 ms): "
            + (", ".join(labels[k] for k in kept) + " qualifies." if kept else "neither SQP rule does, so the objective "
               "phase keeps IPOPT (design/sqp.py says why each one fails).")]
    return out + [""]


def report(data) -> str:
    lines = ["# The optimiser over the whole scene library (issues 14 and 18)", "",
             f"`python benchmarks/bench_library.py` ({data['when']}, {data['git']}; {data['machine']}). "
             f"Every run: `optimise(load(scene), {STARTS}, {SEED})`, one process, the same settings for every scene. "
             f"A start is *at the global optimum* when its certified objective is within {AT_GLOBAL:g} (relative) "
             "of the independent optimum. Times are medians per start (phase 1, objective phase, exchange steps and "
             "certification; the one screening per run is its own column).", "",
             "## The default setting, one row per scene", "",
             "| scene | independent global optimum | best found | rel. difference | certified peak vs 20,001 samples | "
             "starts at global | distinct local optima | failed starts | retries | time per start [ms] wall (CPU) | screening [s] |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for name, row in data["scenes"].items():
        d = row["runs"]["default"]
        ref = row["reference"]
        if "refused" in d:
            lines.append(f"| `{name}` | {fmt(ref['value'])} | refused: {d['refused']} | | | | | | | | |")
            continue
        rel = None if ref["value"] is None or d["best"] is None else (d["best"] - ref["value"]) / ref["value"]
        peak = row.get("dense_peak")
        peak_rel = None if peak is None or d["peak_certified"] is None else (d["peak_certified"] - peak) / peak
        failed = ", ".join(f"{k} {v}" for k, v in d["failed"].items()) or "none"
        lines.append(f"| `{name}` | {fmt(ref['value'])} | {fmt(d['best'])} | {fmt(rel, 2)} | {fmt(peak_rel, 2)} | "
                     f"{d['at_global']}/{STARTS} | {d['optima']} | {failed} | {d['retries']} | "
                     f"{d['median_start_s'] * 1e3:.0f} ({cpu_ms(d)}) | {fmt(d['screen_s'], 2)} |")
    lines += ["", "Independent optima: " + "; ".join(f"`{n}`: {r['reference']['source']}"
                                                    for n, r in data["scenes"].items()), ""]
    if data.get("variants"):
        lines += ["## One change at a time: every option the tool sets, over the library", "",
                  "Each row runs the whole library with one change from the default. *Sum*: starts at the global "
                  f"optimum over all scenes (of {STARTS} x scenes); *worst*: the fewest on one scene; *>= 18*: scenes "
                  "with at least 18 of 20; *failed*: starts that ended without a certified optimum, by status; "
                  "*time*: the median over the scenes of the median time per start, wall (CPU: this process's, "
                  "which leaves out waiting for a core on the shared machine); *wall, CPU*: the whole row's runs.", "",
                  "| change | what | sum | worst (scene) | scenes >= 18/20 | failed | time per start [ms] wall (CPU) | "
                  "wall [s] | CPU [s] |",
                  "|---|---|---|---|---|---|---|---|---|"]
        for name, what, _ in VARIANTS:
            runs = {s: row["runs"].get(name) for s, row in data["scenes"].items()}
            runs = {s: r for s, r in runs.items() if r is not None and "refused" not in r}
            if not runs:
                continue
            total = sum(r["at_global"] for r in runs.values())
            worst = min(runs.items(), key=lambda kv: kv[1]["at_global"])
            good = sum(r["at_global"] >= 18 for r in runs.values())
            failed = {}
            for r in runs.values():
                for k, v in r["failed"].items():
                    failed[k] = failed.get(k, 0) + v
            med = statistics.median(r["median_start_s"] for r in runs.values())
            wall = sum(r["wall_s"] for r in runs.values())
            cpus = [r["median_start_cpu_s"] for r in runs.values() if r.get("median_start_cpu_s") is not None]
            cpu = sum(r.get("cpu_s", math.nan) for r in runs.values())
            med_cpu = f"{statistics.median(cpus) * 1e3:.0f}" if cpus else "-"
            lines.append(f"| {name} | {what} | {total}/{STARTS * len(runs)} | {worst[1]['at_global']} (`{worst[0]}`) | "
                         f"{good}/{len(runs)} | {', '.join(f'{k} {v}' for k, v in failed.items()) or 'none'} | "
                         f"{med * 1e3:.0f} ({med_cpu}) | {wall:.0f} | {cpu:.0f} |")
        lines += ["", *solver_table(data)]
        lines += ["", "Per scene (starts at the global optimum):", "",
                  "| change | " + " | ".join(f"`{s.removeprefix('lib_')}`" for s in data["scenes"]) + " |",
                  "|---|" + "---|" * len(data["scenes"])]
        for name, _, _ in VARIANTS:
            cells = []
            for s, row in data["scenes"].items():
                r = row["runs"].get(name)
                cells.append("-" if r is None else ("refused" if "refused" in r else str(r["at_global"])))
            lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--level", default="full", choices=("full", "small"), help="the library references' level")
    ap.add_argument("--no-variants", action="store_true", help="the default setting only")
    ap.add_argument("--scenes", nargs="*", help="scene names (default: every scene with an objective)")
    ap.add_argument("--out", default=str(ROOT / "results" / "optimise_library.md"))
    ap.add_argument("--resume", action="store_true",
                    help="keep the scenes already in the --out's JSON (from a run that stopped) and run the rest")
    args = ap.parse_args(argv)
    from benchfile import cpu_model, git_state

    import os
    import datetime

    git = git_state(("optdesign",))
    if "uncommitted" in git:  # other people work in the same tree: say how much, not which
        git = git.split(" with ")[0] + f" with uncommitted changes in {git.count(',') + 1} files under optdesign/"
    data = {"when": datetime.date.today().isoformat(), "git": git,
            "machine": f"{cpu_model()}, {os.cpu_count()} cores, load average at the start "
                       f"{', '.join(f'{v:.1f}' for v in os.getloadavg())}",
            "scenes": {}, "variants": not args.no_variants}
    if args.resume and Path(args.out).with_suffix(".json").exists():
        before = json.loads(Path(args.out).with_suffix(".json").read_text())
        data["scenes"] = before["scenes"]
        data["git"] = f"{before['git']} (scenes {', '.join(before['scenes'])}); then {git} (the rest)"
    for path in scenes(args.scenes):
        if path.stem in data["scenes"]:
            continue
        t0 = time.perf_counter()
        ref = library_reference(path, args.level) if path.stem.startswith("lib_") else shipped_reference(path)
        value, design, source = ref if ref is not None else (None, None, "none")
        row = {"reference": {"value": value, "design": design, "source": source,
                             "seconds": time.perf_counter() - t0}, "runs": {}}
        print(f"[{path.stem}] reference {value} ({source}, {row['reference']['seconds']:.1f} s)", flush=True)
        for name, _, patch in VARIANTS if not args.no_variants else VARIANTS[:1]:
            with patch():
                row["runs"][name] = r = run(path, value)
            print(f"  {name}: {r.get('at_global', r.get('refused'))} at global, best {r.get('best')}, "
                  f"failed {r.get('failed')}, {r.get('median_start_s', 0) * 1e3:.0f} ms/start", flush=True)
        d = row["runs"]["default"]
        if "refused" not in d and d.get("design"):
            row["dense_peak"] = dense_peak(path, d["design"])
        data["scenes"][path.stem] = row
        write_file(Path(args.out).with_suffix(".json"), json.dumps(data, indent=1, default=float) + "\n")
        write_file(Path(args.out), report(data))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
