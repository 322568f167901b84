"""Reports of a motion in time (simulate): JSON, the summary table and figures of q, its rate and
the drive load over time, with the run's events (reversals, power-flow switches, rests, the
stall, the stroke end) listed and marked."""
from __future__ import annotations

import textwrap
from pathlib import Path

from .output import SCHEMA, Rows, save_figure, table_chunks


UNITS = {
    "rotary": {"t": "s", "s": "sweep", "sd": "sweep/s", "sdd": "sweep/s^2", "q": "rad", "qd": "rad/s",
               "qdd": "rad/s^2", "drive": "N m", "transmitted": "N m", "kinetic_energy": "J", "power": "W",
               "efficiency_factor": "1", "motor_torque": "N m", "motor_speed": "rad/s"},
    "linear": {"t": "s", "s": "sweep", "sd": "sweep/s", "sdd": "sweep/s^2", "q": "m", "qd": "m/s",
               "qdd": "m/s^2", "drive": "N", "transmitted": "N", "kinetic_energy": "J", "power": "W",
               "efficiency_factor": "1", "motor_torque": "N", "motor_speed": "m/s"},
}
ORDER = ("t", "s", "sd", "sdd", "q", "qd", "qdd", "drive", "transmitted", "kinetic_energy", "power",
         "efficiency_factor", "motor_torque", "motor_speed")


def _columns(result):
    cols = {"t": result.t, **result.columns}
    return {k: cols[k] for k in ORDER if k in cols}


def simulation_json(result) -> dict:
    cols = _columns(result)
    n = len(result.t)
    cycle = {}
    if result.phases:
        from .cycle import cycle_report

        cycle = {"phases": result.phases, "cycle": cycle_report(result)}
    return {
        "schema": SCHEMA, "kind": "simulation", "title": result.scene.title, "file": result.scene.path,
        "sweep": result.scene.sweep.name, "drive": result.drive_kind,
        "integrator": result.integrator, "tolerance": result.tolerance,
        "steps_per_sample": result.steps_per_sample, "error_estimate": result.error_estimate,
        "stop": {"reason": result.stop, "end": result.stop_end, "t": result.t_stop},
        "stats": result.stats, "timings": result.timings, "events": result.events,
        "units": {k: UNITS[result.drive_kind][k] for k in cols},
        **cycle,
        "samples": Rows(n, lambda i: {k: float(v[i]) for k, v in cols.items()}),
    }


def summary(result) -> str:
    return "".join(summary_chunks(result))


def summary_chunks(result):
    """:func:`summary` in pieces: the table's rows a few thousand at a time, then the summary."""
    yield from table_chunks(_columns(result))
    units = UNITS[result.drive_kind]
    where = {"stroke end": f"stroke end ({result.stop_end}: {result.scene.sweep.name} = {result.s[-1]:.6g})",
             "stalled": f"stalled: the mechanism came to rest at {result.scene.sweep.name} = {result.s[-1]:.6g} and "
                        "the self-locking drive holds it there (under eta < 1 its load cannot move it either way)",
             "t_end": "t_end", "cycle end": f"the end of the cycle's last phase ({len(result.phases)} phases)"}[result.stop]
    st = result.stats
    lines = ["",
             f"{result.scene.title}",
             f"integrator {result.integrator}" + (f", {result.steps_per_sample} steps per sample, estimated error "
                                                  f"{result.error_estimate:.3g}" if result.integrator == "rk4" else "")
             + f", tolerance {result.tolerance:g}",
             f"stopped at t = {result.t_stop:.9g} s: {where}",
             f"steps {st['steps']}, right-hand sides {st['rhs_evaluations']}, error-test failures "
             f"{st['error_test_failures']}, integrator calls {st['integrator_calls']} "
             f"({st.get('failed_calls', 0)} failed" + "".join(f", {n} {flag}" for flag, n in st.get("failures", {}).items())
             + f"){_peak_location(st)}, integrate {result.timings['integrate_s'] * 1e3:.1f} ms",
             events_line(result),
             f"q from {result.q[0]:.6g} to {result.q[-1]:.6g} {units['q']}; rate {result.qd.min():.6g} .. "
             f"{result.qd.max():.6g} {units['qd']}; drive {result.drive.min():.6g} .. {result.drive.max():.6g} "
             f"{units['drive']}; kinetic energy {result.kinetic_energy[0]:.6g} -> {result.kinetic_energy[-1]:.6g} J"]
    if result.phases:
        from .cycle import cycle_figures, cycle_lines, profile_figures

        lines += cycle_lines(cycle_figures(result), profile_figures(result))
    yield "\n" + "\n".join(lines)


def events_line(result) -> str:
    """The events in one line: how many of each kind, and the first few with their times."""
    if not result.events:
        return "events: none"
    counts = {}
    for e in result.events:
        counts[e["kind"]] = counts.get(e["kind"], 0) + 1
    listed = ", ".join(f"{e['kind']} {e['t']:.6g} s" for e in result.events[:6])
    more = f", ... ({len(result.events) - 6} more)" if len(result.events) > 6 else ""
    return ("events: " + ", ".join(f"{n} {kind}" for kind, n in counts.items()) + f" ({listed}{more})")


EVENT_STYLE = {"reversal": ("v", "tab:red"), "rest": ("o", "tab:purple"), "power flow": ("D", "tab:green"),
               "stall": ("s", "black"), "stroke end": ("|", "tab:blue")}


def _mark_events(ax, result, values):
    """The events on a curve over time (their samples), one legend entry per kind."""
    import numpy as np

    seen = set()
    for e in result.events:
        i = min(int(np.searchsorted(result.t, e["t"])), len(result.t) - 1)
        marker, colour = EVENT_STYLE.get(e["kind"], ("x", "gray"))
        label = e["kind"] if e["kind"] not in seen else None
        seen.add(e["kind"])
        ax.plot([result.t[i]], [values[i]], marker, color=colour, ms=6 if marker != "|" else 14, mfc="none",
                label=label, zorder=5)


FIGURES = ("q.png", "q_rate.png", "drive_load.png", "cycle.png", "torque_speed.png")


def figures(result, folder, label="folder") -> list:
    """q(t), its rate and the drive load over time, one PNG each; they replace ``folder`` as a
    whole (:func:`optdesign.report.folder.replace_folder`).  Returns the paths written."""
    from .folder import replace_folder

    return replace_folder(folder, lambda tmp: _figures(result, tmp), FIGURES, label=label)


def _figures(result, folder) -> list:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    units = UNITS[result.drive_kind]
    rotary = result.drive_kind == "rotary"
    names = {"q": "crank angle alpha" if rotary else "actuator length x",
             "qd": "crank speed omega_S" if rotary else "actuator speed v_S"}
    load = "T_S" if rotary else "F_S"
    folder = Path(folder)
    written = []
    stop = f"stop: {result.stop}" + (f" ({result.stop_end})" if result.stop_end else "") + (
        f", {len(result.events)} events" if result.events else "")
    for key, file in (("q", "q.png"), ("qd", "q_rate.png"), ("drive", "drive_load.png")):
        fig, ax = plt.subplots(figsize=(7, 3.5))
        if key == "drive":
            ax.plot(result.t, result.drive, lw=1.8, label=f"law {load} (motor)")
            if "transmitted" in result.columns and not (result.transmitted == result.drive).all():
                ax.plot(result.t, result.transmitted, lw=1.0, label=f"{load} - J_d qdd (into the mechanism)")
            _mark_events(ax, result, result.drive)
            ax.set_ylabel(f"drive load [{units['drive']}]")
        else:
            ax.plot(result.t, getattr(result, key), lw=1.5)
            _mark_events(ax, result, getattr(result, key))
            ax.set_ylabel(f"{names[key]} [{units[key]}]")
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8)
        ax.set_xlabel("time t [s]")
        title = textwrap.shorten(result.scene.title, 90, placeholder=" ...")
        ax.set_title(f"{title}\n{result.integrator}, tolerance {result.tolerance:g}, {stop}", fontsize=9)
        ax.grid(alpha=0.3)
        written.append(folder / file)
        save_figure(fig, written[-1])
        plt.close(fig)
    if result.phases:
        from .cycle import cycle_figure, cycle_figures

        written.append(folder / "cycle.png")
        figures = cycle_figures(result)
        cycle_figure(result, figures, written[-1], EVENT_STYLE)
        written += _torque_speed(result, figures, folder)
    return written


def _torque_speed(result, figures, folder) -> list:
    """torque_speed.png of a simulated duty cycle: the simulated motor's operating points over
    analyse's cases (report/sized.py); nothing without [[cases]] or a motor."""
    if "motor" not in figures or not result.scene.cases:
        return []
    from ..model.analysis import analyse
    from .sized import torque_speed_figure

    cases = analyse(result.scene, certify=False).cases
    path = torque_speed_figure(cases, Path(folder) / "torque_speed.png", "simulate: the duty cycle in time",
                               motor=figures["motor"]["name"],
                               simulated=(result.t, result.columns["motor_speed"], result.columns["motor_torque"],
                                          figures["rms_motor_torque"]))
    return [] if path is None else [path]


def _peak_location(stats) -> str:
    """', peaks located between samples with N integrator calls (M steps)', or ''."""
    located = stats.get("peak_location") or {}
    if not located.get("integrator_calls"):
        return ""
    return f"; peaks located between samples with {located['integrator_calls']} more calls ({located['steps']} steps)"
