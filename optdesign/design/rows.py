"""The per-sample quantities of the design problem: one row per quantity, all evaluated
together at any sweep value.

In order: the objective's quantity (peak(NAME) or rms(NAME); for a peak of the drive load or
power also its numerator and denominator, so that the epigraph needs no division by k =
dq/ds), each per-sample constraint, the inner expression of each stroke aggregate
max(...)/min(...), each assembly margin, and k itself.  A :class:`Block` names a family of rows
with its bounds; an :class:`Aggregate` is a max/min over the stroke that the NLP replaces by
an epigraph variable (:func:`lift` takes them out of an expression).

The functions take the problem (``pb``: a :class:`~optdesign.design.problem.DesignProblem`,
which imports this module; hence no annotation) and read or set its attributes.
"""
from __future__ import annotations

import math
import re
import sys
from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..errors import ExpressionError, SceneError
from ..model.certified import InTime
from ..kinematics.mapped import MappedFunction
from ..model.cse import cse_derived
from ..model.mapped import compiled_function
from ..model.quantities import model_value
from ..scene.expressions import Call, Expression, Name, parse
from ..scene.cases import is_case_constraint
from ..scene.where import near_miss
from .bounds import numeric_bounds
from .cases import case_constraint_rows, case_objective_rows, in_sweep


@dataclass(frozen=True)
class Block:
    """A named family of per-sample quantities with bounds (scaled)."""

    name: str
    kind: str       # 'peak', 'constraint', 'aggregate', 'margin', 'dead centre'
    index: int      # row in the per-sample quantity vector
    lower: float    # bounds in physical units (+-inf when open); the NLP's rows are
    upper: float    # quantity/scale in [lower/scale, upper/scale]; for 'peak' unused
    scale: float


@dataclass
class Aggregate:
    """A value per stroke, replaced by a variable of the NLP: a one-argument max/min over the
    stroke (an epigraph, or its located extreme: see :mod:`.nlp`), or the value at the stroke's
    start or end."""

    name: str
    func: str          # 'max', 'min', 'start' or 'end'
    inner: Expression
    index: int = -1    # row of its inner expression in the per-sample vector
    scale: float = 1.0


_OBJECTIVE = re.compile(r"^\s*(peak|rms_sweep|rms)\s*\(\s*(.+?)\s*\)\s*$")  # rms = rms_sweep (over s)


def build_quantities(pb):
    """The problem's per-sample quantity rows and what they mean.  Sets on ``pb``: rows,
    blocks, aggregates, the objective's form (objective_text, objective_kind,
    objective_quantity, objective_fraction, objective_expr), stroke_constraints,
    constant_margins, k_row, and the CasADi functions quantity (and _quantity_many, at many
    samples), quantity_derivatives (v, dv/ds, d2v/ds2) with _dv."""
    scene, mech = pb.scene, pb.mech
    outputs = pb.model.outputs()
    rows, pb.blocks, pb.aggregates = [], [], []
    pb.objective_text = scene.objective.minimise
    m = _OBJECTIVE.match(pb.objective_text)
    pb.objective_quantity = pb.objective_fraction = None
    if scene.cases and case_objective_rows(pb, rows, Block, lambda: _k_ref_start(pb)):  # load cases (design/cases.py)
        pass
    elif m:
        pb.objective_kind, what = m.group(1).replace("rms_sweep", "rms"), m.group(2)
        expr = outputs.get(what)
        if expr is None:
            missing = _missing_output(pb, what, outputs)
            if missing:
                raise ExpressionError(f"{scene.path}: [objective] minimise = {pb.objective_text!r}: unknown "
                                      f"name {what!r}{near_miss(what, set(outputs))}: {missing}")
            expr = model_value(pb.model, parse(what, f"{scene.path}: [objective] minimise"),
                               f"{scene.path}: [objective] minimise")
        pb.objective_quantity = len(rows)
        rows.append(expr)
        if what in ("drive", "power") and pb.objective_kind == "peak":
            k_ref = _k_ref_start(pb)
            numerator, denominator = pb.model.drive_numerator(k_ref)
            if what == "power":
                numerator = numerator * pb.model.qd
            pb.objective_fraction = (len(rows), len(rows) + 1)
            rows += [numerator, denominator]
        pb.blocks.append(Block(pb.objective_text, "peak" if pb.objective_kind == "peak" else "rms",
                               0, -math.inf, math.inf, 1.0))
    else:
        pb.objective_kind = "expression"
        pb.objective_expr = lift(pb, parse(pb.objective_text, f"{scene.path}: [objective] minimise"), "objective")
        if not pb.aggregates:
            parsed = parse(pb.objective_text, f"{scene.path}: [objective] minimise")
            plain = not parsed.points() and mech.resolved.sweep_name not in parsed.names()
            hint = (f"; an expression of parameters alone (a design variable's size) is written "
                    f"\"start({pb.objective_text})\"" if plain else "")
            raise SceneError(
                f"{scene.path}: [objective] minimise = {pb.objective_text!r}: expected peak(NAME), "
                "rms(NAME) or an expression over the stroke with max(...)/min(...)/start(...)/end(...), "
                f"e.g. \"max(y(T)) - min(y(T))\"{hint}"
            )
    pb.stroke_constraints = []
    for c in scene.constraints:
        if is_case_constraint(scene, c):  # per load case: design/cases.py
            continue
        if c.expr.is_aggregate:
            pb.stroke_constraints.append((c, lift(pb, c.expr, c.name)))
        else:
            lo, hi = numeric_bounds(mech.resolved, c)
            expr = model_value(pb.model, c.expr, f"[[constraints]] {c.name}")
            # a constraint on the design alone (no dependence on the sweep) is one row,
            # not one per sample point (repeated rows would be degenerate)
            kind = "constraint" if ca.depends_on(expr, mech.s) else "design constraint"
            pb.blocks.append(Block(c.name, kind, len(rows), lo, hi, 1.0))
            rows.append(expr)
    case_constraint_rows(pb, rows, Block)  # the drive train's, per load case (design/cases.py)
    for a in pb.aggregates:
        a.index = len(rows)
        rows.append(model_value(pb.model, a.inner, a.name))
    # a construction that does not move with the sweep has one margin, not one per point
    # (repeated rows would be degenerate and cost time)
    pb.constant_margins = set()
    for margin in mech.margins:
        if margin.kind == "loop":
            continue
        if not ca.depends_on(margin.expr, mech.s):
            pb.constant_margins.add(len(rows))
        pb.blocks.append(Block(f"assembly of {margin.construction}", "margin", len(rows), 0.0, math.inf, 1.0))
        rows.append(margin.expr)
    pb.k_row = len(rows)
    rows.append(pb.model.k)
    pb.in_time = rows_in_time(pb, rows)
    pb.rows = rows = in_sweep(pb, rows)   # the cases' laws in time through their inverse tau(s)
    pb.quantity = mech.function("quantities", {"v": ca.vertcat(*rows)})
    pb._quantity_many = MappedFunction(pb.quantity, compile=compiled_function)  # at many samples (evaluate_grid)
    v = ca.vertcat(*rows)
    dv = mech.ds(v)
    pb.quantity_derivatives = _derivatives(mech, v, dv)
    pb._dv = dv


def _derivatives(mech, v, dv) -> ca.Function:
    """(s, p) -> (v, dv/ds, d2v/ds2) of the rows ``v`` (with ``dv`` = dv/ds), common
    subexpressions eliminated: from the cache folder keyed by the graph of ``v`` and this code
    (:func:`~optdesign.model.cse.cse_derived`), not by the graph of all three outputs, which is
    then not built on a hit (crane_luffing_drive: 7,600 instructions against 74,000, whose
    serialization alone took 0.15 s of every motor's build).  The same Function."""
    def outputs():
        return [v, dv, mech.ds(dv)]
    if mech.sym is ca.SX and mech.cse_function is not None:
        return cse_derived("quantities_ds", [mech.s, mech.p], v, outputs, ["s", "p"], ["v", "dv", "d2v"],
                           code=(__file__, sys.modules[type(mech).__module__].__file__))
    return mech.function("quantities_ds", dict(zip(("v", "dv", "d2v"), outputs())))


def rows_in_time(pb, rows) -> list:
    """Per case along a law in time (``pb.case_times``: its symbol tau in the rows, design/cases.py):
    (:class:`~optdesign.model.certified.InTime` of the rows that hold its tau and no other one,
    their indices), for the continuous check's enclosure in the law's time."""
    out = []
    times = getattr(pb, "case_times", ())
    for tau, profile in times:
        others = [t for t, _ in times if t is not tau]
        index = [i for i, r in enumerate(rows)
                 if ca.depends_on(r, tau) and not any(ca.depends_on(r, t) for t in others)]
        if index:
            out.append((InTime(pb.mech, ca.vertcat(*[rows[i] for i in index]), tau, profile), np.array(index)))
    return out


# the model's columns that a scene may not have, and why (model/reduction.py: ReducedModel.outputs)
_WHY_MISSING = {
    "power": "the drive's speed is 0 ([drive] speed), so no power flows; give [drive] a speed",
    "static_load": "no static load acts: no [gravity], and no body has a force or torque",
    "reduced_inertia": "no body has a mass or an inertia",
    "reduced_inertia_dq": "no body has a mass or an inertia",
    "inertia_term": "the drive's acceleration is 0 ([drive] acceleration) or no body has a mass",
    "velocity_term": "the drive's speed is 0 ([drive] speed) or no body has a mass",
    "efficiency_factor": "the drive has no efficiency below 1 ([drive] efficiency)",
}


def _missing_output(pb, what, outputs) -> str | None:
    """Why peak(NAME)'s NAME is none of this scene's model columns, with what exists; None when
    NAME is not a plain name, or names a parameter (an expression: evaluated as such)."""
    if (not re.fullmatch(r"[A-Za-z_]\w*", what) or what in pb.mech.resolved.values or what == pb.scene.sweep.name
            or any(q.name == what for q in pb.scene.quantities)):   # a quantity (of the joint forces, too)
        return None
    columns = ", ".join(sorted(outputs))
    why = _WHY_MISSING.get(what)
    head = (f"this scene's model has no {what!r} column because {why}" if why else
            f"it is no column of the model and no parameter")
    return (f"{head}; the columns here: {columns}; or an expression of the points and parameters, "
            "e.g. peak(length(D, B))")


def lift(pb, expr: Expression, where):
    """Replace one-argument max/min calls and start/end values by variables (appended to
    ``pb.aggregates``); return the outer tree."""

    def walk(node):
        if isinstance(node, Call):
            if (node.func in ("max", "min") and len(node.args) == 1) or node.func in ("start", "end"):
                name = f"__aggregate_{len(pb.aggregates)}"
                inner = Expression(f"{node.func}(...) in {where}", node.args[0])
                pb.aggregates.append(Aggregate(name, node.func, inner))
                return Name(name)
            return Call(node.func, tuple(walk(a) for a in node.args))
        for attr in ("left", "right", "operand"):
            if hasattr(node, attr):
                kwargs = {k: walk(getattr(node, k)) if k in ("left", "right", "operand") else getattr(node, k)
                          for k in node.__dataclass_fields__}
                return type(node)(**kwargs)
        return node

    return Expression(expr.source, walk(expr.tree))


def row_name(pb, row):
    """What a per-sample quantity row is, in the scene's words."""
    names = {b.index: b.name for b in pb.blocks}
    names.update({a.index: a.inner.source for a in pb.aggregates})
    if pb.objective_fraction is not None:
        names.update(dict(zip(pb.objective_fraction, ("the drive load times k^4", "k^4"))))
    names[pb.k_row] = "k = dq/ds"
    return names.get(row, f"row {row}")


def _k_ref_start(pb):
    """Median |k| = |dq/ds| over the stroke at the start design (a scale, not a bound)."""
    f = pb.mech.function("k", {"k": pb.model.k})
    k = np.asarray(f.map(len(pb.s_grid))(pb.s_grid[None, :], pb.mech.parameter_values)).ravel()
    return max(float(np.median(np.abs(k))), 1e-12)
