"""Figures of what was sized (issue 29), from a scene's load cases (a
:class:`optdesign.model.case_results.CasesResult`):

- ``torque_speed.png``: the motor's torque-speed plane (speed in rpm, torque in N m): its peak
  envelope (|T| <= peak torque up to the maximum speed), its rated (continuous) one, the speed
  limit, every case's operating points over its stroke, each case's RMS point (the RMS of its
  torque over its time at its mean |speed|), the duty cycle's RMS point and the governing peak;
- ``cylinder.png``: a cylinder's pressure (bar) and pump flow (l/min) through the duty cycle,
  beside the system pressure.

Drawn by optimise (the optimum's cases), analyse --plot and simulate --plot (the scene's)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .drive_train import BAR, LPM, RPM
from .output import new_figure, save_figure

FIGURES = ("torque_speed.png", "cylinder.png")


def _mean_abs(t, v) -> float:
    """The time mean of |v| over a case's samples (trapezoid rule in time)."""
    order = np.argsort(t, kind="stable")
    t, v = np.asarray(t, float)[order], np.abs(np.asarray(v, float)[order])
    span = t[-1] - t[0]
    return float(np.sum(np.diff(t) * (v[1:] + v[:-1]) / 2) / span) if span > 0 else float(np.mean(v))


def case_rms_torque(case, motor) -> float | None:
    """The RMS of the motor torque T_m = T_g + J_r eps_m over the case's time, from the case's
    integrals (model/duty.py's rule): sqrt((int T_g^2 + 2 J_r int T_g eps_m + J_r^2 int eps_m^2) / T)."""
    g = case.integrals
    if not all(k in g for k in ("motor_load_squared", "motor_load_acceleration", "motor_acceleration_squared")):
        return None
    if not (case.duration > 0 and math.isfinite(case.duration)):
        return None
    J = motor["inertia"]
    square = g["motor_load_squared"] + 2 * J * g["motor_load_acceleration"] + J**2 * g["motor_acceleration_squared"]
    return math.sqrt(max(square, 0.0) / case.duration)


def operating_points(cases, motor=None) -> dict:
    """What torque_speed.png shows, in SI (rad/s, N m): {'motor': name, 'limits': the motor's
    numbers, 'cases': {name: {'speed', 'torque', 'rms_speed', 'rms_torque'}}, 'cycle': (mean
    |speed|, RMS torque) or None, 'peak': {case, speed, torque}}; None without a motor.  The
    motor: ``motor`` (a name), else the one the cases' motor_torque is of (train['shown'])."""
    train = cases.train or {}
    motors = train.get("motors") or {}
    if not motors:
        return None
    name = motor if motor in motors else train.get("shown") or next(iter(motors))
    m = motors[name]
    out = {"motor": name, "limits": m, "cases": {}, "cycle": None, "peak": None}
    best = None
    for case_name, c in cases.cases.items():
        if "motor_load_torque" not in c.columns:
            continue
        # this motor's torque T_m = T_g + J_r eps_m (the columns' motor_torque is train['shown']'s)
        torque = np.asarray(c.columns["motor_load_torque"], float) + m["inertia"] * np.asarray(
            c.columns["motor_acceleration"], float)
        rms = case_rms_torque(c, m)
        out["cases"][case_name] = {
            "speed": np.asarray(c.columns["motor_speed"], float), "torque": torque,
            "rms_speed": _mean_abs(c.columns["t"], c.columns["motor_speed"]) if rms is not None else None,
            "rms_torque": rms}
        i = int(np.argmax(np.abs(torque)))
        if best is None or abs(torque[i]) > abs(best[2]):
            best = (case_name, float(c.columns["motor_speed"][i]), float(torque[i]))
    if best is not None:   # where the peak lies on the samples; its value the certified one (m['peak'])
        out["peak"] = {"case": best[0], "speed": best[1], "torque": best[2], "value": m["peak"]}
    duty = cases.duty
    if "reason" not in duty and m.get("rms") is not None:
        moving = [(s, cases.cases[s["case"]]) for s in duty["steps"] if s["kind"] == "case"]
        travel = sum(s["repeat"] * _mean_abs(c.columns["t"], c.columns["motor_speed"]) * c.duration for s, c in moving)
        out["cycle"] = (travel / duty["cycle_time"], m["rms"])
    return out


def torque_speed_figure(cases, path, title="", motor=None, simulated=None) -> Path | None:
    """torque_speed.png of ``cases`` (a CasesResult) at ``path``; None without a motor.
    ``simulated``: (time, motor speed, motor torque, RMS torque) of a simulated duty cycle,
    drawn over the cases' (the profiles followed exactly), its RMS at its mean |speed|."""
    pts = operating_points(cases, motor)
    if pts is None:
        return None
    m = pts["limits"]
    fig, ax = new_figure(figsize=(7.5, 5.2))
    w = m["max_speed"] * RPM
    ax.plot([-w, w, w, -w, -w], [m["peak_torque"], m["peak_torque"], -m["peak_torque"], -m["peak_torque"],
                                 m["peak_torque"]], color="C3", lw=1.6, label=f"peak envelope {m['peak_torque']:.4g} N m")
    ax.plot([-w, w, w, -w, -w], [m["rated_torque"], m["rated_torque"], -m["rated_torque"], -m["rated_torque"],
                                 m["rated_torque"]], color="C2", lw=1.6, ls="--",
            label=f"rated (continuous) {m['rated_torque']:.4g} N m")
    for x in (-w, w):
        ax.axvline(x, color="k", lw=1, ls=":")
    ax.plot([], [], color="k", lw=1, ls=":", label=f"speed limit {m['max_speed'] * RPM:.4g} rpm")
    for k, (name, c) in enumerate(pts["cases"].items()):
        colour = f"C{(k + 4) % 10}"
        ax.plot(c["speed"] * RPM, c["torque"], color=colour, lw=1.2, label=f"case {name}")
        if c["rms_torque"] is not None:
            ax.plot([c["rms_speed"] * RPM], [c["rms_torque"]], "o", color=colour, ms=7, mec="k",
                    label=f"RMS of {name}: {c['rms_torque']:.4g} N m at {c['rms_speed'] * RPM:.4g} rpm")
    if simulated is not None:
        t, speed, torque, rms = simulated
        ax.plot(np.asarray(speed) * RPM, torque, color="0.35", lw=0.9, label="simulated cycle (simulate)")
        mean = _mean_abs(t, speed)
        # each RMS with its cycle's time: the simulated phases need not be [duty]'s cycle
        ax.plot([mean * RPM], [rms], "D", color="0.35", ms=7, mec="k",
                label=f"simulated RMS {rms:.4g} N m at {mean * RPM:.4g} rpm (mean), over its {t[-1] - t[0]:.4g} s")
    if pts["cycle"] is not None:
        speed, torque = pts["cycle"]
        ax.plot([speed * RPM], [torque], "s", color="k", ms=8,
                label=f"duty cycle RMS {torque:.4g} N m at {speed * RPM:.4g} rpm (mean), over its "
                      f"{cases.duty['cycle_time']:.4g} s")
    if pts["peak"] is not None:
        p = pts["peak"]
        ax.plot([p["speed"] * RPM], [p["torque"]], "*", color="k", ms=14,
                label=f"governing peak {p['value']:.4g} N m ({p['case']})")
    ax.set_xlabel("motor speed [rpm]")
    ax.set_ylabel("motor torque [N m]")
    ax.set_title((title + "\n" if title else "") + f"motor {pts['motor']!r}: torque-speed plane")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
    save_figure(fig, Path(path))
    return Path(path)


def cylinder_series(cases) -> dict | None:
    """The cylinder through the duty cycle: {'t', 'pressure' (Pa: the push over the bore, the
    pull over the annulus), 'flow' (m^3/s)} and the sizes; None without a cylinder."""
    from ..model.train import pump_flow

    t_ = cases.train or {}
    if "bore" not in t_ or "reason" in cases.duty:
        return None
    bore, rod = t_["bore"], t_["rod"]
    area, annulus = math.pi * bore**2 / 4, math.pi * (bore**2 - rod**2) / 4
    ts, ps, qs, t0 = [], [], [], 0.0
    for step in cases.duty["steps"]:
        if step["kind"] == "case":
            c = cases.cases[step["case"]]
            order = np.argsort(c.columns["t"], kind="stable")
            F = np.asarray(c.columns["drive"], float)[order]
            for _ in range(math.ceil(step["repeat"])):
                ts.append(t0 + np.asarray(c.columns["t"], float)[order])
                ps.append(np.where(F >= 0, F / area, -F / annulus))
                qs.append(pump_flow(np.asarray(c.columns["drive_speed"], float)[order], bore, rod))
                t0 += c.duration
        else:
            F = step.get("load", 0.0)
            ts.append(np.array([t0, t0 + step["time"]]))
            ps.append(np.full(2, F / area if F >= 0 else -F / annulus))
            qs.append(np.zeros(2))
            t0 += step["time"]
    return {"t": np.concatenate(ts), "pressure": np.concatenate(ps), "flow": np.concatenate(qs),
            "system_pressure": t_["pressure"], "pump_flow": t_["pump_flow"]}


def cylinder_figure(cases, path, title="") -> Path | None:
    """cylinder.png: pressure and pump flow through the duty cycle; None without a cylinder."""
    series = cylinder_series(cases)
    if series is None:
        return None
    fig, (top, bottom) = new_figure(2, 1, figsize=(8, 5.6))
    top.plot(series["t"], series["pressure"] * BAR, color="C0", label="pressure (push: bore side, pull: rod side)")
    top.axhline(series["system_pressure"] * BAR, color="C3", ls="--",
                label=f"system pressure {series['system_pressure'] * BAR:.4g} bar")
    top.set_ylabel("pressure [bar]")
    top.legend(fontsize=8)
    bottom.plot(series["t"], series["flow"] * LPM, color="C1", label="pump flow")
    bottom.axhline(series["pump_flow"] * LPM, color="k", ls=":", label=f"peak {series['pump_flow'] * LPM:.4g} l/min")
    bottom.set_ylabel("flow [l/min]")
    bottom.set_xlabel("time in the duty cycle [s]")
    bottom.legend(fontsize=8)
    for ax in (top, bottom):
        ax.grid(alpha=0.3)
    top.set_title((title + "\n" if title else "") + "the cylinder through the duty cycle")
    save_figure(fig, Path(path))
    return Path(path)


def sized_figures(cases, folder, title="") -> list:
    """torque_speed.png and cylinder.png (those that apply) into ``folder``: the paths written."""
    if cases is None:
        return []
    folder = Path(folder)
    drawn = [torque_speed_figure(cases, folder / "torque_speed.png", title),
             cylinder_figure(cases, folder / "cylinder.png", title)]
    return [p for p in drawn if p is not None]
