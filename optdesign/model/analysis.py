"""Values of the reduced model over the stroke: the front door :func:`analyse`."""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from ..kinematics.mechanism import Mechanism
from ..scene import ResolvedScene, Scene
from ..scene.arguments import scene_argument
from ..scene.expressions import evaluate
from .certified import PEAKS, CertifiedExtremes
from .mapped import MappedFunction
from .joint_structure import JointStructureError
from .joints import PEAKED
from .quantities import environment, joint_calls, joint_forces, model_value
from ..scene.cases import is_case_constraint
from .cases import CaseAnalysis
from .finite import check_columns, check_values
from .intervals_compiled import compile_program
from .blocked import stroke_evaluator
from .quadrature import integrate
from .reduction import ReducedModel
from .time_integrals import TOLERANCE, columns_at, rms_error


@dataclass(frozen=True)
class AnalysisResult:
    """The reduced model over the stroke.

    ``columns`` maps output names (``s``, ``q``, ``reduced_inertia``, ``reduced_inertia_dq``,
    ``static_load``, ``inertia_term``, ``velocity_term``, ``drive``, ``power``, ...) to arrays
    over the samples; names of terms the scene does not use are absent.  ``bodies`` maps body
    name -> ratio name -> array; ``constraints`` maps constraint name -> array (per sample) or
    float (per stroke, its max(...)/min(...) over the continuous stroke).

    ``peaks`` holds the peak |value| of the main columns (drive, static_load, reduced_inertia,
    power) over the continuous stroke, ``peak_at`` where each lies ({s, q, value}: the located
    sweep value, the drive coordinate there and the signed value), ``peaks_sampled`` the same
    peaks on the samples only; ``constraint_extremes`` the min and max of each per-sample
    constraint over the continuous stroke with their sweep values ({min, min_s, max, max_s,
    min_sampled, max_sampled}); ``constraints_sampled`` the per-stroke constraints on the
    samples only.  Without certification (``Analysis(..., certify=False)``) the certified
    entries equal the sampled ones."""

    scene: Scene
    columns: dict
    bodies: dict
    constraints: dict
    peaks: dict
    timings: dict = field(default_factory=dict)
    peaks_sampled: dict = field(default_factory=dict)
    peak_at: dict = field(default_factory=dict)
    constraint_extremes: dict = field(default_factory=dict)
    constraints_sampled: dict = field(default_factory=dict)
    # the scene's [[cases]] (model/cases.py: CasesResult): every case, the governing case of
    # each peak, the duty cycle and the drive train; None without cases
    cases: object = None
    # what the enclosures proved (model/certified.py): per peak and constraint extreme, the
    # bound over the continuous stroke (within kinematics.peaks.CERTIFY_TOL of the value) or the
    # note saying why there is none; empty without certification
    certificates: dict = field(default_factory=dict)
    # [quantities]: name -> array over the samples (their units: scene.quantities)
    quantities: dict = field(default_factory=dict)
    # why the joint forces (columns pin_force(P), ...: model/joints.py) are not there, or None
    joints_note: str | None = None
    # the two routes inside the tool (model/joints.py): the relative differences of the drive load
    # from the joint forces and by virtual work, and the reactions' power; None without joint forces
    joints_routes: dict | None = None

    @property
    def drive_kind(self):
        return self.scene.drive.kind

    def __repr__(self):
        unit = "N m" if self.drive_kind == "rotary" else "N"
        peak = f", peak |drive| {self.peaks['drive']:.6g} {unit}" if "drive" in self.peaks else ""
        return (f"AnalysisResult({self.scene.path!r}: {len(self.columns['s'])} samples{peak}, "
                f"{len(self.constraints)} constraints)")

    def to_dict(self) -> dict:
        """Plain data in SI (numbers, lists, dicts: ready for json.dumps)."""
        from ..scene.plain import result_dict

        return result_dict(self, "analysis")


class Analysis:
    """The compiled stroke evaluation of one scene (a class under :func:`analyse`)."""

    def __init__(self, scene: Scene | ResolvedScene, samples: int | None = None, efficiency_smoothing: float = 0.0,
                 certify: bool = True, joints: bool = False):
        t0 = time.perf_counter()
        self.mech = Mechanism(scene_argument("analyse", scene, ResolvedScene))
        self.mech.interval_compile = compile_program
        self.resolved = self.mech.resolved
        self.scene = scene = self.mech.scene
        self.model = ReducedModel(self.mech, efficiency_smoothing)
        self.s_values = self.mech.stroke(samples)
        outs = dict(self.model.outputs())
        for body, ratios in self.model.body_ratios().items():
            for name, expr in ratios.items():
                outs[f"{body}:{name}"] = expr
        self.per_sample = [c for c in scene.constraints if not c.expr.is_aggregate
                           and not is_case_constraint(scene, c)]   # those per load case: model/cases.py
        self.per_stroke = [c for c in scene.constraints if c.expr.is_aggregate]
        for c in self.per_sample:
            outs[f"constraint:{c.name}"] = model_value(self.model, c.expr, f"[[constraints]] {c.name}")
        # with ``joints``, the force at every joint (model/joints.py): columns pin_force(P), ...
        # (their certified peaks took the toggle press's build from 0.8 to 3.8 s, measured: so they are
        # asked for); where the joint structure cannot be derived, none, and the reason in joints_note
        self.joints, self.joints_note, self.joints_routes = {}, None, None
        try:
            if joints:
                self.joints, self.joints_routes = joint_forces(self.model).outputs(), joint_forces(self.model).routes
        except JointStructureError as exc:
            self.joints_note = str(exc)
        outs.update(self.joints)
        self.peak_names = [k for k in PEAKS if k in outs] + [k for k in self.joints if k.startswith(PEAKED)]
        for q in scene.quantities:   # those of the joint forces from the model (model/quantities.py)
            expr = self.mech.quantities.get(q.name)
            expr = model_value(self.model, q.expr, f"[quantities] {q.name}") if expr is None else expr
            outs[f"quantity:{q.name}"] = expr + 0 * self.mech.s
        self.names = list(outs)
        self._squares = {k: outs[k] for k in ("drive", "power") if k in outs}   # for sweep_rms, built on first use
        self.function = self.mech.function("reduced_model", outs)
        self.mapped = self.function.map(len(self.s_values))
        # over the whole stroke: compiled blocks from the disk cache, else numpy instruction by
        # instruction (SX graphs only; model/blocked.py)
        self.vectorised = stroke_evaluator(self.function)
        self._points = None
        self.certified = CertifiedExtremes(self) if certify else None
        self.case_analysis = CaseAnalysis(self.mech, self.s_values, joints, certify) if scene.cases else None
        self.build_time = time.perf_counter() - t0

    def sweep_rms(self, p_values) -> dict:
        """{name: (RMS over the sweep, its error estimate)} of the drive and the power at the
        parameters ``p_values``: sqrt of the mean of name^2 over the continuous sweep by the
        adaptive Gauss-Kronrod quadrature (:mod:`.quadrature`, to :data:`.time_integrals.TOLERANCE`
        of the integral, the samples its first intervals; a power-flow switch between samples
        closed in by its halving), not the samples' trapezoid rule."""
        if not self._squares:
            return {}
        if not isinstance(self._squares, tuple):
            # compiled from the disk cache where it is there (the same numbers; a study's case
            # spent 13 ms of its ~35 here in CasADi's virtual machine, 3 ms compiled: measured)
            function = MappedFunction(self.mech.function("sweep_squares", self._squares), compile=True)
            self._squares = (list(self._squares), function)
        names, function = self._squares
        columns = columns_at(function, names, np.asarray(p_values, float))
        s = np.sort(self.s_values)
        result = integrate(lambda x, d, piece: np.vstack([columns(x)[k] ** 2 for k in names]),
                           [(float(s[0]), float(s[-1]), 1.0)], [s[1:-1]], TOLERANCE)
        span = float(s[-1] - s[0])
        return {k: (math.sqrt(max(v, 0.0) / span), rms_error(max(v, 0.0), e, span, 0.0))
                for k, v, e in zip(names, result.values, result.errors)}

    def run(self, p_values=None) -> AnalysisResult:
        mech, model = self.mech, self.model
        p_values = mech.parameter_values if p_values is None else np.asarray(p_values, float)
        t0 = time.perf_counter()
        # both certified over the continuous stroke; what they return are minima of a margin or
        # of |dq/ds| narrower than the samples' spacing, where the peaks need finer samples
        narrow = mech.check_assembly(self.s_values, p_values) + model.check_dead_centre(self.s_values, p_values)
        if self.vectorised is not None:
            raw = self.vectorised(self.s_values, p_values)
        else:
            raw = self.mapped(s=self.s_values[None, :], p=p_values)
        n = len(self.s_values)
        values = {k: np.broadcast_to(np.asarray(v, float).ravel(), (n,)).copy() for k, v in raw.items()}
        columns = {"s": self.s_values.copy()}
        bodies, constraints, quantities = {}, {}, {}
        for key, arr in values.items():
            if key.startswith("constraint:"):
                constraints[key.split(":", 1)[1]] = arr
            elif key.startswith("quantity:"):
                quantities[key.split(":", 1)[1]] = arr
            elif ":" in key:
                body, name = key.split(":", 1)
                bodies.setdefault(body, {})[name] = arr
            else:
                columns[key] = arr
        if self.scene.drive.kind == "rotary":
            columns["q"] = np.unwrap(columns["q"])
        check_columns(self, self.s_values, columns, constraints, p_values)   # no NaN/inf: an error naming it
        s = self.s_values
        sampled_stroke = self._per_stroke(p_values, s)
        peaks_sampled, peak_at = {}, {}
        for k in self.peak_names:
            if k in columns:
                i = int(np.argmax(np.abs(columns[k])))
                peaks_sampled[k] = float(abs(columns[k][i]))
                peak_at[k] = {"s": float(s[i]), "q": float(columns["q"][i]), "value": float(columns[k][i])}
        extremes = {}
        for name, v in constraints.items():
            lo, hi = int(np.argmin(v)), int(np.argmax(v))
            extremes[name] = {"min": float(v[lo]), "min_s": float(s[lo]), "max": float(v[hi]), "max_s": float(s[hi])}
        timings = {"build_s": self.build_time, "evaluate_s": time.perf_counter() - t0}
        peaks, stroke = dict(peaks_sampled), dict(sampled_stroke)
        certificates = {}
        if self.certified is not None:
            t1 = time.perf_counter()
            found = self.certified(s, p_values, columns, constraints, narrow)
            peaks, peak_at, certificates = found["peaks"], found["peak_at"], found["certificates"]
            extra = sorted({x for located in found["aggregates"].values() for x in located})
            if extra:  # the located extrema join the samples, inside: start()/end() keep the ends
                stroke = self._per_stroke(p_values, np.r_[s[:-1], extra, s[-1:]])
            extremes = {k: dict(e, min_sampled=extremes[k]["min"], max_sampled=extremes[k]["max"])
                        for k, e in found["constraint_extremes"].items()}
            certificates.update({f"assembly of {name}": {"bound": None, "note": note}
                                 for name, note in mech.assembly_notes.items()})
            if model.dead_centre_note:
                certificates["dead centre"] = {"bound": None, "note": model.dead_centre_note}
            timings["certify_s"] = time.perf_counter() - t1
        else:
            extremes = {k: dict(e, min_sampled=e["min"], max_sampled=e["max"]) for k, e in extremes.items()}
        constraints.update(stroke)
        check_values(self, {**{f"constraint {k!r}": v for k, v in constraints.items() if not np.ndim(v)},
                            **{f"peak |{k}|": v for k, v in peaks.items()}})
        return AnalysisResult(self.scene, columns, bodies, constraints, peaks, timings, peaks_sampled,
                              peak_at, extremes, sampled_stroke,
                              cases=self.case_analysis.run(p_values) if self.case_analysis else None,
                              certificates=certificates, quantities=quantities, joints_note=self.joints_note,
                              joints_routes=self.joints_routes)

    def _per_stroke(self, p_values, s_values):
        """The per-stroke constraints with their aggregates taken over ``s_values``."""
        if not self.per_stroke:
            return {}
        mech = self.mech
        # the model's columns and joint forces that the per-stroke constraints use (model/quantities.py)
        columns = {}
        for c in self.per_stroke:
            used = (c.expr.names() | {f"{f}({p})" for f, p in joint_calls(c.expr)}) - set(mech.env)
            columns.update({k: v for k, v in environment(self.model, c.expr).items() if k in used})
        if self._points is None:  # built once, on the first run that needs it
            self._points = MappedFunction(mech.function("points", dict(mech.points, **columns)))
        names = list(mech.points)
        rows = self._points(s_values, p_values)
        values = self.resolved.environment(p_values)
        values[self.scene.sweep.name] = ca.DM(np.asarray(s_values, float)[None, :])
        points = {k: ca.DM(np.asarray(v)) for k, v in zip(names, rows)}
        values.update({k: ca.DM(np.asarray(v)).reshape((1, -1)) for k, v in zip(columns, rows[len(names):])})
        return {c.name: float(evaluate(c.expr, values, points, f"[[constraints]] {c.name}"))
                for c in self.per_stroke}


def analyse(scene: Scene | ResolvedScene, samples: int | None = None, certify: bool = True,
            joints: bool = False) -> AnalysisResult:
    """The reduced model of ``scene`` over its stroke (front door).  Assembly and dead centres
    are checked over the continuous stroke; the peaks and constraint extremes are certified
    over it too, unless ``certify`` is False (then they are the samples' own).  ``joints``: the
    force at every joint too (columns ``pin_force(P)``, ``pin_force_x(P)``, ...; their peaks
    certified like the drive load's; :mod:`optdesign.model.joints`)."""
    return Analysis(scene, samples, certify=certify, joints=joints).run()
