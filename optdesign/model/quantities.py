"""The reduced model's columns as names in a scene's [[constraints]] and [objective]
expressions: ``static_load``, ``drive``, ... (:data:`optdesign.scene.cases.MODEL_COLUMNS`),
e.g. a tailgate that holds itself open, ``end(static_load) <= -10``.  A parameter of the same
name wins (the scene's own names come first)."""
from __future__ import annotations

from ..scene.cases import MODEL_COLUMNS
from ..scene.expressions import evaluate


def environment(model) -> dict:
    """The mechanism's names (parameters, the sweep) and the model's columns, as graphs of (s, p)."""
    env = dict(model.mech.env)
    for name, expr in model.outputs().items():
        if name in MODEL_COLUMNS and name not in env:
            env[name] = expr
    return env


def model_value(model, expr, where=""):
    """``expr`` evaluated in the model's graph: its points, names and columns."""
    return evaluate(expr, environment(model), model.mech.points, where)
