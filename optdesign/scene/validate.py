"""Whole-scene validation: every cross reference of a scene, in the order of its file.

:class:`Validator` runs when a :class:`~optdesign.scene.scene.Scene` is constructed (each item
has already checked what it can check alone, see :mod:`optdesign.scene.values`): names used
twice, points used before they are built, names and points in expressions, design bounds, the
drive and its law, the simulation's start and span, constraint bounds.  The first problem
raises a :class:`~optdesign.errors.SceneError` (or :class:`~optdesign.errors.ExpressionError`)
that names its place, worded for the person who wrote the file.
"""
from __future__ import annotations

import re

import math

from ..errors import ExpressionError, SceneError
from .elements import (DRIVE_PINS, LAW_NAMES, Body, Constraint, Drive, Gravity, Objective, Parameter,
                       Simulation, Sweep)
from .expressions import constant_value
from .forces import check_forces
from .points import CONSTRUCTIONS, Loop
from .simulation import check_phases
from .validate_cases import DriveSizingValidator, case_columns
from .values import RESERVED, outside_meaningful
from .where import Where, fail, near_miss, show


class Validator:
    """The cross-reference checks of one scene: ``Validator(scene).run()``."""

    def __init__(self, scene):
        self.scene = scene

    def run(self):
        """Check every cross reference, in the order of the file; raise SceneError on the first
        problem, naming its place."""
        if not isinstance(self.scene.title, str):
            self._fail(Where("", key="title"), f"expected a string, found {show(self.scene.title)}")
        if not isinstance(self.scene.source, str):
            self._fail(Where("", key="source"), f"expected a string, found {show(self.scene.source)}")
        if not isinstance(self.scene.reference, dict):
            self._fail(Where("reference"), f"expected a table of free data, found {show(self.scene.reference)}")
        self._check_types()
        values = self._check_parameters()
        names = set(values) | {self.scene.sweep.name}
        built = self._check_points(names)
        self._check_quantities(names, built)
        self._check_bodies(names, built)
        check_forces(self.scene, values, self._check_expression, self._fail)
        if self.scene.gravity is not None:
            where = Where("gravity", key="g")
            self._check_expression(where, self.scene.gravity.g, set(values), [])
            g = constant_value(self.scene.gravity.g, values, where)
            if not g >= 0:   # a sign written for the direction would turn the weight upwards
                self._fail(where, f"expected the magnitude of gravity >= 0 [m/s^2], found {g:g}: it acts "
                                  f"along -y by definition; write g = {abs(g):g}")
        if self.scene.drive is not None:
            self._check_drive(values, built)
        self._check_constraints(values, names, built)
        DriveSizingValidator(self, values).run()      # the cases first: the phases name them
        if self.scene.simulation is not None:
            self._check_simulation(values)

    def _fail(self, where, detail, cls=SceneError):
        fail(where, detail, cls, self.scene.path)

    def _check_types(self):
        for table, items, kinds in (("parameters", self.scene.parameters, (Parameter,)),
                                    ("points", self.scene.points, CONSTRUCTIONS),
                                    ("bodies", self.scene.bodies, (Body,)),
                                    ("constraints", self.scene.constraints, (Constraint,))):
            for i, item in enumerate(items):
                if not isinstance(item, kinds):
                    self._fail(Where(table, index=i), f"expected {' or '.join(k.__name__ for k in kinds)}, "
                                                      f"found {show(item)}")
        for attr, kind in (("sweep", Sweep), ("gravity", Gravity), ("drive", Drive), ("objective", Objective),
                           ("simulation", Simulation)):
            value = getattr(self.scene, attr)
            if not isinstance(value, kind) and not (value is None and attr != "sweep"):
                self._fail(Where(attr), f"expected a {kind.__name__}, found {show(value)}")

    def _check_parameters(self):
        values, seen = {}, set()
        all_names = [p.name for p in self.scene.parameters]
        for p in self.scene.parameters:
            where = Where("parameters", p.name)
            self._check_unique(where, "parameter", p.name, seen)
            if p.name == self.scene.sweep.name:
                self._fail(where, f"{p.name!r} is also the sweep variable's name; rename one of them")
            later = all_names[all_names.index(p.name) + 1:]
            self._check_expression(where, p.value, set(values), [], later=later)
            values[p.name] = constant_value(p.value, values, where)
            if p.is_design:
                self._check_design(p, values[p.name])
        sweep = self.scene.sweep
        for key, attr in (("from", "start"), ("to", "stop"), ("rate", "rate"), ("acceleration", "acceleration")):
            expr = getattr(sweep, attr)
            if expr is not None:
                self._check_expression(Where("sweep", key=key), expr, set(values), [])
                constant_value(expr, values, Where("sweep", key=key))
        if constant_value(sweep.start, values, "") == constant_value(sweep.stop, values, ""):
            self._fail(Where("sweep", key="to"), "the stroke is empty: from and to are equal; "
                                                 "expected two different values")
        return values

    def _check_design(self, p, value):
        where = Where("parameters", p.name)
        lo = -math.inf if p.lower is None else p.lower
        hi = math.inf if p.upper is None else p.upper
        if p.value.names():
            self._fail(where.at("value"), f"a design variable's start must be a number, found {p.value.source!r} "
                                          "(which depends on other parameters)")
        if (p.lower is None) != (p.upper is None):
            # the optimiser searches the box between the bounds: with one side open the
            # objective can push the variable to infinity (an unbounded problem)
            given, missing = ("min", "max") if p.upper is None else ("max", "min")
            self._fail(where.at(given), f"design variable {p.name!r} has {given} but no {missing}: give both "
                                        f"bounds (the optimiser searches the box between them; with one side open "
                                        f"the objective can push {p.name} to {'+' if missing == 'max' else '-'}infinity)")
        if not lo < hi:
            self._fail(where.at("min"), f"min {_exact(lo)} must be below max {_exact(hi)}")
        # a few ulps of slack: a value computed to land on a bound (a study grid's end, 0.1*3)
        # may round to its neighbouring float
        slack = 4 * math.ulp(max(abs(x) for x in (lo, hi, value) if math.isfinite(x)))
        if not lo - slack <= value <= hi + slack:
            self._fail(where.at("value"), f"the start value {_exact(value)} lies outside its bounds "
                                          f"[{_exact(lo)}, {_exact(hi)}] (the design variable's min and "
                                          "max); move the start inside or widen the bounds")

    def _check_points(self, names):
        if not self.scene.points:
            self._fail(Where("points"), "no points: expected at least one construction, e.g. A = { fixed = [0, 0] }")
        built, first = [], {}
        for c in self.scene.points:
            where = Where("points", c.name)
            for name in c.defines:
                if name in first:
                    self._fail(where, f"point {name!r} is constructed twice (also at [points] {first[name]}); "
                                      "rename one of them")
                if name in names:
                    self._fail(where, f"point {name!r} has the name of a parameter or of the sweep; rename one")
            for ref, key in zip(c.uses(), self._use_keys(c)):
                if ref not in built:
                    self._missing_point(where.at(key), ref, built, SceneError)
            local = set(names)
            if isinstance(c, Loop):
                self._check_loop(c, where, names, built)
                local |= set(c.unknowns)
            for key, expr in self._expressions_of(c):
                self._check_expression(where.at(key), expr, local, built)
            self._check_dyad_lengths(c, where)
            for name in c.defines:
                first[name] = c.name
            built.extend(c.defines)
        return built

    def _check_quantities(self, names, built):
        """[quantities]: unique names that are no parameter, point or case column; each an
        expression per sample of the parameters, the sweep, the points and earlier quantities
        (those are already put in: :func:`optdesign.scene.quantities.expanded_items`)."""
        seen, order = set(), [q.name for q in self.scene.quantities]
        for i, q in enumerate(self.scene.quantities):
            where = Where("quantities", q.name)
            self._check_unique(where, "quantity", q.name, seen)
            clash = ("a parameter" if q.name in names - {self.scene.sweep.name} else "the sweep variable"
                     if q.name == self.scene.sweep.name else "a point" if q.name in built else
                     "a load case's column" if q.name in case_columns(self.scene) else None)
            if clash:
                self._fail(where, f"the quantity {q.name!r} has the name of {clash}; rename one of them")
            self._check_expression(where.at("expr"), q.expr, names, built, later=order[i:])

    def _check_dyad_lengths(self, c, where):
        """A dyad's and a slider's lengths are > 0 where they are numbers of the parameters (a
        circle of radius 0 or less meets nothing, or meets in a point that turns any way); one
        that varies along the stroke is checked by the assembly where it is evaluated."""
        if c.KIND not in ("dyad", "slider"):
            return
        for attr, label, kind in c.ROLES:
            expr = getattr(c, attr)
            if kind != "expr" or not attr.startswith("length") or expr.points() or self.scene.sweep.name in expr.names():
                continue
            key = f"{c.KIND} {label}"
            value = constant_value(expr, self.scene.parameter_values(), where.at(key))
            if not value > 0:
                self._fail(where.at(key), f"expected a length > 0 [m], found {value:g}"
                                          + (f" ({expr.source} at the parameters' values)" if expr.names() else "")
                                          + "; a link of length 0 or less cannot be assembled: give its length "
                                            "as a positive number (the side key picks the solution)")

    @staticmethod
    def _use_keys(c):
        if isinstance(c, Loop):
            return ["loop"] + ["closure"] * (len(c.uses()) - 1)
        return [f"{c.KIND} {label}" for _, label, kind in c.ROLES if kind == "point"]

    @staticmethod
    def _expressions_of(c):
        if isinstance(c, Loop):
            out = [(f"lengths[{i}]", e) for i, e in enumerate(c.lengths)]
            out += [(f"angles[{i}]", e) for i, e in enumerate(c.angles)]
            if c.closure is not None and c.closure.angle is not None:
                out.append(("closure line angle", c.closure.angle))
            return out
        return [(f"{c.KIND} {label}", getattr(c, attr)) for attr, label, kind in c.ROLES if kind == "expr"]

    def _check_loop(self, c, where, names, built):
        used = set().union(*(a.names() for a in c.angles))
        for u, guess in c.unknowns.items():
            if u in names:
                self._fail(where.at("unknowns"), f"unknown angle {u!r} has the name of a parameter or of the sweep")
            if u not in used:
                self._fail(where.at("unknowns"), f"the unknown {u!r} appears in none of the angles "
                                                 f"{[a.source for a in c.angles]}" + near_miss(u, used - names))
            self._check_expression(where.at(f"unknowns.{u}"), guess, names, built)
        needed = 0 if c.closure is None else c.closure.equations
        if len(c.unknowns) != needed:
            kind = ("no closure (an open chain)" if c.closure is None else
                    "a closed loop (closure fixed = POINT)" if needed == 2 else
                    "a semi-closed loop (closure line = [POINT, angle])")
            self._fail(where.at("unknowns"),
                       f"found {len(c.unknowns)} unknown angle(s) {sorted(c.unknowns)}, but {kind} gives "
                       f"{needed} equation(s): expected {needed} unknown(s) (a closed loop needs 2, a "
                       "semi-closed one 1, an open chain none)")

    def _check_bodies(self, names, built):
        seen = set()
        for b in self.scene.bodies:
            where = Where("bodies", b.name)
            self._check_unique(where, "body", b.name, seen)
            for ref in b.frame:
                if ref not in built:
                    self._missing_point(where.at("frame"), ref, built, SceneError)
            for key in ("mass", "inertia", "torque"):
                if getattr(b, key) is not None:
                    self._check_expression(where.at(key), getattr(b, key), names, built)
            for key in ("com", "force"):
                for i, e in enumerate(getattr(b, key) or ()):
                    self._check_expression(where.at(f"{key}[{i}]"), e, names, built)
            self._check_physical(b, where)

    def _check_physical(self, b, where):
        """A frame of two distinct points (one point twice gives no angle: the body would stand
        still whatever the mechanism does), and a mass and an inertia that are not negative (a
        massless body is 0) where they are numbers of the parameters; one that varies along the
        stroke is checked where it is evaluated (a negative reduced inertia is an error there)."""
        if b.frame[0] == b.frame[1]:
            self._fail(where.at("frame"), f"[{b.frame[0]!r}, {b.frame[1]!r}] names one point twice: expected two "
                                          "distinct points (the origin and the point its x axis points to)")
        values = None
        for key, what in (("mass", "a mass >= 0 [kg]"), ("inertia", "a moment of inertia >= 0 [kg m^2]")):
            expr = getattr(b, key)
            if expr is None or expr.points() or self.scene.sweep.name in expr.names():
                continue
            values = self.scene.parameter_values() if values is None else values
            value = constant_value(expr, values, where.at(key))
            if not value >= 0:
                self._fail(where.at(key), f"expected {what}, found {value:g}"
                                          + (f" ({expr.source} at the parameters' values)" if expr.names() else ""))

    def _check_drive(self, values, built):
        d = self.scene.drive
        where = Where("drive")
        key = DRIVE_PINS[d.kind]
        for ref in d.pins:
            if ref not in built:
                self._missing_point(where.at(key), ref, built, SceneError)
        for name in ("speed", "acceleration", "efficiency"):
            if getattr(d, name) is not None:
                self._check_expression(where.at(name), getattr(d, name), set(values), [])
                constant_value(getattr(d, name), values, where.at(name))
        if d.efficiency is not None:
            eta = constant_value(d.efficiency, values, where.at("efficiency"))
            if not 0.0 < eta <= 1.0 or outside_meaningful(eta):
                self._fail(where.at("efficiency"), f"expected 0 < eta <= 1, found {eta:g}" + (
                    f" ({outside_meaningful(eta).split(', ', 1)[1]})" if outside_meaningful(eta) else ""))
            if eta < 1.0 and constant_value(d.speed, values, where.at("speed")) == 0.0:
                self._fail(where.at("speed"), f"efficiency {eta:g} < 1 needs the direction of power flow, "
                                              "which a zero speed does not give; set a nonzero speed (its "
                                              "sign is the direction of motion)")
        for key in ("rate", "acceleration"):
            if getattr(self.scene.sweep, key) is not None:
                self._fail(Where("sweep", key=key), f"the scene has a [drive], whose speed and acceleration "
                                                    f"set the motion; remove {key} from [sweep]")
        self._check_drive_law(values)

    def _check_drive_law(self, values):
        """The simulation keys of [drive]: ``law`` uses parameters, q and qd; ``inertia`` is a
        number >= 0 of parameters."""
        d, where = self.scene.drive, Where("drive")
        if d.law is not None:
            for name in LAW_NAMES:
                if name in values or name == self.scene.sweep.name:
                    what = "parameter" if name in values else "sweep variable"
                    self._fail(where.at("law"), f"the {what} {name!r} has the name the law uses for the drive "
                                                f"coordinate (q) or its rate (qd); rename the {what}")
            self._check_expression(where.at("law"), d.law, set(values) | set(LAW_NAMES), [])
        if d.inertia is not None:
            self._check_expression(where.at("inertia"), d.inertia, set(values), [])
            value = constant_value(d.inertia, values, where.at("inertia"))
            if value < 0:
                unit = "kg m^2, the rotor's moment of inertia" if d.kind == "rotary" else "kg, the moving mass"
                self._fail(where.at("inertia"), f"expected a drive inertia >= 0 ({unit}), found {value:g}")

    def _check_simulation(self, values):
        """[simulation]: needs a [drive] with a law; start inside the stroke, t_end > 0,
        tolerance in (0, 0.1]."""
        sim, where = self.scene.simulation, Where("simulation")
        if self.scene.drive is None:
            self._fail(where, "a simulation needs a [drive]")
        if not sim.phases and self.scene.drive.law is None:
            self._fail(where, "a simulation needs the drive's law: add law = \"...\" to [drive] (a torque "
                              "or force in q, qd and parameters, e.g. \"T0*(1 - qd/omega0)\")")
        numbers = {}
        for key in ("start", "speed", "t_end", "tolerance"):
            expr = getattr(sim, key)
            if expr is not None:
                self._check_expression(where.at(key), expr, set(values), [])
                numbers[key] = constant_value(expr, values, where.at(key))
        lo, hi = sorted((constant_value(self.scene.sweep.start, values, ""), constant_value(self.scene.sweep.stop, values, "")))
        if not lo <= numbers["start"] <= hi:
            self._fail(where.at("start"), f"the start {numbers['start']:g} lies outside the stroke "
                                          f"[{lo:g}, {hi:g}] of [sweep] {self.scene.sweep.name}; start inside it")
        if not numbers["t_end"] > 0:
            self._fail(where.at("t_end"), f"expected an end time > 0 s, found {numbers['t_end']:g}")
        if "tolerance" in numbers and not 0 < numbers["tolerance"] <= 0.1:
            self._fail(where.at("tolerance"), f"expected a relative tolerance in (0, 0.1], e.g. 1e-8, "
                                              f"found {numbers['tolerance']:g}")
        if sim.phases:
            check_phases(self.scene, values, self._fail)

    def _check_constraints(self, values, names, built):
        seen = set()
        for c in self.scene.constraints:
            where = Where("constraints", c.name)
            self._check_unique(where, "constraint", c.name, seen)
            self._check_expression(where.at("expr"), c.expr, names | case_columns(self.scene), built, aggregate=True)
            if c.expr.is_aggregate:
                varying_names, varying_points = c.expr.outside_aggregates()
                varying = sorted(varying_names & {self.scene.sweep.name}) + sorted(varying_points)
                if varying:
                    self._fail(where.at("expr"),
                               f"{c.expr.source!r} mixes one value per stroke (min/max with one argument, "
                               f"start, end) with values per sample ({', '.join(map(repr, varying))} outside "
                               "min/max, start and end); expected every sweep-dependent part inside "
                               "min(...), max(...), start(...) or end(...)",
                               ExpressionError)
            bounds = []
            for key, attr in (("min", "lower"), ("max", "upper")):
                e = getattr(c, attr)
                if e is not None:
                    self._check_expression(where.at(key), e, set(values), [])
                    bounds.append(constant_value(e, values, where.at(key)))
            if len(bounds) == 2 and bounds[0] > bounds[1]:
                self._fail(where, f"min {bounds[0]:g} is above max {bounds[1]:g}; nothing can satisfy it")

    # --- names ---
    def _check_unique(self, where, what, name, seen):
        """``name`` is not among the names ``seen`` so far in its table; it is added to them."""
        if name in seen:
            self._fail(where, f"the {what} name {name!r} is used twice; rename one of them")
        seen.add(name)

    def _check_expression(self, where, expr, names, built, aggregate=False, later=()):
        """Every name and point of ``expr`` must be known here; aggregates only where allowed."""
        if expr.is_aggregate and not aggregate:
            self._fail(where, f"{expr.source!r}: min() or max() with one argument is the extreme over "
                              "the whole stroke, and start() and end() the value at its first and last "
                              "sample, which only a [[constraints]] expr may use; for the smaller or "
                              "larger of two values give two arguments, e.g. max(a, b)",
                       ExpressionError)
        for name in sorted(expr.names()):
            if name not in names:
                self._unknown_name(where, expr, name, names, built, later)
        for point in sorted(expr.points()):
            if point not in built:
                self._missing_point(where, point, built, ExpressionError, expr)

    def _unknown_name(self, where, expr, name, names, built, later):
        src = expr.source
        if name in built or name in self.scene.point_names():
            detail = (f"{name!r} is a point, not a number; use x({name}), y({name}), "
                      f"length({name}, Q) or angle(P, {name}, Q)")
        elif name == self.scene.sweep.name:
            detail = (f"the sweep variable {name!r} cannot be used here: expected a value that is the "
                      "same over the whole stroke (numbers, parameters, pi, deg)")
        elif name in later:
            what = "quantit" if where.table == "quantities" else "parameter"
            detail = (f"{name!r} is defined further down" + (" (or is this quantity itself); a quantity may use "
                      "only the quantities" if what == "quantit" else "; a parameter may use only the parameters")
                      + " above it: move its line")
        elif name in ("s", "sec") and re.search(r"(deg|rad|m)\s*/\s*(s|sec)\b", src):
            # "90 deg/s", "180 deg/s^2": a rate written with its time unit
            m = re.match(r"\s*(.*?)\s*/\s*(s|sec)\b", src)
            example = f" (here \"{m.group(1)}\")" if m else ""
            detail = ("units are not read, except 'deg' after an angle: a speed, acceleration or jerk is "
                      f"written without its '/s'{example}: '90 deg' for 90 deg/s, '180 deg' for 180 deg/s^2, 0.5 "
                      "for 0.5 m/s; the scene is in SI (m, kg, s, N, N m, W, rad)")
        elif where.table == "parameters" and name == where.item:
            detail = f"the parameter {name!r} refers to itself; expected a number or earlier parameters"
        else:
            known = sorted(names) + list(RESERVED)
            detail = f"unknown name {name!r}" + (near_miss(name, known) or f"; expected one of: {', '.join(known)}")
        self._fail(where, f"{src!r}: {detail}", ExpressionError)

    def _missing_point(self, where, ref, built, cls, expr=None):
        src = f"{expr.source!r}: " if expr is not None else ""
        if ref in self.scene.point_names():
            detail = (f"point {ref!r} is used before it is built (it is constructed further down in "
                      "[points]); move its line above this one")
        else:
            detail = f"no point {ref!r} is constructed" + (
                near_miss(ref, self.scene.point_names()) or
                (f"; points built so far: {', '.join(built)}" if built else "; no point is built before this"))
        self._fail(where, src + detail, cls)


def _exact(x) -> str:
    """A number in full precision (the shortest text that reads back as the same float), so
    that a message never shows a value and a bound as equal when they differ: 0.4500000000000001."""
    text = repr(float(x))
    return text[:-2] if text.endswith(".0") else text
