"""Screening many designs at once: the NLP's own rows and objective at thousands of candidate
designs, evaluated with numpy one CasADi instruction at a time over all candidates.

CasADi's virtual machine runs a Function's instruction list once per design; here the loop is
turned inside out (as :mod:`optdesign.model.vectorised` does over the stroke): each instruction
is one numpy operation over all designs, so the NLP's rows at 4096 designs cost about as much
as a few hundred evaluations in the virtual machine.  Same graph, same operations, so the
same numbers to round-off.  A Function that is not SX (or has an operation without a numpy
counterpart) is expanded to SX first, else evaluated by CasADi's map; its instructions are kept in
the cache folder (:mod:`optdesign.model.programs`).
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from ..model import programs_c
from ..model.programs import _program, cached_rows
from ..model.vectorised import run_program


class ManyDesigns:
    """A CasADi Function evaluated at many columns of its inputs: ``f(*inputs)`` with each
    input an array (its nonzeros x columns; a 1-D array is the same for every column) gives
    each output as an array (its entries x columns, dense, column-major)."""

    def __init__(self, func: ca.Function):
        self.func = func
        self.program = self._c = self._rows = None
        try:   # (from the cache folder when a run made it before: model/programs.py)
            self.n_work, rows, constants = cached_rows(func)
        except (NotImplementedError, RuntimeError):
            rows = None
        if rows is not None:
            self._rows = (rows, constants)
            self._c = {}   # which inputs are given per column -> programs_c.program(...) or None
        self._maps = {}

    def _numpy_program(self):
        if self.program is None and self._rows is not None:
            made = _program(*self._rows, self.n_work)
            self.program = None if made is None else made[1]
        return self.program

    def _compiled(self, per_column):
        """The C of :mod:`optdesign.model.programs_c` for inputs given per column as ``per_column``
        (the same numbers as the numpy loop), or None."""
        if per_column not in self._c:
            made = programs_c.program(*self._rows, self.n_work, per_column)
            if made is None and programs_c.pending():
                return None   # (not compiled yet: asked again at the next call)
            self._c[per_column] = made
        return self._c[per_column]

    def __call__(self, *inputs) -> list:
        f = self.func
        m = max((np.shape(a)[1] for a in inputs if np.ndim(a) == 2), default=1)
        columns = [np.asarray(a, float) if np.ndim(a) == 2 else np.asarray(a, float).reshape(-1, 1)
                   for a in inputs]
        if self._rows is not None and m > 1:
            per_column = tuple(c.shape[1] > 1 for c in columns)
            made = self._compiled(per_column)
            if made is not None:
                outs = [np.zeros((f.numel_out(j), m)) for j in range(f.n_out())]
                inputs = [c if wide else c[:, 0] for c, wide in zip(columns, per_column)]
                if made[0](made[1], inputs, outs, [f.sparsity_out(j).find() for j in range(f.n_out())]):
                    return outs
        if self._numpy_program() is None:
            if m not in self._maps:
                self._maps[m] = f.map(m)
            return [np.asarray(o) for o in self._maps[m](*[np.broadcast_to(c, (c.shape[0], m)) for c in columns])]
        outs = []
        for j in range(f.n_out()):
            outs.append(np.zeros((f.numel_out(j), m)))
        where = [f.sparsity_out(j).find() for j in range(f.n_out())]

        def store(j, k, value):
            outs[j][where[j][k]] = value

        run_program(self.program, self.n_work, lambda i, k: columns[i][k], store)
        return outs
