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

from ..errors import check_interrupt
from ..scene.expressions import AGGREGATES, GEOMETRIC, STROKE_ENDS, BinOp, Call, Expression, Name, Neg, evaluate
from .quantities import environment, model_value


CHUNK = 256   # cases per buffered call of the constraints' Function (StrokeConstraints._call)


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
        return self._call(A, P)

    def _call(self, A, P) -> np.ndarray:
        """:attr:`function` at each column of ``A`` with its row of ``P`` (cases x constraints):
        through CasADi's buffer interface in calls of CHUNK cases (the last padded with its last
        case; each case evaluated on its own), not its ordinary call, whose conversions to and
        from DM took ~1 ms per 256 cases against 0.035; the same numbers."""
        n = len(P)
        if "buffer" not in self._maps:
            self._maps["buffer"] = self._buffered()
        if self._maps["buffer"] is not None:
            _, buffer, run, a_in, p_in, out = self._maps["buffer"]
            result = np.empty((n, len(self.names)))
            for at in range(0, n, CHUNK):
                c = min(CHUNK, n - at)
                a_in[:c], a_in[c:] = A[:, at:at + c].T, A[:, at + c - 1]
                p_in[:c], p_in[c:] = P[at:at + c], P[at + c - 1]
                try:
                    run()
                except RuntimeError as exc:
                    check_interrupt(exc)   # a Ctrl-C, not a failed evaluation (errors.py)
                    break
                if buffer.ret() != 0:
                    break
                result[at:at + c] = out[:c]
            else:
                return result
        # CasADi's ordinary call: it reports a failure (or returns its NaNs) as it always has
        return np.asarray(self.function.map(n)(A, P.T), float).reshape(len(self.names), n).T

    def _buffered(self):
        """(the Function mapped over CHUNK cases, its buffer, run, its arguments' and result's
        arrays: cases x values, as CasADi lays out k x CHUNK), or None where an input or the output
        is not dense or empty (then its ordinary call)."""
        f = self.function
        sizes = (f.nnz_in(0), f.nnz_in(1), f.nnz_out(0))
        if not (all(sizes) and all(f.sparsity_in(j).is_dense() for j in range(2)) and f.sparsity_out(0).is_dense()):
            return None
        mapped = f.map(f"per_stroke_{CHUNK}", "serial", CHUNK, [], [])
        buffer, run = mapped.buffer()
        a_in, p_in, out = (np.zeros((CHUNK, k)) for k in sizes)
        buffer.set_arg(0, memoryview(a_in))
        buffer.set_arg(1, memoryview(p_in))
        buffer.set_res(0, memoryview(out))
        return mapped, buffer, run, a_in, p_in, out
