"""Values of the reduced model over the stroke: the front door :func:`analyse`."""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from ..kinematics.assembly import AssemblyCheck
from ..kinematics.mechanism import Mechanism
from ..scene import ResolvedScene, Scene
from ..scene.arguments import scene_argument
from .certified import PEAKS, CertifiedExtremes
from ..kinematics.mapped import MappedFunction
from .mapped import compiled_function
from .joint_structure import JointStructureError
from .joints import PEAKED
from .quantities import joint_forces, model_value
from ..scene.cases import is_case_constraint
from .cases import CaseAnalysis
from .cse import cse_function
from .intervals_compiled import compile_program
from .blocked import stroke_evaluator
from .per_stroke import StrokeConstraints
from .quadrature import integrate_arrays
from .runs import run_cases
from .reduction import ReducedModel
from .time_integrals import TOLERANCE, rms_error

# samples per first interval of :meth:`Analysis.sweep_rms_many`'s quadrature: one interval per
# sample cost 15 evaluations per sample even where one round converges (the truck crane's 161
# samples: 2,400 per case); 4 samples per interval keep the 15 Kronrod nodes at most 0.42 sample
# spacings apart, so that a bump of the integrand between two samples still shows in an
# interval's |K15 - G7| and is halved into (tests/test_sweep_rms.py)
RMS_PANEL = 4
# cases per quadrature of :meth:`Analysis.sweep_rms_many` (its arrays, ~2.4 MB per pass at 256 of
# the truck crane's cases, stay in the cache: 1,024 at once took 0.072 ms per case, 4 x 256 0.047)
RMS_CASES = 256


def rms_starts(s) -> np.ndarray:
    """The cuts between the first intervals of :meth:`Analysis.sweep_rms_many`'s quadrature over
    the sorted samples ``s``: every :data:`RMS_PANEL`-th inner sample."""
    return np.asarray(s, float)[RMS_PANEL:-1:RMS_PANEL]


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
                 certify: bool = True, joints: bool = False, cases: bool = True):
        """``cases`` False: the nominal state alone, the scene's [[cases]] left out of the run
        (its ``cases`` None; the start's figures of an optimisation need no more)."""
        t0 = time.perf_counter()
        self.mech = Mechanism(scene_argument("analyse", scene, ResolvedScene))
        self.mech.interval_compile = compile_program
        self.mech.compile_function = compiled_function
        self.mech.cse_function = cse_function
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
        # the per-stroke constraints: their aggregates' per-sample expressions as rows of the model
        self.stroke = StrokeConstraints(self.model, self.per_stroke) if self.per_stroke else None
        if self.stroke is not None:
            outs.update(self.stroke.rows)
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
        self.mapped = MappedFunction(self.function)   # (MX graphs: CasADi's map)
        # over the whole stroke: compiled blocks from the disk cache, else numpy instruction by
        # instruction (SX graphs only; model/blocked.py)
        self.vectorised = stroke_evaluator(self.function, varied=self._varied())
        self._stroke_rows = None   # the aggregates' rows at located sweep values, built on first use
        self.assembly = AssemblyCheck(self.mech)
        self.certified = CertifiedExtremes(self) if certify else None
        # the load cases' columns compiled from the disk cache (the same numbers: CasADi's C)
        self.case_analysis = CaseAnalysis(self.mech, self.s_values, joints, certify, compile=True) if scene.cases and cases else None
        self.build_time = time.perf_counter() - t0

    def _varied(self) -> list:
        """The indices of the parameters whose values differ between the cases of one build (a
        study's axes: the resolved scene's ``variable``)."""
        return [i for i, name in enumerate(self.mech.parameter_names) if name in self.resolved.variable]

    def sweep_rms(self, p_values) -> dict:
        """{name: (RMS over the sweep, its error estimate)} of the drive and the power at the
        parameters ``p_values``: sqrt of the mean of name^2 over the continuous sweep by the
        adaptive Gauss-Kronrod quadrature (:mod:`.quadrature`, to :data:`.time_integrals.TOLERANCE`
        of the integral, every :data:`RMS_PANEL`-th sample a cut between its first intervals; a
        power-flow switch between samples closed in by its halving), not the samples' trapezoid
        rule.  The one case of :meth:`sweep_rms_many`."""
        return self.sweep_rms_many(np.asarray(p_values, float)[None, :])[0]

    def sweep_rms_many(self, P) -> list:
        """:meth:`sweep_rms` of every row of the parameters ``P`` (cases x parameters): one
        quadrature over all cases, each case's intervals refined by its own decisions
        (:func:`.quadrature.integrate_many`: a case's numbers are those of its own call)."""
        P = np.atleast_2d(np.asarray(P, float))
        if not self._squares:
            return [{} for _ in P]
        if len(P) > RMS_CASES:   # (each case's numbers are its own whatever the batch)
            return [r for at in range(0, len(P), RMS_CASES) for r in self.sweep_rms_many(P[at:at + RMS_CASES])]
        if not isinstance(self._squares, tuple):
            # the compiled blocks from the disk cache where they are there, else numpy or
            # CasADi's map (model/blocked.py): each case's quadrature nodes in blocks of its own
            func = self.mech.function("sweep_squares", self._squares)
            self._squares = (list(self._squares), stroke_evaluator(func, varied=self._varied())
                             or MappedFunction(func, compile=compiled_function))
        names, function = self._squares
        s = np.sort(self.s_values)

        def f(x, d, piece, case):
            if isinstance(function, MappedFunction):
                rows = function(x, P[case])
                return np.vstack([np.reshape(row, (1, -1)) ** 2 for row in rows])
            # the nodes come case after case (integrate_many keeps its intervals so)
            got = function.ragged(x, np.bincount(case, minlength=len(P)), P)
            squares = np.empty((len(names), len(x)))
            for k, row in zip(names, squares):
                np.multiply(got[k], got[k], out=row)   # (x ** 2 is x * x)
            return squares

        values, errors = integrate_arrays(f, [(float(s[0]), float(s[-1]), 1.0)], [rms_starts(s)], TOLERANCE,
                                          cases=len(P))[:2]
        span = float(s[-1] - s[0])
        if not span > 0:   # (one sample)
            return [{k: (math.sqrt(max(v, 0.0) / span), rms_error(max(v, 0.0), e, span, 0.0))
                     for k, v, e in zip(names, values[:, c], errors[:, c])} for c in range(len(P))]
        # rms_error's figures over every case at once, its operations in its order (the same numbers)
        squared = np.where(0.0 > values, 0.0, values)   # max(v, 0.0), as Python's max picks
        with np.errstate(all="ignore"):
            rms = np.sqrt(squared / span)
            error = np.where(squared > 0, 0.5 * rms * (errors / squared + 0.0 / span),
                             np.sqrt(np.where(0.0 > errors, 0.0, errors) / span))
        rms, error = rms.T.tolist(), error.T.tolist()
        return [dict(zip(names, zip(r, e))) for r, e in zip(rms, error)]

    def run(self, p_values=None) -> AnalysisResult:
        """The analysis at the parameters ``p_values`` (the scene's own by default): the one case
        of :meth:`run_many`, with its columns over the samples; its error raised."""
        p_values = self.mech.parameter_values if p_values is None else np.asarray(p_values, float)
        runs, values = self._run_many(p_values[None, :])
        case = runs[0]
        if case.error is not None:
            raise case.error
        columns = {"s": self.s_values.copy()}
        bodies, constraints, quantities = {}, {}, {}
        for key, arr in values.items():
            arr = arr[0].copy()
            if key.startswith("constraint:"):
                constraints[key.split(":", 1)[1]] = arr
            elif key.startswith("quantity:"):
                quantities[key.split(":", 1)[1]] = arr
            elif key.startswith("stroke:"):
                continue
            elif ":" in key:
                body, name = key.split(":", 1)
                bodies.setdefault(body, {})[name] = arr
            else:
                columns[key] = arr
        constraints.update(case.stroke)
        return AnalysisResult(self.scene, columns, bodies, constraints, case.peaks, case.timings, case.peaks_sampled,
                              case.peak_at, case.constraint_extremes, case.stroke_sampled, cases=case.cases,
                              certificates=case.certificates, quantities=quantities, joints_note=self.joints_note,
                              joints_routes=self.joints_routes)

    def run_many(self, P) -> list:
        """The analyses of many cases that differ in leaf parameter values only (``P``: cases x
        parameters, :attr:`mech.parameter_names`), each stage over all cases at once: a
        :class:`~.runs.CaseRun` per case (its figures, or the OptdesignError that stopped it in
        ``error``).  Every decision is the case's own: a case's figures are the same bit for bit
        in any batch, and :meth:`run` is the one case."""
        return self._run_many(P)[0]

    def _run_many(self, P):
        """(CaseRun per case, the model's values: name -> cases x samples)."""
        return run_cases(self, np.atleast_2d(np.asarray(P, float)))

    def stroke_rows_at(self, s, P) -> np.ndarray:
        """The per-stroke constraints' aggregate rows at sweep values ``s``, each with its
        parameter row of ``P`` (rows x len(s))."""
        if self._stroke_rows is None:
            self._stroke_rows = MappedFunction(self.mech.function("stroke_rows", {"v": ca.vertcat(
                *self.stroke.rows.values())}))
        return self._stroke_rows(s, P)[0]


def analyse(scene: Scene | ResolvedScene, samples: int | None = None, certify: bool = True,
            joints: bool = False) -> AnalysisResult:
    """The reduced model of ``scene`` over its stroke (front door).  Assembly and dead centres
    are checked over the continuous stroke; the peaks and constraint extremes are certified
    over it too, unless ``certify`` is False (then they are the samples' own).  ``joints``: the
    force at every joint too (columns ``pin_force(P)``, ``pin_force_x(P)``, ...; their peaks
    certified like the drive load's; :mod:`optdesign.model.joints`)."""
    return Analysis(scene, samples, certify=certify, joints=joints).run()
