"""Whole commands where the user waits (issue 18): ``optdesign optimise`` of a 3-variable library
scene (20 starts, figures) and ``optdesign analyse`` of the level-luffing crane, against the
interpreter's floor ``python -c "import optdesign.cli"``.

    python benchmarks/bench_commands.py [--repeats 5] [--scene problems/lib_excavator_boom.toml]

Warm: every command runs once before timing (the disk cache of compiled code filled, the files
in the page cache).  Then ``--repeats`` rounds, each running the floor, analyse and optimise in
turn (one loop: the shared machine's load falls on all three); medians of wall time and of the
child's CPU time (user + system, ``resource.getrusage(RUSAGE_CHILDREN)``; optimise's forked
workers included).  Also ``python -X importtime`` of the analyse and optimise commands: the largest
modules.  Writes the section ``commands`` of results/bench.md.
"""
from __future__ import annotations

import argparse
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from benchfile import ROOT, cpu_model, git_state, write_section  # noqa: E402

CRANE = "problems/level_luffing_crane.toml"
GOAL_ANALYSE_S = 2.0


def run(cmd, env, cwd=ROOT):
    """(wall, CPU of the child) of one command, run in ``cwd``, which must succeed."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} in {cwd} failed ({proc.returncode}): {proc.stderr[-600:]}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def import_profile(env, argv, top=8):
    """The slowest imports (cumulative, top level; python -X importtime) of the command line
    run with ``argv``, and whether it imported scipy.stats."""
    code = "import optdesign.cli.main as m, sys; sys.argv = ['optdesign'] + %r; m.main()" % list(argv)
    proc = subprocess.run([sys.executable, "-X", "importtime", "-c", code], cwd=ROOT, env=env, capture_output=True,
                          text=True)
    rows = []
    for line in proc.stderr.splitlines():
        m = re.match(r"import time:\s+(\d+)\s+\|\s+(\d+)\s+\|(\s*)(\S+)", line)
        if m:
            rows.append((int(m.group(2)), len(m.group(3)), m.group(4)))
    # a module imported again in a forked process appears once more: the largest time, and how often
    largest, count = {}, {}
    for us, depth, name in rows:
        if depth <= 1:
            largest[name] = max(largest.get(name, 0), us)
            count[name] = count.get(name, 0) + 1
    top_level = sorted(largest.items(), key=lambda kv: -kv[1])[:top]
    return ([(name + (f" (x{count[name]})" if count[name] > 1 else ""), us / 1e6) for name, us in top_level],
            any(name == "scipy.stats" for _, _, name in rows))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--scene", default="problems/lib_excavator_boom.toml")
    args = ap.parse_args(argv)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    git, load0 = git_state(), os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp:
        commands = {
            "floor": [sys.executable, "-c", "import optdesign.cli"],
            "analyse": [sys.executable, "-m", "optdesign", "analyse", CRANE, "--json", "-q"],
            "optimise imports": [sys.executable, "-c", "import casadi, matplotlib.backends.backend_agg, "
                                 "matplotlib.figure, optdesign.cli.main, optdesign.design.multistart, "
                                 "optdesign.report.design"],
            "optimise --no-animation": [sys.executable, "-m", "optdesign", "optimise", args.scene, "--starts", "20",
                                        "--out", str(Path(tmp) / "out_no_animation"), "-q", "--no-animation"],
            "optimise": [sys.executable, "-m", "optdesign", "optimise", args.scene, "--starts", "20", "--out",
                         str(Path(tmp) / "out"), "-q"],
        }
        warm_env = dict(env, OPTDESIGN_COMPILE="wait")
        for cmd in commands.values():   # warm: compiled code in the cache, files in the page cache
            run(cmd, warm_env)
        times = {k: [] for k in commands}
        for _ in range(args.repeats):
            for k, cmd in commands.items():
                times[k].append(run(cmd, env))
        figures = sorted(p.name for p in (Path(tmp) / "out").iterdir())
        imports, _ = import_profile(env, ["analyse", CRANE, "--json", "-q"])
        opt_imports, scipy_stats = import_profile(env, ["optimise", args.scene, "--starts", "20", "-q", "--out",
                                                        str(Path(tmp) / "out_imports")])
    load1 = os.getloadavg()
    med = {k: (statistics.median(w for w, _ in v), statistics.median(c for _, c in v)) for k, v in times.items()}
    floor_w, floor_c = med["floor"]
    goal_a = 3 * (floor_w + 0.5)     # 3x of (the floor + 0.5 s)
    goal_b = 3 * floor_w + 0.5       # the stricter reading: 3x the floor, + 0.5 s
    opt_w, opt_c = med["optimise"]
    an_w, an_c = med["analyse"]
    verdict = lambda ok: "met" if ok else "NOT met"  # noqa: E731
    lines = [
        "## Whole commands (`python benchmarks/bench_commands.py`)", "",
        f"Written by `python benchmarks/bench_commands.py --repeats {args.repeats} --scene {args.scene}` on "
        f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; {git}; machine {cpu_model()}, nproc {os.cpu_count()} "
        f"(shared); load average (1, 5, 15 min) {', '.join(f'{v:.2f}' for v in load0)} at the start, "
        f"{', '.join(f'{v:.2f}' for v in load1)} at the end.  Warm (each command run once before timing, "
        f"the compiled code in the disk cache); {args.repeats} rounds of the commands in turn; medians. "
        "CPU = the child's user + system time (optimise's forked workers included: it can exceed the wall time).", "",
        "| command | wall [s] | CPU [s] | goal |", "|---|---:|---:|---|",
        f"| floor: `python -c \"import optdesign.cli\"` | {floor_w:.3f} | {floor_c:.3f} | |",
        f"| `optdesign analyse {CRANE} --json -q` | {an_w:.3f} | {an_c:.3f} | < {GOAL_ANALYSE_S:g} s: "
        f"{verdict(an_w < GOAL_ANALYSE_S)} |",
        f"| `optdesign optimise {args.scene} --starts 20` (figures, report.html, animation; workers = cores) | "
        f"{opt_w:.3f} | {opt_c:.3f} | <= 3 x (floor + 0.5 s) = {goal_a:.2f} s: {verdict(opt_w <= goal_a)}; "
        f"the stricter reading 3 x floor + 0.5 s = {goal_b:.2f} s: {verdict(opt_w <= goal_b)} |",
        f"| of which: the imports the optimise command needs (casadi, matplotlib's Agg canvas and Figure, "
        f"optdesign's design and report) | {med['optimise imports'][0]:.3f} | {med['optimise imports'][1]:.3f} | |",
        f"| the same optimise with `--no-animation` | {med['optimise --no-animation'][0]:.3f} | "
        f"{med['optimise --no-animation'][1]:.3f} | |",
        "", "Every round [s] (wall / CPU): " + "; ".join(
            f"{k}: " + ", ".join(f"{w:.2f}/{c:.2f}" for w, c in v) for k, v in times.items()) + ".",
        "", f"The optimise folder holds: {', '.join(figures)}.", "",
        "Slowest imports of the analyse command (`python -X importtime`, cumulative, top level): "
        + ", ".join(f"{name} {t:.3f} s" for name, t in imports) + ".", "",
        "Slowest imports of the optimise command, warm: " + ", ".join(f"{name} {t:.3f} s" for name, t in opt_imports)
        + f"; scipy.stats {'IMPORTED' if scipy_stats else 'not imported'} (the Sobol starts come from the cache "
        "in the user's cache folder, design/starts.py).",
    ]
    if opt_w > goal_a:
        imp_c, noanim_c = med["optimise imports"][1], med["optimise --no-animation"][1]
        cores = os.cpu_count() or 1
        lines += [
            "", f"The optimise goal is NOT met.  Measured above (CPU, the machine being shared): the imports the command "
            f"needs take {imp_c:.2f} s, the whole command without the animation {noanim_c:.2f} s, with it {opt_c:.2f} s "
            f"(the animation's 30 frames, GIF and MP4: {opt_c - noanim_c:.2f} s), against the goal's {goal_a:.2f} s of "
            f"wall time.  On {cores} cores the command's CPU alone needs at least {opt_c / cores:.2f} s of wall time "
            "(every core busy from the first instant to the last), so the goal needs less work, not only more "
            "overlap.  Tried: the command line imports nothing heavy until a command needs it (the floor above); "
            "the models and the NLP are compiled once and loaded from the disk cache; the Sobol starts are "
            "scipy.stats.qmc's, cached on disk, so a warm run does not import scipy.stats; a process forked as soon "
            "as the scene is loaded imports matplotlib, Pillow and the drawing modules while the starts are solved, "
            "then draws the figures (report/figure_process.py: 2.07 s against 2.26 s, medians of 10 alternating "
            "runs); the figures are drawn without pyplot, the independent ones in processes forked from it; the "
            "drawing and the animation have fixed layouts computed once (no constrained layout, one draw per "
            "file); the animation draws its static parts once, copies the texts that recur in every frame (names, "
            "masses, loads, the caption's words and digits) from sprites and encodes the MP4 from the GIF's frames "
            "while they are drawn.  Tried and left out: the animation's frames drawn by two processes (a forked one "
            "from the last frame back; 2.09 s against 2.11 s, medians of 10 alternating runs, for 0.16 s more CPU, "
            "and frames that then depend on which process drew them by the antialiasing of the labels' boxes); "
            "one BLAS thread (0.04 s).  What would be needed: the rest is matplotlib's own cost per artist (a "
            "frame creates and draws about 40 artists: 18 ms of CPU per frame, the mechanism drawing 0.35 s, the "
            "load figure 0.2 s) and ffmpeg (0.3 s of CPU for the MP4); a frame renderer that moves a few artists "
            "instead of creating them, or fewer files by default."]
    path = write_section("commands", "\n".join(lines) + "\n")
    print("\n".join(lines))
    print(f"wrote {path}", file=sys.stderr)


if __name__ == "__main__":
    main()
