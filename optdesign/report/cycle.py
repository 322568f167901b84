"""A duty cycle in time (``[[simulation.phases]]``): the motor's figures from the simulated
motion, where its limits bind, the same figures from analyse's profiles side by side, and the
cycle's figure.

From the simulation (:mod:`optdesign.dynamics.phases`): the cycle time (the last phase's end),
the motor's peak torque and speed (over the samples and the events' instants), its RMS torque
sqrt(int T_m^2 dt / T) and the energies per cycle, int T_m omega_m dt at the motor and int T_S qd
dt at the drive (both integrated with the motion, to the integration tolerance), and where the
motor's limits bind: its torque at +-peak_torque (a controller saturated, the speed-torque
curve at standstill), its speed beyond max_speed, its RMS torque above the rated torque.

From analyse (:mod:`optdesign.model.duty`: the profile assumed followed): the same figures for
the cycle of ``[duty]`` (or every case once), the motor's peak torque and speed over the cases
the phases use, with the simulation's motor.  Under a stiff speed controller the two agree
(tests/test_duty_simulation.py).
"""
from __future__ import annotations

import math
import textwrap
from pathlib import Path

import numpy as np

from .output import save_figure

BINDS = 1e-3   # a limit binds within this share of it (a controller tracks it to about that)


def cycle_figures(result) -> dict:
    """The cycle's figures from the simulated motion (a :class:`SimulationResult` of phases)."""
    T = float(result.t[-1] - result.t[0])
    sums = {k: sum(p["integrals"][k] for p in result.phases) for k in ("motor_squared", "motor_work", "drive_work")}
    torque, speed = result.columns["motor_torque"], result.columns["motor_speed"]
    out = {"cycle_time": T, "peak_motor_torque": float(np.max(np.abs(torque))),
           "rms_motor_torque": math.sqrt(max(sums["motor_squared"], 0.0) / T) if T > 0 else math.nan,
           "peak_motor_speed": float(np.max(np.abs(speed))), "motor_energy": sums["motor_work"],
           "drive_energy": sums["drive_work"], "mean_motor_power": sums["motor_work"] / T if T > 0 else math.nan,
           "phases": [_phase_figures(result, p) for p in result.phases]}
    motor = _motor(result.scene)
    if motor is not None:
        name, numbers = motor
        out["motor"] = {"name": name, **numbers}
        out["limits"] = binding(result, numbers, out["rms_motor_torque"])
    return out


def _phase_figures(result, p) -> dict:
    """One simulated phase's figures: its times, the motor's RMS and peak torque and peak speed
    over it, the energy at the drive."""
    duration = p["t_end"] - p["t_start"]
    rows = slice(*p["rows"])
    torque, speed = (np.abs(result.columns[k][rows]) for k in ("motor_torque", "motor_speed"))
    return {"name": p["name"], "kind": p["kind"], "t_start": p["t_start"], "t_end": p["t_end"], "duration": duration,
            "rms_motor_torque": math.sqrt(max(p["integrals"]["motor_squared"], 0.0) / max(duration, 1e-300)),
            "peak_motor_torque": float(np.max(torque, initial=0.0)), "peak_motor_speed": float(np.max(speed, initial=0.0)),
            "drive_energy": p["integrals"]["drive_work"]}


def _motor(scene):
    from ..model.train import motor_numbers

    if scene.gearbox is None or not scene.motors:
        return None
    m = next((m for m in scene.motors if m.name == scene.simulation.motor), scene.motors[0])
    return m.name, motor_numbers(m, scene.parameter_values())


def binding(result, motor, rms) -> list:
    """Where the motor's limits bind: intervals of time (per phase) with |T_m| at the peak
    torque or |omega_m| beyond the maximum speed, and the RMS above the rated torque."""
    out = []
    t = result.t
    for limit, values, bound in (("peak torque", np.abs(result.columns["motor_torque"]), motor["peak_torque"]),
                                 ("max speed", np.abs(result.columns["motor_speed"]), motor["max_speed"])):
        hit = values >= bound * (1 - BINDS)
        edges = np.flatnonzero(np.diff(np.r_[0, hit.astype(int), 0]))
        for a, b in zip(edges[::2], edges[1::2]):
            phase = next((p["name"] for p in result.phases if p["t_start"] <= t[a] < p["t_end"]), result.phases[-1]["name"])
            out.append({"limit": limit, "phase": phase, "t_from": float(t[a]), "t_to": float(t[b - 1]),
                        "bound": float(bound), "peak": float(np.max(values[a:b]))})
    if rms > motor["rated_torque"]:
        out.append({"limit": "rated torque", "phase": None, "rms": rms, "bound": motor["rated_torque"]})
    return out


def profile_figures(result) -> dict | None:
    """analyse's figures with the simulation's motor (the profiles followed exactly): ``phases``,
    for each simulated phase that follows a case's profile (a controller on the case's own
    profile and direction, until the profile's end), that case's duration, motor peak and RMS
    torque, peak speed and energy at the drive; ``cycle``, the same over the cycle of [duty]
    (or every case once; None when a case has no motion in time) with its ``steps``; and
    ``same_cycle``, whether the simulated phases are that cycle's steps (then the two cycles
    compare, else only the phases do).  None without [[cases]] or without a motor."""
    from ..model.analysis import analyse

    scene = result.scene
    motor = _motor(scene)
    if motor is None or not scene.cases:
        return None
    name, numbers = motor
    a = analyse(scene).cases   # each case's motor peak located between its samples
    per_case = {c: _case_figures(r, name, numbers["inertia"]) for c, r in a.cases.items()}
    spec = {ph.name: ph for ph in scene.simulation.phases}
    phases = []
    for p in result.phases:
        case = _followed_case(spec[p["name"]], scene)
        if case is not None:
            phases.append({"phase": p["name"], "case": case, **per_case[case]})
    duty, cycle = a.duty, None
    if "steps" in duty:
        cases = {st["case"] for st in duty["steps"] if st["kind"] == "case"}
        cycle = {"cycle_time": duty["cycle_time"], "rms_motor_torque": a.train["motors"][name].get("rms"),
                 "peak_motor_torque": max(per_case[c]["peak_motor_torque"] for c in cases),
                 "peak_motor_speed": max(per_case[c]["peak_motor_speed"] for c in cases),
                 "drive_energy": duty["energy"], "steps": [_step_label(st) for st in duty["steps"]]}
    same = cycle is not None and result.stop == "cycle end" and _same_steps(result, spec, scene, duty["steps"])
    return {"phases": phases, "cycle": cycle, "same_cycle": same}


def _case_figures(r, motor, J) -> dict:
    """A case's figures in analyse with a motor of inertia J: duration, the motor's peak torque
    (located between the samples), RMS torque over the case, peak speed, energy at the drive."""
    a, b, c = (r.integrals[k] for k in ("motor_load_squared", "motor_load_acceleration", "motor_acceleration_squared"))
    sampled = float(np.max(np.abs(r.columns["motor_load_torque"] + J * r.columns["motor_acceleration"])))
    return {"duration": r.duration, "peak_motor_torque": max(r.motors[motor]["peak"], sampled),
            "rms_motor_torque": math.sqrt(max(a + 2 * J * b + J * J * c, 0.0) / r.duration),
            "peak_motor_speed": r.peaks.get("motor_speed", 0.0), "drive_energy": r.integrals["energy"]}


def _followed_case(ph, scene):
    """The case whose profile the phase ``ph`` runs as analyse has it (a controller on the
    case's own profile and direction until the profile ends), or None."""
    if ph.kind != "controller" or ph.case is None or ph.until != "profile":
        return None
    case = next(c for c in scene.cases if c.name == ph.case)
    own = ph.setting.get("profile", case.profile) == case.profile
    return ph.case if own and ph.setting.get("direction", case.direction) == case.direction else None


def _step_label(st) -> str:
    if st["kind"] == "case":
        return st["case"] if st["repeat"] == 1 else f"{st['repeat']:g} x {st['case']}"
    return f"{st['kind']} {st['time']:.6g} s"


def _same_steps(result, spec, scene, steps) -> bool:
    """Whether the simulated phases run the duty cycle's steps in order: each case step (its
    repeats) a phase following that case, each dwell a brake's hold and each hold the motor's,
    of the same time."""
    wanted = []
    for st in steps:
        if st["kind"] == "case":
            if st["repeat"] != int(st["repeat"]):
                return False
            wanted += [("case", st["case"])] * int(st["repeat"])
        else:
            wanted.append((st["kind"], st["time"]))
    ran = []
    for p in result.phases:
        ph = spec[p["name"]]
        case = _followed_case(ph, scene)
        if case is not None:
            ran.append(("case", case))
        elif ph.kind == "hold":
            ran.append(("dwell" if ph.setting == "brake" else "hold", p["t_end"] - p["t_start"]))
        else:
            return False
    return len(ran) == len(wanted) and all(
        x[0] == y[0] and (x[1] == y[1] if x[0] == "case" else math.isclose(x[1], y[1], rel_tol=1e-9))
        for x, y in zip(ran, wanted))


COMPARED = (("cycle_time", "cycle time", "s"), ("peak_motor_torque", "motor peak torque", "N m"),
            ("rms_motor_torque", "motor RMS torque", "N m"), ("peak_motor_speed", "motor peak speed", "rad/s"),
            ("drive_energy", "energy per cycle at the drive", "J"))
PHASE_COMPARED = (("duration", "duration", "s"), ("peak_motor_torque", "motor peak torque", "N m"),
                  ("rms_motor_torque", "motor RMS torque", "N m"), ("peak_motor_speed", "motor peak speed", "rad/s"),
                  ("drive_energy", "energy at the drive", "J"))


def cycle_report(result) -> dict:
    """The cycle's figures (:func:`cycle_figures`) and analyse's (``profiles``: None without
    cases or motor) for the JSON."""
    return {**cycle_figures(result), "profiles": profile_figures(result)}


def _compared(lines, head, sim, ref, rows):
    lines.append(f"  {head:32s} {'simulated':>14s} {'profiles (analyse)':>20s} {'difference':>11s}")
    for key, label, unit in rows:
        value, other = sim[key], None if ref is None else ref.get(key)
        diff = "" if other in (None, 0) else f"{(value - other) / abs(other):+.2e}"
        lines.append(f"  {'  ' + label + ' [' + unit + ']':32s} {value:14.6g} "
                     f"{'' if other is None else format(other, '20.6g'):>20s} {diff:>11s}")


def cycle_lines(figures, profile) -> list:
    """The cycle's summary: the simulation's figures beside analyse's (the whole cycle when the
    phases are [duty]'s steps, else phase by phase, saying that the cycles differ), the limits
    that bind."""
    lines = ["", "duty cycle in time" + (f" with motor {figures['motor']['name']!r}" if "motor" in figures else "")]
    for ph in figures["phases"]:
        lines.append(f"  phase {ph['name']!r} ({ph['kind']}): t = {ph['t_start']:.6g} .. {ph['t_end']:.6g} s, "
                     f"motor RMS torque {ph['rms_motor_torque']:.6g} N m")
    if profile is None or profile["same_cycle"]:
        _compared(lines, "the cycle", figures, None if profile is None else profile["cycle"], COMPARED)
    else:
        ran = ", ".join(ph["name"] + (f" (hold {ph['duration']:.6g} s)" if ph["kind"] == "hold" else "")
                        for ph in figures["phases"])
        duty = profile["cycle"]
        lines.append(f"  the simulated phases ({ran}: {figures['cycle_time']:.6g} s) are not analyse's duty cycle")
        lines.append("  " + ("" if duty is None else f"({', '.join(duty['steps'])}: {duty['cycle_time']:.6g} s): ")
                     + ("compared phase by phase" if profile["phases"] else "no phase follows a case's profile to compare"))
        sim = {ph["name"]: ph for ph in figures["phases"]}
        for ref in profile["phases"]:
            _compared(lines, f"phase {ref['phase']!r}, case {ref['case']!r}", sim[ref["phase"]], ref, PHASE_COMPARED)
    lines.append(f"  energy per cycle at the motor {figures['motor_energy']:.6g} J, mean power "
                 f"{figures['mean_motor_power']:.6g} W")
    if "limits" in figures:
        if not figures["limits"]:
            lines.append("  the motor's limits do not bind")
        for b in figures["limits"]:
            if b["limit"] == "rated torque":
                lines.append(f"  binds: RMS torque {b['rms']:.6g} N m above the rated {b['bound']:.6g} N m")
            else:
                lines.append(f"  binds: {b['limit']} {b['bound']:.6g} in phase {b['phase']!r}, t = {b['t_from']:.6g} .. "
                             f"{b['t_to']:.6g} s (peak {b['peak']:.6g})")
    return lines


def cycle_figure(result, figures, path, event_style=None):
    """Motor speed and torque over the cycle against the motor's limits, the phases and the
    events marked (``event_style``: kind -> (marker, colour))."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax_w, ax_t) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    t = result.t
    motor = figures.get("motor")
    ax_w.plot(t, result.columns["motor_speed"], lw=1.5, color="tab:blue", label="motor speed")
    ax_t.plot(t, result.columns["motor_torque"], lw=1.5, color="tab:orange", label="motor torque")
    if motor is not None:
        for ax, bound, label in ((ax_w, motor["max_speed"], "max speed"), (ax_t, motor["peak_torque"], "peak torque")):
            ax.axhline(bound, color="tab:red", ls="--", lw=1, label=label)
            ax.axhline(-bound, color="tab:red", ls="--", lw=1)
        ax_t.axhline(motor["rated_torque"], color="gray", ls=":", lw=1, label="rated torque")
        ax_t.axhline(figures["rms_motor_torque"], color="tab:green", ls="-.", lw=1,
                     label=f"RMS {figures['rms_motor_torque']:.4g} N m")
        for b in figures.get("limits", []):
            if "t_from" in b:
                for ax in (ax_w, ax_t):
                    ax.axvspan(b["t_from"], max(b["t_to"], b["t_from"] + 1e-3 * t[-1]), color="tab:red", alpha=0.12)
    for ph in figures["phases"]:
        for ax in (ax_w, ax_t):
            ax.axvline(ph["t_start"], color="black", lw=0.6, alpha=0.5)
        ax_w.text(ph["t_start"], 1.0, f" {ph['name']}", transform=ax_w.get_xaxis_transform(), fontsize=7,
                  va="bottom", rotation=20)
    seen = set()
    for e in result.events:
        if e["kind"] == "phase":
            continue
        i = min(int(np.searchsorted(t, e["t"])), len(t) - 1)
        label = e["kind"] if e["kind"] not in seen else None
        seen.add(e["kind"])
        marker, colour = (event_style or {}).get(e["kind"], ("x", "gray"))
        for ax, column in ((ax_w, "motor_speed"), (ax_t, "motor_torque")):
            ax.plot([t[i]], [result.columns[column][i]], marker, mfc="none", color=colour, ms=6,
                    label=label if ax is ax_t else None, zorder=5)
    ax_w.set_ylabel("motor speed [rad/s]")
    ax_t.set_ylabel("motor torque [N m]")
    ax_t.set_xlabel("time t [s]")
    for ax in (ax_w, ax_t):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="lower right")
    title = textwrap.shorten(result.scene.title, 90, placeholder=" ...")
    fig.suptitle(f"{title}\nduty cycle {figures['cycle_time']:.4g} s, {result.integrator} tolerance {result.tolerance:g}",
                 fontsize=9)
    save_figure(fig, Path(path))
    plt.close(fig)
