"""What analyse summarises, over the continuous stroke: the peaks of the drive load, the static
load, the reduced inertia and the power, the extremes of every per-sample constraint, and the
aggregates max(...)/min(...) inside the per-stroke constraints.

Each is a row of one CasADi function of (s, p) with its exact first and second derivatives in
s; the rows' sampled extrema bracket the continuous ones, which the one certification refines
(:func:`~optdesign.kinematics.peaks.continuous_maxima_rows`: Newton on dv/ds = 0, bisection as
its safeguard, the brackets of all rows in lockstep, the intervals at the stroke's ends
included).  A per-stroke constraint is then evaluated on the samples plus the located extrema
of its aggregates, so max(...) and min(...) inside it take their continuous values.
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

from ..kinematics.enclosure import Enclosures
from ..kinematics.peaks import Extremum, Request, continuous_maxima_rows, resolving_points
from ..scene.expressions import Expression
from .intervals_compiled import compile_program
from .mapped import MappedFunction
from .quantities import model_value

PEAKS = ("drive", "static_load", "reduced_inertia", "power")


class CertifiedExtremes:
    """The continuous extremes of one :class:`~optdesign.model.analysis.Analysis` (its
    functions built once, with the analysis)."""

    def __init__(self, analysis):
        mech = analysis.mech
        self.mech = mech
        outputs = dict(analysis.model.outputs(), **analysis.joints)
        rows, self.peak_rows, self.constraint_rows, self.aggregate_rows = [], {}, {}, []
        for name in analysis.peak_names:   # the model's PEAKS and the pins' forces
            if name in outputs:
                self.peak_rows[name] = len(rows)
                rows.append(outputs[name])
        for c in analysis.per_sample:
            self.constraint_rows[c.name] = len(rows)
            rows.append(model_value(analysis.model, c.expr, f"[[constraints]] {c.name}"))
        for c in analysis.per_stroke:
            for func, inner in aggregates(c.expr):
                self.aggregate_rows.append((c.name, func, len(rows)))
                rows.append(model_value(analysis.model, inner, f"[[constraints]] {c.name}"))
        self.n_rows = len(rows)
        v = ca.vertcat(*rows) if rows else ca.DM.zeros(0, 1)
        dv = mech.ds(v)
        self.derivatives = MappedFunction(mech.function("certified_ds", {"v": v, "dv": dv, "d2v": mech.ds(dv)}))
        self.enclosures = Enclosures(self.derivatives.func, compile_program)   # the same program, in intervals
        self.values = MappedFunction(mech.function("certified_v", {"v": v}))
        self.q = MappedFunction(mech.function("q", {"q": mech.q}))

    def many(self, s_values, P, columns, constraints, narrow=None) -> list:
        """The continuous extremes of N cases of this analysis that differ only in their
        parameters: case i at parameters ``P[i]`` (``P``: N x parameters), all sampled on the
        same ``s_values`` (S values, ascending or descending).  ``columns`` and ``constraints``:
        name -> array N x S, case i's sampled columns (``q`` and the peaks' names) and per-sample
        constraints in row i.  ``narrow``: None, or one sequence of (s, width) per case (as
        :meth:`__call__`'s).  Returns one dict per case, in order, each exactly what
        :meth:`__call__` returns for that case alone: every decision of the certification is
        taken per case, so a case's numbers do not depend on the other cases of the batch or on
        its position in it (a study's serial, pool and Dask rows stay byte-identical)."""
        P = np.atleast_2d(np.asarray(P, float))
        n = P.shape[0]
        narrow = [()] * n if narrow is None else list(narrow)
        if len(narrow) != n:
            raise ValueError(f"narrow: one sequence per case ({n}), got {len(narrow)}")
        return [self(s_values, P[i], {k: np.asarray(v)[i] for k, v in columns.items()},
                     {k: np.asarray(v)[i] for k, v in constraints.items()}, narrow[i]) for i in range(n)]

    def __call__(self, s_values, p, columns, constraints, narrow=()):
        """The continuous extremes at parameters ``p``, given the sampled ``columns`` and
        per-sample ``constraints`` of a run on ``s_values``.  ``narrow``: (s, width) of the
        assembly margins' and |dq/ds|'s minima that the samples do not resolve (near a lock-up
        or a dead centre the quantities change over that width): sweep values that resolve
        them join the samples (:func:`~optdesign.kinematics.peaks.resolving_points`) before
        the extrema are bracketed.  Returns a dict: ``peaks`` (name -> |peak|), ``peak_at``
        (name -> {s, q, value}), ``constraint_extremes`` (per-sample constraint -> {min, min_s,
        max, max_s}) and ``aggregates`` (constraint -> located s values of its aggregates)."""
        s_values = np.asarray(s_values, float)
        V = np.empty((self.n_rows, len(s_values)))
        for name, i in self.peak_rows.items():
            V[i] = columns[name]
        for name, i in self.constraint_rows.items():
            V[i] = constraints[name]
        if self.aggregate_rows:
            rows = [i for _, _, i in self.aggregate_rows]
            V[rows] = self.values(s_values, p)[0][rows]
        q_sampled = columns["q"]
        spacing = abs(float(s_values[-1] - s_values[0])) / max(len(s_values) - 1, 1)
        extra = resolving_points(narrow, s_values[0], s_values[-1], spacing)
        if extra:
            s_all = np.r_[s_values, extra]
            order = np.argsort(s_all, kind="stable")
            if s_values[-1] < s_values[0]:
                order = order[::-1]
            V = np.c_[V, self.values(np.array(extra), p)[0]][:, order]
            q_sampled = np.r_[q_sampled, np.full(len(extra), np.nan)][order]
            s_values = s_all[order]
        requests = []
        for i in self.peak_rows.values():
            requests.append(Request(i, "abs", ends=True))
        for i in self.constraint_rows.values():
            requests += [Request(i, "max", ends=True), Request(i, "min", ends=True)]
        for _, func, i in self.aggregate_rows:
            requests.append(Request(i, func, ends=True))
        extrema = self._extrema(s_values, V, p, requests)
        out = {"peaks": {}, "peak_at": {}, "constraint_extremes": {}, "aggregates": {}, "certificates": {}}
        located = iter(extrema)
        for name in self.peak_rows:
            e = next(located)
            out["peaks"][name] = abs(e.value)
            out["peak_at"][name] = {"s": e.s, "q": self._q(e.s, s_values, q_sampled, p), "value": e.value}
            out["certificates"][f"peak |{name}|"] = _certificate(e)
        for name in self.constraint_rows:
            hi, lo = next(located), next(located)
            out["constraint_extremes"][name] = {"min": lo.value, "min_s": lo.s, "max": hi.value, "max_s": hi.s}
            out["certificates"][f"{name} max"] = _certificate(hi)
            out["certificates"][f"{name} min"] = _certificate(lo, -1.0)
        for name, _, _ in self.aggregate_rows:
            out["aggregates"].setdefault(name, []).append(next(located).s)
        return out

    def _extrema(self, s_values, V, p, requests):
        """The largest continuous extremum of each request, certified by the enclosure of the
        same rows (its ``bound`` and ``note``: :func:`~optdesign.kinematics.peaks.certify`)."""
        ascending = len(s_values) < 2 or s_values[-1] >= s_values[0]
        grid, values = (s_values, V) if ascending else (s_values[::-1], V[:, ::-1])
        found = continuous_maxima_rows(lambda s: self.derivatives(s, p), grid, values, requests,
                                       enclosure=self.enclosures.at(p)) if requests else []
        return [ext[0] for ext in found]

    def _q(self, s, s_values, q_sampled, p):
        """The drive coordinate at s, on the branch of the sampled (unwrapped) q."""
        q = float(self.q(np.array([s]), p)[0][0, 0])
        if self.mech.scene.drive.kind != "rotary":
            return q
        known = np.isfinite(q_sampled)
        near = q_sampled[known][int(np.argmin(np.abs(s_values[known] - s)))]
        return float(near + math.remainder(q - near, 2 * math.pi))


class CertifiedPeaks:
    """The peaks |v| of named rows of (s, p) over the continuous stroke, located and certified
    as analyse's (:class:`CertifiedExtremes`: the rows' exact s-derivatives, their enclosure):
    a load case's pin forces (:class:`~optdesign.model.cases.CaseAnalysis`).  ``time`` = (tau,
    profile): rows along a law in time, located and certified in its time (:class:`InTime`)."""

    def __init__(self, mech, rows: dict, time=None):
        self.names = list(rows)
        v = ca.vertcat(*rows.values())
        self.in_time = None if time is None else InTime(mech, v, *time)
        if time is None:
            dv = mech.ds(v)
            self.derivatives = MappedFunction(mech.function("peaks_ds", {"v": v, "dv": dv, "d2v": mech.ds(dv)}))
            self.enclosures = Enclosures(self.derivatives.func, compile_program)

    def __call__(self, s_values, p, columns, names=None, certify=True) -> dict:
        """name -> (|peak|, {s, value}, certificate {bound, note}) at parameters ``p``, from the
        sampled ``columns`` on ``s_values`` (ascending or descending), for the rows ``names``
        (all by default); without ``certify`` located only (the refined sample maxima, no
        enclosure: certificate None)."""
        s_values = np.asarray(s_values, float)
        chosen = [n for n in self.names if names is None or n in names]
        if not chosen:
            return {}
        requests = [Request(self.names.index(n), "abs", ends=True) for n in chosen]
        if self.in_time is not None:
            found = self.in_time.maxima(s_values, p, requests, certify)
        else:
            V = np.array([columns[name] for name in self.names], float)
            if len(s_values) > 1 and s_values[-1] < s_values[0]:
                s_values, V = s_values[::-1], V[:, ::-1]
            found = continuous_maxima_rows(lambda s: self.derivatives(s, p), s_values, V, requests,
                                           enclosure=self.enclosures.at(p) if certify else None)
        return {name: (abs(ext[0].value), {"s": ext[0].s, "value": ext[0].value}, _certificate(ext[0]) if certify else None)
                for name, ext in zip(chosen, found)}


class InTime:
    """Rows v of (s, tau, p) along a law in time (a case's graphs with ``time`` = tau:
    :meth:`~.profiles.MotionProfile.graphs`), located and enclosed as graphs of tau alone, s =
    profile.sweep_at(tau): closed form and smooth in tau, also at a rest, where the law's
    inverse tau(s) has an infinite derivative and defeats the Taylor form (the ventilator's
    squeeze and return never closed through it)."""

    def __init__(self, mech, v, tau, profile):
        self.profile = profile
        v = ca.substitute(v, mech.s, profile.sweep_at(tau))
        assert not ca.depends_on(v, mech.s), "rows in time still depend on s"
        dv = ca.jacobian(v, tau)
        opts = {"cse": True} if mech.sym is ca.SX else {}
        func = ca.Function("rows_in_time", [tau, mech.p], [v, dv, ca.jacobian(dv, tau)], ["s", "p"], ["v", "dv", "d2v"], opts)
        self.derivatives = MappedFunction(func)
        self.enclosures = Enclosures(func, compile_program)

    def grid(self, s_values) -> np.ndarray:
        """The fractions tau of the law's time at ``s_values``, the law's piece ends, 0 and 1."""
        law = self.profile.shape.motion_law
        tau = self.profile.times(np.asarray(s_values, float)) / self.profile.shape.time
        return np.unique(np.clip(np.r_[0.0, tau, law.breaks, 1.0], 0.0, 1.0))

    def maxima(self, s_values, p, requests, certify=True) -> list:
        """:func:`~optdesign.kinematics.peaks.continuous_maxima_rows` of ``requests`` (rows of v)
        over the law's time, on :meth:`grid`, certified unless ``certify`` is False; each
        extremum's s (and a note's position) as a sweep value."""
        tau = self.grid(s_values)
        found = continuous_maxima_rows(lambda t: self.derivatives(t, p), tau, self.derivatives(tau, p)[0], requests,
                                       enclosure=self.enclosures.at(p) if certify else None)
        return [[Extremum(self.sweep(e.s), e.value, e.bound, self._note(e.note)) for e in ext] for ext in found]

    def sweep(self, tau) -> float:
        """The sweep value at the fraction ``tau`` of the law's time."""
        return float(self.profile.law_sweep(np.array([tau]))[0])

    def _note(self, note) -> str:
        """A certificate's note with its position as a sweep value (the branch and bound's is tau)."""
        if " s = " not in note:
            return note
        head, tail = note.split(" s = ", 1)
        number, rest = tail.split(" ", 1)
        return f"{head} s = {self.sweep(float(number)):.9g} {rest}"


def _certificate(e, sign=1.0) -> dict:
    """What the enclosure proved of one extremum: ``bound`` (of |v|, of v for a max, of v from
    below for a min; None without one) and ``note`` (why not, "" when certified)."""
    bound = None if e.bound is None else sign * e.bound
    return {"bound": bound, "note": e.note}


def aggregates(expr: Expression) -> list:
    """The one-argument max(...)/min(...) calls of a stroke expression, in order, as (func,
    inner expression)."""
    return [(func, Expression(f"{func}(...) in {expr.source}", inner)) for func, inner in expr.aggregate_calls()]
