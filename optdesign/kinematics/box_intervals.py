"""Interval evaluation of a CasADi SX Function over boxes: every input an interval.

:class:`~.enclosure.IntervalProgram` takes intervals of the sweep value with the parameters as
points; this one takes each input's every entry as an interval, so that a Function of (s, x)
can be enclosed over a box of design variables x (:mod:`optdesign.design.energy_bound`).  Each
operation is :mod:`.intervals`' (outward rounded, NaN where undefined on the whole interval);
``jump`` marks, per evaluation, that some operation's outcome was not decided over its
operands (a comparison, sign, if_else, floor or atan2 across its branch cut): the plain
enclosure holds there, a mean-value form (which needs a differentiable function) does not.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from .intervals import _binary, _unary
from .enclosure import _BINARY_OPS, _UNARY_OPS, _name


class BoxProgram:
    """An SX Function's instructions, run in interval arithmetic over arrays of boxes."""

    def __init__(self, func: ca.Function):
        if not func.is_a("SXFunction"):
            raise NotImplementedError("the graph is not SX")
        self.func = func
        self.shapes = [func.size1_out(j) for j in range(func.n_out())]
        self.rows = [func.sparsity_out(j).row() for j in range(func.n_out())]
        self.program = []
        for k in range(func.n_instructions()):
            op = func.instruction_id(k)
            if op not in (ca.OP_INPUT, ca.OP_OUTPUT, ca.OP_CONST) and op not in _BINARY_OPS and op not in _UNARY_OPS:
                raise NotImplementedError(f"operation {_name(op)} has no interval enclosure here")
            const = float(func.instruction_constant(k)) if op == ca.OP_CONST else None
            self.program.append((op, func.instruction_input(k), func.instruction_output(k), const))
        self.n_work = func.sz_w()

    def __call__(self, inputs):
        """``inputs``: per input of the Function, (lo, hi) arrays of shape (entries, n): n boxes.
        Returns (per output, (lo, hi) arrays (rows, n)) and ``jump`` (n,) bool."""
        n = inputs[0][0].shape[1]
        work = [None] * self.n_work
        out = [(np.full((m, n), np.nan), np.full((m, n), np.nan)) for m in self.shapes]
        jump = np.zeros(n, bool)
        with np.errstate(all="ignore"):
            for op, i, o, const in self.program:
                if op == ca.OP_INPUT:
                    lo, hi = inputs[i[0]]
                    work[o[0]] = (lo[i[1]], hi[i[1]])
                elif op == ca.OP_CONST:
                    work[o[0]] = (np.full(n, const), np.full(n, const))
                elif op == ca.OP_OUTPUT:
                    row = self.rows[o[0]][o[1]]
                    out[o[0]][0][row], out[o[0]][1][row] = work[i[0]]
                else:
                    if op in _BINARY_OPS:
                        (a, b), (c, d) = work[i[0]], work[i[1]]
                        lo, hi, und = _binary(op, a, b, c, d)
                    else:
                        lo, hi, und = _unary(op, *work[i[0]])
                    work[o[0]] = (np.broadcast_to(lo, (n,)), np.broadcast_to(hi, (n,)))
                    if und is not None:
                        jump |= np.broadcast_to(und, (n,))
        return out, jump
