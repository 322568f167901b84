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
from operator import itemgetter

import casadi as ca
import numpy as np

from ..kinematics.batches import parameters_used
from ..kinematics.enclosure import Enclosures
from ..kinematics.linear_parts import LinearParts
from ..kinematics.peaks import Extremum, Request, continuous_maxima_rows, maxima_of_cases, resolving_points
from ..scene.expressions import Expression
from .intervals_compiled import compile_program
from ..kinematics.mapped import MappedFunction
from .mapped import compiled_function
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
        # the requests (every peak |v|, each constraint's max and min, each aggregate) and where
        # each figure's is among them, the same for every call
        requests = [Request(i, "abs", ends=True) for i in self.peak_rows.values()]
        for i in self.constraint_rows.values():
            requests += [Request(i, "max", ends=True), Request(i, "min", ends=True)]
        self.requests = tuple(requests + [Request(i, func, ends=True) for _, func, i in self.aggregate_rows])
        k_peaks, k_extremes = len(self.peak_rows), len(self.constraint_rows)
        self._figures = (tuple((j, name, f"peak |{name}|") for j, name in enumerate(self.peak_rows)),
                         tuple((k_peaks + 2 * i, name, f"{name} max", f"{name} min")
                               for i, name in enumerate(self.constraint_rows)),
                         tuple((k_peaks + 2 * k_extremes + j, name)
                               for j, (name, _, _) in enumerate(self.aggregate_rows)))
        v = ca.vertcat(*rows) if rows else ca.DM.zeros(0, 1)
        dv = mech.ds(v)
        # the rows followed by the assembly's relative margins (with_margins: both certified in
        # one call; the same expressions as each one's own Function, so the same numbers; a call
        # of some rows runs the instructions those need), or the rows alone where that Function
        # has no enclosure (or there are no margins)
        derivatives, assembly = None, analysis.assembly
        if assembly.rows:
            assembly._build_derivatives()
            both = mech.function("certified_ds", {name: ca.vertcat(a, b) for name, a, b in zip(
                ("v", "dv", "d2v"), (v, dv, mech.ds(dv)), assembly.expressions)})
            enclosures = Enclosures(both, compile_program)   # the same program, in intervals
            if enclosures.reason is None:
                derivatives, self.enclosures = both, enclosures
        self.margins = derivatives is not None
        if derivatives is None:
            derivatives = mech.function("certified_ds", {"v": v, "dv": dv, "d2v": mech.ds(dv)})
            self.enclosures = Enclosures(derivatives, compile_program)
        # compiled from the disk cache where it is there (CasADi's C of the same graph: ~14x faster per point)
        self.derivatives = MappedFunction(derivatives, compile=compiled_function)
        self.values = MappedFunction(mech.function("certified_v", {"v": v}), compile=compiled_function)
        # the aggregates' rows at the samples (not among the sampled columns), once per distinct
        # value of the parameters they depend on (a batch varying masses: once)
        inner = ca.vertcat(*[rows[i] for _, _, i in self.aggregate_rows]) if self.aggregate_rows else None
        func = None if inner is None else mech.function("certified_aggregates", {"v": inner})
        self.aggregate_values = None if func is None else MappedFunction(func, compile=compiled_function)
        self.aggregate_parameters = None if func is None else parameters_used(mech, inner)
        self.q = MappedFunction(mech.function("q", {"q": mech.q}), compile=compiled_function)
        self.fixed_rows, self.fixed_parameters = _fixed_rows(mech, rows)
        self._linear = LinearParts.of_axes(mech, rows, compile_program)   # (a study's pre-filter)

    def with_margins(self):
        """(evaluate, enclosure) of this analysis's rows followed by its assembly's relative
        margins, the rows' own (:func:`~optdesign.kinematics.joint.maxima_together`), or None
        where the Function has no margins."""
        return (self.derivatives, self.enclosures) if self.margins else None

    def many(self, s_values, P, columns, constraints, narrow=None) -> list:
        """The continuous extremes of N cases of this analysis that differ only in their
        parameters: case i at parameters ``P[i]`` (``P``: N x parameters), all sampled on the
        same ``s_values`` (S values, ascending or descending).  ``columns`` and ``constraints``:
        name -> array N x S, case i's sampled columns (``q`` and the peaks' names) and per-sample
        constraints in row i.  ``narrow``: None, or one sequence of (s, width) per case (as
        :meth:`__call__`'s).  Returns one dict per case, in order, each what :meth:`__call__`
        returns for that case alone, bit for bit: every decision of the certification is taken
        per case (:mod:`optdesign.kinematics.extrema`), so a case's numbers do not depend on the
        other cases of the batch or on its position in it (a study's serial, pool and Dask rows
        stay byte-identical).  The work is arrays over all cases: one evaluation of the rows per
        Newton step and one of the enclosure per pass of the branch and bound for the batch."""
        return [found.case(c) for found, c in self.found(s_values, P, columns, constraints, narrow)]

    def found(self, s_values, P, columns, constraints, narrow=None) -> list:
        """:meth:`many`'s figures as the branch and bound gives them, without a dict per case:
        per case ``(found, c)``, case c of a :class:`Found` (``found.case(c)`` is the case's
        dict of :meth:`many`)."""
        places = [None] * (len(np.atleast_2d(P)) if narrow is None else len(narrow))
        for index, found in self._by_sweep(s_values, P, columns, constraints, narrow):
            for c, i in enumerate(index.tolist()):
                places[i] = (found, c)
        return places

    def _by_sweep(self, s_values, P, columns, constraints, narrow):
        """(the cases' numbers, their :class:`Found`) per group of cases of :meth:`many` that
        share their sweep values."""
        P = np.atleast_2d(np.asarray(P, float))
        n = P.shape[0]
        narrow = [()] * n if narrow is None else list(narrow)
        if len(narrow) != n:
            raise ValueError(f"narrow: one sequence per case ({n}), got {len(narrow)}")
        s_values = np.asarray(s_values, float)
        spacing = abs(float(s_values[-1] - s_values[0])) / max(len(s_values) - 1, 1)
        groups = {}   # cases with the same extra sweep values share a grid
        for i, near in enumerate(narrow):
            extra = tuple(resolving_points(near, s_values[0], s_values[-1], spacing)) if near else ()
            groups.setdefault(extra, []).append(i)
        for extra, index in groups.items():
            index = np.array(index)
            if len(index) == n:   # every case (in order): the arrays as they are
                found = self._group(s_values, P, columns, constraints, list(extra))
            else:
                found = self._group(s_values, P[index], {k: np.asarray(v)[index] for k, v in columns.items()},
                                    {k: np.asarray(v)[index] for k, v in constraints.items()}, list(extra))
            yield index, found

    def __call__(self, s_values, p, columns, constraints, narrow=()):
        """The continuous extremes at parameters ``p``, given the sampled ``columns`` and
        per-sample ``constraints`` of a run on ``s_values``.  ``narrow``: (s, width) of the
        assembly margins' and |dq/ds|'s minima that the samples do not resolve (near a lock-up
        or a dead centre the quantities change over that width): sweep values that resolve
        them join the samples (:func:`~optdesign.kinematics.peaks.resolving_points`) before
        the extrema are bracketed.  Returns a dict: ``peaks`` (name -> |peak|), ``peak_at``
        (name -> {s, q, value}), ``constraint_extremes`` (per-sample constraint -> {min, min_s,
        max, max_s}), ``aggregates`` (constraint -> located s values of its aggregates) and
        ``certificates``.  The batch of one case of :meth:`many`."""
        return self.many(s_values, np.asarray(p, float).ravel()[None, :],
                         {k: np.asarray(v)[None] for k, v in columns.items()},
                         {k: np.asarray(v)[None] for k, v in constraints.items()}, [narrow])[0]

    def _group(self, s_values, P, columns, constraints, extra):
        """:meth:`many` of cases that share their sweep values (``extra`` joining the samples)."""
        inputs = self._inputs(s_values, P, columns, constraints, extra)
        if inputs is None:
            return Found(*([[]] * len(P),) * 5, (), (), ())
        grid, values, requests, made = inputs
        parts, combine = self._parts(grid, values, P, requests)
        return made(combine([maxima_of_cases(evaluate, grid, V, r, enclosure=enclosure)
                             for evaluate, V, r, enclosure in parts]))

    def begin(self, s_values, P, columns, constraints):
        """:meth:`found`'s work for cases whose sweep values are the samples (no narrow minima
        to resolve) up to its calls of the one certification: (parts, grid, finish), the calls
        as (evaluate, V, requests, enclosure) each on the ascending ``grid``, ``finish`` the
        function that makes :meth:`found`'s result from what
        :func:`~optdesign.kinematics.peaks.maxima_of_cases` gives for each part; or None where
        there is nothing to certify.  Another caller may run the parts together with its own
        (:func:`~optdesign.kinematics.joint.maxima_together`: the same numbers)."""
        P = np.atleast_2d(np.asarray(P, float))
        inputs = self._inputs(np.asarray(s_values, float), P, columns, constraints, [])
        if inputs is None:
            return None
        grid, values, requests, made = inputs
        parts, combine = self._parts(grid, values, P, requests)

        def finish(results):
            found = made(combine(results))
            return [(found, c) for c in range(len(P))]

        return parts, grid, finish

    def _inputs(self, s_values, P, columns, constraints, extra):
        """(the ascending grid, the rows on it: cases x rows x len(grid), the requests, the
        function making the group's :class:`Found` from (s, value, bound, notes)) of the cases
        ``P`` on ``s_values`` with ``extra``; None without requests."""
        n, S = P.shape[0], len(s_values)
        V = np.empty((n, self.n_rows, S))
        for name, i in self.peak_rows.items():
            V[:, i] = columns[name]
        for name, i in self.constraint_rows.items():
            V[:, i] = constraints[name]
        if self.aggregate_rows:
            V[:, [i for _, _, i in self.aggregate_rows]] = self._aggregates(s_values, P)
        q_sampled = np.asarray(columns["q"], float)
        if extra:
            s_all = np.r_[s_values, extra]
            order = np.argsort(s_all, kind="stable")
            if s_values[-1] < s_values[0]:
                order = order[::-1]
            V = np.concatenate([V, self._values(np.array(extra), P)], axis=2)[:, :, order]
            q_sampled = np.c_[q_sampled, np.full((n, len(extra)), np.nan)][:, order]
            s_values = s_all[order]
        requests = list(self.requests)
        if not requests:
            return None
        ascending = len(s_values) < 2 or s_values[-1] >= s_values[0]
        grid, values = (s_values, V) if ascending else (s_values[::-1], V[:, :, ::-1])
        k_peaks = len(self.peak_rows)
        peaks, extremes, aggregates = self._figures

        def made(found):
            s, v, bound, notes = found
            q = self._q(s[:, :k_peaks], s_values, q_sampled, P)
            return Found(s.tolist(), v.tolist(), bound.tolist(), notes, q, peaks, extremes, aggregates)

        return grid, values, requests, made

    def _parts(self, grid, values, P, requests):
        """(the calls of :func:`~optdesign.kinematics.peaks.maxima_of_cases` that give the
        ``requests``' (s, value, bound, notes): (evaluate, V, requests, enclosure) each, the
        function that makes those from what the calls give): those of the rows that depend on
        none of the study's axes (:func:`_fixed_rows`: a study of masses, the transmission angle
        and the cylinder's lengths) apart from the others, once per group of cases equal bit for
        bit in the parameters those rows read and in their sampled values (a batch of masses:
        once); each case gets its group's numbers, what the case alone gives (the same
        operations on the same bits).  Without such rows, or without others, all in one call as
        before (an analysis without axes)."""
        fixed = [j for j, r in enumerate(requests) if r.row in self.fixed_rows]
        enclosure = self._linear.at(self.enclosures.at(P), P)   # (the axes' pre-filter, for several cases)
        if not fixed or len(fixed) == len(requests):
            return [(_per_case(self.derivatives, P), values, requests, enclosure)], lambda found: found[0]
        moving = [j for j in range(len(requests)) if j not in fixed]
        rows = sorted({requests[j].row for j in fixed})
        # by the bits of the parameters those rows read and of each row's samples (views, not
        # one key made of copies of them: the same groups)
        first, inverse = _groups([P[:, self.fixed_parameters].view(np.int64)]
                                 + [values[:, r].view(np.int64) for r in rows])
        Q = P[first]
        parts = [(_per_case(self.derivatives, P), values, [requests[j] for j in moving], enclosure),
                 (_per_case(self.derivatives, Q), values[first], [requests[j] for j in fixed], self.enclosures.at(Q))]

        def combine(found):
            (s_m, v_m, b_m, n_m), (s_f, v_f, b_f, n_f) = found
            n, k = len(P), len(requests)
            s, v, bound = np.empty((n, k)), np.empty((n, k)), np.empty((n, k))
            for out, a, b in ((s, s_m, s_f), (v, v_m, v_f), (bound, b_m, b_f)):
                out[:, moving], out[:, fixed] = a, b[inverse]
            # each case's notes in the requests' order: its moving notes then its group's fixed
            # ones, rearranged (the same objects as placing them one by one)
            place = itemgetter(*np.argsort(np.array(moving + fixed), kind="stable").tolist())
            notes = [list(place(own + n_f[g])) for own, g in zip(n_m, inverse.tolist())]   # (k >= 2: a tuple)
            return s, v, bound, notes

        return parts, combine

    def _values(self, s, P):
        """The rows at the sweep values ``s`` for each case: cases x rows x len(s)."""
        n, m = P.shape[0], len(s)
        flat = self.values(np.tile(s, n), np.repeat(P, m, axis=0))[0]   # rows x (cases * len(s))
        return flat.reshape(self.n_rows, n, m).transpose(1, 0, 2)

    def _aggregates(self, s, P):
        """The aggregates' rows at the sweep values ``s`` for each case (cases x rows x len(s)),
        evaluated once per distinct value (by its bits) of the parameters they depend on: a
        case's rows are computed with another case's parameters only where they differ in
        parameters the rows' graph does not read (the same bits)."""
        key = np.ascontiguousarray(P[:, self.aggregate_parameters]).view(np.int64)
        first, inverse = np.zeros(1, int), np.zeros(len(P), int)   # (rows that read no parameter)
        if key.shape[1]:
            _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
        Q, m = P[first], len(s)
        flat = self.aggregate_values(np.tile(s, len(Q)), np.repeat(Q, m, axis=0))[0]   # rows x (distinct * len(s))
        return flat.reshape(-1, len(Q), m).transpose(1, 0, 2)[inverse.reshape(-1)]

    def _q(self, s, s_values, q_sampled, P):
        """The drive coordinate at each case's sweep values ``s`` (cases x k), on the branch of
        its sampled (unwrapped) q: a list of lists."""
        n, k = s.shape
        q = self.q(s.ravel(), P[0] if n == 1 else np.repeat(P, k, axis=0))[0][0].reshape(n, k)   # (one case: its vector)
        if self.mech.scene.drive.kind == "rotary" and k:
            distance = np.abs(s_values[None, None, :] - s[:, :, None])
            known = np.isfinite(q_sampled)   # the samples', not the joined sweep values'
            if np.count_nonzero(known) < known.size:
                distance = np.where(known[:, None, :], distance, np.inf)
            near = q_sampled[np.arange(n)[:, None], np.argmin(distance, axis=2)]   # (np.take_along_axis's, cheaper)
            turn = [math.remainder(x, 2 * math.pi) for x in (q - near).ravel().tolist()]   # (np.vectorize's, cheaper)
            q = near + np.array(turn, float).reshape(q.shape)
        return q.tolist()


class Found:
    """The certified extremes of a group of cases (:meth:`CertifiedExtremes.many`) as the branch
    and bound gives them: per case (lists over the cases) the located s and the value there, the
    bound and the note of every request, and q at the peaks' s; ``peaks``, ``extremes`` and
    ``aggregates`` place the requests ((j, name, certificate's name), (j, name, max's, min's),
    (j, name)).  :meth:`case` is a case's dict."""

    __slots__ = ("s", "v", "bound", "notes", "q", "peaks", "extremes", "aggregates")

    def __init__(self, s, v, bound, notes, q, peaks, extremes, aggregates):
        self.s, self.v, self.bound, self.notes, self.q = s, v, bound, notes, q
        self.peaks, self.extremes, self.aggregates = peaks, extremes, aggregates

    def case(self, c) -> dict:
        """Case ``c``'s dict of :meth:`CertifiedExtremes.many`: a bound of NaN is None, a min's
        bound negated (the bounds are floats here)."""
        sc, vc, bc, nc, qc = self.s[c], self.v[c], self.bound[c], self.notes[c], self.q[c]
        found = {"peaks": {}, "peak_at": {}, "constraint_extremes": {}, "aggregates": {}, "certificates": {}}
        found_peaks, found_at, certificates = found["peaks"], found["peak_at"], found["certificates"]
        for j, name, key in self.peaks:
            value, b = vc[j], bc[j]
            found_peaks[name] = abs(value)
            found_at[name] = {"s": sc[j], "q": qc[j], "value": value}
            certificates[key] = {"bound": None if b != b else b, "note": nc[j]}
        for j, name, high, low in self.extremes:
            found["constraint_extremes"][name] = {"min": vc[j + 1], "min_s": sc[j + 1], "max": vc[j], "max_s": sc[j]}
            b, b_low = bc[j], bc[j + 1]
            certificates[high] = {"bound": None if b != b else b, "note": nc[j]}
            certificates[low] = {"bound": None if b_low != b_low else -b_low, "note": nc[j + 1]}
        for j, name in self.aggregates:
            found["aggregates"].setdefault(name, []).append(sc[j])
        return found


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
            func = mech.function("peaks_ds", {"v": v, "dv": dv, "d2v": mech.ds(dv)})
            # compiled from the disk cache where it is there (the same numbers, as CertifiedExtremes')
            self.derivatives = MappedFunction(func, compile=compiled_function)
            self.enclosures = Enclosures(func, compile_program)

    def __call__(self, s_values, p, columns, names=None, certify=True) -> dict:
        """name -> (|peak|, {s, value}, certificate {bound, note}) at parameters ``p``, from the
        sampled ``columns`` on ``s_values`` (ascending or descending), for the rows ``names``
        (all by default); without ``certify`` located only (the refined sample maxima, no
        enclosure: certificate None).  The batch of one case of :meth:`many`."""
        return self.many(s_values, np.asarray(p, float).ravel()[None, :],
                         {k: np.asarray(v, float)[None] for k, v in columns.items()}, names, certify)[0]

    def many(self, s_values, P, columns, names=None, certify=True) -> list:
        """:meth:`__call__` of N cases at once, all on the same ``s_values``: case i at
        parameters ``P[i]`` with its sampled ``columns`` in row i (name -> N x len(s_values)).
        One dict per case, bit for bit what the case alone gives (every decision per case:
        :func:`~optdesign.kinematics.peaks.maxima_of_cases`); one evaluation of the rows per
        Newton step and one of the enclosure per pass of the branch and bound for the batch."""
        s_values = np.asarray(s_values, float)
        P = np.atleast_2d(np.asarray(P, float))
        chosen = [n for n in self.names if names is None or n in names]
        if not chosen:
            return [{} for _ in P]
        requests = [Request(self.names.index(n), "abs", ends=True) for n in chosen]
        if self.in_time is not None:
            s, v, bound, notes = self.in_time.maxima_of_cases(s_values, P, requests, certify)
        else:
            V = np.stack([np.asarray(columns[name], float) for name in self.names], axis=1)   # cases x rows x S
            if len(s_values) > 1 and s_values[-1] < s_values[0]:
                s_values, V = s_values[::-1], V[:, :, ::-1]
            s, v, bound, notes = maxima_of_cases(_per_case(self.derivatives, P), s_values, V, requests,
                                                 enclosure=self.enclosures.at(P) if certify else None)
        out = []
        for c in range(len(P)):
            sc, vc, bc = s[c].tolist(), v[c].tolist(), bound[c].tolist()
            out.append({name: (abs(vc[j]), {"s": sc[j], "value": vc[j]},
                               _certificate(None if bc[j] != bc[j] else bc[j], notes[c][j]) if certify else None)
                        for j, name in enumerate(chosen)})
        return out


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
        self.derivatives = MappedFunction(func, compile=compiled_function)   # (as CertifiedPeaks')
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

    def maxima_of_cases(self, s_values, P, requests, certify=True):
        """The largest extremum of each request of N cases (parameters ``P``: N x parameters)
        over the law's time, as :func:`~optdesign.kinematics.peaks.maxima_of_cases` gives them
        (s, value, bound: arrays cases x requests; notes), each s and note's position a sweep
        value: case i's numbers those of :meth:`maxima` of case i alone."""
        tau = self.grid(s_values)
        n, m = len(P), len(tau)
        V = self.derivatives(np.tile(tau, n), np.repeat(P, m, axis=0))[0].reshape(-1, n, m).transpose(1, 0, 2)
        s, v, bound, notes = maxima_of_cases(_per_case(self.derivatives, P), tau, V, requests,
                                             enclosure=self.enclosures.at(P) if certify else None)
        s = self.profile.law_sweep(s.ravel()).reshape(s.shape)   # (element by element: each as :meth:`sweep`'s)
        return s, v, bound, [[self._note(x) for x in row] for row in notes]

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


def _per_case(derivatives, P):
    """``evaluate(s, cases)`` of :func:`~optdesign.kinematics.peaks.maxima_of_cases`: the
    MappedFunction ``derivatives`` at s with each case's row of ``P``; one case: with its vector
    (CasADi's map without a parameter row per value, cheaper; the same Function at the same
    numbers, so the same bits)."""
    if len(P) == 1:
        p = P[0]
        return lambda s, cases: derivatives(s, p)
    return lambda s, cases: derivatives(s, P[cases])


def _fixed_rows(mech, rows) -> tuple:
    """(the rows, by index, whose graphs depend on none of the study's axes, the parameters
    that those rows read), by the graphs' structure (CasADi's which_depends): no rows where the
    analysis has no axes (one branch and bound for all, :meth:`CertifiedExtremes._parts`) or
    an axis is not a leaf parameter."""
    axes = mech.resolved.axes
    if not axes or any(a not in mech.parameter_names for a in axes):
        return frozenset(), np.zeros(0, int)
    moved = {mech.parameter_names.index(a) for a in axes}
    used = [parameters_used(mech, row) for row in rows]
    fixed = [i for i, u in enumerate(used) if not moved & set(u.tolist())]
    return frozenset(fixed), np.unique(np.concatenate([used[i] for i in fixed] + [np.zeros(0, int)])).astype(int)


def _groups(keys) -> tuple:
    """(the first case of each group of cases equal in every array of ``keys`` (each cases x
    values), each case's group): a case compared whole with each group's first (a batch of a
    study: all in one group)."""
    inverse = np.full(len(keys[0]), -1)
    first = []
    while (inverse < 0).any():
        i = int(np.argmax(inverse < 0))
        same = inverse < 0
        for key in keys:
            same &= (key == key[i]).all(axis=1)
        inverse[same] = len(first)
        first.append(i)
    return np.array(first, int), inverse


def _certificate(bound, note, sign=1.0) -> dict:
    """What the enclosure proved of one extremum: ``bound`` (of |v|, of v for a max, of v from
    below for a min; None without one: NaN) and ``note`` (why not, "" when certified)."""
    return {"bound": None if bound is None or bound != bound else sign * bound, "note": note}


def aggregates(expr: Expression) -> list:
    """The one-argument max(...)/min(...) calls of a stroke expression, in order, as (func,
    inner expression)."""
    return [(func, Expression(f"{func}(...) in {expr.source}", inner)) for func, inner in expr.aggregate_calls()]
