"""[quantities]: named per-sample expressions of the mechanism, written once and used by name.

A quantity is an expression of the parameters, the sweep variable, the points (``length``,
``angle``, ``x``, ``y``) and earlier quantities, with a unit for the reports::

    [quantities]
    rocker = { expr = "angle(D, C) - angle(D, A)", unit = "rad" }
    ram = "y(C)"                   # no unit given: the reports show none

Wherever a body's load, a constraint or the objective names it, its expression stands in its
place: the scene's items are rewritten once, as the scene is made (:func:`expanded_items`:
the syntax trees with the quantity's tree for its name, the user's text kept for messages),
so the validation, the design problem and every check see the expression itself (a law
profile's speed too, which may use a quantity of the sweep and parameters alone); the
objective, read later as text, finds the quantities among the mechanism's names
(:class:`optdesign.kinematics.mechanism.Mechanism`).  ``analyse`` reports each quantity per
sample (the CSV's columns, the JSON's ``quantities`` with ``quantity_units``).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from .expressions import BinOp, Call, Expression, Name, Neg
from .values import check_name, parse_required, set_field
from .where import Where, fail, show

KEYS = ("expr", "unit")


@dataclass(frozen=True)
class Quantity:
    """A named per-sample expression with its unit (free text such as 'rad', 'm'; '' none)."""

    name: str
    expr: Expression
    unit: str = ""

    def __post_init__(self):
        where = Where("quantities", str(self.name))
        check_name(self.name, where, "quantity")
        set_field(self, "expr", parse_required(self.expr, where.at("expr"),
                                               "an expression per sample, e.g. \"angle(C, D, A)\""))
        if not isinstance(self.unit, str):
            fail(where.at("unit"), f"expected the unit as a string such as \"rad\" or \"m\", found {show(self.unit)}")


def read_quantities(data) -> list:
    """The [quantities] table: ``name = "expr"`` or ``name = { expr = "...", unit = "..." }``."""
    if not isinstance(data, dict):
        fail(Where("quantities"), f"expected a table of named expressions, e.g. rocker = \"angle(C, D, A)\", "
                                  f"found {show(data)}")
    out = []
    for name, spec in data.items():
        if isinstance(spec, dict):
            for key in spec:
                if key not in KEYS:
                    fail(Where("quantities", name, key), f"unknown key {key!r}; expected expr and unit")
            out.append(Quantity(name, spec.get("expr"), spec.get("unit", "")))
        else:
            out.append(Quantity(name, spec))
    return out


def expand(expr: Expression | None, trees: dict):
    """``expr`` with each quantity's name replaced by its tree (``trees``: name -> tree); its
    source text unchanged.  None stays None."""
    if expr is None or not trees or not (expr.names() & set(trees)):
        return expr
    return Expression(expr.source, _substitute(expr.tree, trees))


def _substitute(node, trees):
    if isinstance(node, Name):
        return trees.get(node.name, node)
    if isinstance(node, Neg):
        return Neg(_substitute(node.operand, trees))
    if isinstance(node, BinOp):
        return BinOp(node.op, _substitute(node.left, trees), _substitute(node.right, trees))
    if isinstance(node, Call) and node.func not in ("length", "angle", "x", "y"):
        return Call(node.func, tuple(_substitute(a, trees) for a in node.args))
    return node


def expanded_items(scene) -> dict:
    """The scene's fields that hold expressions using quantities, rewritten (see the module's
    docstring): the quantities themselves (each with the earlier ones put in), the bodies'
    loads, the constraints and the law profiles' speeds.  {} when the scene has no quantities."""
    if not scene.quantities:
        return {}
    trees, quantities = {}, []
    for q in scene.quantities:
        q = dataclasses.replace(q, expr=expand(q.expr, trees)) if isinstance(q, Quantity) else q
        quantities.append(q)
        if isinstance(q, Quantity):
            trees[q.name] = q.expr.tree
    bodies = []
    for b in scene.bodies:
        if not dataclasses.is_dataclass(b):
            bodies.append(b)
            continue
        changes = {k: expand(getattr(b, k), trees) for k in ("mass", "inertia", "torque")}
        changes.update({k: tuple(expand(e, trees) for e in getattr(b, k)) for k in ("com", "force")
                        if getattr(b, k) is not None})
        bodies.append(dataclasses.replace(b, **changes))
    constraints = [dataclasses.replace(c, expr=expand(c.expr, trees)) if dataclasses.is_dataclass(c) else c
                   for c in scene.constraints]
    profiles = [_law_expanded(p, trees) for p in scene.profiles]   # a law's speed (inline in a case too)
    cases = [dataclasses.replace(c, profile=_law_expanded(c.profile, trees))
             if dataclasses.is_dataclass(c) and dataclasses.is_dataclass(c.profile) else c for c in scene.cases]
    return {"quantities": tuple(quantities), "bodies": tuple(bodies), "constraints": tuple(constraints),
            "profiles": tuple(profiles), "cases": tuple(cases)}


def uses_points(expr) -> bool:
    """True when ``expr`` calls length, angle, x or y of points."""
    def walk(node):
        if isinstance(node, Call):
            return node.func in ("length", "angle", "x", "y") or any(walk(a) for a in node.args)
        if isinstance(node, Neg):
            return walk(node.operand)
        if isinstance(node, BinOp):
            return walk(node.left) or walk(node.right)
        return False
    return walk(expr.tree)


def _law_expanded(profile, trees):
    """A profile of kind 'law' with the quantities in its speed expression put in."""
    if getattr(profile, "kind", None) != "law" or getattr(profile, "speed", None) is None:
        return profile
    return dataclasses.replace(profile, speed=expand(profile.speed, trees))
