"""An SX Function (s, p) over many sweep values at once, in compiled blocks: the C of
:mod:`.blocked_c` from the disk cache (:mod:`.compiled`), run over a stroke or over many cases.

:class:`BlockedFunction` pads a stroke to whole blocks and maps the library's ``NAME(s[1 x
BLOCK], p)`` over them (CasADi's map, through its buffer interface); the rows of many cases that
share the sweep values and differ only in the parameters the library was written for (a study's
axes: ``NAME_cases``, called through ctypes) in one call that does the work they share once per
block.  :func:`stroke_evaluator` gives it, or numpy's :class:`~.vectorised.VectorisedSX` while the
cache has no library.
"""
from __future__ import annotations

import ctypes
import hashlib

import casadi as ca
import numpy as np

from . import blocked_c, compiled
from .blocked_c import blocked_source, supports
from .vectorised import VectorisedSX

BLOCK = 64     # samples per block
CHUNK = 64     # blocks per mapped call over many cases (BlockedFunction.ragged)
# the blocks compiled at -O2, not FLAGS' -O1: the truck crane's model over its 161 samples 0.087 ->
# 0.025 ms per case (256 cases, compiled code alone; the same numbers bit for bit: no fast-math, no
# contraction), compiling its 18 kB of C 0.33 -> 0.42 s
LEVEL = "-O2"
_CASES_ARGS = (ctypes.c_void_p, ctypes.c_longlong, ctypes.c_void_p, ctypes.c_longlong, ctypes.c_longlong,
               ctypes.c_void_p, ctypes.c_void_p)


class BlockedFunction:
    """A library written by :func:`blocked_source` run over a row of sweep values: the row padded
    to whole blocks (with its last value), CasADi's map over the blocks through its buffer
    interface, the padding dropped.  Called like :class:`~.vectorised.VectorisedSX`: (s_row, p)
    -> {output name: array over the row}.  Not for concurrent use (one buffer per block count)."""

    def __init__(self, external: ca.Function, block: int = BLOCK, cases=None):
        """``cases``: (the library's ``NAME_cases`` through ctypes, the values of work it needs,
        the indices of the parameters it lets differ between cases), or None."""
        self.external, self.block = external, block
        self.names = [external.name_out(j) for j in range(external.n_out())]
        self._maps = {}
        self._cases = None
        if cases is not None:
            run, work, varied = cases
            fixed = np.setdiff1d(np.arange(external.nnz_in(1)), varied)
            self._cases = (run, np.empty(work), fixed)

    def __call__(self, s_row, p) -> dict:
        s = np.asarray(s_row, float).ravel()
        n = len(s)
        blocks = max(-(-n // self.block), 1)
        if blocks not in self._maps:
            mapped = self.external.map(f"{self.external.name()}_{blocks}", "serial", blocks, [1], [])
            buffer, run = mapped.buffer()
            s_in, p_in = np.zeros(blocks * self.block), np.zeros(self.external.nnz_in(1))
            buffer.set_arg(0, memoryview(s_in))
            buffer.set_arg(1, memoryview(p_in))
            self._maps[blocks] = (mapped, buffer, run, s_in, p_in)
        mapped, buffer, run, s_in, p_in = self._maps[blocks]
        s_in[:n] = s
        s_in[n:] = s[-1] if n else 0.0
        p_in[:] = np.asarray(p, float).ravel()
        outs = [np.empty(blocks * self.block) for _ in self.names]   # fresh: the caller keeps them
        for j, out in enumerate(outs):
            buffer.set_res(j, memoryview(out))
        run()
        return {name: out[:n] for name, out in zip(self.names, outs)}

    def many(self, s_row, P) -> dict:
        """{output name: array cases x sweep values}: the row ``s_row`` for every parameter row
        of ``P`` (cases x parameters), each case padded to whole blocks as :meth:`__call__` pads
        it, every block with its case's parameters: a case's numbers are those of its own call,
        whatever the other cases."""
        s = np.asarray(s_row, float).ravel()
        P = np.atleast_2d(np.asarray(P, float))
        return self._rows(np.broadcast_to(s, (len(P), len(s))), P, flat=False)

    def _rows(self, S, P, flat=True) -> dict:
        """{output name: values over ``S.ravel()``}: row i of ``S`` (cases x values) with the
        parameters ``P[i]``, each row in blocks of its own padded with its last value.  ``flat``
        False: each output cases x values, a view of the padded blocks (not copied: a batch's
        outputs are megabytes, each copy in fresh memory)."""
        cases, n = S.shape
        if self._cases is not None and cases > 1 and self._shared(S, P):
            return self._shared_rows(S[0], P, flat)
        per = max(-(-n // self.block), 1)
        rows = np.empty((cases, per * self.block))   # a case's blocks: its row padded with its last value
        rows[:, :n] = S
        rows[:, n:] = S[:, -1:] if n else 0.0
        outs = self._run(rows.reshape(-1), np.repeat(P, per, axis=0))
        if not flat:
            return {k: v.reshape(cases, per * self.block)[:, :n] for k, v in outs.items()}
        return {k: v.reshape(cases, per * self.block)[:, :n].reshape(-1) for k, v in outs.items()}

    def _shared(self, S, P) -> bool:
        """Whether the rows ``S`` are the same sweep values and the parameter rows ``P`` differ
        only where the library's ``NAME_cases`` lets them."""
        fixed = self._cases[2]
        return bool((S.strides[0] == 0 or np.array_equal(S, np.broadcast_to(S[0], S.shape)))
                    and np.array_equal(P[:, fixed], np.broadcast_to(P[0, fixed], (len(P), len(fixed)))))

    def _shared_rows(self, s, P, flat) -> dict:
        """:meth:`_rows` of the row ``s`` for every parameter row of ``P`` in one call of
        ``NAME_cases``: the row padded as each case's is, the work that depends on the sweep value
        alone done once per block, the rest per case; each value on the same operands as in
        ``NAME`` (the same numbers)."""
        run, work, _ = self._cases
        n, cases = len(s), len(P)
        width = max(-(-n // self.block), 1) * self.block
        row = np.empty(width)
        row[:n] = s
        row[n:] = s[-1] if n else 0.0
        P = np.ascontiguousarray(P, float)
        outs = [np.empty((cases, width)) for _ in self.names]
        res = np.array([o.ctypes.data for o in outs], dtype=np.uintp)
        run(row.ctypes.data, width, P.ctypes.data, cases, P.shape[1], res.ctypes.data, work.ctypes.data)
        return {k: v[:, :n].reshape(-1) if flat else v[:, :n] for k, v in zip(self.names, outs)}

    def ragged(self, s, counts, P) -> dict:
        """{output name: array over ``s``}: the first ``counts[0]`` values of ``s`` with the
        parameters ``P[0]``, the next ``counts[1]`` with ``P[1]``, ...: each case's values in
        blocks of its own (padded with its last value), mapped calls of at most CHUNK blocks."""
        s = np.asarray(s, float).ravel()
        counts = np.asarray(counts, int)
        P = np.atleast_2d(np.asarray(P, float))
        if len(counts) and counts[0] > 0 and np.all(counts == counts[0]):   # as many values each: many()'s layout
            return self._rows(s.reshape(len(counts), counts[0]), P)
        block = self.block
        per = -(-counts // block)
        first = np.cumsum(per) - per
        ends = np.cumsum(counts)
        case = np.repeat(np.arange(len(counts)), counts)
        where = first[case] * block + np.arange(len(s)) - (ends - counts)[case]
        last = np.where(counts > 0, s[np.maximum(ends - 1, 0)] if len(s) else 0.0, 0.0)
        s_in = np.repeat(last, per * block)
        s_in[where] = s
        return {name: values[where] for name, values in self._run(s_in, np.repeat(P, per, axis=0)).items()}

    def _run(self, s_in, p_in) -> dict:
        """{output name: values over ``s_in``} (whole blocks; block j with the parameters
        ``p_in[j]``), in mapped calls of CHUNK blocks that read and write the arrays in place,
        the rest of at most CHUNK blocks through :meth:`_blocks`."""
        block, total = self.block, len(p_in)
        outs = {name: np.empty(total * block) for name in self.names}
        full = total // CHUNK * CHUNK
        if full:
            buffer, run = self._direct()
            p_in = np.ascontiguousarray(p_in)
            for start in range(0, full, CHUNK):
                at = slice(start * block, (start + CHUNK) * block)
                buffer.set_arg(0, memoryview(s_in[at]))
                buffer.set_arg(1, memoryview(p_in[start:start + CHUNK].reshape(-1)))
                for j, name in enumerate(self.names):
                    buffer.set_res(j, memoryview(outs[name][at]))
                run()
        if full < total:
            part = self._blocks(s_in[full * block:], p_in[full:])
            for name, values in part.items():
                outs[name][full * block:] = values
        return outs

    def _direct(self):
        """The mapped Function of CHUNK blocks whose buffer :meth:`_run` points at its arrays."""
        if "direct" not in self._maps:
            mapped = self.external.map(f"{self.external.name()}_blocks_{CHUNK}", "serial", CHUNK, [], [])
            self._maps["direct"] = mapped.buffer()
        return self._maps["direct"]

    def _blocks(self, s_in, p_rows) -> dict:
        """The outputs over whole blocks ``s_in``, block j with the parameters ``p_rows[j]`` (at
        most CHUNK blocks: one mapped Function per power of two of blocks, the call padded)."""
        n = len(p_rows)
        size = 1 << max(n - 1, 0).bit_length()
        if ("chunk", size) not in self._maps:
            mapped = self.external.map(f"{self.external.name()}_blocks_{size}", "serial", size, [], [])
            buffer, run = mapped.buffer()
            s_buf, p_buf = np.zeros(size * self.block), np.zeros(size * self.external.nnz_in(1))
            outs = [np.zeros(size * self.block) for _ in self.names]
            buffer.set_arg(0, memoryview(s_buf))
            buffer.set_arg(1, memoryview(p_buf))
            for j, out in enumerate(outs):
                buffer.set_res(j, memoryview(out))
            self._maps[("chunk", size)] = (buffer, run, s_buf, p_buf, outs)
        buffer, run, s_buf, p_buf, outs = self._maps[("chunk", size)]
        s_buf[:len(s_in)], s_buf[len(s_in):] = s_in, s_in[-1]
        p_buf[:p_rows.size] = p_rows.ravel()
        p_buf[p_rows.size:] = np.tile(p_rows[-1], size - n)
        run()
        return {name: out[:n * self.block].copy() for name, out in zip(self.names, outs)}


def stroke_evaluator(func: ca.Function, wait: bool | None = None, varied=()):
    """The fastest evaluator of ``func`` (s, p) over a whole stroke that is at hand: the
    compiled blocks from the disk cache (:mod:`.compiled`; on a miss they are compiled, in the
    background unless ``wait``), else numpy's :class:`~.vectorised.VectorisedSX`, else None
    (MX graphs: CasADi's map).  ``varied``: the indices of the parameters that differ between the
    cases of a batch (a study's axes): the library then also runs many cases that share their
    sweep values doing their shared work once (its name, and so its key, says which)."""
    if supports(func):
        varied = sorted({int(i) for i in varied})
        name = "optdesign_blocked"
        if varied:
            name = "optdesign_cases_" + hashlib.sha256(repr(varied).encode()).hexdigest()[:16]

        def load(path):
            external = ca.external(name, path)
            if not varied:
                return external, None
            try:
                library = ctypes.CDLL(path)
            except OSError as exc:   # (compiled._load: rebuilt next time)
                raise RuntimeError(str(exc)) from exc
            run = library[f"{name}_cases"]
            run.argtypes, run.restype = _CASES_ARGS, ctypes.c_int
            work = library[f"{name}_cases_work"]
            work.restype = ctypes.c_longlong
            return external, (run, int(work()), varied)

        made = compiled.external(func, name, lambda n: blocked_source(func, n, BLOCK, varied=varied or None), wait,
                                 LEVEL, load, code=(blocked_c.__file__, __file__))
        if made is not None:
            return BlockedFunction(made[0], BLOCK, made[1])
        if varied:   # (being compiled: the plain library where the cache holds it, the same numbers)
            return stroke_evaluator(func, wait)
    try:
        return VectorisedSX(func)
    except NotImplementedError:
        return None
