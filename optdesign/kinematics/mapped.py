"""A CasADi Function (s, p) evaluated at many sweep values, with one parameter vector or a
parameter row per value, through CasADi's buffer interface (no DM conversions): how the assembly
check, the model's analyses, the design problem and its solver evaluate per-sample quantities and
their s-derivatives."""
from __future__ import annotations

import casadi as ca
import numpy as np

from ..errors import check_interrupt

PER_POINT_CHUNK = 1024   # values per mapped call with a parameter row per value at most


class MappedFunction:
    """A CasADi Function (s, p) evaluated at a row of sweep values with one parameter vector.

    CasADi's map over the values, called through its buffer interface: the arguments and
    results are numpy arrays it reads and writes in place, so a call costs the evaluation
    alone (about 3 us for the quantities and their s-derivatives at one s) instead of the
    ~40 us of converting to and from DM; the numbers are CasADi's own.  One mapped Function
    and buffer per number of values, built on first use (cheap).  Not for concurrent use: a
    DesignProblem (with the problems with_bounds derives from it) and each Solver has its own,
    and they belong to one thread (studies build per thread; parallel starts fork).

    ``compile``: a function that returns ``func`` compiled, or None (the model's layer passes
    :func:`optdesign.model.mapped.compiled_function`: the Function from the disk cache of
    compiled code when it is there; on a miss it is compiled in the background and this run
    uses CasADi's virtual machine): the same numbers, several times faster."""

    def __init__(self, func: ca.Function, compile=None):
        self.func = func
        if compile is not None:
            self.func = compile(func) or func
        self._maps = {}
        # the buffers hold an output's structural nonzeros only: where they go in the dense
        # output (column-major), per output
        self._dense = [(func.size1_out(j), func.sparsity_out(j).find()) for j in range(func.n_out())]
        self._n_p = func.nnz_in(1) if func.n_in() > 1 else 0
        self._buffered = (all(func.sparsity_in(j).is_dense() for j in range(func.n_in()))
                          and all(func.size2_out(j) == 1 for j in range(func.n_out())))

    def __call__(self, s, p) -> list:
        """Every output at every value of ``s``: a list of arrays (output rows x len(s)).  ``p``:
        the parameter vector, or an array len(s) x parameters of each value's own (many cases'
        points in one call: the same numbers, point by point, as a call per case)."""
        s = np.asarray(s, float).ravel()
        n = len(s)
        p = np.asarray(p, float)
        if p.ndim == 2:
            return self._per_point(s, p)
        mapped, buffer, run, s_in, p_in, outs = self._mapped(n)
        if self._buffered:
            s_in[:] = s
            p_in[:] = p.ravel()
            try:
                run()
                if buffer.ret() == 0:
                    return [self._densify(o, j, n) for j, o in enumerate(outs)]
            except RuntimeError as exc:
                check_interrupt(exc)   # a Ctrl-C, not a failed evaluation (errors.py)
        # CasADi's ordinary call: it reports a failure (or returns its NaNs) as it always has
        return [np.asarray(o) for o in mapped(s[None, :], p)]

    def _per_point(self, s, p):
        """As __call__ with a parameter row per value: mapped over both inputs, in calls of a
        power of two values (padded with the last value: one mapped Function per size)."""
        n = len(s)
        if p.shape != (n, self._n_p):
            raise ValueError(f"p: one row of {self._n_p} parameters per value ({n}); got {p.shape}")
        if not n:
            return [np.zeros((self.func.size1_out(j), 0)) for j in range(self.func.n_out())]
        if n > PER_POINT_CHUNK:   # in pieces: less padding (each value on its own)
            parts = [self._per_point(s[i:i + PER_POINT_CHUNK], p[i:i + PER_POINT_CHUNK])
                     for i in range(0, n, PER_POINT_CHUNK)]
            return [np.concatenate(a, axis=1) for a in zip(*parts)]
        size = max(8, 1 << (n - 1).bit_length())
        key = ("per point", size)
        if key not in self._maps:
            mapped = self.func.map(f"{self.func.name()}_pp{size}", "serial", size, [], [])
            buffer, run = mapped.buffer()
            s_in, p_in = np.zeros(size), np.zeros(size * self.func.nnz_in(1))
            outs = [np.zeros(mapped.nnz_out(j)) for j in range(mapped.n_out())]
            buffer.set_arg(0, memoryview(s_in))
            buffer.set_arg(1, memoryview(p_in))
            for j, out in enumerate(outs):
                buffer.set_res(j, memoryview(out))
            self._maps[key] = (mapped, buffer, run, s_in, p_in.reshape(size, -1), outs)
        mapped, buffer, run, s_in, p_rows, outs = self._maps[key]
        if not self._buffered:
            return [np.asarray(o)[:, :n] for o in mapped(np.r_[s, np.full(size - n, s[-1])][None, :],
                                                        np.r_[p, np.repeat(p[-1:], size - n, axis=0)].T)]
        s_in[:n], s_in[n:] = s, s[-1]
        p_rows[:n], p_rows[n:] = p, p[-1]
        try:
            run()
            if buffer.ret() == 0:
                return [self._densify(o, j, size)[:, :n] for j, o in enumerate(outs)]
        except RuntimeError as exc:
            check_interrupt(exc)
        return [np.asarray(o)[:, :n] for o in mapped(s_in[None, :], p_rows.T)]

    def _densify(self, nonzeros, j, n):
        """Output j (rows x n, dense) from the n evaluations' structural nonzeros."""
        rows, where = self._dense[j]
        if len(where) == rows:  # a dense column: the nonzeros are the output itself
            return nonzeros.reshape(n, rows).T.copy()
        dense = np.zeros((n, rows))
        dense[:, where] = nonzeros.reshape(n, len(where))
        return dense.T

    def _mapped(self, n):
        if n not in self._maps:
            mapped = self.func.map(f"{self.func.name()}_{n}", "serial", n, [1], [])
            buffer, run = mapped.buffer()
            s_in, p_in = np.zeros(n), np.zeros(self.func.nnz_in(1))
            outs = [np.zeros(mapped.nnz_out(j)) for j in range(mapped.n_out())]
            buffer.set_arg(0, memoryview(s_in))
            buffer.set_arg(1, memoryview(p_in))
            for j, out in enumerate(outs):
                buffer.set_res(j, memoryview(out))
            self._maps[n] = (mapped, buffer, run, s_in, p_in, outs)
        return self._maps[n]
