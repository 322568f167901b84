"""`optdesign simulate SCENE`: the motion in time under the scene's drive law (CLI module).

Imports cheaply (CasADi and numpy only inside :func:`run`), as ``cli.COMMAND_MODULES`` asks."""
from __future__ import annotations

import sys

HELP = "motion in time under the drive law of [drive] from the start in [simulation] (CVODES BDF/Adams, RK4)"

UNITS = {
    "rotary": {"t": "s", "s": "sweep", "sd": "sweep/s", "sdd": "sweep/s^2", "q": "rad", "qd": "rad/s",
               "qdd": "rad/s^2", "drive": "N m", "transmitted": "N m", "kinetic_energy": "J", "power": "W",
               "efficiency_factor": "1"},
    "linear": {"t": "s", "s": "sweep", "sd": "sweep/s", "sdd": "sweep/s^2", "q": "m", "qd": "m/s",
               "qdd": "m/s^2", "drive": "N", "transmitted": "N", "kinetic_energy": "J", "power": "W",
               "efficiency_factor": "1"},
}
ORDER = ("t", "s", "sd", "sdd", "q", "qd", "qdd", "drive", "transmitted", "kinetic_energy", "power",
         "efficiency_factor")


def add_arguments(p):
    from .main import _samples

    p.add_argument("scene", help="scene file (TOML) with [drive] law and [simulation], e.g. problems/sim_slider_crank.toml")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help="override a parameter (repeatable)")
    p.add_argument("--integrator", choices=("bdf", "adams", "rk4"), default=None,
                   help="bdf: CVODES BDF, Newton (implicit, stiff cases); adams: CVODES Adams, functional "
                        "iteration (non-stiff); rk4: fixed-step explicit RK4 (default: the scene's, else bdf)")
    p.add_argument("--tolerance", type=float, default=None, help="relative tolerance (default: the scene's, else 1e-8)")
    p.add_argument("--steps", type=int, default=None, help="rk4 only: steps per output sample (default 20)")
    p.add_argument("--samples", type=_samples, default=None, help="output samples over 0 .. t_end (default: the scene's)")
    p.add_argument("--t-end", type=float, default=None, dest="t_end", help="end time [s] (default: the scene's)")
    p.add_argument("--plot", metavar="DIR", help="write figures (PNG) of q, its rate and the drive load over time into DIR")


def run(args):
    from .main import _emit, _load
    from ..report.common import to_json
    from ..dynamics.simulator import simulate

    result = simulate(_load(args), integrator=args.integrator, tolerance=args.tolerance, steps=args.steps,
                      samples=args.samples, t_end=args.t_end)
    if args.plot:
        for path in figures(result, args.plot):
            print(f"wrote {path}", file=sys.stderr)
    _emit(args, to_json(simulation_json(result)) if args.json else "", summary(result))


def _columns(result):
    cols = {"t": result.t, **result.columns}
    return {k: cols[k] for k in ORDER if k in cols}


def simulation_json(result) -> dict:
    from ..report.common import SCHEMA

    cols = _columns(result)
    n = len(result.t)
    return {
        "schema": SCHEMA, "kind": "simulation", "title": result.scene.title, "file": result.scene.path,
        "sweep": result.scene.sweep.name, "drive": result.drive_kind,
        "integrator": result.integrator, "tolerance": result.tolerance,
        "steps_per_sample": result.steps_per_sample, "error_estimate": result.error_estimate,
        "stop": {"reason": result.stop, "end": result.stop_end, "t": result.t_stop},
        "stats": result.stats, "timings": result.timings,
        "units": {k: UNITS[result.drive_kind][k] for k in cols},
        "samples": [{k: float(v[i]) for k, v in cols.items()} for i in range(n)],
    }


def summary(result) -> str:
    from ..report.common import table

    units = UNITS[result.drive_kind]
    where = {"stroke end": f"stroke end ({result.stop_end}: {result.scene.sweep.name} = {result.s[-1]:.6g})",
             "stalled": f"stalled: the mechanism came to rest at {result.scene.sweep.name} = {result.s[-1]:.6g} and "
                        "the self-locking drive holds it there (under eta < 1 its load cannot move it either way)",
             "t_end": "t_end"}[result.stop]
    st = result.stats
    lines = [table(_columns(result)), "",
             f"{result.scene.title}",
             f"integrator {result.integrator}" + (f", {result.steps_per_sample} steps per sample, estimated error "
                                                  f"{result.error_estimate:.3g}" if result.integrator == "rk4" else "")
             + f", tolerance {result.tolerance:g}",
             f"stopped at t = {result.t_stop:.9g} s: {where}",
             f"steps {st['steps']}, right-hand sides {st['rhs_evaluations']}, error-test failures "
             f"{st['error_test_failures']}, integrate {result.timings['integrate_s'] * 1e3:.1f} ms",
             f"q from {result.q[0]:.6g} to {result.q[-1]:.6g} {units['q']}; rate {result.qd.min():.6g} .. "
             f"{result.qd.max():.6g} {units['qd']}; drive {result.drive.min():.6g} .. {result.drive.max():.6g} "
             f"{units['drive']}; kinetic energy {result.kinetic_energy[0]:.6g} -> {result.kinetic_energy[-1]:.6g} J"]
    return "\n".join(lines)


def figures(result, folder) -> list:
    """q(t), its rate and the drive load over time, one PNG each; returns the paths written."""
    import textwrap
    from pathlib import Path

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..report.common import save_figure

    units = UNITS[result.drive_kind]
    rotary = result.drive_kind == "rotary"
    names = {"q": "crank angle alpha" if rotary else "actuator length x",
             "qd": "crank speed omega_S" if rotary else "actuator speed v_S"}
    load = "T_S" if rotary else "F_S"
    folder = Path(folder)
    written = []
    stop = f"stop: {result.stop}" + (f" ({result.stop_end})" if result.stop_end else "")
    for key, file in (("q", "q.png"), ("qd", "q_rate.png"), ("drive", "drive_load.png")):
        fig, ax = plt.subplots(figsize=(7, 3.5))
        if key == "drive":
            ax.plot(result.t, result.drive, lw=1.8, label=f"law {load} (motor)")
            if "transmitted" in result.columns and not (result.transmitted == result.drive).all():
                ax.plot(result.t, result.transmitted, lw=1.0, label=f"{load} - J_d qdd (into the mechanism)")
            ax.legend(fontsize=8)
            ax.set_ylabel(f"drive load [{units['drive']}]")
        else:
            ax.plot(result.t, getattr(result, key), lw=1.5)
            ax.set_ylabel(f"{names[key]} [{units[key]}]")
        ax.set_xlabel("time t [s]")
        title = textwrap.shorten(result.scene.title, 90, placeholder=" ...")
        ax.set_title(f"{title}\n{result.integrator}, tolerance {result.tolerance:g}, {stop}", fontsize=9)
        ax.grid(alpha=0.3)
        written.append(folder / file)
        save_figure(fig, written[-1])
        plt.close(fig)
    return written
