"""The figure ``motion.png`` of a scene with load cases on profiles: the sweep coordinate (the
output, where the motion is stated on it) over one duty cycle against time, its position,
speed, acceleration and jerk, beside the motor's torque and speed (the drive's without a
motor).  Case steps are drawn from each case's samples in time order, holds as the rest they
are (the position held, no speed, the hold's torque), dwells idle; the jerk is shown where the
case's profile is a motion law in time (its closed form); a segments profile's dwell as the
rest it is."""
from __future__ import annotations

import math

import numpy as np

from .output import new_figure, save_figure
from .units import sweep_scale

ROWS = (("s", "position"), ("sd", "speed"), ("sdd", "acceleration"), ("jerk", "jerk"))


def motion_figure(result, cr, path):
    """Draw the cycle of ``cr`` (a CasesResult of ``result``'s scene) at ``path``; None (nothing
    written) when the cycle has no time."""
    if "reason" in cr.duty or not any("sd" in c.columns for c in cr.cases.values()):
        return None
    scene = result.scene
    factor, unit = sweep_scale(scene)
    unit = unit or ("rad" if scene.drive.kind == "rotary" else "m")
    motor = any("motor_torque" in c.columns for c in cr.cases.values())
    torque_key, speed_key = ("motor_torque", "motor_speed") if motor else ("drive", "drive_speed")
    rows = [r for r in ROWS if any(r[0] in c.columns for c in cr.cases.values())]
    fig, axes = new_figure(len(rows) + 2, 1, figsize=(8, 1.9 * (len(rows) + 2)), sharex=True)
    t0 = 0.0
    for step in cr.duty["steps"]:
        if step["kind"] == "case":
            c = cr.cases[step["case"]]
            times, columns = _with_dwells(c)
            for _ in range(math.ceil(step["repeat"])):
                t = t0 + times
                for ax, (key, _) in zip(axes, rows):
                    if key in columns:
                        ax.plot(t, columns[key] * factor, color="C0")
                axes[-2].plot(t, columns[torque_key], color="C0")
                axes[-1].plot(t, columns[speed_key], color="C0")
                t0 += c.duration
            continue
        t = np.array([t0, t0 + step["time"]])
        held = None
        if step["kind"] == "hold":   # at rest at one end of the case's motion, carrying its load
            c = cr.cases[step["case"]]
            order = np.argsort(c.columns["t"], kind="stable")
            held = c.columns["s"][order][-1 if step["at"] == "end" else 0]
            level = step.get("motor_load_torque" if motor else "load", 0.0)
        else:
            level = 0.0
        colour = "C1" if step["kind"] == "hold" else "C2"
        for ax, (key, _) in zip(axes, rows):
            if key == "s":
                if held is not None:
                    ax.plot(t, [held * factor] * 2, color=colour)
            else:
                ax.plot(t, [0.0, 0.0], color=colour)
        axes[-2].plot(t, [level, level], color=colour)
        axes[-1].plot(t, [0.0, 0.0], color=colour)
        t0 += step["time"]
    rate = {"position": "", "speed": "/s", "acceleration": "/s^2", "jerk": "/s^3"}
    for ax, (key, label) in zip(axes, rows):
        ax.set_ylabel(f"{scene.sweep.name} {label}\n[{unit}{rate[label]}]", fontsize=8)
    units = "N m" if scene.drive.kind == "rotary" else "N"
    axes[-2].set_ylabel(f"{torque_key}\n[{units}]", fontsize=8)
    axes[-1].set_ylabel(f"{speed_key}\n[{'rad/s' if scene.drive.kind == 'rotary' else 'm/s'}]", fontsize=8)
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time in the cycle [s]")
    axes[0].set_title(f"the motion of {scene.sweep.name} over the cycle and the "
                      f"{'motor' if motor else 'drive'} (cases blue, holds orange, dwells green)", fontsize=9)
    save_figure(fig, path)
    return path


def _with_dwells(c):
    """A case's times and columns in time order, each dwell of its segments profile drawn as
    the rest it is: its stop's sample again at the dwell's end (the sample holds the arrival)."""
    order = np.argsort(c.columns["t"], kind="stable")
    t = c.columns["t"][order]
    columns = {k: np.asarray(v)[order] for k, v in c.columns.items() if np.ndim(v) == 1 and len(v) == len(order)}
    for start, end, stop in c.rests:
        i = np.flatnonzero((columns["s"] == stop) & (np.abs(t - start) <= 1e-9 * max(end, 1.0)))
        if i.size:
            j = int(i[0])
            t = np.insert(t, j + 1, end)
            columns = {k: np.insert(v, j + 1, v[j]) for k, v in columns.items()}
    return t, columns
