"""The analyses of many cases at once (:meth:`~.analysis.Analysis.run_many`): each stage over
cases x samples.

A batch's cases differ in leaf parameter values only (one build).  The stages, each over every
case of the batch in one go: the assembly check and the dead-centre check over the continuous
stroke (:meth:`~optdesign.kinematics.assembly.AssemblyCheck.many`,
:meth:`~.reduction.ReducedModel.dead_centres`: once per group of cases equal in the geometry they
depend on), the model's columns (one compiled call over all cases' samples:
:meth:`~.blocked.BlockedFunction.many`), the finiteness check, the sampled peaks and constraint
extremes (argmax over each case's row), the per-stroke constraints (:mod:`.per_stroke`), the
certified extremes (:mod:`.certified`), and a scene's load cases.  Every decision is taken per
case, on the case's own numbers, so a case's figures are the same bit for bit whatever batch it
is in; a case that fails (it does not assemble, a dead centre, a value that is not finite) carries
its error, and the others are unaffected."""
from __future__ import annotations

import math
import time

import numpy as np

from ..errors import OptdesignError
from ..kinematics.assembly import ASSEMBLY_TOL
from ..kinematics.joint import Distinct, maxima_together
from ..kinematics.peaks import Request, extrema_lists, extrema_of_cases, maxima_arrays
from .finite import check_columns, check_values


class CaseRun:
    """One case of :meth:`~.analysis.Analysis.run_many`: the figures of its
    :class:`~.analysis.AnalysisResult` (the per-stroke constraints' values in ``stroke``, their
    sampled values in ``stroke_sampled``), or ``error``, the OptdesignError that stopped it.

    A certified case's figures (``FIGURES``) are made from its batch's numbers when first asked
    for: ``batch`` is then (the batch's :class:`_Figures`, the case's number in the batch, its
    :class:`~.certified.Found` and its place there), which a study's rows read as columns
    (:func:`optdesign.study.analysed._columns`); None otherwise (a figure not set is empty)."""

    FIGURES = ("peaks", "peak_at", "peaks_sampled", "constraint_extremes", "stroke", "stroke_sampled",
               "certificates", "timings")

    def __init__(self):
        self.cases, self.error, self.batch = None, None, None

    def __getattr__(self, name):   # (only for an attribute not set: a figure not made yet)
        if name not in CaseRun.FIGURES:
            raise AttributeError(name)
        batch = self.__dict__.get("batch")
        made = {name: {}} if batch is None else batch[0].made(name, *batch[1:])
        for k, value in made.items():   # (a figure set or made before is kept)
            self.__dict__.setdefault(k, value)
        return self.__dict__[name]

    def __getstate__(self):   # (pickled: its figures, not its batch's)
        for name in CaseRun.FIGURES:
            getattr(self, name)
        return {**self.__dict__, "batch": None}


class _Figures:
    """The figures of a batch's certified cases as :func:`run_cases` computed them (lists over
    the batch's cases), each case's dicts made when asked for (:meth:`made`)."""

    def __init__(self, keys, by_case, names, sampled, lows, notes, dead):
        self.keys, self.by_case, self.names, self.sampled = keys, by_case, names, sampled
        self.stroke = sampled   # the per-stroke constraints' rows (at the located aggregates: set by run_cases)
        self.lows, self.notes, self.dead, self.timings = lows, notes, dead, {}

    def made(self, name, i, found, c) -> dict:
        """The figure ``name`` of case ``i`` (case ``c`` of ``found``), with those made with it."""
        if name == "peaks_sampled":
            return {name: dict(zip(self.keys, self.by_case[i]))}
        if name == "stroke_sampled":
            return {name: dict(zip(self.names, self.sampled[i]))}
        if name == "stroke":
            return {name: dict(zip(self.names, self.stroke[i]))}
        if name == "timings":
            return {name: dict(self.timings)}
        got = found.case(c)
        certificates = got["certificates"]
        certificates.update({f"assembly of {k}": {"bound": None, "note": note} for k, note in self.notes[i].items()})
        if self.dead[i]:
            certificates["dead centre"] = {"bound": None, "note": self.dead[i]}
        lows = self.lows
        extremes = {k: dict(e, min_sampled=lows[k][0][i], max_sampled=lows[k][2][i])
                    for k, e in got["constraint_extremes"].items()}
        return {"peaks": got["peaks"], "peak_at": got["peak_at"], "certificates": certificates,
                "constraint_extremes": extremes}

    def columns(self, found, cases) -> tuple:
        """:meth:`made`'s values of the batch's cases ``cases`` ((i, c) each: its number here, its
        place in ``found``), column by column (a study's rows): (name, |value|s, s's) per peak,
        (key, values) per sampled peak, (name, mins, maxs) per constraint extreme (as
        ``found.case`` places them), (name, floats) per per-stroke constraint."""
        s, v, by_case, stroke = found.s, found.v, self.by_case, self.stroke
        i_s, c_s = [i for i, _ in cases], [c for _, c in cases]
        return ([(name, [abs(v[c][j]) for c in c_s], [s[c][j] for c in c_s]) for j, name, _ in found.peaks],
                [(k, [by_case[i][m] for i in i_s]) for m, k in enumerate(self.keys)],
                [(name, [v[c][j + 1] for c in c_s], [v[c][j] for c in c_s]) for j, name, _, _ in found.extremes],
                [(name, [float(stroke[i][m]) for i in i_s]) for m, name in enumerate(self.names)])

    def peaks(self, found, c) -> list:
        """Case ``c`` of ``found``: its peaks' values, in order (its ``peaks``' values)."""
        v = found.v[c]
        return [abs(v[j]) for j, _, _ in found.peaks]


def run_cases(a, P):
    """(a CaseRun per row of ``P``, the model's values: name -> cases x samples) of the
    :class:`~.analysis.Analysis` ``a``."""
    t0 = time.perf_counter()
    s, n = a.s_values, len(P)
    runs = [CaseRun() for _ in range(n)]
    narrow = [[] for _ in range(n)]
    notes = [{} for _ in range(n)]
    # one case certified: its assembly margins and its extremes in one branch and bound
    # (_together: the same numbers); else the assembly, then the model, then the extremes
    assembled, values, dead_found, places, split = (_together(a, s, P) if a.certified is not None and n == 1
                                                    else (a.assembly.many(s, P), None, None, None, None))
    for i, found in enumerate(assembled):   # both certified over the continuous stroke
        if isinstance(found, OptdesignError):
            runs[i].error = found
        else:
            narrow[i], notes[i] = list(found[0]), found[1]
    values = _model_values(a, P) if values is None else values
    live = [i for i in range(n) if runs[i].error is None]
    dead = [""] * n
    if live:
        if dead_found is None or live != [0]:
            dead_found = a.model.dead_centres(s, P[live], values["k"][live])
        for i, found in zip(live, dead_found):
            if isinstance(found, OptdesignError):
                runs[i].error = found
            else:
                narrow[i] += found[0]
                dead[i] = found[1]
    columns, constraints, bad = _split(s, values, n) if split is None else split
    _check_finite(a, s, columns, constraints, P, runs, bad)
    sampled = a.stroke.values(values, P) if a.stroke is not None else np.zeros((n, 0))
    names = a.stroke.names if a.stroke is not None else []
    peaks = {k: (np.argmax(np.abs(columns[k]), axis=1)) for k in a.peak_names if k in columns}
    extremes = {k: (np.argmin(v, axis=1), np.argmax(v, axis=1)) for k, v in constraints.items()}
    rows = np.arange(n)
    found = {}
    for k, i in peaks.items():
        value, q = columns[k][rows, i], columns["q"][rows, i]
        found[k] = (np.abs(value).tolist(), s[i].tolist(), q.tolist(), value.tolist())
    lows = {k: (v[rows, lo].tolist(), s[lo].tolist(), v[rows, hi].tolist(), s[hi].tolist())
            for (k, (lo, hi)), v in zip(extremes.items(), constraints.values())}
    t1 = time.perf_counter()
    keys = list(found)
    by_case = list(zip(*(f[0] for f in found.values()))) if keys else [()] * n   # |peak| per case
    stroke_rows = sampled.tolist()
    certify = a.certified is not None
    figures = _Figures(keys, by_case, names, stroke_rows, lows, notes, dead) if certify else None
    if not certify:
        for i in (i for i in range(n) if runs[i].error is None):
            _sampled_figures(runs[i], i, keys, by_case, names, stroke_rows)
            _sampled_places(runs[i], i, found, lows)
        for r in runs:
            r.constraint_extremes = {k: dict(e, min_sampled=e["min"], max_sampled=e["max"])
                                     for k, e in r.constraint_extremes.items()}
    extra = [None] * n
    if certify:   # each certified case's figures made from the batch's when asked for (CaseRun)
        live = [i for i in range(n) if runs[i].error is None]
        if places is None or live != [0] or narrow[0]:   # (_together's: for case 0 alone, on the samples)
            places = _certified(a, s, P, columns, constraints, narrow, live)
        for i, got in zip(live, places):
            r = runs[i]
            if isinstance(got, OptdesignError):
                r.error = got
                _sampled_figures(r, i, keys, by_case, names, stroke_rows)
                _sampled_places(r, i, found, lows)
                continue
            place, c = got
            r.batch = (figures, i, place, c)
            located = sorted({place.s[c][j] for j, _ in place.aggregates})
            if located:
                extra[i] = np.asarray(located, float)
        if any(x is not None for x in extra):
            figures.stroke = a.stroke.values(values, P, _at_extra(a, P, extra)).tolist()
    t2 = time.perf_counter()
    for r in runs:
        if r.error is not None:
            continue
        if r.batch is not None:   # (its values without making its dicts)
            finite = _finite_sum(figures.stroke[r.batch[1]], figures.peaks(*r.batch[2:]))
        else:
            finite = _finite_sum(r.stroke.values(), r.peaks.values())
        if not finite:
            try:
                check_values(a, {**{f"constraint {k!r}": v for k, v in r.stroke.items()},
                                 **{f"peak |{k}|": v for k, v in r.peaks.items()}})
            except OptdesignError as exc:
                r.error = exc
    live = [i for i in range(n) if runs[i].error is None]
    if a.case_analysis and live:   # the load cases of every case at once (model/case_runs.py)
        for i, found in zip(live, a.case_analysis.run_many(P[live])):
            runs[i].cases, runs[i].error = (None, found) if isinstance(found, OptdesignError) else (found, None)
    timings = {"build_s": a.build_time, "evaluate_s": (t1 - t0) / n}
    if certify:
        timings["certify_s"] = (t2 - t1) / n
        figures.timings = timings
    for r in runs:
        if r.error is None:
            if r.batch is None:
                r.timings = dict(timings)
        elif r.batch is not None:
            r.timings = {}   # (a case that failed after its certificate: none, as every failed case)
    return runs, values


def _sampled_figures(r, i, keys, by_case, names, stroke_rows):
    """Case ``i``'s sampled peaks and per-stroke constraints (also its figures, until certified
    ones replace them)."""
    r.peaks_sampled = dict(zip(keys, by_case[i]))
    r.stroke_sampled = dict(zip(names, stroke_rows[i]))
    r.peaks, r.stroke = dict(r.peaks_sampled), dict(r.stroke_sampled)


def _sampled_places(r, i, found, lows):
    """Case ``i``'s peaks' and constraint extremes' places at the samples (the figures where no
    certificate gives them)."""
    r.peak_at = {k: {"s": f[1][i], "q": f[2][i], "value": f[3][i]} for k, f in found.items()}
    r.constraint_extremes = {k: {"min": e[0][i], "min_s": e[1][i], "max": e[2][i], "max_s": e[3][i]}
                             for k, e in lows.items()}


def _finite_sum(first, second) -> bool:
    """Whether the sum of the values ``first`` and ``second`` (iterables) is finite: then every
    value is (a value that is not finite, or None, makes it not; so may an overflow, which the
    exact check then clears)."""
    try:
        return math.isfinite(sum(second, sum(first)))
    except TypeError:
        return False


def _certified(a, s, P, columns, constraints, narrow, live) -> list:
    """The certified extremes of the cases ``live`` (:meth:`~.certified.CertifiedExtremes.found`:
    per case its Found and its place there), or per case its OptdesignError: a batch in which
    one case fails is certified again case by case (each case's result is the same alone)."""
    if not live:
        return []

    def rows(which):
        if len(which) == len(P):   # every case (live is in order): the arrays as they are
            return columns, constraints
        return ({k: v[which] for k, v in columns.items()}, {k: v[which] for k, v in constraints.items()})

    try:
        return a.certified.found(s, P[live], *rows(live), [narrow[i] for i in live])
    except OptdesignError as exc:
        if len(live) == 1:
            return [exc]
    out = []
    for i in live:
        try:
            out += a.certified.found(s, P[[i]], *rows([i]), [narrow[i]])
        except OptdesignError as exc:
            out.append(exc)
    return out


def _together(a, s, P):
    """(the assembly check of the one case ``P`` (:meth:`~optdesign.kinematics.assembly.
    AssemblyCheck.many`'s), the model's values (:func:`_model_values`), the dead-centre check of
    the case or None, its certified extremes on the samples (:func:`_certified`'s) or None):
    where the case assembles at its samples, is finite and passes the dead-centre check with no
    minimum narrower than the samples, the continuous minima of its assembly margins and its
    certified extremes in one call of the one certification
    (:func:`~optdesign.kinematics.joint.maxima_together`: each part's numbers what it gives
    alone; a certified analysis spent about half its time in the two calls' fixed costs).  The
    extremes are the case's only where the assembly check then passes with no narrow minimum
    (run_cases checks), as the assembly's minima decide where the extremes are sampled; else
    (and where the call raises) they are None and found as before: the case's numbers are the
    same either way."""
    pending = a.assembly.begin(s, P)
    values = _model_values(a, P)

    def alone():
        return a.assembly.finish(pending, [extrema_of_cases(evaluate, pending.grid, V, requests, enclosure=enclosure)
                                           for evaluate, V, requests, enclosure in pending.parts])

    if not pending.parts or pending.staged[0][0] or any(getattr(p[3], "reason", None) is not None for p in pending.parts):
        return alone(), values, None, None, None   # (nothing to join, or it fails at its samples)
    dead = a.model.dead_centres(s, P, values["k"])
    split = columns, constraints, bad = _split(s, values, 1)
    plan = None
    if not isinstance(dead[0], OptdesignError) and not dead[0][0] and not bad.any():
        plan = a.certified.begin(s, P, columns, constraints)
    # (both grids the samples, ascending: the same numbers)
    if plan is None or len(plan[0]) != 1 or len(pending.parts) != 1 or np.any(pending.parts[0][3].sign != 1.0):
        return alone(), values, dead, None, split
    joint = a.certified.with_margins()
    enclosure = None if joint is None else joint[1].at(P)
    if enclosure is None or getattr(enclosure, "reason", None) is not None:
        return alone(), values, dead, None, split
    evaluate = joint[0]
    (_, V, requests, _), margins = plan[0][0], pending.parts[0][3].rows
    T = pending.staged[0][2][None]   # (the case's relative margins, all of them: rows by their index)
    mine = [Request(int(i), "min", ends=True, tol=ASSEMBLY_TOL) for i in margins]
    p = P[0]
    try:
        found, top, bound, notes, (f, g) = maxima_together(
            pending.grid, [(V, requests), (T if pending.direction > 0 else T[:, :, ::-1], mine)],
            lambda s, cases: evaluate(s, p), Distinct(enclosure))
    except OptdesignError:   # (an invariant failed: each call alone says which, as before)
        return alone(), values, dead, None, split
    assembled = a.assembly.finish(pending, [extrema_lists(found, bound[g:], notes[g:], 1, mine, True, g)])
    k = len(requests)
    return assembled, values, dead, plan[2]([maxima_arrays(found, top[f:f + k], bound[f:f + k], notes[f:f + k], 1, k)]), \
        split


def _split(s, values, n):
    """(the columns, the per-sample constraints, per case whether its columns hold a value that
    is not finite or a negative reduced inertia: :func:`_check_finite`'s test) of the model's
    ``values`` (of ``n`` cases)."""
    columns = {"s": np.broadcast_to(s, (n, len(s)))}
    columns.update({k: v for k, v in values.items() if ":" not in k})
    constraints = {k.split(":", 1)[1]: v for k, v in values.items() if k.startswith("constraint:")}
    bad = np.zeros(n, bool)
    for v in (*columns.values(), *constraints.values()):   # a row's sum is finite where every value is (one
        bad |= ~np.isfinite(np.sum(v, axis=1))            # that overflows: check_columns clears the case)
    if "reduced_inertia" in columns:
        bad |= np.any(columns["reduced_inertia"] < 0, axis=1)
    return columns, constraints, bad


def _model_values(a, P):
    """The model's outputs over the samples of every case: name -> cases x samples."""
    s = a.s_values
    n = len(s)
    if a.vectorised is not None:
        raw = a.vectorised.many(s, P)
    else:
        out = a.mapped(np.tile(s, len(P)), np.repeat(P, n, axis=0))
        raw = {k: v.reshape(len(P), n) for k, v in zip(a.names, out)}
    values = {}
    for k, v in raw.items():   # (the compiled blocks' outputs are cases x samples already: kept as they are)
        v = np.asarray(v, float)
        values[k] = v if v.shape == (len(P), n) else np.ascontiguousarray(np.broadcast_to(v, (len(P), n)))
    if a.scene.drive.kind == "rotary":
        values["q"] = np.unwrap(values["q"], axis=1)
    return values


def _check_finite(a, s, columns, constraints, P, runs, bad):
    """:func:`~.finite.check_columns` of the cases ``bad`` (:func:`_split`'s: whose columns hold
    a value that is not finite or a negative reduced inertia; the others pass it: nothing to
    look at)."""
    for i in np.flatnonzero(bad):
        if runs[i].error is None:
            try:
                check_columns(a, s, {k: v[i] for k, v in columns.items()}, {k: v[i] for k, v in constraints.items()},
                              P[i])
            except OptdesignError as exc:
                runs[i].error = exc


def _at_extra(a, P, extra):
    """Per case the aggregate rows at its located sweep values (None without), in one call."""
    cases = [i for i, x in enumerate(extra) if x is not None]
    s = np.concatenate([extra[i] for i in cases])
    rows = a.stroke_rows_at(s, np.repeat(P[cases], [len(extra[i]) for i in cases], axis=0))
    out, start = [None] * len(extra), 0
    for i in cases:
        out[i] = rows[:, start:start + len(extra[i])]
        start += len(extra[i])
    return out
