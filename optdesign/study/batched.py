"""Many analyses of one built model in lockstep: their certification's interval work done together.

A case of an analyse study costs a few milliseconds of CasADi and tens of milliseconds of
certification, nearly all of it the enclosures' interval program run in numpy over a few hundred
intervals per call (:mod:`optdesign.kinematics.enclosure`): some 900 instructions, each a few
numpy calls whose fixed cost (microseconds each) outweighs their work at that size.  Here the
cases of a batch run their analyses side by side and every call of theirs to
``Enclosure.bounds`` is answered by one call over all their intervals at once, each interval
with its own case's parameters (per-interval point intervals), so numpy's per-call cost is paid
once per batch and pass, not once per case.

Each case runs its own unchanged :meth:`~optdesign.model.analysis.Analysis.run` in a thread of
its own, used as a coroutine: exactly one thread runs at a time (the others wait for their turn),
and a case hands its turn on when it asks for bounds; once every case of the batch has asked (or
finished), the gathered calls are evaluated together and the cases resume in order.  So nothing
runs concurrently, the order of everything is fixed, and a case's numbers are those of its own
run: the interval operations work element by element, and an interval's result does not depend
on the other intervals of the call (tests/test_study_batched.py checks every case's row against
its own run, on the truck crane and a generated family of machines).
"""
from __future__ import annotations

import threading

import numpy as np

from ..kinematics import enclosure as _enclosure

CHUNK = 8192   # intervals per gathered call at most (numpy's arrays stay in the cache: measured
#                on the truck crane, 21 us per interval at 5,000 intervals, 25 us at 50,000)


class _Case:
    """One job of the lockstep, its thread and its turn."""

    def __init__(self, job):
        self.job, self.asked, self.answer = job, None, None
        self.turn, self.parked = threading.Event(), threading.Event()   # its turn given; handed back
        self.result, self.error, self.done, self.abandoned = None, None, False, False


def lockstep(jobs: list) -> list:
    """Run the zero-argument callables ``jobs`` (each an analysis of one case) in lockstep, their
    enclosure bounds gathered (module docstring).  Returns, per job in order, ``(value, None)`` or
    ``(None, exception)`` for a job that raised."""
    cases = [_Case(job) for job in jobs]

    def run(case):
        def gather(enclosure, lo, hi, rows):
            case.asked = (enclosure, np.asarray(lo, float), np.asarray(hi, float), rows)
            case.parked.set()
            case.turn.wait()
            case.turn.clear()
            if case.abandoned:   # an exception in the caller (Ctrl-C): this case ends here
                raise _Abandoned()
            return case.answer

        _enclosure.GATHER.bounds = gather
        case.turn.wait()
        case.turn.clear()
        try:
            if case.abandoned:
                raise _Abandoned()
            case.result = case.job()
        except BaseException as exc:   # noqa: BLE001 - handed to the caller with the case
            case.error = exc
        finally:
            case.done = True
            case.parked.set()

    def give_turn(case):
        case.parked.clear()
        case.turn.set()
        case.parked.wait()

    threads = [threading.Thread(target=run, args=(case,), daemon=True) for case in cases]
    for t in threads:
        t.start()
    try:
        for case in cases:
            give_turn(case)
        while True:
            asking = [c for c in cases if not c.done]
            if not asking:
                break
            _answer(asking)
            for case in asking:
                give_turn(case)
    finally:   # after an exception here (Ctrl-C): each case still waiting ends, none is left behind
        for case in cases:
            if not case.done:
                case.abandoned = True
                give_turn(case)
        for t in threads:
            t.join()
    return [(c.result, c.error) for c in cases]


class _Abandoned(Exception):
    """Raised in a case whose batch was abandoned while it waited for its bounds."""


def _answer(cases):
    """The gathered bounds calls of ``cases``, grouped by interval program, in calls of at most
    CHUNK intervals; each case's answer as its own call would have given it (the rows it did
    not ask for NaN)."""
    groups = {}
    for c in cases:
        groups.setdefault(id(c.asked[0].program), []).append(c)
    for group in groups.values():
        start = 0
        while start < len(group):
            end, size = start + 1, len(group[start].asked[1])
            while end < len(group) and size + len(group[end].asked[1]) <= CHUNK:
                size += len(group[end].asked[1])
                end += 1
            _answer_together(group[start:end])
            start = end


def _answer_together(cases):
    program = cases[0].asked[0].program
    sizes = [len(c.asked[1]) for c in cases]
    lo = np.concatenate([c.asked[1] for c in cases])
    hi = np.concatenate([c.asked[2] for c in cases])
    p = np.concatenate([np.repeat(np.asarray(c.asked[0].p, float).reshape(1, -1), n, axis=0)
                        for c, n in zip(cases, sizes)])   # intervals x parameters
    asked = [c.asked[3] for c in cases]
    rows = None if any(r is None for r in asked) else np.unique(np.concatenate([np.asarray(r, int) for r in asked]))
    L, U, m_lo, m_hi = _enclosure.Enclosure(program, p).bounds(lo, hi, rows)
    edges = np.cumsum([0] + sizes)
    for c, r, a, b in zip(cases, asked, edges[:-1], edges[1:]):
        parts = [x[:, a:b].copy() for x in (L, U, m_lo, m_hi)]
        if r is not None:
            other = np.setdiff1d(np.arange(L.shape[0]), np.asarray(r, int))
            for x in parts:
                x[other] = np.nan
        c.answer = tuple(parts)
        c.asked = None
