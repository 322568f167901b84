"""Assembly over the whole stroke, not only at the samples.

Every construction that can fail to assemble has a margin (:class:`~.mechanism.Margin`), a
smooth function of the sweep value s: a dyad's ``4 d^2 Lp^2 - (d^2 + Lp^2 - Lq^2)^2`` (the
squared height of its triangle, times 4 d^2), a slider's ``L^2 - dist(p, line)^2``, a closed
loop's Jacobian determinant.  Each is divided by its size far from the limit, so that the
*relative margin* is dimensionless: the squared sine of the dyad's or slider's angle at its
limit, the sine of the angle between the loop Jacobian's columns (kept at the sign of its branch).

The check has two parts, and a stroke passes only both:

* at the samples: no relative margin at or below its limit (:data:`LOCKUP_MARGIN` for dyads and
  sliders, :data:`LOOP_LOCKUP` for loops), every loop closed by Newton's method and staying on
  one branch;
* between the samples: every interior local minimum of a sampled relative margin, and each end
  interval, brackets a continuous minimum, refined by the one certification
  (:func:`~.peaks.continuous_maxima_rows`: Newton on the exact derivative dm/ds from CasADi,
  bisection as its safeguard).  A minimum at or below the limit is a lock-up (the margin
  touches zero: a four-bar's toggle, a slider at its end of travel) or a stretch of the stroke
  that does not assemble (the margin dips below zero between two samples).

The error names the construction and the located position: the minimum of a touch, the point
where the margin crosses zero on entering a stretch that does not assemble (located by
bisection), or the first sample where a loop does not close.  The earliest failure along the
sweep is reported.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..errors import AssemblyError
from ..scene.written import sweep_unit
from .batches import parameters_used, same_cases
from .enclosure import Enclosures, Selected
from .mapped import MappedFunction
from .peaks import Request, extrema_of_cases, narrow_minima

# A dyad or slider whose relative margin is below this is at (or numerically at) its limit
# position: velocities there grow like 1/sqrt(margin) and the derivatives lose about
# eps/(relative margin) of their accuracy, so such a stroke is refused rather than evaluated.
LOCKUP_MARGIN = 1e-10
ASSEMBLY_TOL = 1e-6   # the enclosure's tolerance on a relative margin's minimum
# The same limit for a loop, whose relative margin is a sine where a dyad's is a squared sine.
LOOP_LOCKUP = math.sqrt(LOCKUP_MARGIN)


def fmt_s(value, scene) -> str:
    """A sweep value in messages, in the units the scene wrote it: 10 significant digits (a
    located position is meant to be read to 1e-9), and in degrees too when the sweep is an angle
    (:func:`sweep_is_angle`); a length, a time or any other coordinate as the plain number."""
    return f"{value:.10g} ({math.degrees(value):.6g} deg)" if sweep_is_angle(scene) else f"{value:.10g}"


# The fields of each construction that hold an angle: a sweep that is a term of one of them is
# an angle (a crank's, a jib's), also when its range is written in radians as plain numbers.
_ANGLE_FIELDS = {"Polar": ("angle",), "Slider": ("angle",), "Loop": ("angles",)}


def sweep_is_angle(scene) -> bool:
    """True when the sweep is an angle: its range written with deg or pi, or the sweep variable
    itself a term (+ or -) of a construction's angle, e.g. ``polar = ["A", "r", "phi"]`` or
    ``"phi + 90 deg"``.  A sweep used only inside another expression there (a normalised time
    tau in ``psi0 + h*(tau - sin(2*pi*tau)/(2*pi))``), or in a length, is not."""
    sweep = scene.sweep
    if sweep_unit(scene):   # written in deg or with pi: an angle
        return True
    for c in scene.points:
        for name in _ANGLE_FIELDS.get(type(c).__name__, ()):
            value = getattr(c, name, None)
            for e in value if isinstance(value, (tuple, list)) else (value,):
                if hasattr(e, "tree") and _is_term(e.tree, sweep.name):
                    return True
    return False


def _is_term(node, name) -> bool:
    """True when Name(``name``) is a term of the sum ``node`` (through + - and negation)."""
    kind = type(node).__name__
    if kind == "Name":
        return node.name == name
    if kind == "Neg":
        return _is_term(node.operand, name)
    if kind == "BinOp" and node.op in ("+", "-"):
        return _is_term(node.left, name) or _is_term(node.right, name)
    return False


class Pending:
    """:meth:`AssemblyCheck.begin`'s check of the cases ``P`` on ``s_values``, waiting for its
    ``parts``' minima (on ``grid``; the kinds' cases ``kinds``); ``groups`` None: nothing to check."""

    def __init__(self, P, s_values):
        self.P, self.s_values, self.kinds, self.parts = P, s_values, [], []
        self.groups = self.grid = self.G = self.staged = self.direction = None   # (groups None: nothing to check)


@dataclass(frozen=True)
class _Failure:
    """Where one construction first fails along the sweep (``at``: its position along the
    sweep's direction, for ordering) and the message saying so."""

    at: float
    order: int
    s: float
    construction: str
    message: str


class AssemblyCheck:
    """The assembly check of one :class:`~.mechanism.Mechanism` (its functions built once, on
    first use).  Call it with the stroke's sweep values and the parameter vector."""

    def __init__(self, mech):
        self.mech = mech
        self.rows = []      # (margin, relative margin expression, limit)
        for m in mech.centres + mech.margins:
            limit = LOOP_LOCKUP if m.kind == "loop" else LOCKUP_MARGIN
            self.rows.append((m, m.expr / m.scale, limit))
        self.varies = [bool(ca.depends_on(rel, mech.s)) for _, rel, _ in self.rows]
        self._sampled = None
        self._derivatives = None
        self._maps = {}   # the functions' MappedFunction, built on first use
        self.notes = {}   # of the last call: construction -> why its margin has no enclosure's proof

    # --- functions ---
    def _sampled_function(self):
        mech = self.mech
        outs = {"r": ca.vertcat(*(rel for _, rel, _ in self.rows)) if self.rows else ca.DM.zeros(0, 1)}
        closing = [(j, loop) for j, loop in enumerate(mech.loops) if loop.solution is not None]
        for j, loop in closing:
            outs[f"res{j}"] = loop.residual
            outs[f"u{j}"] = loop.solution
        if mech.points:
            outs["size"] = ca.mmax(ca.fabs(ca.horzcat(*mech.points.values())))
        return mech.function("assembly", outs), closing

    def _build_derivatives(self):
        if self._derivatives is None:
            mech = self.mech
            r = ca.vertcat(*(rel for _, rel, _ in self.rows))
            dr = mech.ds(r)
            self.expressions = (r, dr, mech.ds(dr))   # (also rows of CertifiedExtremes' Function)
            self._derivatives = mech.function("assembly_ds", dict(zip(("r", "dr", "d2r"), self.expressions)))
            self._enclosures = Enclosures(self._derivatives, mech.interval_compile)   # the same program, in intervals

    def _mapped(self, key, func):
        """``func`` at many sweep values (:class:`~.mapped.MappedFunction`, compiled by the
        mechanism's ``compile_function`` when it has one: the same numbers)."""
        if key not in self._maps:
            self._maps[key] = MappedFunction(func, compile=self.mech.compile_function)
        return self._maps[key]

    def _relative(self, s, p, i):
        self._build_derivatives()
        return float(self._mapped("derivatives", self._derivatives)([s], p)[0][i, 0])

    # --- the check ---
    def __call__(self, s_values, p_values):
        """Raise :class:`AssemblyError` at the earliest place along the sweep where a
        construction does not assemble or reaches its limit position, at or between samples.
        Else return the margins' minima that the samples do not resolve, as (s, width) (what
        a certified peak must sample more finely: :func:`~.peaks.resolving_points`).  The one
        case of :meth:`many` (its notes in :attr:`notes`)."""
        found = self.many(s_values, np.asarray(p_values, float)[None, :])[0]
        if isinstance(found, AssemblyError):
            raise found
        narrow, self.notes = found
        return narrow

    def many(self, s_values, P) -> list:
        """Per case (a row of the parameters ``P``): ``(narrow, notes)`` (the minima the samples
        do not resolve; construction -> why its margin has no enclosure's proof) or the case's
        :class:`AssemblyError`.  The margins depend on the geometry alone: cases equal in its
        parameters are checked once (:func:`~.batches.same_cases`).  :meth:`begin`, the minima
        of its parts (:func:`~.peaks.extrema_of_cases`), :meth:`finish`."""
        pending = self.begin(s_values, P)
        return self.finish(pending, [extrema_of_cases(evaluate, pending.grid, V, requests, enclosure=enclosure)
                                     for evaluate, V, requests, enclosure in pending.parts])

    def begin(self, s_values, P) -> "Pending":
        """The check of :meth:`many` up to the margins' continuous minima: the samples of every
        case in one call, the crossings located; its :attr:`Pending.parts` the calls of the one
        certification that find the minima between the samples (one per kind of case: the same
        rows and signs), for :meth:`finish` (run alone or with others': :mod:`.joint`)."""
        P = np.atleast_2d(np.asarray(P, float))
        s_values = np.asarray(s_values, float)
        pending = Pending(P, s_values)
        if not self.rows and not self.mech.loops:
            return pending
        if self._sampled is None:
            self._sampled = self._sampled_function()
            self._uses = parameters_used(self.mech, *self._sampled[0].call([self.mech.s, self.mech.p]))
        pending.groups = same_cases(P, self._uses)
        G = P[[g for g, _ in pending.groups]]
        f, closing = self._sampled
        n = len(s_values)
        res = dict(zip(f.name_out(), self._mapped("sampled", f)(np.tile(s_values, len(G)), np.repeat(G, n, axis=0))))
        direction = 1.0 if n < 2 or s_values[-1] >= s_values[0] else -1.0
        staged = []
        for c in range(len(G)):
            one = {k: v[:, c * n:(c + 1) * n] for k, v in res.items()}
            R = one["r"].reshape(len(self.rows), n)
            failures = self._loops(one, closing, s_values, direction)
            more, sign, T, first_bad, rows = self._sampled_margins(R, s_values, G[c], direction)
            staged.append((failures + more, sign, T, first_bad, rows))
        self._resolve_crossings(staged, s_values, G, direction)
        pending.G, pending.staged, pending.direction = G, staged, direction
        pending.grid = s_values if direction > 0 else s_values[::-1]
        if n >= 2:
            pending.kinds, pending.parts = self._between(G, staged, direction)
        return pending

    def finish(self, pending, extrema) -> list:
        """:meth:`many`'s result from :meth:`begin`'s ``pending`` and what
        :func:`~.peaks.extrema_of_cases` gives for each of its parts (``extrema``)."""
        P = pending.P
        if pending.groups is None:
            return [([], {}) for _ in P]
        between = {}
        for cases, found in zip(pending.kinds, extrema):
            between.update(zip(cases.tolist(), found))
        s_values, G, direction = pending.s_values, pending.G, pending.direction
        checked = []
        for c, (failures, sign, T, first_bad, rows) in enumerate(pending.staged):
            failures, narrow, notes = self._continuous(s_values, G[c], sign, first_bad, rows, between.get(c), direction,
                                                       failures)
            if failures:
                first = min(failures, key=lambda x: (x.at, x.order))
                checked.append(AssemblyError(first.message, construction=first.construction, s=first.s))
            else:
                checked.append((narrow, notes))
        out = [None] * len(P)
        for (first, members), found in zip(pending.groups, checked):
            for i in members:
                out[i] = found
        return out

    def _sampled_margins(self, R, s_values, p, direction):
        """(failures at the samples, each row's sign, the signed margins T, row -> its first failing
        sample, the rows whose continuous minima are looked for: those that vary with s and have
        a finite value) of one case's relative margins ``R`` (rows x samples)."""
        sign = np.ones(len(self.rows))
        for i, (m, _, _) in enumerate(self.rows):
            if m.kind == "loop":  # a loop's determinant keeps the sign of its branch
                finite = R[i][np.isfinite(R[i])]
                sign[i] = 1.0 if not finite.size or finite[0] >= 0 else -1.0
        T = sign[:, None] * R
        failures, first_bad = [], {}
        for i, (m, _, limit) in enumerate(self.rows):
            bad = np.flatnonzero(~(T[i] > limit))
            if bad.size:
                first_bad[i] = k = int(bad[0])
                failures.append(self._sampled_failure(i, k, T, s_values, p, sign, direction))
        rows = [i for i in range(len(self.rows)) if self.varies[i] and np.any(np.isfinite(T[i]))]
        return failures, sign, T, first_bad, tuple(rows)

    def _between(self, P, staged, direction) -> tuple:
        """(the cases of each kind, the calls of the one certification that find their rows'
        continuous minima: (evaluate, V, requests, enclosure) each, on the ascending grid): the
        cases with the same rows and signs in one (the enclosure's proof between the samples)."""
        kinds = {}
        for c, (_, sign, _, _, rows) in enumerate(staged):
            if rows:
                kinds.setdefault((rows, tuple(sign[list(rows)])), []).append(c)
        self._build_derivatives()
        ascending = direction > 0
        cases_of, parts = [], []
        for (rows, signs), cases in kinds.items():
            rows, signs, cases = list(rows), np.array(signs)[:, None], np.array(cases)
            V = np.stack([staged[c][2][rows] for c in cases])
            V = V if ascending else V[:, :, ::-1]
            Pc = P[cases]

            def evaluate(s, which, rows=rows, signs=signs, Pc=Pc):
                found = self._derivative_points(s, Pc[which])
                return tuple(signs * a[rows] for a in found)

            requests = [Request(j, "min", ends=True, tol=ASSEMBLY_TOL) for j in range(len(rows))]
            enclosure = Selected(self._enclosures.at(Pc), rows, signs.ravel())   # the proof between the samples
            cases_of.append(cases)
            parts.append((evaluate, V, requests, enclosure))
        return cases_of, parts

    def _derivative_points(self, s, P):
        """(R, dR/ds, d2R/ds2) of every relative margin at each sweep value of ``s`` with its own
        parameter row of ``P``."""
        self._build_derivatives()
        return tuple(self._mapped("derivatives", self._derivatives)(s, P))

    def _continuous(self, s_values, p, sign, first_bad, rows, extrema, direction, failures):
        """One case's ``failures`` (at the samples) with those between the samples, the minima
        that pass but are narrower than the samples' spacing ((s, width) each:
        :func:`~.peaks.narrow_minima`) and the notes, from its rows' continuous minima
        ``extrema`` (None without)."""
        failures, narrow, notes = list(failures), [], {}
        if extrema is not None:
            rows = list(rows)

            def evaluate_many(s):
                return tuple(sign[rows, None] * a[rows] for a in self._derivative_points(s, np.tile(p, (len(s), 1))))

            notes = {self.rows[i][0].construction: extrema[j][0].note for j, i in enumerate(rows)
                     if extrema[j][0].note}
            for j, i in enumerate(rows):
                m, _, limit = self.rows[i]
                low = [e for e in extrema[j] if e.value <= limit]
                if not low:
                    if i not in first_bad:
                        one = lambda s, j=j: tuple(a[j] for a in evaluate_many(s))  # noqa: E731
                        narrow += narrow_minima(one, extrema[j], _spacing(s_values))
                    continue
                e = min(low, key=lambda e: direction * e.s)
                k = first_bad.get(i)
                if k is not None and direction * e.s >= direction * s_values[k]:
                    # the samples already fail first; a touch beside a failing sample names it better
                    if e.value >= -limit and abs(e.s - s_values[k]) <= _spacing(s_values):
                        failures = [x for x in failures if x.order != i]
                        failures.append(self._touch(i, e.s, e.value, direction))
                    continue
                failures.append(self._continuous_failure(i, e, s_values, p, sign, direction))
        return failures, narrow, notes

    def _sampled_failure(self, i, k, T, s_values, p, sign, direction):
        m, _, limit = self.rows[i]
        v = T[i, k]
        if math.isnan(v):
            return self._failure(i, s_values[k], direction, (
                f"cannot be evaluated at {self._name} = {fmt_s(s_values[k], self.mech.scene)} (its margin is NaN: a "
                "point it is built from does not assemble there). Check the constructions it uses."))
        if v >= -limit or m.kind == "dyad centres":
            return self._touch(i, s_values[k], v, direction)
        if k == 0 or not T[i, k - 1] > limit:
            return self._failure(i, s_values[k], direction, (
                f"cannot assemble at {self._name} = {fmt_s(s_values[k], self.mech.scene)}: {self._meet(m)} "
                f"(relative margin {v:.3g} < 0). Change its lengths or narrow the sweep."))
        return _Crossing(i, s_values[k - 1], s_values[k], sign[i], v, s_values[k])   # its s: :meth:`_resolve_crossings`

    def _resolve_crossings(self, staged, s_values, P, direction):
        """Each :class:`_Crossing` among the cases' failures (a margin that fails at a sample and
        passed at the one before) made its failure: where the margin crosses zero, located by
        bisection for all of them at once (:func:`_crossings`; each its own steps)."""
        pending = [(c, j, x) for c, (failures, *_) in enumerate(staged)
                   for j, x in enumerate(failures) if isinstance(x, _Crossing)]
        if not pending:
            return
        cases = np.array([c for c, _, _ in pending])
        rows = np.array([x.row for _, _, x in pending])
        signs = np.array([x.sign for _, _, x in pending])

        def relative(s, which):
            r = self._derivative_points(s, P[cases[which]])[0]
            return signs[which] * r[rows[which], np.arange(len(which))]

        self._build_derivatives()
        found = _crossings(relative, np.array([x.lo for _, _, x in pending]), np.array([x.hi for _, _, x in pending]))
        for (c, j, x), s0 in zip(pending, found.tolist()):
            i, m = x.row, self.rows[x.row][0]
            staged[c][0][j] = self._singular(i, s0, direction) if m.kind == "loop" else self._failure(i, s0, direction, (
                f"cannot assemble past {self._name} = {fmt_s(s0, self.mech.scene)}: it reaches its limit position "
                f"there and {self._meet(m)} beyond it (relative margin {x.value:.3g} < 0 at the sample "
                f"{self._name} = {fmt_s(x.sample, self.mech.scene)}). Change its lengths or narrow the sweep."))

    def _continuous_failure(self, i, e, s_values, p, sign, direction):
        m, _, limit = self.rows[i]
        if e.value >= -limit or m.kind == "dyad centres":
            return self._touch(i, e.s, e.value, direction)
        # the margin dips below zero between two samples: name where it enters that stretch
        before = s_values[(s_values - e.s) * direction < 0]
        lo = before[-1] if before.size else s_values[0]
        relative = lambda s: sign[i] * self._relative(s, p, i)  # noqa: E731
        s0 = _crossing(relative, lo, e.s) if relative(lo) > 0 else e.s
        if m.kind == "loop":
            return self._singular(i, s0, direction)
        s1 = _crossing(relative, _next_sample(s_values, e.s, direction), e.s)
        return self._failure(i, s0, direction, (
            f"cannot assemble from {self._name} = {fmt_s(s0, self.mech.scene)} to {fmt_s(s1, self.mech.scene)}, between two samples: "
            f"{self._meet(m)} there (relative margin down to {e.value:.3g} at {self._name} = "
            f"{fmt_s(e.s, self.mech.scene)}; the samples alone miss it). Change its lengths or narrow the sweep."))

    def _touch(self, i, s, value, direction):
        m, _, limit = self.rows[i]
        if m.kind == "dyad centres":
            return self._failure(i, s, direction, (
                f"has its two centres at one place at {self._name} = {fmt_s(s, self.mech.scene)} (squared distance "
                f"{value:.3g} <= {limit:g} of the sum of its squared lengths): its circles are one "
                "circle and its point is not determined there (a kite or parallelogram folding). "
                "Narrow the sweep so that it stops short of this position, or change its lengths."))
        what = ("is at a singular position (its closure's Jacobian is singular: a locking position)"
                if m.kind == "loop" else "is at its limit (lock-up) position")
        return self._failure(i, s, direction, (
            f"{what} at {self._name} = {fmt_s(s, self.mech.scene)} (relative margin {value:.3g} <= {limit:g}): "
            "its velocities are infinite there. Narrow the sweep so that it stops short of this "
            "position, or change its lengths."))

    def _singular(self, i, s, direction):
        return self._failure(i, s, direction, (
            f"passes a singular (locking) position at {self._name} = {fmt_s(s, self.mech.scene)}: its closure's "
            "Jacobian changes sign there, so the loop folds onto another branch or locks. Narrow "
            "the sweep so that it stops short of this position, or change its lengths."))

    def _failure(self, i, s, direction, text):
        m = self.rows[i][0]
        kind = "dyad" if m.kind == "dyad centres" else m.kind
        return _Failure(direction * float(s), i, float(s), m.construction,
                        f"{self.mech.scene.path}: [points] {m.construction} ({kind}) {text}")

    @property
    def _name(self):
        return self.mech.scene.sweep.name
    @staticmethod
    def _meet(m):
        return {"dyad": "its circles do not meet", "slider": "its circle and line do not meet",
                "loop": "it does not close"}[m.kind]

    def _loops(self, res, closing, s_values, direction):
        """Loops that Newton's method does not close at a sample, or that jump to another
        branch between two samples."""
        failures = []
        name = self._name
        path = self.mech.scene.path
        for j, loop in closing:
            order = len(self.rows) + j
            r = np.asarray(res[f"res{j}"]).ravel()
            scale = np.maximum(1.0, np.asarray(res["size"]).ravel())
            bad = np.flatnonzero(~(r <= 1e-9 * scale))
            if bad.size:
                k = int(bad[0])
                failures.append(_Failure(direction * s_values[k], order, float(s_values[k]), loop.loop.name, (
                    f"{path}: [points] {loop.loop.name} (loop): Newton's method does not close the "
                    f"loop at {name} = {fmt_s(s_values[k], self.mech.scene)} (residual {r[k]:.3g}). The loop cannot "
                    "assemble there, or the initial guesses lead elsewhere: check the lengths, the "
                    "sweep range and the unknowns' guesses.")))
                continue
            u = np.atleast_2d(np.asarray(res[f"u{j}"]))
            jumps = np.abs(np.diff(np.unwrap(u, axis=1), axis=1)) if u.shape[1] > 1 else np.zeros((1, 0))
            if jumps.size:
                typical = np.median(jumps, axis=1, keepdims=True)
                bad = np.argwhere((jumps > 10 * typical + 1e-9) & (jumps > 0.3))
                if bad.size:
                    k = int(bad[0][1])
                    failures.append(_Failure(direction * s_values[k], order, float(s_values[k]), loop.loop.name, (
                        f"{path}: [points] {loop.loop.name} (loop): the solution jumps to another "
                        f"assembly branch between {name} = {fmt_s(s_values[k], self.mech.scene)} and "
                        f"{fmt_s(s_values[k + 1], self.mech.scene)}. Give initial guesses that follow the branch (they "
                        "may use the sweep variable), or narrow the sweep.")))
        return failures


def _spacing(s_values):
    return abs(float(s_values[-1] - s_values[0])) / max(len(s_values) - 1, 1)


def _next_sample(s_values, s, direction):
    after = s_values[(s_values - s) * direction > 0]
    return after[0] if after.size else s_values[-1]


@dataclass(frozen=True)
class _Crossing:
    """A failure still to be located: margin ``row`` (times ``sign``) passes at ``lo`` and
    fails at the sample ``hi`` (= ``sample``, its value there ``value``)."""

    row: int
    lo: float
    hi: float
    sign: float
    value: float
    sample: float


def _crossings(f, a, b, iterations=200):
    """:func:`_crossing` of many brackets at once, each with its own steps (a bracket's number
    is the same in any batch): ``f(s, which)`` the functions of the brackets ``which`` at ``s``."""
    a, b = np.array(a, float), np.array(b, float)
    started = f(a, np.arange(len(a))) > 0
    going, out = started.copy(), a.copy()
    for _ in range(iterations):
        live = np.flatnonzero(going)
        if not live.size:
            break
        mid = 0.5 * (a[live] + b[live])
        done = (mid == a[live]) | (mid == b[live])
        going[live[done]] = False
        live, mid = live[~done], mid[~done]
        if not live.size:
            break
        up = f(mid, live) > 0
        a[live[up]], b[live[~up]] = mid[up], mid[~up]
    return np.where(started, b, out)


def _crossing(f, a, b):
    """Where f crosses zero between a (f > 0) and b (f <= 0 or NaN), by bisection down to
    neighbouring floats: the first point with f <= 0, within an ulp or so of the crossing
    (a point where the construction no longer assembles; ``a`` itself if f(a) is not > 0)."""
    return float(_crossings(lambda s, which: np.array([f(float(s[0]))]), [a], [b])[0])
