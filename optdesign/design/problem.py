"""The design problem as an NLP for IPOPT, with the peak over the continuous stroke.

Formulation (what makes it fast and regular):

* Design variables are the scene's bounded parameters, scaled to [0, 1] by their bounds.  All
  other leaf parameters are NLP *parameters*, so the optimal objective's sensitivity to each of
  them comes from IPOPT's multipliers (``lam_p``).
* The peak over the stroke is an epigraph ``-t <= v(s_j)/F_ref <= t`` written only at a few
  sample points s_j: a uniform base grid plus movable *slots*.  The s_j are NLP parameters too,
  so an exchange step moves slots onto the continuous extrema found at the last solution and
  re-solves without rebuilding anything.  The loop ends when the epigraph value and the peak of
  the continuous stroke (refined by Newton, :mod:`optdesign.kinematics.peaks`) agree within ``peak_tol``.
* Per-sample constraints (transmission angle, any expression) and assembly margins live on the
  same points and are checked on the continuous stroke in the same way.
* A stroke aggregate max(e)/min(e) in a constraint or objective becomes a variable a with
  e(s_j) <= a (or >= a): an epigraph where the bound makes it conservative (the outer
  expression is monotone in a in that direction at the start design), else the *located*
  extreme a = e(s_d) at a designated slot that the exchange puts on the continuous extreme
  (an equality max(y) - min(y) == H, a lower bound on a stroke: exact at a fixed active set,
  see :mod:`.nlp`); start(e)/end(e) are e at the stroke's ends.
  Its rows, and the dead-centre guard's (the drive coordinate keeps moving: sigma*k(s)/k_ref >=
  margin), are imposed only at the stroke's ends and the slots, where their extrema mostly are;
  the exchange puts a slot wherever one of them is exceeded, on a base point too.
* Everything is scaled to order one by its value at the scene's start design: F_ref for the
  drive load, the start's range for each constraint and margin.
* Constraint bounds are only the NLP's lbg/ubg (passed at solve time): every named constraint
  keeps its rows in g with +-inf on an open side, so :meth:`DesignProblem.with_bounds` gives a
  problem with other bounds that shares the built NLP and solvers (a Pareto front by the
  epsilon-constraint method needs no rebuild per point).

This module holds the problem itself: its settings, design variables and their scaling, the
parameter vectors and the scales taken at the start design.  The build's other steps live in
:mod:`.rows` (the per-sample quantities and the objective's form), :mod:`.nlp` (the NLP, its
IPOPT solvers and row bounds), :mod:`.bounds` (other constraint bounds on the same NLP) and
:mod:`.aggregates` (stroke aggregates, monotonicity, the rms quadrature).
"""
from __future__ import annotations

import math
import sys
from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..errors import SceneError
from ..kinematics.mechanism import Mechanism
from ..model.cse import cse_derived, cse_function
from ..model.intervals_compiled import compile_program
from ..model.mapped import compiled_function
from ..model.reduction import ReducedModel
from ..scene import Scene
from . import aggregates, nlp, rows
from . import bounds as bounds_  # (with_bounds' argument is named bounds)
from .cases import case_grid, on_case_break
from .rows import Block


@dataclass(frozen=True)
class SolverSettings:
    """How the design problem is solved (the scene says only *what*)."""

    tol: float = 1e-10             # IPOPT tol on the scaled problem
    max_iter: int = 300            # IPOPT iterations per solve
    grid: int = 13                 # base sample points of the epigraph (ends included)
    slots: int = 6                 # movable sample points put on the located extrema
    peak_tol: float = 1e-8         # relative agreement of epigraph and continuous peak
    constraint_tol: float = 1e-7   # allowed violation of a scaled constraint between samples
    max_exchanges: int = 20        # exchange steps per start
    rms_panels: int = 16           # composite Gauss-Legendre panels (4 nodes each) for rms(...), doubled until accurate
    rms_tol: float = 1e-7          # relative agreement of the rms with twice as many panels
    efficiency_smoothing: float = 1e-3  # width of the power-flow switch, times the power scale
    dead_centre_margin: float = 1e-3    # sigma*k/k_ref at least this (k = dq/ds)
    print_level: int = 0


class DesignProblem:
    """The NLP of one scene's design problem.  Build once; solve from many starts."""

    def __init__(self, scene: Scene, settings: SolverSettings | None = None):
        self.scene = scene
        self.settings = settings = settings or SolverSettings()
        if scene.objective is None:
            raise SceneError(f"{scene.path}: nothing to optimise: add an [objective] table, e.g. minimise = \"peak(drive)\"")
        design = [p for p in scene.parameters if p.is_design]
        if not design:
            raise SceneError(f"{scene.path}: no design variables: give some parameters bounds, e.g. e = {{ value = 1.6, min = 0.5, max = 3.0 }}")
        self.mech = mech = Mechanism(scene)
        mech.interval_compile = compile_program
        mech.compile_function = compiled_function
        mech.cse_function = cse_function
        names = list(mech.parameter_names)
        self.design_names = [p.name for p in design]
        self.design_index = [names.index(n) for n in self.design_names]
        self.fixed_names = [n for n in names if n not in self.design_names]
        self.fixed_index = [names.index(n) for n in self.fixed_names]
        self.lower = np.array([-math.inf if p.lower is None else p.lower for p in design])
        self.upper = np.array([math.inf if p.upper is None else p.upper for p in design])
        self.start = mech.parameter_values[self.design_index].copy()
        finite = np.isfinite(self.lower) & np.isfinite(self.upper)
        self.z_offset = np.where(finite, self.lower, 0.0)
        self.z_scale = np.where(finite, self.upper - self.lower, np.maximum(np.abs(self.start), 1.0))
        # with load cases, their profiles' phase boundaries too (design/cases.py)
        self.s_grid = case_grid(mech) if scene.cases else mech.stroke()
        # what is built on first use (warm solver, tracking function), shared with every
        # problem derived by with_bounds (a shallow copy keeps this dict)
        self._built = {}
        self.model = self._model()
        rows.build_quantities(self)
        self._scales()
        nlp.build_nlp(self)

    # --- parameter vectors ---
    def full_parameters(self, x_design, fixed=None):
        p = self.mech.parameter_values.copy() if not isinstance(x_design, (ca.SX, ca.MX)) else None
        if p is None:
            parts = [None] * len(self.mech.parameter_names)
            for j, i in enumerate(self.design_index):
                parts[i] = x_design[j]
            for j, i in enumerate(self.fixed_index):
                parts[i] = fixed[j]
            return ca.vertcat(*parts)
        p[self.design_index] = x_design
        if fixed is not None:
            p[self.fixed_index] = fixed
        return p

    def to_z(self, x):
        return (np.asarray(x, float) - self.z_offset) / self.z_scale

    def to_x(self, z):
        return self.z_offset + self.z_scale * np.asarray(z, float)

    def nlp_parameters(self, fixed, s_points, x_ref=None, tracking=None):
        """The NLP's parameter vector: fixed parameters, sample points, tracking of the points.
        Where each located extreme is held at ``x_ref`` is noted for :meth:`row_bounds`
        (:func:`.nlp.designation`)."""
        nd = len(self.design_names)
        x_ref = self.start if x_ref is None else x_ref
        tracking = np.zeros((self.n_points, nd)) if tracking is None else tracking
        if self.located:
            nlp.designation(self, fixed, s_points, x_ref)
        return np.r_[fixed, s_points, x_ref, tracking.ravel(order="F")]

    # --- the model and the per-sample quantities (built by rows.build_quantities) ---
    def _model(self):
        model = ReducedModel(self.mech)
        if model.uses_efficiency:
            power = ca.Function("power", [self.mech.s, self.mech.p], [model.u * model.qd])
            p_ideal = np.abs(np.asarray(power.map(len(self.s_grid))(self.s_grid[None, :], self.mech.parameter_values)))
            width = self.settings.efficiency_smoothing * max(float(np.nanmax(p_ideal)), 1e-12)
            model = ReducedModel(self.mech, efficiency_smoothing=width)
        return model

    def evaluate_grid(self, x, fixed=None, s_values=None):
        """Per-sample quantities (rows x samples) at design x on the scene's grid."""
        s_values = self.s_grid if s_values is None else np.asarray(s_values, float)
        return self._quantity_many(s_values, self.full_parameters(x, fixed))[0]

    def _once(self, key, build):
        """``build()``, called once for this problem and every problem derived from it."""
        if key not in self._built:
            self._built[key] = build()
        return self._built[key]

    @property
    def quantity_tracking(self):
        """How each row's extrema move with the parameters: d2v/ds2 and d(dv/ds)/dp, for peak
        tracking (built on first use: only exchange steps need it)."""
        mech, dv = self.mech, self._dv

        def outputs():
            return [mech.ds(dv), ca.jacobian(dv, mech.p)]

        def build():
            if mech.sym is ca.SX:   # eliminated once, kept under the key of dv and this code (model/cse.py)
                f = cse_derived("quantities_tracking", [mech.s, mech.p], dv, outputs, ["s", "p"], ["d2v", "dvdp"],
                                code=(__file__, sys.modules[Mechanism.__module__].__file__))
            else:
                f = mech.function("quantities_tracking", dict(zip(("d2v", "dvdp"), outputs())))
            return compiled_function(f) or f   # from the disk cache of compiled code: the same numbers
        return self._once("tracking", build)

    def tracking_gradient(self, s, x, fixed, row):
        """ds*/dx of the extremum of ``row`` at sweep value s and design x (0 where the row's
        curvature in s vanishes: no extremum to follow)."""
        if on_case_break(self, s):  # a load case's profile kinks there: the extreme stays put (design/cases.py)
            return np.zeros(len(self.design_names))
        p = self.full_parameters(x, fixed)
        out = self.quantity_tracking(s, p)
        d2v = float(out[0][row])
        dvdp = np.asarray(out[1])[row, self.design_index]
        if abs(d2v) <= 1e-12 * max(float(np.max(np.abs(dvdp))), 1e-300):
            return np.zeros(len(self.design_names))
        return -dvdp / d2v

    # --- scaling from the start design ---
    def _scales(self):
        v = self.evaluate_grid(self.start)
        if not np.all(np.isfinite(v)):
            bad = [r for r in range(v.shape[0]) if not np.all(np.isfinite(v[r]))]
            first = int(np.flatnonzero(~np.all(np.isfinite(v), axis=0))[0])
            raise SceneError(
                f"{self.scene.path}: the start design does not assemble over the whole stroke: "
                f"{', '.join(rows.row_name(self, r) for r in bad)} not finite, first at "
                f"{self.scene.sweep.name} = {self.s_grid[first]:.6g}; run `optdesign analyse` on it "
                "to see where, and move the start values"
            )
        def scale_of(row):
            return max(float(np.max(np.abs(v[row]))), 1e-12)

        self.blocks = [
            Block(b.name, b.kind, b.index, b.lower, b.upper, scale_of(b.index) if b.kind not in ("constraint", "design constraint")
                  else max(scale_of(b.index), *(abs(x) for x in (b.lower, b.upper) if math.isfinite(x))))
            for b in self.blocks
        ]
        for a in self.aggregates:
            a.scale = scale_of(a.index)
        k = v[self.k_row]
        self.k_sign = 1.0 if np.median(k) >= 0 else -1.0
        self.k_ref = max(float(np.median(np.abs(k))), 1e-12)
        self.f_ref = self.blocks[0].scale if self.objective_kind in ("peak", "rms", "rms_time", "mix") else 1.0
        self.start_quantities = v

    # The methods below are the problem's interface (the solver, studies and tests call them);
    # each hands the work to the module that owns it.

    # --- the NLP (built by nlp.build_nlp) ---
    def row_bounds(self, s_points):
        """The bounds of the NLP's rows (lbg, ubg) for the sample points ``s_points``
        (:func:`.nlp.row_bounds`)."""
        return nlp.row_bounds(self, s_points)

    @property
    def warm_solver(self):
        """IPOPT for an exchange step (:func:`.nlp.warm_solver`).  Built on first use (once for
        this problem and those derived by with_bounds): with the sample points learned from
        earlier starts most runs need none."""
        return self._once("warm solver", lambda: nlp.warm_solver(self))

    # --- other bounds on the same NLP (see .bounds) ---
    def with_bounds(self, bounds) -> DesignProblem:
        """This problem with other bounds on some of the scene's constraints, without a rebuild
        (:func:`.bounds.with_bounds`, which says what is shared and what is exact)."""
        return bounds_.with_bounds(self, bounds)

    def constraint_bounds(self, name) -> tuple:
        """(lower, upper) of the scene's constraint ``name`` in physical units (+-inf when open)."""
        return bounds_.constraint_bounds(self, name)

    # --- stroke aggregates and rms (see .aggregates) ---
    def aggregates_of(self, w) -> np.ndarray:
        """The stroke aggregates' values (physical units) in an NLP solution vector ``w``."""
        return aggregates.aggregates_of(self, w)

    def aggregate_start(self, ag) -> float:
        """The aggregate's value on the scene's samples at the start design."""
        return aggregates.aggregate_start(self, ag)

    def stroke_value(self, outer, extremes, x=None) -> float:
        """A stroke expression evaluated with its aggregates taken from ``extremes``
        ((aggregate name, 'max'|'min') -> value, as found by the continuous check) and its
        parameters at the design ``x`` (default: the scene's values)."""
        return aggregates.stroke_value(self, outer, extremes, x)

    def _outer(self, expr, a, p):
        """A stroke expression of the aggregate values ``a`` and parameters ``p`` (kept for
        benchmarks/bench_optimise.py, which compiles stroke expressions through it)."""
        return aggregates.outer_value(self, expr, a, p)

    def rms(self, x, fixed=None, panels=None) -> float:
        """RMS of the objective's quantity over the continuous stroke at design x (composite
        Gauss-Legendre, ``panels`` x 4 nodes)."""
        return aggregates.rms(self, x, fixed, panels)

    def rms_sampled(self, x, fixed=None) -> float:
        """RMS on the scene's samples (trapezoid rule)."""
        return aggregates.rms_sampled(self, x, fixed)

