"""What an analysis says to a person: the scene's constraints checked against their bounds (which
are violated, by how much, where in the stroke), the summary in the units the scene wrote, and
the per-sample table as CSV with a unit in every header.  Files stay in SI except where a
column's header names another unit."""
from __future__ import annotations

import numpy as np

from ..scene import ResolvedScene
from .units import DEG, ColumnUnits, constraint_scale, number, scaled, sweep_scale, sweep_unit

SI = {"rotary": ColumnUnits({"q": "rad", "reduced_inertia": "kg m^2", "reduced_inertia_dq": "kg m^2/rad",
                             "static_load": "N m", "damping_load": "N m", "inertia_term": "N m", "velocity_term": "N m",
                             "drive": "N m", "power": "W", "k": "rad/unit of s"}),
      "linear": ColumnUnits({"q": "m", "reduced_inertia": "kg", "reduced_inertia_dq": "kg/m", "static_load": "N",
                             "damping_load": "N", "inertia_term": "N", "velocity_term": "N", "drive": "N", "power": "W",
                             "k": "m/unit of s"})}

ORDER = ("s", "q", "k", "reduced_inertia", "reduced_inertia_dq", "static_load", "damping_load", "inertia_term",
         "velocity_term", "drive", "power", "efficiency_factor")


def _bounds(result):
    """name -> (constraint, lower, upper) in SI (None where absent)."""
    resolved = ResolvedScene(result.scene)
    out = {}
    for c in result.scene.constraints:
        lo = None if c.lower is None else resolved.constant(c.lower, f"[[constraints]] {c.name}, min")
        hi = None if c.upper is None else resolved.constant(c.upper, f"[[constraints]] {c.name}, max")
        out[c.name] = (c, lo, hi)
    return out


def _tolerance(bound, values):
    return 1e-6 * max(1.0, abs(bound), float(np.nanmax(np.abs(values))) if np.size(values) else 0.0)


def violations(result) -> list:
    """Every violated bound of the scene's constraints: dicts with ``name``, ``bound`` ('min' or
    'max'), ``limit``, ``worst`` (the value furthest beyond it, over the continuous stroke where
    the analysis certified it), ``by`` (how far beyond, > 0), ``at`` (the sweep value of the
    worst; None for a per-stroke constraint), ``from``/``to`` (the sampled range of the stroke
    where it is violated), all in SI; and ``unit``/``factor`` for showing them."""
    extremes = getattr(result, "constraint_extremes", {}) or {}
    s = result.columns["s"]
    out = []
    for name, (c, lo, hi) in _bounds(result).items():
        value = result.constraints.get(name)
        if value is None:
            continue
        factor, unit = constraint_scale(c)
        for bound, limit, sign in (("min", lo, -1.0), ("max", hi, 1.0)):
            if limit is None:
                continue
            if np.ndim(value):
                e = extremes.get(name)
                if e is not None:
                    worst, at = (e["max"], e["max_s"]) if sign > 0 else (e["min"], e["min_s"])
                else:
                    i = int(np.argmax(sign * value))
                    worst, at = float(value[i]), float(s[i])
                bad = sign * (value - limit) > _tolerance(limit, value)
                over = sign * (worst - limit)
                if over <= _tolerance(limit, value) and not bad.any():
                    continue
                span = (float(s[bad].min()), float(s[bad].max())) if bad.any() else (at, at)
                out.append({"name": name, "bound": bound, "limit": limit, "worst": float(worst),
                            "by": float(max(over, 0.0)), "at": float(at), "from": span[0], "to": span[1],
                            "unit": unit, "factor": factor})
            else:
                over = sign * (float(value) - limit)
                if over > _tolerance(limit, [value]):
                    out.append({"name": name, "bound": bound, "limit": limit, "worst": float(value), "by": over,
                                "at": None, "from": None, "to": None, "unit": unit, "factor": factor})
    return out


def violations_json(result) -> list:
    """:func:`violations` for JSON (SI, without the display factor)."""
    return [{k: v for k, v in item.items() if k not in ("factor", "unit")} | {"unit_shown": item["unit"]}
            for item in violations(result)]


def violation_text(result, item) -> str:
    """'transmission angle: below its min 30 deg by 1.83 deg (28.17 deg at theta = 60 deg; violated for
    theta = 52.3 .. 60 deg)'."""
    f, unit = item["factor"], item["unit"]
    sf, su = sweep_scale(result.scene)
    name = result.scene.sweep.name
    side = "below its min" if item["bound"] == "min" else "above its max"
    u = f" {unit}" if unit else ""
    text = (f"{item['name']}: {side} {number(item['limit'] * f)}{u} by {number(item['by'] * f, 3)}{u} "
            f"({_beside(item['worst'], item['limit'], f, True)}{u}")
    if item["at"] is not None:
        su_ = f" {su}" if su else ""
        text += f" at {name} = {number(item['at'] * sf)}{su_}; violated for {name} = {number(item['from'] * sf)} .. " \
                f"{number(item['to'] * sf)}{su_})"
    else:
        text += " over the stroke)"
    return text


def column_display(result, key):
    """(factor, unit) to show column ``key`` in: kN (kN m, kW) where large, the sweep and a
    crank angle in deg where the scene wrote the sweep in deg."""
    kind = result.drive_kind
    if key == "s":
        return sweep_scale(result.scene)
    if key == "q" and kind == "rotary" and sweep_unit(result.scene) == "deg":
        return 1 / DEG, "deg"
    unit = SI[kind].get(key, "")
    return scaled(result.columns[key], unit) if key in result.columns else (1.0, unit)


def _beside(value, bound, factor, violated) -> str:
    """``value`` shown in 4 digits, or in as many as it takes to differ from ``bound`` when it
    violates it (a miss of 0.0006 deg on 60 deg reads 60.0006, not 60)."""
    digits = 4
    while violated and bound is not None and digits < 15 and number(value * factor, digits) == number(bound * factor, digits):
        digits += 1
    return number(value * factor, digits)


def summary_lines(result) -> list:
    """The analysis in a few lines, in the scene's units: the peaks with where they lie, each
    constraint's range or value against its bounds, every violation spelled out."""
    sf, su = sweep_scale(result.scene)
    sweep = result.scene.sweep.name
    su_ = f" {su}" if su else ""
    lines = [result.scene.title]
    if result.scene.cases:   # the peaks below are not the cases': say so
        lines.append("the nominal [drive] state (its speed and acceleration at every position; the load cases, "
                     "their governing peaks and the drive train follow below):")
    peak_at = getattr(result, "peak_at", {}) or {}
    for key, v in result.peaks.items():
        factor, unit = column_display(result, key)
        at = peak_at.get(key, {}).get("s")
        if at is None and key in result.columns:
            at = float(result.columns["s"][int(np.argmax(np.abs(result.columns[key])))])
        where = f" at {sweep} = {number(at * sf)}{su_}" if at is not None else ""
        lines.append(f"peak |{key}| = {number(v * factor, 5)} {unit}{where}".replace("  ", " "))
    bad = {(v["name"], v["bound"]) for v in violations(result)}
    extremes = getattr(result, "constraint_extremes", {}) or {}
    for name, (c, lo, hi) in _bounds(result).items():
        value = result.constraints.get(name)
        if value is None:
            continue
        f, unit = constraint_scale(c)
        u = f" {unit}" if unit else ""
        state = "VIOLATED" if (name, "min") in bad or (name, "max") in bad else "ok"
        if np.ndim(value):
            e = extremes.get(name, {"min": float(np.min(value)), "max": float(np.max(value))})
            shown = f"{number(e['min'] * f)} .. {number(e['max'] * f)}{u}"
        else:
            shown = f"{_beside(value, lo if lo is not None else hi, f, state == 'VIOLATED')}{u}"
        limits = " and ".join(f"{b} {number(x * f)}{u}" for b, x in (("min", lo), ("max", hi)) if x is not None)
        if lo is not None and lo == hi:   # an equality: say how closely it counts as met
            tol = _tolerance(lo, [value] if not np.ndim(value) else value)
            state += f" (an equality: met within {number(tol * f, 2)}{u}, 1e-6 of its size; optimise holds its " \
                     "constraints to 1e-7 of theirs)"
        lines.append(f"{name}: {shown} ({limits}): {state}")
    for item in violations(result):
        lines.append("  violated: " + violation_text(result, item))
    return lines


def csv_text(result) -> str:
    """The per-sample columns and per-sample constraints as CSV, every header 'name [unit]', in
    SI except the sweep and angle constraints, which are in deg where the scene wrote deg."""
    import csv
    import io

    cols, heads = [], []
    for key in [c for c in ORDER if c in result.columns] + [c for c in result.columns if c not in ORDER]:
        factor, unit = (sweep_scale(result.scene) if key == "s" else (1.0, SI[result.drive_kind].get(key, "")))
        cols.append(np.asarray(result.columns[key]) * factor)
        heads.append(f"{result.scene.sweep.name if key == 's' else key} [{unit or '-'}]")
    bounds = _bounds(result)
    for name, v in result.constraints.items():
        if np.ndim(v):
            factor, unit = constraint_scale(bounds[name][0]) if name in bounds else (1.0, "")
            cols.append(np.asarray(v) * factor)
            heads.append(f"{name} [{unit or '-'}]")
    units = {q.name: q.unit for q in result.scene.quantities}
    for name, v in result.quantities.items():   # [quantities] in SI, with the unit the scene gave
        cols.append(np.asarray(v))
        heads.append(f"{name} [{units.get(name) or '-'}]")
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(heads)
    for row in zip(*cols):
        writer.writerow([repr(float(x)) for x in row])
    return buf.getvalue()


def kinematics_summary(result) -> str:
    """The kinematics in a few lines: the stroke in the scene's units, the points and bodies, and
    each moving point's largest speed and acceleration with where they lie."""
    sf, su = sweep_scale(result.scene)
    name = result.scene.sweep.name
    su_ = f" {su}" if su else ""
    s = result.s
    lines = [result.scene.title,
             f"{len(s)} samples of {name} = {number(s[0] * sf)} .. {number(s[-1] * sf)}{su_}; "
             f"{len(result.points)} points, {len(result.bodies)} bodies"]
    for p, d in result.points.items():
        speed = np.hypot(d["vx"], d["vy"])
        acc = np.hypot(d["ax"], d["ay"])
        if np.nanmax(speed, initial=0.0) == 0 and np.nanmax(acc, initial=0.0) == 0:
            continue
        i, j = int(np.nanargmax(speed)), int(np.nanargmax(acc))
        lines.append(f"  {p}: speed up to {number(speed[i])} m/s at {name} = {number(s[i] * sf)}{su_}, "
                     f"acceleration up to {number(acc[j])} m/s^2 at {name} = {number(s[j] * sf)}{su_}")
    return "\n".join(lines)
