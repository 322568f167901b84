"""Validation of the items that size a drive: [profiles], [[cases]], [duty], [gearbox],
[[motors]] and [cylinder], against the rest of the scene.

Called by :class:`optdesign.scene.validate.Validator` after the other checks.  Every error
names the item: a case overriding an unknown parameter (with the near miss), a design variable
or a derived one; a case naming an unknown profile; a profile whose top speed cannot be
reached in the stroke (with the case whose values were used); a duty step naming an unknown
case; a gear ratio <= 0 (also as a design variable's lower bound); a motor or cylinder value
<= 0; a gearbox or motor beside a linear drive, a cylinder beside a rotary one.
"""
from __future__ import annotations

from .cases import CASE_COLUMNS, MODEL_COLUMNS, Case, Duty, case_values, is_case_constraint
from .cycles import ways_of
from .expressions import constant_value, parse
from .profiles import CYCLE, Profile, profile_shape
from .quantities import uses_points
from .segments import segment_ends
from .train import MOTOR_UNITS, Cylinder, Gearbox, Motor
from .values import outside_meaningful
from .where import Where, near_miss, show


class DriveSizingValidator:
    """The checks of one scene's drive-sizing items: ``DriveSizingValidator(validator, values).run()``."""

    def __init__(self, validator, values):
        self.v = validator
        self.scene = validator.scene
        self.values = values
        params = {p.name: p for p in self.scene.parameters}
        self.params = params
        self.design = {n for n, p in params.items() if p.is_design}
        self.uses = {n: p.value.names() for n, p in params.items()}

    def fail(self, where, detail):
        self.v._fail(where, detail)

    def run(self):
        sc = self.scene
        for attr, kinds in (("profiles", Profile), ("cases", Case), ("motors", Motor)):
            for i, item in enumerate(getattr(sc, attr)):
                if not isinstance(item, kinds):
                    self.fail(Where(attr, index=i), f"expected a {kinds.__name__}, found {show(item)}")
        for attr, kind in (("duty", Duty), ("gearbox", Gearbox), ("cylinder", Cylinder)):
            if getattr(sc, attr) is not None and not isinstance(getattr(sc, attr), kind):
                self.fail(Where(attr), f"expected a {kind.__name__}, found {show(getattr(sc, attr))}")
        self.ends = (constant_value(sc.sweep.start, self.values, ""), constant_value(sc.sweep.stop, self.values, ""))
        self.length = abs(self.ends[1] - self.ends[0])
        self.profiles = {}
        for p in sc.profiles:
            if p.name in self.profiles:
                self.fail(p.where(), f"the profile name {p.name!r} is used twice; rename one of them")
            self.profiles[p.name] = p
            self._profile(p, self.values)
        self._cases()
        self._case_constraints()
        self._duty()
        self._gearbox()
        self._motors()
        self._cylinder()

    # --- helpers ---
    def depends_on_design(self, expr) -> str | None:
        """The design variable ``expr`` uses (directly or through derived parameters), or None."""
        seen, todo = set(), set(expr.names())
        while todo:
            n = todo.pop()
            if n in self.design:
                return n
            if n in self.uses and n not in seen:
                seen.add(n)
                todo |= self.uses[n]
        return None

    def number(self, where, expr, values=None, what="parameters", design=False):
        """``expr`` as a number of the scene's parameters (no sweep, no points); unless
        ``design``, it may not depend on a design variable."""
        self.v._check_expression(where, expr, set(self.params), [])
        if not design:
            name = self.depends_on_design(expr)
            if name is not None:
                self.fail(where, f"{expr.source!r} depends on the design variable {name!r}; expected a value "
                                 f"that is the same for every design ({what})")
        return constant_value(expr, self.values if values is None else values, where)

    def positive(self, where, expr, what, strict=True, design=False):
        value = self.number(where, expr, design=design)
        if not (value > 0 if strict else value >= 0):
            self.fail(where, f"expected {what} {'>' if strict else '>='} 0, found {value:g}")
        if outside_meaningful(value):
            self.fail(where, f"expected {what} {'>' if strict else '>='} 0, {outside_meaningful(value)}")
        return value

    # --- profiles and cases ---
    def _profile(self, p, values, suffix="", case=None):
        """``case``: the case that runs it (its direction gives a segments profile's ends)."""
        names = set(self.params) | ({self.scene.sweep.name} if p.kind == "law" else set())
        exprs = [(p.where(key), getattr(p, key)) for key in p.keys]
        exprs += [(seg.where.at(f"{seg.where.key}.{key}"), getattr(seg, key)) for seg in p.segments or ()
                  for key in ("to", "time", "speed", "acceleration", "dwell") if getattr(seg, key) is not None]
        if p.kind == "law" and uses_points(p.speed):
            used = sorted(parse(p.speed.source, str(p.where("speed"))).names() & {q.name for q in self.scene.quantities})
            self.fail(p.where("speed"), f"{p.speed.source!r} uses the mechanism's points"
                      + (f" (through [quantities] {', '.join(used)})" if used else "") + ": a law's speed is an "
                      "expression of the sweep and the parameters (and quantities of them alone)")
        for where, expr in exprs:
            self.v._check_expression(where, expr, names, [])
            name = self.depends_on_design(expr)
            if name is not None:
                self.fail(where, f"{expr.source!r} depends on the design variable {name!r}: a profile "
                                 "is the same motion for every design")
        if p.kind == CYCLE:   # (a case runs it as its ways, checked as cases; here the cycle alone)
            for way in ways_of(self.scene, Case(p.name, None, {}), p, values)[0]:
                self._profile(way.profile, case_values(self.scene, way, values), suffix, way)
            return None
        ends = None
        if p.segments is not None:
            ends = segment_ends(p.segments, values, *self.ends) if case is None else (
                self.ends if case.sign > 0 else self.ends[::-1])
        return profile_shape(p, values, self.length, suffix, ends)

    def _cases(self):
        sc = self.scene
        seen = set()
        for case in sc.cases:
            where = Where("cases", case.name)
            if case.name in seen:
                self.fail(where, f"the case name {case.name!r} is used twice; rename one of them")
            seen.add(case.name)
            if sc.drive is None:
                self.fail(where, "load cases need a [drive] (the drive they load)")
            if case.direction is None:
                self.fail(where.at("direction"), "missing key 'direction': expected 'forward' (from -> to) or 'reverse'")
            values = self.case_values(case)
            if isinstance(case.profile, str):
                if case.profile not in self.profiles:
                    known = sorted(self.profiles)
                    self.fail(where.at("profile"), f"no profile {case.profile!r} in [profiles]" + (
                        near_miss(case.profile, known) or f"; profiles: {', '.join(known) or 'none'}"))
                self._profile(self.profiles[case.profile], values, f" (with the parameters of case {case.name!r})", case)
            elif case.profile is not None:
                self._profile(case.profile, values, case=case)
            if case.weight is not None:
                if sc.duty is not None:
                    self.fail(where.at("weight"), "a weight is the case's share of the cycle without [duty]; "
                                                  "with [duty], repeat the case in its cycle instead")
                self.positive(where.at("weight"), case.weight, "a weight", strict=False)
        if sc.cases and sc.duty is None and all(
                c.weight is not None and self.number(Where("cases", c.name).at("weight"), c.weight) == 0
                for c in sc.cases):
            # the default cycle would have no time: its RMS was a division by zero (a traceback)
            self.fail(Where("cases", sc.cases[-1].name).at("weight"),
                      "every case has weight 0, so the duty cycle is empty; give a case a weight > 0 (or "
                      "write the cycle as [duty] cycle = [...])")

    def _case_constraints(self):
        """A constraint per case: its case exists; a case column only in a per-sample
        constraint, and only where the scene has what makes it (a gearbox, one motor, a rod)."""
        sc = self.scene
        names = [c.name for c in sc.cases]
        needs = {"motor_speed": sc.gearbox is not None, "motor_acceleration": sc.gearbox is not None,
                 "motor_load_torque": sc.gearbox is not None, "motor_torque": len(sc.motors) == 1,
                 "rod_buckling": sc.cylinder is not None and sc.cylinder.rod is not None}
        why = {"motor_torque": "exactly one [[motors]] entry (a catalogue's motors bring their own limits)",
               "rod_buckling": "a [cylinder] with its rod"}
        for c in sc.constraints:
            where = Where("constraints", c.name)
            if c.case is not None and c.case not in names:
                self.fail(where.at("case"), f"no case {c.case!r}" + (near_miss(c.case, names) or
                                                                    f"; cases: {', '.join(names) or 'none'}"))
            if not is_case_constraint(sc, c):
                continue
            used = sorted(c.expr.names() & set(CASE_COLUMNS))
            if c.expr.is_aggregate and used:
                self.fail(where.at("expr"), f"{c.expr.source!r}: a case column ({', '.join(used)}) in a value per "
                                            "stroke; a case's column holds per sample: write it without max/min")
            for name in used:
                if name in self.params:
                    self.fail(where.at("expr"), f"{name!r} is a parameter and a case column; rename the parameter")
                if not needs.get(name, True):
                    self.fail(where.at("expr"), f"{c.expr.source!r}: {name!r} needs "
                                                f"{why.get(name, 'a [gearbox]')}")

    def case_values(self, case):
        """The parameter values of ``case``: its overrides (evaluated with the scene's values)
        in place of the leaf parameters they name, derived parameters recomputed."""
        where = Where("cases", case.name)
        for name, expr in case.overrides.items():
            at = where.at(f"set.{name}")
            if name not in self.params:
                known = sorted(self.params)
                what = ("the sweep variable (the stroke is the same in every case)" if name == self.scene.sweep.name
                        else f"an unknown parameter {name!r}")
                self.fail(at, f"the case overrides {what}" + (near_miss(name, known) or
                                                              f"; parameters: {', '.join(known) or 'none'}"))
            if name in self.design:
                self.fail(at, f"{name!r} is a design variable: the design is the same in every case; override "
                              "a plain parameter (a payload, a load, a friction value)")
            if self.uses[name]:
                self.fail(at, f"{name!r} is derived from other parameters ({self.params[name].value.source!r}); "
                              "override the parameters it is made of")
            self.number(at, expr)
        return case_values(self.scene, case, self.values)

    def _duty(self):
        duty = self.scene.duty
        if duty is None:
            return
        names = [c.name for c in self.scene.cases]
        if not names:
            self.fail(Where("duty"), "a duty cycle needs [[cases]]: its steps run the cases")
        if duty.steps and all(step.kind == "dwell" for step in duty.steps):
            self.fail(Where("duty", key="cycle"), "the cycle holds only dwells, in which the drive neither moves nor "
                                                  f"carries a load (its RMS would be 0): add the cases it runs, e.g. "
                                                  f"cycle = [{names[0]!r}, {{ dwell = 10 }}]".replace("'", '"'))
        for step in duty.steps:
            where = Where("duty", key=f"cycle[{step.index}]")
            if step.case is not None and step.case not in names:
                self.fail(where, f"no case {step.case!r}" + (near_miss(step.case, names) or f"; cases: {', '.join(names)}"))
            if step.duration is not None:
                self.positive(where, step.duration, f"a {step.kind} duration in s")

    # --- the drive train ---
    def _gearbox(self):
        g, drive = self.scene.gearbox, self.scene.drive
        if g is None:
            return
        where = Where("gearbox")
        if drive is None or drive.kind != "rotary":
            self.fail(where, "a gearbox needs a rotary [drive] (type = \"rotary\"); a linear drive is sized by [cylinder]")
        ratio = self.positive(where.at("ratio"), g.ratio, "a gear ratio i = motor speed / drive speed", design=True)
        name = g.ratio.source.strip()
        if name in self.design:
            for key, bound in (("min", self.params[name].lower), ("max", self.params[name].upper)):
                if bound is not None and outside_meaningful(bound):
                    self.fail(Where("parameters", name, key), f"the gear ratio's bound: {outside_meaningful(bound)}")
        if name in self.design and (self.params[name].lower is None or not self.params[name].lower > 0):
            lo = self.params[name].lower
            self.fail(Where("parameters", name, "min"), f"the gear ratio's lower bound must be > 0, found "
                                                        f"{'none' if lo is None else f'{lo:g}'}; give min > 0")
        if g.efficiency is not None:
            eta = self.number(where.at("efficiency"), g.efficiency)
            if not 0 < eta <= 1 or outside_meaningful(eta):
                self.fail(where.at("efficiency"), f"expected 0 < eta <= 1, found {eta:g}" + (
                    f" ({outside_meaningful(eta).split(', ', 1)[1]})" if outside_meaningful(eta) else ""))

    def _motors(self):
        sc = self.scene
        if not sc.motors:
            return
        if sc.gearbox is None:
            self.fail(Where("motors", sc.motors[0].name), "a motor needs a [gearbox] (ratio = 1 for a direct drive)")
        seen = set()
        for m in sc.motors:
            where = Where("motors", m.name)
            if m.name in seen:
                self.fail(where, f"the motor name {m.name!r} is used twice; rename one of them")
            seen.add(m.name)
            numbers = {k: self.positive(where.at(k), getattr(m, k), f"a value in {MOTOR_UNITS[k]}", strict=k != "inertia")
                       for k in MOTOR_UNITS}
            if numbers["peak_torque"] < numbers["rated_torque"]:
                self.fail(where.at("peak_torque"), f"the peak torque {numbers['peak_torque']:g} is below the rated "
                                                   f"torque {numbers['rated_torque']:g}; expected peak >= rated")

    def _cylinder(self):
        c, drive = self.scene.cylinder, self.scene.drive
        if c is None:
            return
        where = Where("cylinder")
        if drive is None or drive.kind != "linear":
            self.fail(where, "a cylinder needs a linear [drive] (type = \"linear\"); a rotary drive is sized by "
                             "[gearbox] and [[motors]]")
        if not self.scene.cases:
            self.fail(where, "a cylinder is sized from the peak forces and speeds of the load cases, and the scene has "
                             "no [[cases]], so it would be ignored; add the cases (e.g. [[cases]] name = \"raise\" with "
                             "a profile) or remove [cylinder]")
        numbers = {key: self.positive(where.at(key), getattr(c, key), key.replace("_", " "))
                   for key in ("pressure", "modulus", "buckling_safety", "length_factor")}
        # the scene is in SI: a modulus written in GPa (210) or MPa, a pressure in bar (160) or
        # MPa (16) is a number no rod or hydraulic system has; it sized a 7 m rod, silently
        for key, least, what, example in (
                ("modulus", 1e8, "any rod material's Young's modulus (steel: 210e9 Pa)", "210 GPa as 210e9"),
                ("pressure", 1e4, "a hydraulic system pressure (160 bar = 16e6 Pa)", "160 bar as 160e5")):
            if numbers[key] < least:
                self.fail(where.at(key), f"{numbers[key]:g} Pa is far below {what}; the scene is in SI "
                                         f"(Pa): write {example}")
        if numbers["buckling_safety"] < 1:
            self.fail(where.at("buckling_safety"), f"expected a safety factor >= 1 against Euler buckling, found "
                                                   f"{numbers['buckling_safety']:g}")
        sizes = {k: self.positive(where.at(k), getattr(c, k), f"a {k} diameter in m", design=True)
                 for k in ("rod", "bore") if getattr(c, k) is not None}
        if len(sizes) == 2 and not sizes["rod"] < sizes["bore"]:
            self.fail(where.at("rod"), f"the rod ({sizes['rod']:g} m) must be thinner than the bore ({sizes['bore']:g} m)")


def case_columns(scene) -> set:
    """The case columns a [[constraints]] expr may use: with [[cases]], those of
    :data:`.cases.CASE_COLUMNS`; without, the model's :data:`.cases.MODEL_COLUMNS` (a scene with a
    [drive]; model/quantities.py)."""
    if scene.cases:
        return set(CASE_COLUMNS)
    return set(MODEL_COLUMNS) if scene.drive is not None else set()
