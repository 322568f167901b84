"""The interval programs of the certificate (:mod:`optdesign.kinematics.enclosure`) compiled to
C through the disk cache (:mod:`.compiled`), called on whole arrays of intervals.

:func:`compile_program` wraps an :class:`~optdesign.kinematics.enclosure.IntervalProgram` in a
:class:`CompiledProgram`, called as the program is (intervals [lo, hi], parameters, rows) and
giving the same arrays; its C (:mod:`optdesign.kinematics.interval_c`) does the same interval
operations with the same outward rounding.  While the library is not there (the first run of a
program: it is compiled in the background as the models are, ``OPTDESIGN_COMPILE``), without a
C compiler, or with ``OPTDESIGN_INTERVALS=numpy``, the numpy program runs.

Parameters may be one vector for every interval or one row per interval (an array of shape
intervals x parameters): a study's cases stacked into one call.  Then the work that depends on
s but on none of the parameters that differ between the rows (a study that varies masses and
loads: the kinematics) is done once per distinct interval, and only the rest per row, in two
calls of the same C (:mod:`~optdesign.kinematics.interval_c`): the same operations on the same
operands, so the same bits as one call per row.
"""
from __future__ import annotations

import ctypes
import os
import time

import numpy as np

from ..kinematics import enclosure, interval_c, intervals
from ..kinematics.interval_c import c_source, dependencies, stacked_rows
from . import compiled

NAME = "optdesign_intervals"
RETRY_S = 2.0   # while the library is being compiled, looked for again at most this often
SHARED = 0.75   # the two phases where the distinct intervals are at most this fraction of them
_loaded = {}     # cache key -> the C function (one dlopen per library and process)
_generator = []  # the hash of the code that writes the C (part of every entry's key)
_addressof, _view = ctypes.addressof, ctypes.c_char.from_buffer


def address(a: np.ndarray) -> int:
    """The address of the first element of ``a`` (C-contiguous) for a C call: through ctypes'
    view of its buffer, about 4 times cheaper than ``a.ctypes.data`` (the glue of a one-case
    certification takes ~80 of them), which an array the view refuses (read-only, empty) takes."""
    try:
        return _addressof(_view(a))
    except (TypeError, ValueError, BufferError):
        return a.ctypes.data


def generator() -> str:
    """A hash of the modules that make an interval program and write its C: the key of a
    library names its graph and this, so that the C is written only when it is compiled."""
    if not _generator:
        import hashlib
        from pathlib import Path

        h = hashlib.sha256()
        for module in (enclosure, interval_c, intervals):
            h.update(Path(module.__file__).read_bytes())
        _generator.append(h.hexdigest()[:16])
    return _generator[0]


def backend() -> str:
    """'c' (compiled when the cache can) or 'numpy' (``OPTDESIGN_INTERVALS=numpy``)."""
    return "numpy" if os.environ.get("OPTDESIGN_INTERVALS", "").strip().lower() == "numpy" else "c"


def compile_program(program, wait: bool | None = None):
    """``program`` (an IntervalProgram) evaluated by compiled C where it can be, else itself."""
    if backend() == "numpy" or compiled.mode() == "off":
        return program
    return CompiledProgram(program, wait)


class CompiledProgram:
    """An IntervalProgram's C twin: the library looked up (and compiled) at the first call; the
    numpy program runs while there is none."""

    def __init__(self, program, wait: bool | None = None):
        self.program, self.wait = program, wait
        self.shapes, self.rows = program.shapes, program.rows
        self._function, self._forms, self._tried = None, None, -np.inf
        self._offsets, self._total = stacked_rows(program)
        self._need, self._phases, self._written, self._plans, self._nan = {}, {}, {}, {}, None
        self.n_p = program.func.nnz_in(1) if program.func.n_in() > 1 else 0
        self._reads, self._params, self._selects = dependencies(program)
        self._outputs = np.array([entry[0] == interval_c.ca.OP_OUTPUT for entry in program.varying], bool)

    def _library(self):
        if self._function is None and time.monotonic() - self._tried > RETRY_S:
            self._tried = time.monotonic()
            graph = self.program.func.serialize()
            # (the key names the levels: a library compiled before they were its own, at -O0, is not reused)
            key = compiled.entry_key("intervals", graph, {"generator": generator(), "levels": "own"})
            if key is None:
                self._tried = np.inf   # no compiler: numpy for good
                return None
            if key not in _loaded:
                def prepare(folder):   # the C written only to be compiled
                    c_file = folder / f"{key}.src{os.getpid()}.c"
                    compiled.write_atomic(c_file, c_source(self.program, NAME)[0].encode())
                    return {"kind": "source", "name": NAME, "source": str(c_file), "cleanup": [str(c_file)],
                            "own_levels": True}

                path = compiled.library(key, prepare, self.wait)   # (its C grows as the program: no MAX_GRAPH)
                if path is None:
                    return None
                try:
                    function = getattr(ctypes.CDLL(str(path)), NAME)
                except (OSError, AttributeError) as exc:
                    compiled.remove(key)
                    compiled.say_once(key, f"optdesign: the compiled library {key} did not load ({exc}); it will be "
                                           "rebuilt")
                    return None
                forms = getattr(ctypes.CDLL(str(path)), f"{NAME}_forms", None)
                if forms is None:   # (a library written before it had one)
                    compiled.remove(key)
                    return None
                forms.restype = None
                forms.argtypes = [ctypes.c_long, ctypes.c_void_p, ctypes.c_long, ctypes.c_long, *[ctypes.c_void_p] * 20]
                function.restype = ctypes.c_int
                function.argtypes = [ctypes.c_long, *[ctypes.c_void_p] * 3, ctypes.c_long, *[ctypes.c_void_p] * 9,
                                     ctypes.c_long]
                _loaded[key] = function, forms
            self._function, self._forms = _loaded[key]
        return self._function

    @property
    def subsets_pay(self) -> bool:
        """Whether a call on a subset of the outputs costs less (the C runs only the instructions
        they need; numpy's cost is mostly per instruction and call)."""
        return self._function is not None or self._library() is not None

    def __getstate__(self):   # (pickled, e.g. to a figure process: the library is looked up again there)
        return {**self.__dict__, "_function": None, "_forms": None, "_tried": -np.inf, "_plans": {}, "_nan": None}

    def forms(self, rows, whole, mid, ends, end_a, end_b, r_above, r_below):
        """:meth:`~optdesign.kinematics.enclosure.Enclosure.bounds`'s forms in C (the same
        operations in the same order as its numpy: the same bits), from the program's outputs
        ``whole`` (v, v' and v'' over the intervals: v_lo, v_hi, v_jump, d_lo, d_hi, d_jump,
        e_lo, e_hi), ``mid`` (v and v' at the expansion points) and ``ends`` (v at the distinct
        ends, ``end_a`` and ``end_b`` each interval's two); only the rows ``rows`` (all: None),
        the others NaN.  Returns (L, U)."""
        m, n = whole[0].shape
        rows = np.arange(m) if rows is None else np.asarray(rows)
        kept = [np.ascontiguousarray(a) for a in (*whole, *mid, *ends)]   # (alive through the call)
        kept += [np.ascontiguousarray(a, np.int64) for a in (rows, end_a, end_b)]
        kept += [np.ascontiguousarray(a, float) for a in (r_above, r_below)]
        out = np.empty((2, m, n))   # (out_lo, out_hi: C writes every interval of the rows asked, NaN the others)
        if len(rows) < m:
            unasked = np.ones(m, bool)
            unasked[rows] = False
            out[:, unasked] = np.nan
        at = [address(a) for a in kept] + [address(out)]
        self._forms(len(rows), at[14], n, kept[13].shape[1], *at[:14], *at[15:19], at[19], at[19] + 8 * m * n)
        out_lo, out_hi = out
        return out_lo, out_hi

    def need(self, rows, outputs=None):
        """The varying instructions that the outputs of ``rows`` (all: None) need, of the
        outputs ``outputs`` (all: None), as bytes."""
        fast = (None if rows is None else np.asarray(rows).tobytes(), outputs)   # (the same rows often asked again)
        if fast in self._need:
            return self._need[fast]
        key = (None if rows is None else frozenset(int(r) for r in rows), None if outputs is None else frozenset(outputs))
        if key not in self._need:
            varying = self.program.varying
            if key == (None, None):
                mask = np.ones(len(varying), np.uint8)
            else:
                every = range(max(self.program.shapes, default=0))
                kept = {entry[-1][1] for entry in self.program._subset(every if rows is None else rows, outputs)}
                mask = np.array([entry[-1][1] in kept for entry in varying], np.uint8)
            self._need[key] = np.ascontiguousarray(mask)
        self._need[fast] = self._need[key]
        return self._need[key]

    def phases(self, need, varied: int):
        """The two phases of a call of the instructions ``need`` (a mask) when the parameters
        ``varied`` (bit k: parameter k) differ between the rows: (need of the shared call, need
        of the per-row call, each instruction's column among the values the second imports from
        the first), or None where the shared call would run under a quarter of the work."""
        key = (need.tobytes(), varied)
        if key not in self._phases:
            mixed = np.array([(mask & varied) != 0 for mask in self._params], bool) | self._outputs
            for j in self._selects:   # (an if_else reads its two if_else_zero's branches: kept with it)
                if mixed[j]:
                    mixed[self._reads[j]] = True
            needed = need.astype(bool)
            shared, own = needed & ~mixed, needed & mixed
            boundary = np.zeros(len(need), bool)
            for j in np.flatnonzero(own):
                boundary[self._reads[j]] = True
            boundary &= shared
            col = np.full(len(need), -1, np.int64)
            col[boundary] = np.arange(np.count_nonzero(boundary))
            found = None
            if 4 * np.count_nonzero(shared) >= np.count_nonzero(needed):
                found = (shared.astype(np.uint8) + boundary, own.astype(np.uint8) + 3 * boundary.astype(np.uint8), col)
            self._phases[key] = found
        return self._phases[key]

    def __call__(self, lo, hi, p, rows=None, outputs=None, varied=None, fill=True):
        """As :meth:`IntervalProgram.__call__`: per output (lo, hi, jump), output rows x intervals.
        ``varied``: with a row of parameters per interval, a bitmask (bit k: parameter k) of
        those that may differ between the rows (None: found from ``p``); lo and hi the same
        array: points (one key to sort).  ``fill`` False: the rows not asked for (of the outputs
        asked for) are left unset, not NaN, for a caller that reads only the rows it asked for
        (:meth:`forms`)."""
        function = self._library()
        if function is None:
            return self.program(lo, hi, p, rows, outputs)
        point = lo is hi
        lo = np.ascontiguousarray(np.asarray(lo, float).ravel())
        hi = lo if point else np.ascontiguousarray(np.asarray(hi, float).ravel())
        n = len(lo)
        p = np.ascontiguousarray(np.asarray(p, float))
        stride = p.shape[-1] if p.ndim == 2 else 0
        if p.ndim == 2 and p.shape[0] != n:
            raise ValueError(f"p: one row of parameters per interval ({n}), or one vector; got {p.shape}")
        if (p.shape[-1] if p.ndim == 2 else p.size) != self.n_p or p.ndim > 2:   # (C would read past its end)
            raise ValueError(f"p: {self.n_p} parameters per vector (the Function's second input); got shape "
                             f"{p.shape}")
        if p.size == 0:
            p = np.zeros(1)
        need, need_at, total, unwritten = self._plan(rows, outputs)
        out = np.empty((2, total, n))   # (out_lo, out_hi)
        if unwritten is not None and fill:   # (NaN: the rows C does not write)
            out[:, unwritten] = np.nan
        out_lo, out_hi = out
        out_jump = np.zeros((total, n), np.bool_)
        at = address(out)
        out_at = (at, at + 8 * total * n, address(out_jump))
        two = self._shared(lo, hi, p, need, point, varied) if p.ndim == 2 and n > 1 else None
        if two is not None:   # the work shared by the rows once per distinct interval, then each row's
            (first, second, col), (lo_1, hi_1, src) = two
            k, m = int(np.count_nonzero(first == 2)), len(lo_1)
            sh_lo, sh_hi, sh_jump = np.empty((k, m)), np.empty((k, m)), np.zeros((k, m), np.bool_)
            shared = (address(col), address(sh_lo), address(sh_hi), address(sh_jump))
            p_at, src_at = address(p), address(src)
            if function(m, address(lo_1), address(hi_1), p_at, 0, address(first), *out_at, *shared, src_at, 0) != 0 or \
                    function(n, address(lo), address(hi), p_at, stride, address(second), *out_at, *shared, src_at,
                             m) != 0:
                raise MemoryError("the compiled interval program could not allocate its work arrays")
        elif n:
            lo_at = address(lo)
            if function(n, lo_at, lo_at if point else address(hi), address(p), stride, need_at, *out_at,
                        None, None, None, None, None, 0) != 0:
                raise MemoryError("the compiled interval program could not allocate its work arrays")
        if total == self._total:
            return [(out_lo[o:o + m], out_hi[o:o + m], out_jump[o:o + m]) for o, m in zip(self._offsets, self.shapes)]
        nan, no = self._placeholders(n)
        return [(out_lo[o:o + m], out_hi[o:o + m], out_jump[o:o + m]) if o + m <= total else (nan[:m], nan[:m], no[:m])
                for o, m in zip(self._offsets, self.shapes)]

    def _plan(self, rows, outputs):
        """(the instructions a call of the outputs ``outputs`` of ``rows`` needs (:meth:`need`),
        that mask's address, the stacked rows C writes up to, the rows below that it leaves
        unwritten: an index, or None), found once per rows and outputs."""
        key = (None if rows is None else np.asarray(rows).tobytes(), outputs)
        plan = self._plans.get(key)
        if plan is None:
            need = self.need(rows, outputs)
            total = self._total
            if outputs is not None:   # (the stacked rows up to the last output asked for: C writes no others)
                total = max((self._offsets[j] + self.shapes[j] for j in outputs), default=0)
            unwritten = np.flatnonzero(self._unwritten(need)[:total])
            plan = self._plans[key] = (need, address(need), total, unwritten if len(unwritten) else None)
        return plan

    def _placeholders(self, n):
        """Read-only NaN values and False flags (output rows x n) for the outputs a call was not
        asked for: views of one buffer, grown as calls grow."""
        if self._nan is None or self._nan[0].shape[1] < n:
            width = max(n, 2 * (0 if self._nan is None else self._nan[0].shape[1]), 64)
            nan, no = np.full((max(self.shapes), width), np.nan), np.zeros((max(self.shapes), width), np.bool_)
            nan.flags.writeable, no.flags.writeable = False, False
            self._nan = nan, no
        return self._nan[0][:, :n], self._nan[1][:, :n]

    def _unwritten(self, need):
        """The stacked output rows that a call of the instructions ``need`` leaves unwritten."""
        key = need.tobytes()
        if key not in self._written:
            written = np.zeros(self._total, bool)
            for (op, i, *_), kept in zip(self.program.varying, need):
                if kept and op == interval_c.ca.OP_OUTPUT:
                    written[self._offsets[i[0]] + self.rows[i[0]][i[1]]] = True
            self._written[key] = ~written
        return self._written[key]

    def _shared(self, lo, hi, p, need, point=False, varied=None):
        """The two phases (:meth:`phases`) and the distinct intervals (lo, hi, and each
        interval's index among them) of a call with a row of parameters ``p`` per interval, or
        None where they would not pay; ``point``: lo is hi; ``varied``: as :meth:`__call__`'s."""
        if varied is None:
            varied = 0
            for k in np.flatnonzero(np.any(p != p[0], axis=0)):
                varied |= 1 << int(k)
        phases = self.phases(need, varied)
        if phases is None:
            return None
        bits_lo, bits_hi = lo.view(np.int64), hi.view(np.int64)   # (by their bits: -0.0 is not 0.0)
        if point:
            order = np.argsort(bits_lo)
            first = np.ones(len(lo), bool)
            first[1:] = np.diff(bits_lo[order]) != 0
        else:
            order = np.lexsort((bits_hi, bits_lo))
            first = np.ones(len(lo), bool)
            first[1:] = (np.diff(bits_lo[order]) != 0) | (np.diff(bits_hi[order]) != 0)
        if np.count_nonzero(first) > SHARED * len(lo):
            return None
        src = np.empty(len(lo), np.int64)
        src[order] = np.cumsum(first) - 1
        pick = order[first]
        lo_1 = np.ascontiguousarray(lo[pick])
        return phases, (lo_1, lo_1 if point else np.ascontiguousarray(hi[pick]), src)
