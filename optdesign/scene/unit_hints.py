"""What to say when a number is written with a unit the scene does not read ("15 t", "300 mm"):
the scene reads SI numbers, and 'deg' after an angle; the hint gives the number in SI."""
from __future__ import annotations

import re

# unit -> (factor to SI, SI unit)
UNITS = {
    "t": (1e3, "kg"), "kg": (1.0, "kg"), "g": (1e-3, "kg"),
    "km": (1e3, "m"), "m": (1.0, "m"), "cm": (1e-2, "m"), "mm": (1e-3, "m"),
    "MN": (1e6, "N"), "kN": (1e3, "N"), "N": (1.0, "N"),
    "MNm": (1e6, "N m"), "MN m": (1e6, "N m"), "kNm": (1e3, "N m"), "kN m": (1e3, "N m"), "Nm": (1.0, "N m"),
    "N m": (1.0, "N m"),
    "MW": (1e6, "W"), "kW": (1e3, "W"), "W": (1.0, "W"),
    "h": (3600.0, "s"), "min": (60.0, "s"), "s": (1.0, "s"), "ms": (1e-3, "s"),
    "MPa": (1e6, "Pa"), "kPa": (1e3, "Pa"), "bar": (1e5, "Pa"), "Pa": (1.0, "Pa"),
    "rad": (1.0, "rad"), "rpm": (0.10471975511965977, "rad/s"),
    "rad/s": (1.0, "rad/s"), "rad/s^2": (1.0, "rad/s^2"), "rad/s^3": (1.0, "rad/s^3"),
    "m/s^2": (1.0, "m/s^2"), "m/s^3": (1.0, "m/s^3"),
    "m/s": (1.0, "m/s"), "mm/s": (1e-3, "m/s"), "m/min": (1 / 60, "m/s"),
    "kgm2": (1.0, "kg m^2"), "kg m2": (1.0, "kg m^2"), "kg m^2": (1.0, "kg m^2"),
}


def _scaled(number_text: str, factor: float) -> str:
    """``number_text`` times ``factor`` written as the user would: '15' x 1e3 -> '15e3'."""
    import math

    exponent = math.log10(factor)
    if "e" not in number_text.lower() and abs(exponent - round(exponent)) < 1e-12:
        return f"{number_text}e{round(exponent)}"
    return f"{float(number_text) * factor:.12g}"


def hint(number_text: str, unit: str) -> str:
    """The advice for ``number_text`` followed by ``unit``, e.g. ('15', 't') -> "units are not
    read, except 'deg' after an angle: write 15 t as 15e3 (kg), or as an expression such as
    \\"15*1000\\"; the scene is in SI (m, kg, s, N, N m, W)"."""
    unit = re.sub(r"\s+", " ", unit.strip())
    head = "units are not read, except 'deg' after an angle"
    tail = "; the scene is in SI (m, kg, s, N, N m, W, rad)"
    try:
        float(number_text)
    except ValueError:
        return head + tail
    if unit.lower() in ("degree", "degrees", "degs", "grad"):
        return f"{head}: write {number_text} {unit} as \"{number_text} deg\"{tail}"
    known = UNITS.get(unit) or UNITS.get(unit.replace(" ", ""))
    if known is None:
        return f"{head}: write {number_text} {unit} as a number in SI units{tail}"
    factor, si = known
    if factor == 1.0:
        return f"{head}: write {number_text} {unit} as {number_text} (already {si}){tail}"
    product = f"{number_text}*{factor:.12g}" if factor >= 1 else f"{number_text}/{1 / factor:.12g}"
    return (f"{head}: write {number_text} {unit} as {_scaled(number_text, factor)} ({si}), or as an expression "
            f"such as \"{product}\"{tail}")


TOML_VALUE = re.compile(r"^\s*([A-Za-z0-9_\-\"']+)\s*=\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s+([A-Za-z][A-Za-z0-9/ ^]*?)\s*(#.*)?$")


def toml_hint(line: str) -> str:
    """For a TOML line such as 'mP = 15 t' (a number and a unit, not a string): the hint, else ''."""
    m = TOML_VALUE.match(line)
    if not m:
        return ""
    number, unit = m.group(2), m.group(3)
    if unit == "deg":
        return f": write an angle in degrees as a string, {m.group(1)} = \"{number} deg\""
    return f": {hint(number, unit)}"
