"""Units as the scene wrote them: degrees where the scene wrote ``deg``, kN (kN m, kW) where
values are large.  Files (JSON, CSV) stay in SI; only what a person reads is converted."""
from __future__ import annotations

import math

import numpy as np

from ..scene.written import sweep_unit, written_in_deg  # noqa: F401  (used by the report modules)

DEG = math.pi / 180.0


JOINT_UNITS = (("pin_force", "N"), ("slider_normal", "N"), ("slider_moment", "N m"))   # model/joints.py


class ColumnUnits(dict):
    """The units of the model's columns by name, and the joint forces' (``pin_force(P)``, ...:
    :mod:`optdesign.model.joints`) by their prefix."""

    def __missing__(self, key):
        for prefix, unit in JOINT_UNITS:
            if isinstance(key, str) and key.startswith(prefix) and key.endswith(")"):
                return unit
        raise KeyError(key)

    def __contains__(self, key):
        return dict.__contains__(self, key) or any(isinstance(key, str) and key.startswith(p) and key.endswith(")")
                                                   for p, _ in JOINT_UNITS)

    def get(self, key, default=None):
        return self[key] if key in self else default


def sweep_scale(scene) -> tuple:
    """(factor, unit): sweep values times factor are in the unit the scene wrote."""
    unit = sweep_unit(scene)
    return (1 / DEG, "deg") if unit == "deg" else (1.0, unit)


def sweep_label(scene) -> str:
    unit = sweep_unit(scene)
    return f"{scene.sweep.name} [{unit}]" if unit else scene.sweep.name


def constraint_scale(constraint) -> tuple:
    """(factor, unit) of a constraint for a person: deg when its bounds were written in deg."""
    if written_in_deg(constraint.lower, constraint.upper):
        return 1 / DEG, "deg"
    return 1.0, ""


# a force element's number given by a design variable alone: its unit (scene/forces.py)
ELEMENT_UNITS = {("spring", "rate"): "N/m", ("damper", "rate"): "N s/m", ("torsion", "rate"): "N m/rad",
                 ("torsion", "preload"): "N m", ("spring", "preload"): "N", ("gas_spring", "extended_force"): "N",
                 ("constant", "tension"): "N", ("gas_spring", "progression"): ""}


def parameter_unit(parameter, kind="length", scene=None) -> tuple:
    """(factor, unit) of a design variable: deg when its value was written in deg (an angle),
    none for a ratio (a parameter of ``scene``'s [gearbox] ratio: motor speed / drive speed),
    the unit of the force element's number it is (a spring's rate in N/m, a preload in N, ...),
    else rad for an angle and m for a length."""
    if written_in_deg(parameter.value):
        return 1 / DEG, "deg"
    if scene is not None and is_ratio(scene, parameter.name):
        return 1.0, ""
    for f in getattr(scene, "forces", ()):
        for key, expr in f.numbers.items():
            if expr.source.strip() == parameter.name and (f.kind, key) in ELEMENT_UNITS:
                return 1.0, ELEMENT_UNITS[(f.kind, key)]
    return (1.0, "rad") if kind == "angle" else (1.0, "m")


def is_ratio(scene, name) -> bool:
    """True when parameter ``name`` makes the scene's gear ratio (dimensionless)."""
    gearbox = getattr(scene, "gearbox", None)
    return gearbox is not None and name in gearbox.ratio.names()


LARGE = {"N": ("kN", "MN"), "N m": ("kN m", "MN m"), "W": ("kW", "MW"), "kg": ("t", "kt")}


def scaled(values, unit) -> tuple:
    """(factor, unit) that keeps the largest |value| readable: N -> kN from 10 kN, MN from
    10 MN (likewise N m, W; kg -> t)."""
    peak = float(np.nanmax(np.abs(np.asarray(values, float)), initial=0.0)) if np.size(values) else 0.0
    if unit in LARGE:
        if peak >= 1e7:
            return 1e-6, LARGE[unit][1]
        if peak >= 1e4:
            return 1e-3, LARGE[unit][0]
    return 1.0, unit


ROUND_OFF = 1e-9   # a value this small relative to the values shown beside it is round-off: shown as 0


def number(value, digits=4, scale=0.0) -> str:
    """``value`` to ``digits`` significant digits without an exponent where it is readable
    (6380, 0.0254), with one where it is not (1.2e-07, 3.4e+09); 0 where it is round-off
    beside values of size ``scale`` (|value| <= ROUND_OFF * scale: a motor speed's 3.9e-149
    at rest beside its 524 rad/s)."""
    v = float(value)
    if not np.isfinite(v):
        return str(v)
    if abs(v) <= ROUND_OFF * abs(scale):
        return "0"
    if v != 0 and not 1e-4 <= abs(v) < 1e7:
        return f"{v:.{digits}g}"
    return np.format_float_positional(v, precision=digits, unique=False, fractional=False, trim="-")


def quantity(value, unit, digits=4) -> str:
    """A value with its unit, large ones scaled: ``quantity(171492.2, 'N')`` -> '171.5 kN'."""
    factor, shown = scaled([value], unit)
    return f"{number(value * factor, digits)} {shown}".rstrip()


def peak_quantity(result) -> str:
    """What result.peak_certified is the peak of: the objective's peak(NAME), NAME (the drive
    load for peak(drive), but also e.g. length(D, B) - 3)."""
    import re

    m = re.match(r"^\s*peak\s*\(\s*(.+?)\s*\)\s*$", result.scene.objective.minimise or "")
    return m.group(1) if m else "drive"


KIND_TEXT = {
    "peak": "certified over the continuous stroke",
    "rms": "an RMS over the sweep by Gauss-Legendre quadrature, checked against twice as many panels and rechecked "
           "by the trapezoid rule on 16 and 8 times denser samples (Richardson)",
    "rms_time": "an RMS over the duty cycle's time by adaptive quadrature to 1e-10, at every start's design; the NLP's "
                "rule on the cases' samples gave objective_sampled",
    "mix": "a certified peak plus an RMS over the duty cycle's time by adaptive quadrature to 1e-10; the NLP's rule "
           "on the cases' samples gave objective_sampled",
    "expression": "a value of the design, no stroke in it",
    "extremes": "an expression of extremes over the stroke, each certified over the continuous stroke",
}


def objective_kind_text(result) -> str:
    """What the objective's value is, honestly: a certified peak or an integral; an expression
    of min/max over the stroke (each checked over the continuous stroke to the objective's
    tolerance, design/certify.py) says so, one of parameters and stroke-end values that it has
    no extreme in it."""
    kind = result.objective_kind
    if kind in ("rms_time", "mix"):
        from ..design.cycle_certify import uncertified

        if uncertified(result.scene):
            return (f"the RMS over the duty cycle's time of {', '.join(uncertified(result.scene))} by the NLP's rule on "
                    "the cases' samples, not certified")
    if kind == "expression":
        from ..scene.expressions import parse

        if parse(result.scene.objective.minimise, "[objective] minimise").aggregate_calls():
            kind = "extremes"
    return KIND_TEXT.get(kind, KIND_TEXT["peak"])
