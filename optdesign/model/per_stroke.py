"""The per-stroke constraints of an analysis (``max(length(D, B)) / min(length(D, B)) <= 1.7``)
over many cases at once, on arrays.

Each one-argument max(...)/min(...) and each start(...)/end(...) in a per-stroke constraint is a
value over the stroke of a per-sample expression: that expression is a row of the model
(evaluated with its columns, over cases x samples), and the rest of the constraint is a graph of
those values and the parameters, one compiled Function called over all cases.  The aggregates
over the samples give the sampled value; with the certified analysis, the extrema that the
certificate located (the sweep values it returns for each aggregate) join the samples, so that
max(...) and min(...) take their continuous values, and start()/end() keep the stroke's ends."""
from __future__ import annotations

import casadi as ca
import numpy as np

from ..scene.expressions import AGGREGATES, GEOMETRIC, STROKE_ENDS, BinOp, Call, Expression, Name, Neg, evaluate
from .quantities import environment, model_value


def _is_aggregate(node) -> bool:
    return isinstance(node, Call) and (node.func in STROKE_ENDS or (node.func in AGGREGATES and len(node.args) == 1))


class StrokeConstraints:
    """The per-stroke constraints ``constraints`` of a :class:`~.reduction.ReducedModel`:
    :attr:`rows` (column name -> per-sample graph, for the model's Function), then
    :meth:`values` over cases."""

    def __init__(self, model, constraints):
        mech = model.mech
        self.names = [c.name for c in constraints]
        self.rows, self.calls = {}, []   # calls: per constraint [(func, column name)]
        trees = []
        for c in constraints:
            calls = []

            def replace(node):
                if _is_aggregate(node):   # its per-sample expression: a row; here a name for its value
                    key = f"stroke:{len(self.rows)}"
                    inner = Expression(f"{node.func}(...) in {c.expr.source}", node.args[0])
                    self.rows[key] = model_value(model, inner, f"[[constraints]] {c.name}") + 0 * mech.s
                    calls.append((node.func, key))
                    return Name(key)
                if isinstance(node, BinOp):
                    return BinOp(node.op, replace(node.left), replace(node.right))
                if isinstance(node, Neg):
                    return Neg(replace(node.operand))
                if isinstance(node, Call) and node.func not in GEOMETRIC:
                    return Call(node.func, tuple(replace(a) for a in node.args))
                return node

            trees.append(replace(c.expr.tree))
            self.calls.append(calls)
        values = mech.sym.sym("aggregates", len(self.rows))   # one vector (an MX Function's input too)
        env = dict(environment(model), **{key: values[i] for i, key in enumerate(self.rows)})
        outer = [evaluate(Expression(c.expr.source, tree), env, mech.points, f"[[constraints]] {c.name}")
                 for c, tree in zip(constraints, trees)]
        self.keys = [key for calls in self.calls for _, key in calls]
        self.function = ca.Function("per_stroke", [values, mech.p], [ca.vertcat(*outer)])
        self._maps = {}

    def values(self, columns, P, extra=None) -> np.ndarray:
        """The constraints' values (cases x constraints) from the aggregates' rows over the
        samples, ``columns`` (name -> cases x samples).  ``extra``: per case None or its
        aggregate rows at the located sweep values that join its samples (rows x located)."""
        P = np.atleast_2d(np.asarray(P, float))
        A = np.empty((len(self.keys), len(P)))
        funcs = [func for calls in self.calls for func, _ in calls]
        for i, (func, key) in enumerate(zip(funcs, self.keys)):
            v = columns[key]
            A[i] = v[:, 0] if func == "start" else v[:, -1] if func == "end" else \
                np.max(v, axis=1) if func == "max" else np.min(v, axis=1)
        cases = [case for case, more in enumerate(extra or ()) if more is not None and more.shape[1]]
        if cases:   # each case's located values joined to its max/min (exact: in any order)
            joined = np.concatenate([extra[case] for case in cases], axis=1)
            starts = np.cumsum([0] + [extra[case].shape[1] for case in cases[:-1]])
            for i, func in enumerate(funcs):
                if func == "max":
                    A[i, cases] = np.maximum(A[i, cases], np.maximum.reduceat(joined[i], starts))
                elif func == "min":
                    A[i, cases] = np.minimum(A[i, cases], np.minimum.reduceat(joined[i], starts))
        n = len(P)
        if n not in self._maps:
            self._maps[n] = self.function.map(n)
        return np.asarray(self._maps[n](A, P.T), float).reshape(len(self.names), n).T
