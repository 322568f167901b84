"""The continuous check: the worst value of every block over the continuous stroke at a
solution, against its bound (or, for the peak, against the epigraph), with the sampled worst
values beside it.  A solve is certified when nothing is exceeded by more than its tolerance;
otherwise the located extrema are where the exchange moves the slots (:mod:`.solver`).

A certified solve's reported values are certified too: once nothing is exceeded, the largest
and smallest value of every constraint, margin, dead-centre guard and aggregate are located
over the continuous stroke, each extremum refined whether near its bound or not (the check
itself refines only the extrema that can matter to a bound), so an inactive constraint is
reported by its true range, not by the samples' or the stroke ends' values."""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..kinematics.mapped import MappedFunction
from ..model.mapped import compiled_function
from ..kinematics.enclosure import Enclosures
from ..model.intervals_compiled import compile_program
from ..kinematics.peaks import Request, continuous_maxima_rows
from .cycle_certify import cycle_rms, recheck_cycle, rms_key
from .problem import DesignProblem

DENSE = 16   # the recheck's samples per interval of the scene's grid
_WORDS = {"abs": "peak |value|", "max": "largest value", "min": "smallest value"}


def _target(value, sense) -> float:
    """What a check maximises: |v|, v or -v."""
    return abs(value) if sense == "abs" else (value if sense == "max" else -value)


CHECK_TOL = 1e-7   # the enclosure's tolerance (in units of a check's scale) where its own is 0


@dataclass(frozen=True)
class Check:
    """One comparison of the continuous check: the extrema of quantity row ``row`` (|v|, max
    or min: ``sense``) against ``bound`` (an upper bound unless ``upper`` is False), in units
    of ``scale``, with tolerance ``tol``.  kind 'rms': the rms block's peak, certified only."""

    name: str
    row: int
    sense: str
    scale: float
    bound: float
    tol: float
    upper: bool = True
    kind: str = "bound"

    @property
    def request(self) -> Request:
        """Refine every grid maximum of the target, and an extremum inside the first or last
        interval of the grid too (where the sampled target rises towards an end, the end's own
        value would otherwise stand in for it).  Every one: a sampled maximum far below the
        bound can hide a continuous one above it (the knuckle press's blanking bump: 13,223 N m
        on the samples, 15,065 between them, against an epigraph of 15,005; skipping the grid
        maxima more than 10 % of the scale below the bound left only the stroke ends' 25 N m
        as the 'certified' peak, and that start won).  ``tol``: the enclosure's, the check's own
        (CHECK_TOL where that is 0), in the check's scale."""
        return Request(self.row, self.sense, ends=True, tol=max(self.tol, CHECK_TOL) * self.scale)

    def amount(self, value) -> float:
        """By how much ``value`` exceeds the bound, in units of the scale (< 0: within it)."""
        if self.sense == "abs":
            return (abs(value) - self.bound) / self.scale
        sign = 1.0 if self.upper else -1.0
        return (sign * value - sign * self.bound) / self.scale


class ContinuousCheck:
    """The continuous check of one problem's solutions (with its own buffered evaluation of
    the per-sample quantities' s-derivatives: one per solver, not for concurrent use)."""

    def __init__(self, problem: DesignProblem):
        self.pb = problem
        # the per-sample quantities' s-derivatives at many sweep values
        self.derivatives = MappedFunction(problem.quantity_derivatives, compile=compiled_function)
        self._enclosures = None
        self.notes = {}   # of the last certified call: (name, sense) -> why it has no certificate

    @property
    def enclosures(self) -> Enclosures:
        """The same program in interval arithmetic: the proof between the samples.  Built on
        first use (an objective phase's solution; :meth:`.solver.Solver.warm` builds it before
        the workers fork): a problem whose starts all fail phase 1 never needs it
        (crane_luffing_drive's 5.5 kW motor: 0.25-0.35 s of CPU to build)."""
        if self._enclosures is None:
            self._enclosures = Enclosures(self.pb.quantity_derivatives, compile_program)
        return self._enclosures

    def __call__(self, x, fixed, w, s_points):
        """Worst values of every block over the continuous stroke at design x.

        Returns (violations, certified, sampled): violations is a list of (amount, s, row) with
        amount > 0 where a bound (or the epigraph) is exceeded by more than its tolerance,
        sorted largest first, near-active extrema included with amount <= 0.  The extrema of
        all blocks are refined together (:func:`~optdesign.kinematics.peaks.continuous_maxima_rows`: one
        evaluation of every row per Newton step of all brackets).  Where the refined extrema
        are within their bounds, the same rows are enclosed over the continuous stroke
        (:func:`~optdesign.kinematics.peaks.certify`, with every extreme the report shows):
        an extremum between the samples that the grid does not bracket (a force bump narrower
        than the sample spacing) is then found, located and reported as a violation, where
        the exchange moves a slot.  ``self.notes`` says which values have no such proof."""
        pb = self.pb
        p = pb.full_parameters(x, fixed)
        grid = pb.s_grid
        V = pb.evaluate_grid(x, fixed)
        checks = self.checks(x, fixed, w, s_points)
        evaluate = lambda s: self.derivatives(s, p)  # noqa: E731
        requests = [c.request for c in checks]
        rms = self._rms(checks, x, fixed)
        out, certified, sampled = self._compare(checks, continuous_maxima_rows(evaluate, grid, V, requests), V, rms)
        self.notes = {}
        if not any(v[0] > 0 for v in out):  # the proof, and what the report shows: every extreme located
            keys, more, full_s = self._extreme_requests(V)
            found = self._certified(evaluate, grid, V, requests + more, p)
            out, certified, sampled = self._compare(checks, found[:len(checks)], V, rms)
            self.notes = {(c.name, c.sense): ext[0].note for c, ext in zip(checks, found) if ext[0].note}
            if not any(v[0] > 0 for v in out):
                certified.update({key: ext[0].value for key, ext in zip(keys, found[len(checks):])})
                sampled.update(full_s)
                self.notes.update({key: ext[0].note for key, ext in zip(keys, found[len(checks):]) if ext[0].note})
        for ag in pb.aggregates:  # a value at a stroke end is exact: the grid's first or last sample
            if ag.func in ("start", "end"):
                certified[(ag.name, ag.func)] = sampled[(ag.name, ag.func)] = float(V[ag.index, 0 if ag.func == "start" else -1])
        return out, certified, sampled

    def _certified(self, evaluate, grid, V, requests, p) -> list:
        """:func:`~optdesign.kinematics.peaks.continuous_maxima_rows` of ``requests`` with the
        enclosure: a case's rows along a law in time in its time (``pb.in_time``: closed form
        and smooth at a rest, where the law's inverse in the rows of s defeats the enclosure),
        the others in s."""
        owner = {int(row): (g, j) for g, (_, index) in enumerate(self.pb.in_time) for j, row in enumerate(index)}
        found = [None] * len(requests)
        plain = [k for k, r in enumerate(requests) if r.row not in owner]
        if plain:
            maxima = continuous_maxima_rows(evaluate, grid, V, [requests[k] for k in plain], enclosure=self.enclosures.at(p))
            for k, ext in zip(plain, maxima):
                found[k] = ext
        for g, (in_time, _) in enumerate(self.pb.in_time):
            mine = [k for k, r in enumerate(requests) if owner.get(r.row, (None,))[0] == g]
            if mine:
                local = [replace(requests[k], row=owner[requests[k].row][1]) for k in mine]
                for k, ext in zip(mine, in_time.maxima(grid, p, local)):
                    found[k] = ext
        return found

    def _rms(self, checks, x, fixed) -> dict:
        """The rms block's check (its quadrature against one with twice the panels), once."""
        pb = self.pb
        if not any(c.kind == "rms" for c in checks):
            return {}
        rms, finer = pb.rms(x, fixed), pb.rms(x, fixed, 2 * pb.rms_panels)
        return {"amount": abs(rms - finer) / max(finer, 1e-300) - pb.settings.rms_tol, "value": finer,
                "sampled": pb.rms_sampled(x, fixed)}

    def _compare(self, checks, extrema, V, rms) -> tuple:
        """(violations, certified, sampled) of the checks from their located extrema."""
        grid = self.pb.s_grid
        out, certified, sampled = [], {}, {}
        for c, ext in zip(checks, extrema):
            vals = V[c.row]
            certified[(c.name, c.sense)] = ext[0].value
            sampled[(c.name, c.sense)] = float(np.max(np.abs(vals)) if c.sense == "abs" else (np.max(vals) if c.sense == "max" else np.min(vals)))
            if c.kind == "rms":
                certified[(c.name, "rms")], sampled[(c.name, "rms")] = rms["value"], rms["sampled"]
                out.append((rms["amount"], 0.5 * (grid[0] + grid[-1]), None))
            else:
                out += [(c.amount(e.value) - c.tol, e.s, c.row) for e in ext]
        out.sort(key=lambda v: v[0], reverse=True)
        return out, certified, sampled

    def recheck(self, x, fixed, w, s_points, certified, sampled) -> str | None:
        """The certified values of a solve, checked by another path before the solve may count:
        the design's quantities on a grid DENSE times finer than the scene's, every local
        extremum of every checked row refined (none skipped, the stroke's end intervals too).
        None when they agree, else the reason the solve is not certified: a target (|v|, v or
        -v) of the dense check above the certified one by more than the check's tolerance,
        or a certified value below its own sampled one (a certified peak below a sampled
        peak is a contradiction, never a result), or a certified integral (the rms objective,
        an RMS over the duty cycle) that a dense rule does not confirm."""
        pb = self.pb
        grid = pb.s_grid
        dense = np.linspace(grid[0], grid[-1], DENSE * (len(grid) - 1) + 1)
        p = pb.full_parameters(x, fixed)
        V = pb.evaluate_grid(x, fixed, dense)
        checks = [c for c in self.checks(x, fixed, w, s_points) if c.kind != "rms"]
        found = continuous_maxima_rows(lambda s: self.derivatives(s, p), dense, V, [c.request for c in checks])
        for c, ext in zip(checks, found):
            key = (c.name, c.sense)
            if key not in certified:
                continue
            mine = _target(certified[key], c.sense)
            if key in sampled and mine < _target(sampled[key], c.sense) - 1e-12 * c.scale:
                return (f"the certified {_WORDS[c.sense]} of {c.name} ({certified[key]:.10g}) is below its "
                        f"sampled one ({sampled[key]:.10g})")
            other = _target(ext[0].value, c.sense)
            if not np.isfinite(other) or (other - mine) / c.scale > max(c.tol, 1e-12):
                return (f"the {_WORDS[c.sense]} of {c.name} is {ext[0].value:.10g} at s = {ext[0].s:.8g} on "
                        f"{len(dense)} samples with every extremum refined, beyond its certified "
                        f"{certified[key]:.10g}")
        # the integrals: the rms objective over the sweep, the RMS over the duty cycle's time
        return self._recheck_rms(x, fixed, certified) or recheck_cycle(pb, x, fixed, certified)

    def _recheck_rms(self, x, fixed, certified) -> str | None:
        """The rms objective's certified value (Gauss-Legendre) against the trapezoid rule on
        grids 16 and 8 times finer than the scene's, Richardson-extrapolated: None when they
        agree within that rule's error estimate (a third of their difference) or rms_tol."""
        pb = self.pb
        key = next(((b.name, "rms") for b in pb.blocks if b.kind == "rms"), None)
        if key is None or key not in certified:
            return None
        grid, rule = pb.s_grid, []
        for factor in (16, 8):
            s = np.linspace(grid[0], grid[-1], factor * (len(grid) - 1) + 1)
            v = pb.evaluate_grid(x, fixed, s)[pb.objective_quantity]
            rule.append(math.sqrt(np.trapezoid(v**2, s) / (s[-1] - s[0])))
        other, estimate = rule[0] + (rule[0] - rule[1]) / 3, abs(rule[0] - rule[1]) / 3
        if abs(certified[key] - other) <= max(estimate, pb.settings.rms_tol * abs(other)):
            return None
        return (f"the rms of {key[0]} is {other:.10g} by the trapezoid rule on {len(grid) * 16 - 15} samples "
                f"(Richardson, +- {estimate:.2g}), against its certified {certified[key]:.10g}")

    def add_cycle(self, x, fixed, certified):
        """Each integrated quantity's RMS over the duty cycle's time at design ``x``, certified
        (:func:`.cycle_certify.cycle_rms`), put into ``certified`` (and its error estimate)."""
        for what, (value, error) in cycle_rms(self.pb, x, fixed).items():
            certified[rms_key(what)] = value
            certified[(rms_key(what)[0], "error")] = error

    def _extreme_requests(self, V) -> tuple:
        """What :meth:`extremes` locates: (keys, requests, the sampled values)."""
        pb = self.pb
        tol = pb.settings.constraint_tol   # certified to the checks' own tolerance, in each one's scale
        rows = [(b.name, b.index, b.scale) for b in pb.blocks if b.kind in ("constraint", "design constraint", "margin")]
        rows += [(ag.name, ag.index, ag.scale) for ag in pb.aggregates if ag.func in ("max", "min")]
        rows.append(("dead centre", pb.k_row, pb.k_ref))
        keys, requests, sampled = [], [], {}
        for name, row, scale in rows:
            v = V[row]
            for sense in ("max", "min"):
                sampled[(name, sense)] = float(np.max(v) if sense == "max" else np.min(v))
                keys.append((name, sense))
                requests.append(Request(row, sense, ends=True, tol=tol * abs(float(scale))))
        return keys, requests, sampled

    def extremes(self, evaluate, grid, V, enclosure=None) -> tuple:
        """The largest and smallest value over the continuous stroke of every constraint,
        margin, dead-centre guard and max/min aggregate, each local extremum refined
        (whatever its distance from a bound) and the stroke's end intervals too, certified by
        ``enclosure`` when given: ({(name, 'max'|'min'): value}, the same on the samples)."""
        keys, requests, sampled = self._extreme_requests(V)
        found = continuous_maxima_rows(evaluate, grid, V, requests, enclosure=enclosure) if requests else []
        return {key: ext[0].value for key, ext in zip(keys, found)}, sampled

    def checks(self, x, fixed, w, s_points) -> list:
        """What the continuous check compares, in the order it reports: the epigraph of the
        peak (or the rms block's peak, bound-free), each constraint's upper then lower bound,
        each aggregate against its NLP value, and the dead-centre guard."""
        pb, st = self.pb, self.pb.settings
        nd = len(pb.design_names)
        t = float(w[nd]) if pb.n_t else None
        a = pb.aggregates_of(w)
        checks = []
        for b in pb.blocks:
            if b.kind == "peak":
                # the epigraph's own value: the largest |v| at the NLP's points (IPOPT may leave t
                # a hair below it, within its constraint tolerance)
                at_points = pb.evaluate_grid(x, fixed, s_points)
                reference = max(t * pb.f_ref, float(np.max(np.abs(at_points[b.index]))))
                checks.append(Check(b.name, b.index, "abs", pb.f_ref, reference, st.peak_tol * reference / pb.f_ref))
            elif b.kind == "rms":
                checks.append(Check(b.name, b.index, "abs", 1.0, math.inf, 0.0, kind="rms"))
            elif b.kind in ("constraint", "design constraint", "margin"):
                if math.isfinite(b.upper):
                    checks.append(Check(b.name, b.index, "max", b.scale, b.upper, st.constraint_tol))
                if math.isfinite(b.lower):
                    checks.append(Check(b.name, b.index, "min", b.scale, b.lower, st.constraint_tol, upper=False))
        # an aggregate of the objective: to the objective's own tolerance (peak_tol of its value),
        # not its scale's (max(y) - min(y) of 0.28 m out of y ~ 22 m: 3e-6 apart otherwise)
        in_objective = pb.objective_expr.names() if pb.objective_kind == "expression" else set()
        for i, ag in enumerate(pb.aggregates):
            # a located extreme is a value of the stroke (an equality may hold it): as tight as a peak
            tol = min(st.constraint_tol, st.peak_tol) if i in pb.located else st.constraint_tol
            if ag.name in in_objective:
                tol = min(tol, st.peak_tol * pb.objective_scale / ag.scale)
            if ag.func == "max":
                checks.append(Check(ag.name, ag.index, "max", ag.scale, float(a[i]), tol))
            elif ag.func == "min":
                checks.append(Check(ag.name, ag.index, "min", ag.scale, float(a[i]), tol, upper=False))
        checks.append(Check("dead centre", pb.k_row, "min" if pb.k_sign > 0 else "max", pb.k_ref,
                            pb.k_sign * st.dead_centre_margin * pb.k_ref, 0.0, upper=pb.k_sign < 0))
        return checks
