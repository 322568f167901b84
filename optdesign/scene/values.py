"""Checking single values of a scene item, as its dataclass is constructed.

Each function takes the raw value (from the TOML file or a script) and its :class:`Where`, and
returns the value to store (expressions parsed, lists as tuples) or raises a
:class:`~optdesign.errors.SceneError` naming the place.  Cross references between items are
checked later, by :mod:`optdesign.scene.validate`.
"""
from __future__ import annotations

import re

from .expressions import CONSTANTS, constant_value, parse
from .where import fail, near_miss, show

RESERVED = tuple(CONSTANTS)
_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z_0-9]*\Z")


def set_field(obj, name, value):
    """Store a checked value on a frozen dataclass."""
    object.__setattr__(obj, name, value)


def parse_required(value, where, expectation="a number or an expression"):
    """A required expression (parsed)."""
    if value is None:
        fail(where, f"missing key {where.key.split()[0]!r}: expected {expectation}" if where.key
             else f"no value: expected {expectation}")
    return parse(value, where)


# the magnitudes a physical input may have (besides 0 where 0 is allowed): within them, the
# products and fourth powers the computation takes (a rod's d^4, a gear ratio squared times an
# inertia, a jerk's square root times a speed) stay far inside a float's range (1e-308 .. 1e308);
# outside them, 1e300 overflowed and 1e-300 divided by zero (tracebacks)
MEANINGFUL = (1e-50, 1e50)


def outside_meaningful(value) -> str | None:
    """Why a finite number != 0 lies outside :data:`MEANINGFUL`, or None when it lies inside."""
    lo, hi = MEANINGFUL
    if value != 0 and not lo <= abs(value) <= hi:
        return (f"found {value:g}, outside {lo:g} .. {hi:g} in magnitude, where the computation's products and "
                "powers stay within a float's range; check its unit (the scene is in SI)")
    return None


def parse_optional(value, where):
    return None if value is None else parse(value, where)


def parse_vector(value, where, n, expectation):
    """A list of ``n`` expressions, parsed; ``where.key`` names it."""
    if not isinstance(value, (list, tuple)) or len(value) != n:
        fail(where, f"expected {expectation} (a list of {n} numbers or expressions), found {show(value)}")
    return tuple(parse(v, where.at(f"{where.key}[{i}]")) for i, v in enumerate(value))


def parse_bound(value, where):
    """A design bound: a number, or an expression of numbers, pi and deg."""
    if value is None:
        return None
    return constant_value(parse(value, where), {}, where)


def check_name(value, where, what):
    """A name that expressions can refer to (letters, digits, _; not a constant)."""
    if not isinstance(value, str) or not _IDENTIFIER.match(value):
        fail(where, f"expected a {what} name (letters, digits and _, not starting with a digit), "
                    f"found {show(value)}")
    if value in RESERVED:
        fail(where, f"{value!r} is reserved for a constant (pi, deg); choose another {what} name")
    return value


def check_label(value, where, what):
    """A free-text name (bodies, constraints): a non-empty string."""
    if not isinstance(value, str) or not value.strip():
        fail(where, f"expected the {what}'s name as a non-empty string, found {show(value)}")
    return value


def check_point(value, where):
    """A reference to a point by name."""
    if not isinstance(value, str):
        fail(where, f"expected a point name (a string such as \"A\"), found {show(value)}")
    return value


def check_side(value, where, choices, meaning):
    """One of ``choices`` (a dyad's or slider's side); ``meaning`` explains them."""
    if value is None:
        fail(where, f"missing key 'side': expected {' or '.join(map(repr, choices))} ({meaning})")
    if value not in choices:
        fail(where, f"expected {' or '.join(map(repr, choices))} ({meaning}), found {show(value)}"
                    + near_miss(value, choices))
    return value
