"""Reports of a scene's load cases (analyse): the JSON keys ``cases``, ``governing``, ``duty`` and
``drive_train``, the table's section after the nominal one, and the figures ``cases.png`` (each
case's drive load, and motor torque, over the stroke) and ``duty.png`` (the duty cycle in time).
Everything here reads :class:`optdesign.model.case_results.CasesResult`; a scene without cases adds
nothing."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .output import new_figure, save_figure, table
from .units import ColumnUnits

FIGURES = ("cases.png", "duty.png", "motion.png", "torque_speed.png", "cylinder.png")
CASE_COLUMNS = ("s", "t", "q", "sd", "sdd", "jerk", "drive_speed", "drive_acceleration", "static_load", "inertia_term",
                "velocity_term", "drive", "power", "efficiency_factor", "motor_speed", "motor_acceleration",
                "motor_load_torque", "motor_torque", "rod_buckling")
UNITS = {   # the joint forces (pin_force(P), ...) by their prefix: report/units.ColumnUnits
    "rotary": ColumnUnits({"t": "s", "drive_speed": "rad/s", "drive_acceleration": "rad/s^2", "drive": "N m",
                           "static_load": "N m", "reduced_inertia": "kg m^2", "power": "W", "motor_speed": "rad/s",
                           "motor_acceleration": "rad/s^2", "motor_load_torque": "N m", "motor_torque": "N m",
                           "energy": "J", "cycle_time": "s"}),
    "linear": ColumnUnits({"t": "s", "drive_speed": "m/s", "drive_acceleration": "m/s^2", "drive": "N",
                           "static_load": "N", "reduced_inertia": "kg", "power": "W", "rod_buckling": "1", "energy": "J",
                           "cycle_time": "s"}),
}


def _unit(units, key) -> str:
    """' UNIT' after a number in the console; nothing for a ratio (rod_buckling: '1')."""
    unit = units.get(key, "")
    return f" {unit}" if unit and unit != "1" else ""


def _cases(result):
    return getattr(result, "cases", None)


# --- JSON ------------------------------------------------------------------------------------
def cases_json(result) -> dict:
    """The per-case keys of ``analyse --json`` (empty without [[cases]])."""
    cr = _cases(result)
    if cr is None:
        return {}
    cases = {}
    for name, c in cr.cases.items():
        names = [k for k in CASE_COLUMNS if k in c.columns]
        n = len(c.columns["s"])
        cases[name] = {
            "direction": c.direction, "profile": c.profile, "efficiency": c.efficiency, "set": c.overrides,
            "duration": c.duration, "peaks": c.peaks, "peak_at": c.peak_at,
            # the peaks are certified: their samples' largest and the enclosures' bounds
            "peaks_sampled": c.peaks_sampled, "certificates": c.certificates,
            "motors": c.motors,   # each motor's peak torque in this case, certified as the peaks
            "integrals": {k: v for k, v in c.integrals.items() if not k.startswith("motor_")},
            "samples": [{k: c.columns[k][i] for k in names} | {"scene_sample": bool(c.on_samples[i])}
                        | ({"constraints": {k: v[i] for k, v in c.constraints.items()}} if c.constraints else {})
                        for i in range(n)],
            "constraints": {k: {"min": float(np.min(v)), "max": float(np.max(v))} for k, v in c.constraints.items()},
        }
    out = {"cases": cases, "governing": cr.governing,
           "duty": {k: v for k, v in cr.duty.items() if k != "integrals"}}
    if cr.train:
        out["drive_train"] = cr.train
    return out


# --- table -----------------------------------------------------------------------------------
def cases_table(result, samples: bool = True) -> str:
    """The table's section on the load cases: the scene's samples with columns per case (not
    with ``samples`` false: the summary), then per case its peaks, the governing case of each
    peak, the duty cycle and the drive train."""
    cr = _cases(result)
    if cr is None:
        return ""
    from .units import sweep_scale

    kind = result.scene.drive.kind
    units, sweep = UNITS[kind], result.scene.sweep.name
    sf, su = sweep_scale(result.scene)   # the sweep in the unit the scene wrote (deg)
    at = lambda s: f"{sweep} = {s * sf:.8g}{' ' + su if su else ''}"  # noqa: E731
    first = next(iter(cr.cases.values()))
    cols = {sweep: first.columns["s"][first.on_samples]}
    for name, c in cr.cases.items():
        tag = name.replace(" ", "_")
        for key in ("t", "drive", "motor_torque", "rod_buckling"):
            if key in c.columns:
                cols[f"{key}[{tag}]"] = c.columns[key][c.on_samples]
    if samples:
        lines = ["", "", "load cases (each over the scene's samples plus its profile's phase boundaries, taken from "
                 "both sides; the table shows the scene's samples)", table(cols), ""]
    else:
        lines = ["", "", "load cases (each over the scene's samples plus its profile's phase boundaries, taken from "
                 "both sides; every sample: --table)"]
    for name, c in cr.cases.items():
        settings = ", ".join(f"{k} = {v:.6g}" for k, v in c.overrides.items())
        lines.append(f"case {name!r}: {c.direction}, {'profile ' + c.profile if c.profile else '[drive] speed'}, "
                     f"efficiency {c.efficiency}{', set ' + settings if settings else ''}; "
                     + (f"stroke time {c.duration:.6g} s" if math.isfinite(c.duration) else
                        "no stroke time (the constant [drive] speed with an acceleration is no motion in time)"))
        for key, value in c.peaks.items():
            lines.append(f"  peak |{key}| = {value:.8g}{_unit(units, key)} at {at(c.peak_at[key]['s'])}")
        for key, v in c.constraints.items():
            lines.append(f"  constraint {key!r}: min {np.min(v):.8g} at {at(c.columns['s'][np.argmin(v)])}, "
                         f"max {np.max(v):.8g} at {at(c.columns['s'][np.argmax(v)])}")
        if c.integrals:
            lines.append(f"  RMS over its time {c.integrals['rms_time']:.8g} {units['drive']}, energy "
                         f"{c.integrals['energy']:.8g} J (driving {c.integrals['energy_driving']:.8g} J)")
            lines += unresolved_lines(c.integrals.get("unresolved"), units)
    lines.append("governing cases:")
    for key, g in cr.governing.items():
        lines.append(f"  peak |{key}| = {g['value']:.8g}{_unit(units, key)}: case {g['case']!r} at {at(g['s'])}")
    lines += _duty_lines(cr.duty, units) + _train_lines(cr.train, kind)
    return "\n".join(lines)


def unresolved_lines(unresolved, units) -> list:
    """The integrals over time that the adaptive quadrature could not bring within its tolerance
    (model/cases.py ``_certified``): a warning with the value, its error estimate and what to do."""
    if not unresolved:
        return []
    shown = {"energy": ("energy", "J"), "rms_time": ("RMS over its time", units["drive"])}
    parts = [f"{shown[key][0]} {u['value']:.6g} {shown[key][1]} +- {u['error']:.2g} (the rule on the "
             f"{u['samples']} samples: {u['sampled_value']:.6g})" for key, u in unresolved.items()]
    return [f"  WARNING: not resolved by the quadrature ({'; '.join(parts)}): the drive's load changes faster than "
            "the quadrature follows, as at a lock-up, where the drive turns ever faster for the same motion of "
            "the output; these integrals (and the duty cycle's) are not certified: keep the design away from the lock-up"]


def _duty_lines(duty, units):
    if "reason" in duty:
        return [f"duty cycle: none ({duty['reason']})"]
    def step(s):
        if s["kind"] == "case":
            return f"{s['case']}{' x' + str(s['repeat']) if s['repeat'] > 1 else ''} {s['time']:.4g} s"
        if s["kind"] == "hold":
            return f"hold at the {s['at']} of {s['case']} {s['time']:.4g} s"
        return f"dwell {s['time']:.4g} s"
    steps = ", ".join(step(s) for s in duty["steps"])
    rms = "; ".join(f"{k} {v:.8g}{_unit(units, k)}" for k, v in duty["rms_time"].items())
    return [f"duty cycle: {duty['cycle_time']:.8g} s ({steps})",
            f"  RMS over the cycle's time: {rms}",
            f"  energy per cycle {duty['energy']:.8g} J (driving {duty['energy_driving']:.8g} J), mean power "
            f"{duty['mean_power']:.8g} W"]


def inertia_ratio_text(m, ratio_label, optimal_label) -> str:
    """A motor's inertia ratio and classical optimal gear ratio; none for a rotor of no inertia
    (both were printed as 'inf')."""
    if not math.isfinite(m["inertia_ratio"]):
        return "inertia ratio and optimal gear ratio: none (the rotor's inertia is 0)"
    return (f"inertia ratio {ratio_label}{m['inertia_ratio']:.4g}, {optimal_label} sqrt(J_load/J_r) = "
            f"{m['optimal_ratio']:.4g}")


def _train_lines(train, kind):
    if not train:
        return []
    if kind == "linear":
        t = train
        if "bore_undetermined" in t:
            return [f"cylinder at {t['pressure'] * 1e-5:.6g} bar: peak push {t['peak_push']:.8g} N, pull "
                    f"{t['peak_pull']:.8g} N, full extension {t['full_extension'] * 1e3:.6g} mm",
                    f"  bore needed: {t['bore_undetermined']}; rod needed for buckling "
                    f"{t['rod_needed_buckling'] * 1e3:.6g} mm; with rod {t['rod'] * 1e3:.6g} mm: Euler load "
                    f"{t['euler_force']:.8g} N, buckling utilisation {t['buckling_utilisation']:.4g}"]
        return [f"cylinder at {t['pressure'] * 1e-5:.6g} bar: peak push {t['peak_push']:.8g} N, pull "
                f"{t['peak_pull']:.8g} N, full extension {t['full_extension'] * 1e3:.6g} mm",
                f"  bore needed {t['bore_needed'] * 1e3:.6g} mm, rod needed for buckling "
                f"{t['rod_needed_buckling'] * 1e3:.6g} mm; with bore {t['bore'] * 1e3:.6g} mm, rod {t['rod'] * 1e3:.6g} "
                f"mm: Euler load {t['euler_force']:.8g} N, buckling utilisation {t['buckling_utilisation']:.4g}, "
                f"pressures {t['pressure_push'] * 1e-5:.6g} / {t['pressure_pull'] * 1e-5:.6g} bar (push / pull), "
                f"pump flow {t['pump_flow'] * 6e4:.6g} l/min"]
    lines = [f"drive train: gear ratio i = {train['ratio']:.6g} (motor speed / drive speed)"]
    rpm = 30 / math.pi
    for name, m in train.get("motors", {}).items():
        rms = (f"RMS {m['rms']:.6g} N m" if "rms" in m else "RMS not checked (no duty cycle in time)")
        lines.append(f"  motor {name!r}: peak {m['peak']:.6g} N m (peak torque {m['peak_torque']:.6g}), "
                     f"{rms} (rated {m['rated_torque']:.6g}), speed {m['peak_speed']:.6g} rad/s = "
                     f"{m['peak_speed'] * rpm:.5g} rpm (max {m['max_speed']:.6g} rad/s = {m['max_speed'] * rpm:.5g} rpm); "
                     f"{inertia_ratio_text(m, 'J_load/(i^2 J_r) = ', 'optimal ratio')}: "
                     f"{'fits' if m['fits'] else 'does not fit'}")
    if train.get("motors"):
        lines.append(f"  smallest motor that fits: {train['smallest_fitting'] or 'none'} (J_load = "
                     f"{next(iter(train['motors'].values()))['load_inertia']:.6g}, the largest reduced inertia over the cases)")
    if len(train.get("motors", {})) > 1 and train.get("shown"):
        why = "the smallest that fits" if train["shown"] == train["smallest_fitting"] else "none fits: the first listed"
        lines.append(f"  motor_torque above (the cases' peaks, the cycle's RMS) is that of motor {train['shown']!r} ({why})")
    return lines


# --- CSV -------------------------------------------------------------------------------------
def cases_csv(result, path) -> list:
    """Beside ``path`` (analyse --csv FILE): FILE-STEM_case-NAME.csv per case (its samples, every
    header 'name [unit]', SI but the sweep in the unit the scene wrote) and FILE-STEM_cycle.csv
    (the duty cycle's time series: the cases' samples in time, holds and dwells as their two
    ends); the paths written (none without cases)."""
    import csv
    import io
    import re

    from .files import write_file
    from .units import sweep_scale

    cr = _cases(result)
    if cr is None:
        return []
    path = Path(path)
    units = UNITS[result.scene.drive.kind]
    sf, su = sweep_scale(result.scene)
    sweep = result.scene.sweep.name

    more = {"q": "rad" if result.scene.drive.kind == "rotary" else "m", "inertia_term": units["drive"],
            "velocity_term": units["drive"], "sd": f"{'rad' if su in ('deg', 'rad') else 'm'}/s"}

    def head(key):
        unit = ColumnUnits({**units, **more}).get(key, "")
        return f"{sweep} [{su or '-'}]" if key == "s" else f"{key} [{unit if unit not in ('', '1') else '-'}]"

    def text(heads, rows):
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(heads)
        writer.writerows(rows)
        return buf.getvalue()

    written = []
    for name, c in cr.cases.items():
        keys = [k for k in CASE_COLUMNS if k in c.columns]
        cols = [np.asarray(c.columns[k], float) * (sf if k == "s" else 1.0) for k in keys]
        slug = re.sub(r"[^A-Za-z0-9]+", "_", name).strip("_")
        written.append(write_file(path.with_name(f"{path.stem}_case-{slug}.csv"),
                                    text([head(k) for k in keys], [[repr(float(x)) for x in row] for row in zip(*cols)])))
    if "reason" not in cr.duty:
        keys = [k for k in ("s", "drive", "power", "motor_speed", "motor_torque") if k in first_columns(cr)]
        rows, t0 = [], 0.0
        for step in cr.duty["steps"]:
            if step["kind"] == "case":
                c = cr.cases[step["case"]]
                order = np.argsort(c.columns["t"], kind="stable")
                for _ in range(math.ceil(step["repeat"])):
                    for i in order:
                        rows.append([repr(t0 + float(c.columns["t"][i])), step["case"]]
                                    + [repr(float(c.columns[k][i]) * (sf if k == "s" else 1.0)) for k in keys])
                    t0 += c.duration
            else:
                for end in (t0, t0 + step["time"]):
                    level = step.get("load", 0.0) if step["kind"] == "hold" else 0.0
                    rows.append([repr(end), step["kind"]] + [repr(level) if k == "drive" else "" for k in keys])
                t0 += step["time"]
        written.append(write_file(path.with_name(f"{path.stem}_cycle.csv"),
                                    text(["t [s]", "step"] + [head(k) for k in keys], rows)))
    return written


def first_columns(cr) -> set:
    """The columns every case has."""
    return set.intersection(*(set(c.columns) for c in cr.cases.values()))


# --- figures ---------------------------------------------------------------------------------
def cases_figures(result, folder) -> list:
    """cases.png, duty.png and the figures of what was sized (torque_speed.png, cylinder.png:
    report/sized.py) into ``folder`` (nothing without cases); the paths written."""
    return [p for job in cases_figure_jobs(result, folder) for p in job()]


def cases_figure_jobs(result, folder) -> list:
    """:func:`cases_figures` as jobs, each drawing one figure (or none) and returning the paths
    it wrote (for report/forked.run_jobs)."""
    cr = _cases(result)
    if cr is None:
        return []
    from .sized import sized_figures

    folder = Path(folder)

    def duty():
        save_figure(_duty_figure(cr, UNITS[result.scene.drive.kind]), folder / "duty.png")
        return [folder / "duty.png"]

    def motion():
        from .output_motion import motion_figure   # the sweep's motion in time beside the motor's

        return [folder / "motion.png"] if motion_figure(result, cr, folder / "motion.png") is not None else []

    jobs = [lambda: [case_load_figure(cr, result.scene, folder / "cases.png")]]
    if "reason" not in cr.duty:
        jobs += [duty, motion]
    return jobs + [lambda: sized_figures(cr, folder)]


def case_load_figure(cr, scene, path, title="load cases over the stroke") -> Path:
    """Each case's drive load (and motor torque, rod buckling) over the stroke, the sweep in the
    unit the scene wrote, the governing case of each marked: ``path`` (a CasesResult ``cr``)."""
    from .units import number, quantity, scaled, sweep_scale

    units, sweep = UNITS[scene.drive.kind], scene.sweep.name
    sf, su = sweep_scale(scene)
    keys = [k for k in ("drive", "motor_torque", "rod_buckling") if any(k in c.columns for c in cr.cases.values())]
    fig, axes = new_figure(len(keys), 1, figsize=(7, 3.2 * len(keys)))
    axes = np.atleast_1d(axes)
    for ax, key in zip(axes, keys):
        unit = units.get(key, "") if units.get(key) != "1" else ""
        f, shown = scaled(np.concatenate([np.asarray(c.columns[key], float) for c in cr.cases.values()
                                          if key in c.columns]), unit)   # kN where large
        for name, c in cr.cases.items():
            ax.plot(np.asarray(c.columns["s"]) * sf, np.asarray(c.columns[key]) * f, label=name)
        g = cr.governing.get(key)
        if g:
            ax.plot([g["s"] * sf], [np.sign(cr.cases[g["case"]].peak_at[key]["value"]) * g["value"] * f], "k*", ms=10,
                    label=f"governing: {g['case']}, {quantity(g['value'], unit)} at {number(g['s'] * sf)} {su}".rstrip())
        ax.set_ylabel(f"{key} [{shown or '-'}]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    axes[-1].set_xlabel(f"{sweep} [{su}]" if su else sweep)
    axes[0].set_title(title)
    save_figure(fig, Path(path))
    return Path(path)


def _duty_figure(cr, units):
    """The drive load (and motor torque) through one duty cycle, against time."""
    fig, ax = new_figure(figsize=(8, 3.6))
    t0 = 0.0
    key = "motor_torque" if any("motor_torque" in c.columns for c in cr.cases.values()) else "drive"
    for step in cr.duty["steps"]:
        if step["kind"] == "case":
            c = cr.cases[step["case"]]
            order = np.argsort(c.columns["t"], kind="stable")
            for _ in range(math.ceil(step["repeat"])):   # a weight's fraction drawn as a whole stroke
                ax.plot(t0 + c.columns["t"][order], c.columns[key][order], color="C0")
                t0 += c.duration
        else:
            level = step.get("motor_load_torque" if key == "motor_torque" else "load", 0.0)
            ax.plot([t0, t0 + step["time"]], [level, level], color="C1" if step["kind"] == "hold" else "C2")
            t0 += step["time"]
    rms = cr.duty["rms_time"].get(key)
    if rms is not None:
        ax.axhline(rms, color="k", ls="--", lw=1, label=f"RMS over the cycle {rms:.4g}")
        ax.axhline(-rms, color="k", ls="--", lw=1)
        ax.legend(fontsize=8)
    ax.set_xlabel("time in the cycle [s]")
    ax.set_ylabel(f"{key} [{units.get(key, '')}]")
    ax.set_title("duty cycle (cases blue, holds orange, dwells green)")
    ax.grid(alpha=0.3)
    return fig
