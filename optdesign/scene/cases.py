"""Load cases ([[cases]]) and the duty cycle ([duty]) of a scene.

A :class:`Case` is one way the drive is used: parameter overrides (the payload, an extra load
given as a parameter, a friction value), the direction of motion over the stroke, the
direction of power flow for the efficiency, and the motion (a profile of [profiles], given by
name or inline; without one, the drive's constant [drive] speed and acceleration).  The
:class:`Duty` cycle is a sequence of steps: a case's motion (repeated), a hold (the drive at
rest at one end of a case's motion, carrying its static load) and a dwell (the drive idle, no
load).  Without [duty] the cycle is every case once, in order.

Each item checks what it can alone; :mod:`optdesign.scene.validate_cases` checks them against
the scene.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from .expressions import Expression
from .profiles import KEYS, Profile
from .values import check_label, parse_optional, parse_required, set_field
from .where import Where, fail, near_miss, show

DIRECTIONS = {"forward": 1, "reverse": -1}
# a case's per-sample columns that a [[constraints]] expr may use in a scene with [[cases]]
CASE_COLUMNS = ("drive", "power", "static_load", "inertia_term", "velocity_term", "drive_speed",
                "drive_acceleration", "motor_speed", "motor_acceleration", "motor_load_torque", "motor_torque",
                "rod_buckling")
# the reduced model's columns that a [[constraints]] expr or the objective may use in a scene
# with a [drive] and no [[cases]] (model/quantities.py), e.g. end(static_load)
MODEL_COLUMNS = ("drive", "power", "static_load", "damping_load", "inertia_term", "velocity_term",
                 "reduced_inertia")


# the joint forces (model/joints.py) a constraint may use: in a scene with [[cases]], per case
JOINT_FUNCTIONS = ("pin_force", "pin_force_x", "pin_force_y", "slider_normal", "slider_moment")


def uses_joint_forces(expr) -> bool:
    """True when ``expr`` calls pin_force(P), slider_normal(P), ..."""
    def walk(node):
        if getattr(node, "func", None) in JOINT_FUNCTIONS:
            return True
        children = list(getattr(node, "args", ())) + [getattr(node, k) for k in ("left", "right", "operand")
                                                      if hasattr(node, k)]
        return any(walk(c) for c in children)

    return walk(expr.tree)


def is_case_constraint(scene, constraint) -> bool:
    """True when ``constraint`` is evaluated per load case: it names a case, or uses a case's
    columns or the joint forces (a scene with [[cases]])."""
    if not scene.cases:
        return False
    return (constraint.case is not None or bool(constraint.expr.names() & set(CASE_COLUMNS))
            or uses_joint_forces(constraint.expr))
FLOWS = ("auto", "driving", "braking")
CASE_KEYS = ("name", "set", "direction", "efficiency", "profile", "weight")


@dataclass(frozen=True)
class Case:
    """One load case.

    ``overrides`` maps parameter names to values (numbers or expressions of the scene's
    parameters, evaluated with the scene's values); ``direction`` is 'forward' (the sweep runs
    from [sweep] from to to) or 'reverse'; ``efficiency`` is 'auto' (seed 1's rule: 1/eta while
    the drive delivers power, eta while it takes power back), 'driving' (1/eta throughout) or
    'braking' (eta throughout); ``profile`` is a profile's name, a :class:`Profile`, or None
    (the drive's constant [drive] speed and acceleration, mirrored for 'reverse');
    ``weight`` (>= 0, absent: 1) is the case's share of the duty cycle when the scene has no
    [duty]: the cycle runs each case ``weight`` times (0.5: every other cycle)."""

    name: str
    direction: str
    overrides: dict = field(default_factory=dict)
    efficiency: str = "auto"
    profile: str | Profile | None = None
    weight: Expression | None = None

    def __post_init__(self):
        where = Where("cases", str(self.name))
        check_label(self.name, where, "case")
        if self.direction is not None and self.direction not in DIRECTIONS:   # (None: checked with the scene)
            fail(where.at("direction"), f"expected 'forward' (from -> to) or 'reverse', found {show(self.direction)}"
                 + near_miss(self.direction, DIRECTIONS))
        if self.efficiency not in FLOWS:
            fail(where.at("efficiency"), "expected 'auto' (by the direction of power flow), 'driving' (1/eta) or "
                                         f"'braking' (eta), found {show(self.efficiency)}" + near_miss(self.efficiency, FLOWS))
        if not isinstance(self.overrides, dict):
            fail(where.at("set"), f"expected a table of parameter values, e.g. {{ mL = 2000 }}, found {show(self.overrides)}")
        set_field(self, "overrides", {k: parse_required(v, where.at(f"set.{k}")) for k, v in self.overrides.items()})
        if self.profile is not None and not isinstance(self.profile, (str, Profile)):
            fail(where.at("profile"), f"expected a profile's name or an inline profile table, found {show(self.profile)}")
        set_field(self, "weight", parse_optional(self.weight, where.at("weight")))

    @property
    def sign(self) -> int:
        """+1 forward, -1 reverse."""
        return DIRECTIONS[self.direction]


STEP_KINDS = ("case", "hold", "dwell")


@dataclass(frozen=True)
class DutyStep:
    """One step of the duty cycle: ``kind`` 'case' (the case's motion, ``repeat`` times),
    'hold' (``duration`` s at rest at the ``at`` end, 'start' or 'end', of ``case``'s motion,
    carrying its static load with the power flow ``efficiency``: 'driving', 1/eta, or
    'braking', eta) or 'dwell' (``duration`` s idle, no load)."""

    kind: str
    case: str | None = None
    duration: Expression | None = None
    repeat: int = 1
    at: str = "end"
    efficiency: str = "driving"
    index: int = 0

    def __post_init__(self):
        where = Where("duty", key=f"cycle[{self.index}]")
        if self.kind not in STEP_KINDS:
            fail(where, f"expected a case name, {{ case = NAME, repeat = N }}, {{ hold = SECONDS, case = NAME }} "
                        f"or {{ dwell = SECONDS }}, found {show(self.kind)}")
        if self.kind == "hold" and self.case is None:
            fail(where, "a hold needs the case whose load it carries: { hold = SECONDS, case = NAME } "
                        "(at its motion's end, or at = \"start\"); for an idle pause without load write "
                        "{ dwell = SECONDS }")
        if self.kind in ("case", "hold") and not isinstance(self.case, str):
            fail(where, f"expected the name of a case, found {show(self.case)}")
        if self.kind in ("hold", "dwell"):
            set_field(self, "duration", parse_required(self.duration, where, f"the {self.kind}'s duration in s"))
        if isinstance(self.repeat, bool) or not isinstance(self.repeat, int) or self.repeat < 1:
            fail(where, f"repeat: expected a whole number >= 1, found {show(self.repeat)}")
        if self.at not in ("start", "end"):
            fail(where, f"at: expected 'start' or 'end' of the case's motion, found {show(self.at)}")
        if self.efficiency not in ("driving", "braking"):
            fail(where, f"efficiency: expected 'driving' (1/eta) or 'braking' (eta), found {show(self.efficiency)}")


@dataclass(frozen=True)
class Duty:
    """The duty cycle: its steps in order."""

    steps: tuple

    def __post_init__(self):
        set_field(self, "steps", tuple(self.steps))
        if not self.steps:
            fail(Where("duty", key="cycle"), "the cycle is empty; list its steps, e.g. cycle = [\"raise\", "
                                             "{ dwell = 10 }, \"lower\"]")


def case_values(scene, case: Case, values: dict | None = None) -> dict:
    """Every parameter's value in ``case``: its overrides (evaluated with the scene's
    ``values``, default: the scene's own) in place of the parameters they name, derived
    parameters recomputed from them."""
    from .expressions import constant_value

    base = scene.parameter_values() if values is None else values
    over = {n: constant_value(e, base, Where("cases", case.name, f"set.{n}")) for n, e in case.overrides.items()}
    out = {}
    for p in scene.parameters:
        out[p.name] = over[p.name] if p.name in over else constant_value(p.value, out, Where("parameters", p.name))
    return out


def read_step(item, index) -> DutyStep:
    """One entry of ``[duty] cycle``: a case name, or a table with case/repeat, hold/case/at/
    efficiency, or dwell."""
    where = Where("duty", key=f"cycle[{index}]")
    if isinstance(item, str):
        return DutyStep("case", item, index=index)
    if not isinstance(item, dict):
        fail(where, f"expected a case name or a table, found {show(item)}")
    if "hold" in item:
        allowed, kind = ("hold", "case", "at", "efficiency"), "hold"
    elif "dwell" in item:
        allowed, kind = ("dwell",), "dwell"
    else:
        allowed, kind = ("case", "repeat"), "case"
    for key in item:
        if key not in allowed:
            fail(where, f"unknown key {key!r} in a {kind} step" + (near_miss(key, allowed)
                                                                 or f"; expected {', '.join(allowed)}"))
    return DutyStep(kind, item.get("case"), item.get(kind) if kind != "case" else None, item.get("repeat", 1),
                    item.get("at", "end"), item.get("efficiency", "driving"), index)


def read_profile(name, data, place=None) -> Profile:
    """A profile from its TOML table (``[profiles.NAME]``, or inline in a case at ``place``)."""
    where = place or Where("profiles", str(name))
    if not isinstance(data, dict):
        fail(where, f"expected a table such as {{ kind = \"trapezoidal\", speed = 0.1, acceleration = 0.05, "
                    f"deceleration = 0.05 }}, found {show(data)}")
    keys = KEYS + ("segments",)
    for key in data:
        if key not in keys:
            fail(where.at(key), f"unknown key {key!r}" + (near_miss(key, keys) or f"; expected one of {', '.join(keys)}"))
    return Profile(name, data.get("kind"), *(data.get(k) for k in KEYS[1:]), segments=data.get("segments"), place=place)


def read_case(data) -> Case:
    """A case from its [[cases]] table (keys checked by the reader)."""
    profile = data.get("profile")
    if isinstance(profile, dict):
        profile = read_profile(str(data.get("name")), profile, Where("cases", str(data.get("name")), "profile"))
    return Case(data.get("name"), data.get("direction"), data.get("set", {}), data.get("efficiency", "auto"),
                profile, data.get("weight"))

