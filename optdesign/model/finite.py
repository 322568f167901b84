"""No NaN or inf presented as a result: :func:`check_columns` and :func:`check_values` stop an
analysis whose model column, per-sample or per-stroke constraint or peak is not a finite number,
with a :class:`~optdesign.errors.ResultError` that names the quantity, the first stroke position
where it is not finite and, found by evaluating the scene's own items there, the first point,
body value or drive value that is not finite (the cause: ``mass = "mC*sqrt(theta - 0.5)"`` below
theta = 0.5, a centre of mass ``1/(theta - theta)``, a point at a polar length that is NaN).

A body's ratios (``R_z``, ``dR_z_dq``, ``i_m``, ...) are left out on purpose: where a body stands
still they are undefined or infinite by their definition (README, "JSON output"), and the model
columns do not depend on them.  A reduced inertia below zero is refused too: with positive masses
and inertias it cannot be (it is a sum of squares).
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

from ..errors import ResultError

LABELS = {"s": "the sweep value", "q": "the drive coordinate q", "k": "the ratio k = dq/ds",
          "reduced_inertia": "the reduced inertia", "reduced_inertia_dq": "the reduced inertia's derivative",
          "static_load": "the static load", "damping_load": "the dampers' load",
          "inertia_term": "the inertia term", "velocity_term": "the velocity term",
          "drive": "the drive load", "power": "the drive power", "efficiency_factor": "the efficiency factor"}


def _what(value) -> str:
    return "NaN" if math.isnan(value) else ("+inf" if value > 0 else "-inf")


def check_columns(analysis, s, columns: dict, constraints: dict, p_values) -> None:
    """Every model column and per-sample constraint finite at every sample, and the reduced
    inertia not negative; else a ResultError at the first sample where one is not."""
    scene = analysis.scene
    items = [(LABELS.get(k, k) + f" ({k})", v) for k, v in columns.items()]
    items += [(f"constraint {k!r}", v) for k, v in constraints.items() if np.ndim(v)]
    first = None
    for label, values in items:
        values = np.asarray(values, float)
        bad = ~np.isfinite(values)
        if bad.any():
            i = int(np.argmax(bad))
            if first is None or i < first[0]:
                first = (i, label, float(values[i]))
    if first is not None:
        i, label, value = first
        why = (": its expression is not defined there (acos or asin of a value outside [-1, 1], the square root "
               "of a negative number, a division by zero)") if label.startswith("constraint") else \
            cause(analysis, s[i], p_values)
        raise ResultError(f"{scene.path}: {label} is {_what(value)} at {scene.sweep.name} = {s[i]:.9g} "
                          f"(sample {i + 1} of {len(s)}){why}")
    inertia = columns.get("reduced_inertia")
    if inertia is not None and (np.asarray(inertia) < 0).any():
        i = int(np.argmax(np.asarray(inertia) < 0))
        raise ResultError(f"{scene.path}: the reduced inertia (reduced_inertia) is negative, {inertia[i]:.6g}, at "
                          f"{scene.sweep.name} = {s[i]:.9g} (sample {i + 1} of {len(s)}): a body's mass or inertia "
                          "is negative there (they must be > 0)")


def check_values(analysis, named: dict) -> None:
    """Values over the whole stroke (per-stroke constraints, peaks) finite; else a ResultError."""
    for label, value in named.items():
        if value is not None and not math.isfinite(float(value)):
            raise ResultError(f"{analysis.scene.path}: {label} is {_what(float(value))} over the stroke")


def cause(analysis, s_value, p_values) -> str:
    """'; the first ... that is not finite there: ...' from the scene's own items at s_value, or
    a hint when every item is finite (a derivative that blows up, a degenerate geometry)."""
    try:
        items = list(_items(analysis, s_value, p_values))
        for where, value in items:
            if not math.isfinite(value):
                return (f"; the first of the scene's values that is not finite there: {where} = {_what(value)}"
                        + (_coinciding(analysis, where[6:-4], s_value, p_values) if where.startswith("point ") else ""))
        for where, value in items:
            if where.startswith("the drive's points") and value == 0.0:
                return (f"; {where} coincide there, so the drive's {'angle' if analysis.scene.drive.kind == 'rotary' else 'length'} "
                        "has no derivative (a crank or an actuator of zero length)")
    except Exception:  # noqa: BLE001  (a diagnosis must never hide the error it explains)
        pass
    return ("; every point, mass, load and drive value is finite there: a derivative is not (a kink or a "
            "square root at zero in an expression, a geometry that degenerates there)")


def _coinciding(analysis, name, s_value, p_values) -> str:
    """', built from A and K, which coincide there ...' when two of the points that point
    ``name``'s construction refers to coincide at s_value (a frame or a link of zero length)."""
    mech = analysis.mech
    spec = next((p for p in mech.scene.points if p.name == name), None)
    refs = [] if spec is None else [v for k, v in vars(spec).items()
                                    if k != "name" and isinstance(v, str) and v in mech.points]
    pairs = [(a, b) for i, a in enumerate(refs) for b in refs[i + 1:] if a != b]
    if not pairs:
        return ""
    f = mech.function("coinciding", {f"d{i}": ca.sumsqr(mech.points[a] - mech.points[b]) for i, (a, b) in enumerate(pairs)})
    values = f(s_value, p_values)
    values = values if isinstance(values, (list, tuple)) else [values]
    for (a, b), d in zip(pairs, values):
        if float(np.asarray(d, float).ravel()[0]) == 0.0:
            return (f", built from {a} and {b}, which coincide there (a frame or a link of zero length): check the "
                    f"lengths that place {a} and {b}, e.g. a parameter set to 0")
    return ""


def _items(analysis, s_value, p_values):
    """(name, value) of the scene's items at one sweep value, in the order they are built."""
    mech = analysis.mech
    scene = mech.scene
    outs = {}
    for name, point in mech.points.items():
        outs[f"point {name} (x)"], outs[f"point {name} (y)"] = point[0], point[1]
    for b in scene.bodies:
        for key in ("mass", "inertia", "torque"):
            expr = getattr(b, key)
            if expr is not None:
                outs[f"[[bodies]] {b.name} {key}"] = mech.value(expr, f"[[bodies]] {b.name}.{key}")
        for key in ("com", "force"):
            vec = getattr(b, key)
            if vec is not None:
                for axis, expr in zip("xy", vec):
                    outs[f"[[bodies]] {b.name} {key} ({axis})"] = mech.value(expr, f"[[bodies]] {b.name}.{key}")
    drive = scene.drive
    if drive is not None:
        for key in ("speed", "acceleration", "efficiency"):
            expr = getattr(drive, key, None)
            if expr is not None:
                outs[f"[drive] {key}"] = mech.value(expr, f"[drive] {key}")
    if drive is not None:
        a, b = drive.pins
        outs[f"the drive's points {a} and {b}"] = ca.sqrt(ca.sumsqr(mech.points[b] - mech.points[a]))
    names = list(outs)
    f = mech.function("finite_check", {f"o{i}": outs[n] for i, n in enumerate(names)})
    values = f(s_value, p_values)
    values = values if isinstance(values, (list, tuple)) else [values]
    for name, v in zip(names, values):
        yield name, float(np.asarray(v, float).ravel()[0])


__all__ = ["check_columns", "check_values", "cause"]


# the figures of the load cases that are infinite by their definition: a rotor of no inertia
# has an infinite inertia ratio and optimal gear ratio (the report says so in words)
INFINITE_BY_DEFINITION = {"inertia_ratio", "optimal_ratio"}
FIGURES = {"drive_squared": "the time integral of the drive load squared (its RMS over time)",
           "rms_time": "the RMS over time", "energy": "the energy", "energy_driving": "the driving energy",
           "mean_power": "the mean power", "motor_load_squared": "the time integral of the motor's load torque squared"}


def check_cases(result, unit) -> None:
    """Every figure of a load-case analysis finite: each case's integrals over time (its RMS,
    energy), the duty cycle's (RMS over time, energy, mean power) and the drive train's numbers;
    else a ResultError naming the case or figure and the largest drive load of the cases (a
    load whose square exceeds a float's range, 1.8e308, made an RMS of NaN with exit 0)."""
    for name, r in result.cases.items():
        bad = np.flatnonzero(~np.isfinite(r.columns["drive"]))
        if bad.size:
            i = bad[0]
            raise ResultError(f"case {name!r}: the drive load is {_what(r.columns['drive'][i])} at the sweep value "
                              f"{r.columns['s'][i]:.10g} (node {i + 1} of {r.columns['drive'].size}): the "
                              "case's motion or load is not defined there (e.g. a speed law with an infinite "
                              "slope where its speed is 0); check the case's profile and values")
    loads = {name: float(np.max(np.abs(r.columns["drive"]))) for name, r in result.cases.items()}

    def cause(name):
        if name is None:
            return ""
        sets = ", ".join(f"{k} = {v:g}" for k, v in result.cases[name].overrides.items())
        return (f": the drive load of case {name!r} reaches {loads[name]:.3g} {unit}"
                + (f" (the case sets {sets})" if sets else "")
                + (", whose square exceeds the largest number a float holds (1.8e308)" if loads[name] > 1e154 else ""))

    worst = max(loads, key=loads.get) if loads else None
    places = [(f"case {name!r}", r.integrals, name) for name, r in result.cases.items()]
    places += [("the duty cycle", result.duty, worst), ("the drive train", result.train, worst)]
    for where, figures, name in places:
        found = _first_not_finite(figures)
        if found is not None:
            key, value = found
            what = FIGURES.get(key.rsplit(".", 1)[-1], key)
            raise ResultError(f"{where}: {what} is {_what(value)}{cause(name)}; check the values of the scene and of "
                              "its cases")


def _first_not_finite(value, key=""):
    """(the dotted key, the value) of the first number in ``value`` that is not finite, or None."""
    if isinstance(value, dict):
        items = value.items()
    elif isinstance(value, (list, tuple)):
        items = ((str(i), v) for i, v in enumerate(value))
    else:
        ok = not isinstance(value, (float, np.floating)) or math.isfinite(value)
        return None if ok or key.rsplit(".", 1)[-1] in INFINITE_BY_DEFINITION else (key, float(value))
    for k, v in items:
        found = _first_not_finite(v, f"{key}.{k}" if key else str(k))
        if found is not None:
            return found
    return None
