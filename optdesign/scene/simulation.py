"""A duty cycle in time: the phases of ``[simulation]`` (``[[simulation.phases]]``).

A phase drives the mechanism by one law until its end; the next phase starts from the state
where it ended.  The drive of a phase (exactly one key):

- ``law = "EXPR"``: the torque (force) as an expression of parameters, ``q``, ``qd`` and ``t``
  (the time since the phase began): the motor's torque [N m] with a [gearbox] and [[motors]],
  else the drive's T_S (F_S) as ``[drive] law``;
- ``motor = "forward" | "reverse"``: the motor at full torque on its speed-torque curve,
  T_m = +-peak_torque (1 -+ omega_m / max_speed) (peak torque at standstill, none at the
  maximum speed);
- ``controller = { gain = K, position_gain = K_p, profile = NAME, direction = "forward" |
  "reverse" }``: a proportional speed controller tracking the profile in time from the phase's
  start, T_m = K (omega_m* - omega_m) saturated at +-peak_torque, with an optional position
  loop around it (profile and direction default to the phase's case's);
- ``brake = TORQUE``: a torque of that size against the motion at the phase's start;
- ``hold = "motor" | "brake"``: the mechanism held at rest, by the motor carrying the static
  load ('motor') or by a brake with the motor idle ('brake').

A phase ends at ``until = { position = SWEEP_VALUE }``, ``{ time = SECONDS }`` (since the phase
began), ``"rest"`` (the speed through zero) or ``"profile"`` (a controller's profile ends);
``case`` takes a load case's parameter overrides for the phase.  This module reads and checks
the phases alone (:func:`read_phases`) and against the scene (:func:`check_phases`).
"""
from __future__ import annotations

from dataclasses import dataclass

from .expressions import Expression, constant_value
from .values import check_label, parse_required, set_field
from .where import Where, fail, near_miss, show

PHASE_KEYS = ("name", "law", "motor", "controller", "brake", "hold", "until", "case")
DRIVES = ("law", "motor", "controller", "brake", "hold")
UNTIL = ("position", "time", "rest", "profile")
CONTROLLER_KEYS = ("gain", "position_gain", "profile", "direction")
DIRECTIONS = ("forward", "reverse")
HOLDS = ("motor", "brake")
TABLE = "simulation.phases"


@dataclass(frozen=True)
class Phase:
    """One phase: ``name``, its drive ``kind`` (one of :data:`DRIVES`) and ``setting`` (the law
    or brake torque as an Expression, the motor's direction, the hold's holder, the controller's
    table with ``gain`` parsed), its end ``until`` ('position', 'time', 'rest', 'profile') with
    ``until_value`` (an Expression or None), the load ``case`` it takes its parameters from, and
    its ``index`` in the list."""

    name: str
    kind: str
    setting: object
    until: str
    until_value: Expression | None = None
    case: str | None = None
    index: int = 0

    def where(self, key=None) -> Where:
        return Where(TABLE, self.name, key)

    def __post_init__(self):
        where = self.where()
        check_label(self.name, where, "phase")
        if self.kind not in DRIVES:
            fail(where, f"unknown drive {show(self.kind)}" + near_miss(self.kind, DRIVES))
        if self.kind in ("law", "brake"):
            set_field(self, "setting", parse_required(self.setting, where.at(self.kind), "a torque [N m] or force [N]"))
        elif self.kind == "motor" and self.setting not in DIRECTIONS:
            fail(where.at("motor"), f"expected 'forward' or 'reverse' (the motor's direction on its speed-torque "
                                    f"curve), found {show(self.setting)}" + near_miss(self.setting, DIRECTIONS))
        elif self.kind == "hold" and self.setting not in HOLDS:
            fail(where.at("hold"), f"expected 'motor' (the motor carries the static load) or 'brake' (a brake holds "
                                   f"it, the motor idle), found {show(self.setting)}" + near_miss(self.setting, HOLDS))
        elif self.kind == "controller":
            set_field(self, "setting", _controller(self.setting, where.at("controller")))
        if self.until not in UNTIL:
            fail(where.at("until"), f"unknown end {show(self.until)}" + near_miss(self.until, UNTIL))
        if self.until in ("position", "time"):
            set_field(self, "until_value", parse_required(self.until_value, where.at(f"until.{self.until}")))
        if self.until == "profile" and self.kind != "controller":
            fail(where.at("until"), "\"profile\" ends a controller's phase with its profile; this phase has no "
                                    "controller: end it at { position = ... }, { time = ... } or \"rest\"")
        if self.kind == "hold" and self.until != "time":
            fail(where.at("until"), f"a hold ends after a time: expected until = {{ time = SECONDS }}, found {self.until!r}")
        if self.case is not None:
            check_label(self.case, where.at("case"), "case")


def _controller(data, where):
    if not isinstance(data, dict):
        fail(where, f"expected a table {{ gain = K, profile = NAME, direction = \"forward\" }}, found {show(data)}")
    for key in data:
        if key not in CONTROLLER_KEYS:
            fail(where.at(f"controller.{key}"), f"unknown key {key!r}" + (
                near_miss(key, CONTROLLER_KEYS) or f"; expected one of {', '.join(CONTROLLER_KEYS)}"))
    out = dict(data)
    out["gain"] = parse_required(data.get("gain"), where.at("controller.gain"),
                                 "the speed controller's gain K [N m s/rad at the motor], > 0")
    if data.get("position_gain") is not None:
        out["position_gain"] = parse_required(data["position_gain"], where.at("controller.position_gain"))
    if "direction" in data and data["direction"] not in DIRECTIONS:
        fail(where.at("controller.direction"), f"expected 'forward' or 'reverse', found {show(data['direction'])}"
             + near_miss(data["direction"], DIRECTIONS))
    if "profile" in data and not isinstance(data["profile"], str):
        fail(where.at("controller.profile"), f"expected the name of a [profiles] table, found {show(data['profile'])}")
    return out


def read_phases(data) -> tuple:
    """The phases of ``[[simulation.phases]]`` (the TOML list), shapes checked."""
    if not isinstance(data, list) or not data:
        fail(Where("simulation", key="phases"), f"expected an array of tables [[simulation.phases]], each with a "
                                                f"name, a drive (law, motor, controller, brake or hold) and until, found {show(data)}")
    out = []
    for i, item in enumerate(data):
        name = item.get("name") if isinstance(item, dict) else None
        where = Where(TABLE, name, index=i)
        if not isinstance(item, dict):
            fail(where, f"expected a table, found {show(item)}")
        for key in item:
            if key not in PHASE_KEYS:
                fail(where.at(key), f"unknown key {key!r}" + (near_miss(key, PHASE_KEYS)
                                                              or f"; expected one of {', '.join(PHASE_KEYS)}"))
        if name is None:
            fail(where.at("name"), "missing key 'name'")
        drives = [k for k in DRIVES if k in item]
        if len(drives) != 1:
            fail(where, f"expected exactly one drive ({', '.join(DRIVES)}), found "
                        f"{', '.join(drives) if drives else 'none'}")
        until = item.get("until")
        if until is None:
            fail(where.at("until"), "missing key 'until': expected { position = SWEEP_VALUE }, { time = SECONDS }, "
                                    "\"rest\" or \"profile\"")
        if isinstance(until, dict):
            if len(until) != 1 or next(iter(until)) not in ("position", "time"):
                key = next(iter(until), "")
                fail(where.at("until"), f"expected {{ position = SWEEP_VALUE }} or {{ time = SECONDS }}, found "
                                        f"{show(until)}" + near_miss(key, ("position", "time")))
            kind, value = next(iter(until.items()))
        elif until in ("rest", "profile"):
            kind, value = until, None
        else:
            fail(where.at("until"), f"expected {{ position = SWEEP_VALUE }}, {{ time = SECONDS }}, \"rest\" or "
                                    f"\"profile\", found {show(until)}" + near_miss(until, UNTIL))
        out.append(Phase(name, drives[0], item[drives[0]], kind, value, item.get("case"), i))
    return tuple(out)


def check_phases(scene, values, fail_at) -> None:
    """The phases against the scene (``values``: the parameters' values; ``fail_at(where,
    detail)`` raises): unique names, known cases and profiles (near misses), a motor for the
    motor's laws, positions inside the stroke, times > 0, gains and brake torques > 0."""
    sim = scene.simulation
    cases = {c.name: c for c in scene.cases}
    profiles = {p.name for p in scene.profiles}
    sweep = scene.sweep
    lo, hi = sorted((constant_value(sweep.start, values, ""), constant_value(sweep.stop, values, "")))
    seen = set()
    if sim.motor is not None and sim.motor not in {m.name for m in scene.motors}:
        fail_at(Where("simulation", key="motor"), f"unknown motor {sim.motor!r}" + (
            near_miss(sim.motor, [m.name for m in scene.motors]) or "; give the name of a [[motors]] entry"))
    for ph in sim.phases:
        where = ph.where()
        if ph.name in seen:
            fail_at(where, f"the phase name {ph.name!r} is used twice; rename one of them")
        seen.add(ph.name)
        if ph.case is not None and ph.case not in cases:
            fail_at(where.at("case"), f"unknown case {ph.case!r}" + (near_miss(ph.case, cases)
                                                                     or "; give the name of a [[cases]] entry"))
        if ph.kind in ("motor", "controller") or (ph.kind == "hold" and ph.setting == "motor"):
            if scene.gearbox is None or not scene.motors:
                fail_at(where.at(ph.kind), f"a {ph.kind} phase needs the motor: add [gearbox] (ratio = 1 for a direct "
                                           "drive) and [[motors]] with its inertia, peak torque and maximum speed")
            if len(scene.motors) > 1 and sim.motor is None:
                fail_at(Where("simulation", key="motor"), f"the catalogue has {len(scene.motors)} motors: name the one "
                                                          "that drives, e.g. motor = " + repr(scene.motors[0].name))
        if ph.kind == "controller":
            case = cases.get(ph.case)
            profile = ph.setting.get("profile", case.profile if case else None)
            direction = ph.setting.get("direction", case.direction if case else None)
            if profile is None or direction is None:
                fail_at(where.at("controller"), "the controller tracks a profile in a direction: give profile = NAME "
                                                "and direction = \"forward\"/\"reverse\", or a case that has them")
            if isinstance(profile, str) and profile not in profiles:
                fail_at(where.at("controller.profile"), f"unknown profile {profile!r}" + (
                    near_miss(profile, profiles) or "; give the name of a [profiles] table"))
            _positive(ph.setting["gain"], values, where.at("controller.gain"), fail_at)
            if ph.setting.get("position_gain") is not None:
                _positive(ph.setting["position_gain"], values, where.at("controller.position_gain"), fail_at)
        if ph.kind in ("law", "brake"):
            known = set(values) | ({"q", "qd", "t"} if ph.kind == "law" else set())
            for name in sorted(ph.setting.names() - known):
                fail_at(where.at(ph.kind), f"unknown name {name!r} in the {ph.kind} {ph.setting.source!r}"
                        + (near_miss(name, sorted(known)) or "; expected parameters" + (", q, qd and t (the time since "
                                                                                         "the phase began)" if ph.kind == "law" else "")))
        if ph.kind == "brake":
            _positive(ph.setting, values, where.at("brake"), fail_at)
        if ph.until == "position":
            x = constant_value(ph.until_value, values, where.at("until.position"))
            if not lo <= x <= hi:
                fail_at(where.at("until.position"), f"the position {x:g} lies outside the stroke [{lo:g}, {hi:g}] of "
                                                    f"[sweep] {sweep.name}: the phase could never end there")
        if ph.until == "time":
            _positive(ph.until_value, values, where.at("until.time"), fail_at)


def _positive(expr, values, where, fail_at):
    x = constant_value(expr, values, where)
    if not x > 0:
        fail_at(where, f"expected a value > 0, found {x:g}")
