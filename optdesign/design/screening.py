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

import multiprocessing
import threading

import casadi as ca
import numpy as np

from ..model.programs import cached_program
from ..model.vectorised import run_program


class ManyDesigns:
    """A CasADi Function evaluated at many columns of its inputs: ``f(*inputs)`` with each
    input an array (its nonzeros x columns; a 1-D array is the same for every column) gives
    each output as an array (its entries x columns, dense, column-major)."""

    def __init__(self, func: ca.Function):
        self.func = func
        self.program = None
        try:   # (from the cache folder when a run made it before: model/programs.py)
            self.n_work, self.program = cached_program(func)
        except (NotImplementedError, RuntimeError):
            self.program = None
        self._maps = {}

    def __call__(self, *inputs) -> list:
        f = self.func
        m = max((np.shape(a)[1] for a in inputs if np.ndim(a) == 2), default=1)
        columns = [np.asarray(a, float) if np.ndim(a) == 2 else np.asarray(a, float).reshape(-1, 1)
                   for a in inputs]
        if self.program is None:
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


SHARE_MIN = 256   # designs per process, at least, when a screening is shared among processes


def shared(screen, xs, processes, *args) -> tuple:
    """``screen(xs, *args)`` (arrays over the designs, the rows of ``xs``) with the designs shared
    among up to ``processes`` processes: this one and forked ones, each screening a contiguous
    share.  Every operation is elementwise over the designs (:class:`ManyDesigns`), so a design's
    numbers do not depend on which others are screened with it: the same bit for bit as one
    call (tests/test_screening_shared.py).  For the command's first problem, whose screening
    stands alone before any start can run (crane_luffing_drive's 4 kW motor: 0.9 s of CPU), while
    the other core is idle.  One process when this is not the only thread (a fork then could
    copy a lock held by another), when the platform cannot fork, or for few designs; a share
    whose process fails is screened here."""
    xs = np.atleast_2d(np.asarray(xs, float))
    parts = min(int(processes), len(xs) // SHARE_MIN)
    if parts < 2 or threading.active_count() > 1 or "fork" not in multiprocessing.get_all_start_methods():
        return screen(xs, *args)
    context = multiprocessing.get_context("fork")
    cuts = np.linspace(0, len(xs), parts + 1).astype(int)
    others = []
    try:
        for a, b in zip(cuts[1:-1], cuts[2:]):
            ours, theirs = context.Pipe(duplex=False)
            process = context.Process(target=_share, args=(theirs, screen, xs[a:b], args), daemon=True)
            process.start()
            theirs.close()
            others.append((process, ours, slice(a, b)))
        results = [screen(xs[:cuts[1]], *args)]
        for _, conn, part in others:
            try:
                got = conn.recv()
            except (EOFError, OSError):
                got = None
            results.append(got if got is not None else screen(xs[part], *args))
    finally:
        for process, conn, _ in others:
            conn.close()
            process.join(timeout=5)
            if process.is_alive():
                process.kill()
                process.join()
    return tuple(np.concatenate(values) for values in zip(*results))


def _share(conn, screen, xs, args):
    """A forked process's share of :func:`shared` (None sent when it failed: screened again there)."""
    try:
        conn.send(screen(xs, *args))
    except Exception:   # noqa: BLE001 - the parent screens this share itself
        conn.send(None)
    finally:
        conn.close()
