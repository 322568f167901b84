"""The reduced model's columns and the joint forces as names in a scene's [[constraints]] and
[objective] expressions.

- the columns ``static_load``, ``drive``, ... (:data:`optdesign.scene.cases.MODEL_COLUMNS`),
  e.g. a tailgate that holds itself open, ``end(static_load) <= -10``; a parameter of the same
  name wins (the scene's own names come first);
- the joint forces (:mod:`.joints`): ``pin_force(P)`` (the magnitude of the force at pin P),
  ``pin_force_x(P)``, ``pin_force_y(P)``, ``slider_normal(P)``, ``slider_moment(P)``, built
  for a model the first time an expression uses one; ``pin_force(P, Q)`` (and ``_x``, ``_y``)
  the force at pin P on the party that runs from P to the point Q.
"""
from __future__ import annotations

import casadi as ca

from ..errors import SceneError
from ..scene.cases import JOINT_FUNCTIONS, MODEL_COLUMNS, uses_joint_forces
from ..scene.expressions import Call, evaluate
from .joints import JointForces

def joint_forces(model) -> JointForces:
    """The model's joint forces, built once per model."""
    if getattr(model, "_joint_forces", None) is None:
        model._joint_forces = JointForces(model)
    return model._joint_forces


def joint_calls(expr) -> set:
    """The joint-force calls of ``expr``: {(function, point)}."""
    out = set()

    def walk(node):
        if isinstance(node, Call):
            if node.func in JOINT_FUNCTIONS:   # pin_force(P) or pin_force(P, Q): 'P' or 'P, Q'
                out.add((node.func, ", ".join(a.name for a in node.args)))
                return
            for a in node.args:
                walk(a)
        for attr in ("left", "right", "operand"):
            if hasattr(node, attr):
                walk(getattr(node, attr))

    walk(expr.tree)
    return out


def environment(model, expr=None) -> dict:
    """The mechanism's names (parameters, the sweep), the model's columns and, where ``expr``
    uses them, the joint forces, as graphs of (s, p)."""
    env = dict(model.mech.env)
    for name, column in model.outputs().items():
        if name in MODEL_COLUMNS and name not in env:
            env[name] = column
    if expr is not None:   # a [quantities] entry of the joint forces: the model's (the mechanism has none)
        for q in model.scene.quantities:
            if q.name in expr.names() and q.name not in env and uses_joint_forces(q.expr):
                env[q.name] = model_value(model, q.expr, f"[quantities] {q.name}")
    calls = joint_calls(expr) if expr is not None else set()
    if calls:
        outputs = joint_forces(model).outputs()
        for func, point in sorted(calls):
            if ", " in point:   # pin_force(P, Q): the force at P on the party that runs to Q
                f = joint_forces(model).party_force(*point.split(", "))
                env[f"{func}({point})"] = ca.sqrt(ca.sumsqr(f)) if func == "pin_force" else f["xy".index(func[-1])]
                continue
            pin = joint_forces(model).structure.same.get(point, point)
            name = f"{func}({pin})"
            if name not in outputs:
                kind = "slider" if func.startswith("slider") else "pin"
                known = sorted({k.split("(")[1][:-1] for k in outputs if k.startswith(kind) and ", " not in k})
                raise SceneError(f"{model.scene.path}: {expr.source!r}: {point!r} is no {kind} of the mechanism's "
                                 f"joint structure; its {kind}s: {', '.join(known) or 'none'}")
            env[f"{func}({point})"] = outputs[name]
    return env


def model_value(model, expr, where=""):
    """``expr`` evaluated in the model's graph: its points, names, columns and joint forces."""
    return evaluate(expr, environment(model, expr), model.mech.points, where)
