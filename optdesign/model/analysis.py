"""Values of the reduced model over the stroke: the front door :func:`analyse`."""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from ..kinematics.mechanism import Mechanism
from ..scene import ResolvedScene, Scene
from ..scene.arguments import scene_argument
from ..scene.expressions import evaluate
from .cases import CaseAnalysis
from .finite import check_columns, check_values
from .reduction import ReducedModel
from .vectorised import VectorisedSX


@dataclass(frozen=True)
class AnalysisResult:
    """The reduced model over the stroke.

    ``columns`` maps output names (``s``, ``q``, ``reduced_inertia``, ``reduced_inertia_dq``,
    ``static_load``, ``inertia_term``, ``velocity_term``, ``drive``, ``power``, ...) to arrays
    over the samples; names of terms the scene does not use are absent.  ``bodies`` maps body
    name -> ratio name -> array; ``constraints`` maps constraint name -> array (per sample) or
    float (per stroke); ``peaks`` holds the peak |value| of the main columns."""

    scene: Scene
    columns: dict
    bodies: dict
    constraints: dict
    peaks: dict
    timings: dict = field(default_factory=dict)
    # the scene's [[cases]] (model/cases.py: CasesResult): every case, the governing case of
    # each peak, the duty cycle and the drive train; None without cases
    cases: object = None

    @property
    def drive_kind(self):
        return self.scene.drive.kind


class Analysis:
    """The compiled stroke evaluation of one scene (a class under :func:`analyse`)."""

    def __init__(self, scene: Scene | ResolvedScene, samples: int | None = None, efficiency_smoothing: float = 0.0):
        t0 = time.perf_counter()
        self.mech = Mechanism(scene_argument("analyse", scene, ResolvedScene))
        self.resolved = self.mech.resolved
        self.scene = scene = self.mech.scene
        self.model = ReducedModel(self.mech, efficiency_smoothing)
        self.s_values = self.mech.stroke(samples)
        outs = dict(self.model.outputs())
        for body, ratios in self.model.body_ratios().items():
            for name, expr in ratios.items():
                outs[f"{body}:{name}"] = expr
        self.per_sample = [c for c in scene.constraints if not c.expr.is_aggregate]
        self.per_stroke = [c for c in scene.constraints if c.expr.is_aggregate]
        for c in self.per_sample:
            outs[f"constraint:{c.name}"] = self.mech.value(c.expr, f"[[constraints]] {c.name}")
        self.names = list(outs)
        self.function = self.mech.function("reduced_model", outs)
        self.mapped = self.function.map(len(self.s_values))
        try:  # numpy over the whole stroke, instruction by instruction (SX graphs only)
            self.vectorised = VectorisedSX(self.function)
        except NotImplementedError:
            self.vectorised = None
        self._points_map = None
        self.case_analysis = CaseAnalysis(self.mech, self.s_values) if scene.cases else None
        self.build_time = time.perf_counter() - t0

    def run(self, p_values=None) -> AnalysisResult:
        mech, model = self.mech, self.model
        p_values = mech.parameter_values if p_values is None else np.asarray(p_values, float)
        t0 = time.perf_counter()
        mech.check_assembly(self.s_values, p_values)
        model.check_dead_centre(self.s_values, p_values)
        if self.vectorised is not None:
            raw = self.vectorised(self.s_values, p_values)
        else:
            raw = self.mapped(s=self.s_values[None, :], p=p_values)
        n = len(self.s_values)
        values = {k: np.broadcast_to(np.asarray(v, float).ravel(), (n,)).copy() for k, v in raw.items()}
        columns = {"s": self.s_values.copy()}
        bodies, constraints = {}, {}
        for key, arr in values.items():
            if key.startswith("constraint:"):
                constraints[key.split(":", 1)[1]] = arr
            elif ":" in key:
                body, name = key.split(":", 1)
                bodies.setdefault(body, {})[name] = arr
            else:
                columns[key] = arr
        if self.scene.drive.kind == "rotary":
            columns["q"] = np.unwrap(columns["q"])
        check_columns(self, self.s_values, columns, constraints, p_values)   # no NaN/inf: an error naming it
        constraints.update(self._per_stroke(p_values))
        peaks = {k: float(np.max(np.abs(columns[k]))) for k in
                 ("drive", "static_load", "reduced_inertia", "power") if k in columns}
        timings = {"build_s": self.build_time, "evaluate_s": time.perf_counter() - t0}
        check_values(self, {**{f"constraint {k!r}": v for k, v in constraints.items() if not np.ndim(v)},
                            **{f"peak |{k}|": v for k, v in peaks.items()}})
        return AnalysisResult(self.scene, columns, bodies, constraints, peaks, timings,
                              cases=self.case_analysis.run(p_values) if self.case_analysis else None)

    def _per_stroke(self, p_values):
        if not self.per_stroke:
            return {}
        mech = self.mech
        if self._points_map is None:  # built once, on the first run that needs it
            self._points_map = mech.function("points", dict(mech.points)).map(len(self.s_values))
        rows = self._points_map(s=self.s_values[None, :], p=p_values)
        values = self.resolved.environment(p_values)
        values[self.scene.sweep.name] = ca.DM(self.s_values[None, :])
        points = {k: ca.DM(np.asarray(v)) for k, v in rows.items()}
        return {c.name: float(evaluate(c.expr, values, points, f"[[constraints]] {c.name}"))
                for c in self.per_stroke}


def analyse(scene: Scene | ResolvedScene, samples: int | None = None) -> AnalysisResult:
    """The reduced model of ``scene`` over its stroke (front door)."""
    return Analysis(scene, samples).run()
