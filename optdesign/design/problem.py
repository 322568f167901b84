"""The design problem as an NLP for IPOPT, with the peak over the continuous stroke.

Formulation (what makes it fast and regular):

* Design variables are the scene's bounded parameters, scaled to [0, 1] by their bounds.  All
  other leaf parameters are NLP *parameters*, so the optimal objective's sensitivity to each of
  them comes from IPOPT's multipliers (``lam_p``).
* The peak over the stroke is an epigraph ``-t <= v(s_j)/F_ref <= t`` written only at a few
  sample points s_j: a uniform base grid plus movable *slots*.  The s_j are NLP parameters too,
  so an exchange step moves slots onto the continuous extrema found at the last solution and
  re-solves without rebuilding anything.  The loop ends when the epigraph value and the peak of
  the continuous stroke (refined by Newton, :mod:`optdesign.model.peaks`) agree within ``peak_tol``.
* Per-sample constraints (transmission angle, any expression) and assembly margins live on the
  same points and are checked on the continuous stroke in the same way.
* A stroke aggregate max(e)/min(e) in a constraint or objective becomes an epigraph variable a
  with e(s_j) <= a (or >= a), valid when the outer expression is monotone in a in the direction
  that the bound makes conservative; this is checked at the start and an error explains otherwise.
  Its rows, and the dead-centre guard's (the drive coordinate keeps moving: sigma*k(s)/k_ref >=
  margin), are imposed only at the stroke's ends and the slots, where their extrema mostly are;
  the exchange puts a slot wherever one of them is exceeded, on a base point too.
* Everything is scaled to order one by its value at the scene's start design: F_ref for the
  drive load, the start's range for each constraint and margin.
* Constraint bounds are only the NLP's lbg/ubg (passed at solve time): every named constraint
  keeps its rows in g with +-inf on an open side, so :meth:`DesignProblem.with_bounds` gives a
  problem with other bounds that shares the built NLP and solvers (a Pareto front by the
  epsilon-constraint method needs no rebuild per point).
"""
from __future__ import annotations

import copy
import dataclasses
import math
import re
from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..errors import SceneError
from ..scene.expressions import Call, Expression, Name, evaluate, near_miss
from ..model.mapped import MappedFunction
from ..kinematics.mechanism import Mechanism
from ..model.reduction import ReducedModel
from ..scene.elements import Scene


@dataclass(frozen=True)
class SolverSettings:
    """How the design problem is solved (the scene says only *what*)."""

    tol: float = 1e-10             # IPOPT tol on the scaled problem
    max_iter: int = 300            # IPOPT iterations per solve
    grid: int = 13                 # base sample points of the epigraph (ends included)
    slots: int = 6                 # movable sample points put on the located extrema
    peak_tol: float = 1e-8         # relative agreement of epigraph and continuous peak
    constraint_tol: float = 1e-7   # allowed violation of a scaled constraint between samples
    max_exchanges: int = 12        # exchange steps per start
    rms_panels: int = 16           # composite Gauss-Legendre panels (4 nodes each) for rms(...), doubled until accurate
    rms_tol: float = 1e-7          # relative agreement of the rms with twice as many panels
    efficiency_smoothing: float = 1e-3  # width of the power-flow switch, times the power scale
    dead_centre_margin: float = 1e-3    # sigma*k/k_ref at least this (k = dq/ds)
    print_level: int = 0


@dataclass(frozen=True)
class Block:
    """A named family of per-sample quantities with bounds (scaled)."""

    name: str
    kind: str       # 'peak', 'constraint', 'aggregate', 'margin', 'dead centre'
    index: int      # row in the per-sample quantity vector
    lower: float    # bounds in physical units (+-inf when open); the NLP's rows are
    upper: float    # quantity/scale in [lower/scale, upper/scale]; for 'peak' unused
    scale: float


@dataclass
class Aggregate:
    """A one-argument max/min over the stroke, replaced by an epigraph variable."""

    name: str
    func: str          # 'max' or 'min'
    inner: Expression
    index: int = -1    # row of its inner expression in the per-sample vector
    scale: float = 1.0


_OBJECTIVE = re.compile(r"^\s*(peak|rms)\s*\(\s*(.+?)\s*\)\s*$")


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
        self.s_grid = mech.stroke()
        # what is built on first use (warm solver, tracking function), shared with every
        # problem derived by with_bounds (a shallow copy keeps this dict)
        self._built = {}
        self.model = self._model()
        self._quantities()
        self._scales()
        self._nlp()

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

    # --- the model and the per-sample quantities ---
    def _model(self):
        model = ReducedModel(self.mech)
        if model.uses_efficiency:
            power = ca.Function("power", [self.mech.s, self.mech.p], [model.u * model.qd])
            p_ideal = np.abs(np.asarray(power.map(len(self.s_grid))(self.s_grid[None, :], self.mech.parameter_values)))
            width = self.settings.efficiency_smoothing * max(float(np.nanmax(p_ideal)), 1e-12)
            model = ReducedModel(self.mech, efficiency_smoothing=width)
        return model

    def _quantities(self):
        scene, mech = self.scene, self.mech
        outputs = self.model.outputs()
        rows, self.blocks, self.aggregates = [], [], []
        self.objective_text = scene.objective.minimise
        m = _OBJECTIVE.match(self.objective_text)
        self.objective_quantity = self.objective_fraction = None
        if m:
            self.objective_kind, what = m.group(1), m.group(2)
            expr = outputs.get(what)
            if expr is None:
                expr = mech.value(_parse(what, "[objective] minimise"), "[objective] minimise")
            self.objective_quantity = len(rows)
            rows.append(expr)
            if what in ("drive", "power") and self.objective_kind == "peak":
                k_ref = self._k_ref_start()
                numerator, denominator = self.model.drive_numerator(k_ref)
                if what == "power":
                    numerator = numerator * self.model.qd
                self.objective_fraction = (len(rows), len(rows) + 1)
                rows += [numerator, denominator]
            self.blocks.append(Block(self.objective_text, "peak" if self.objective_kind == "peak" else "rms",
                                     0, -math.inf, math.inf, 1.0))
        else:
            self.objective_kind = "expression"
            self.objective_expr = self._lift(_parse(self.objective_text, "[objective] minimise"), "objective")
            if not self.aggregates:
                raise SceneError(
                    f"{scene.path}: [objective] minimise = {self.objective_text!r}: expected peak(NAME), "
                    "rms(NAME) or an expression over the stroke with max(...)/min(...), e.g. "
                    "\"max(y(T)) - min(y(T))\""
                )
        self.stroke_constraints = []
        for c in scene.constraints:
            if c.expr.is_aggregate:
                self.stroke_constraints.append((c, self._lift(c.expr, c.name)))
            else:
                lo, hi = self._bounds(c)
                expr = mech.value(c.expr, f"[[constraints]] {c.name}")
                # a constraint on the design alone (no dependence on the sweep) is one row,
                # not one per sample point (repeated rows would be degenerate)
                kind = "constraint" if ca.depends_on(expr, mech.s) else "design constraint"
                self.blocks.append(Block(c.name, kind, len(rows), lo, hi, 1.0))
                rows.append(expr)
        for a in self.aggregates:
            a.index = len(rows)
            rows.append(mech.value(a.inner, a.name))
        # a construction that does not move with the sweep has one margin, not one per point
        # (repeated rows would be degenerate and cost time)
        self.constant_margins = set()
        for margin in mech.margins:
            if margin.kind == "loop":
                continue
            if not ca.depends_on(margin.expr, mech.s):
                self.constant_margins.add(len(rows))
            self.blocks.append(Block(f"assembly of {margin.construction}", "margin", len(rows), 0.0, math.inf, 1.0))
            rows.append(margin.expr)
        self.k_row = len(rows)
        rows.append(self.model.k)
        self.rows = rows
        self.quantity = mech.function("quantities", {"v": ca.vertcat(*rows)})
        self._quantity_many = MappedFunction(self.quantity)  # at many samples (evaluate_grid)
        v = ca.vertcat(*rows)
        dv = mech.ds(v)
        self.quantity_derivatives = mech.function("quantities_ds", {"v": v, "dv": dv, "d2v": mech.ds(dv)})
        self._dv = dv

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
        return self._once("tracking", lambda: mech.function(
            "quantities_tracking", {"d2v": mech.ds(dv), "dvdp": ca.jacobian(dv, mech.p)}))

    def _bounds(self, c):
        """A constraint's (lower, upper) as numbers (they may name fixed parameters)."""
        from ..scene.expressions import constant_value

        values = self.scene.parameter_values()
        where = f"{self.scene.path}: [[constraints]] {c.name!r}"
        lo = -math.inf if c.lower is None else constant_value(c.lower, values, f"{where} min")
        hi = math.inf if c.upper is None else constant_value(c.upper, values, f"{where} max")
        return lo, hi

    def _lift(self, expr: Expression, where):
        """Replace one-argument max/min calls by epigraph variables; return the outer tree."""

        def walk(node):
            if isinstance(node, Call):
                if node.func in ("max", "min") and len(node.args) == 1:
                    name = f"__aggregate_{len(self.aggregates)}"
                    inner = Expression(f"{node.func}(...) in {where}", node.args[0])
                    self.aggregates.append(Aggregate(name, node.func, inner))
                    return Name(name)
                return Call(node.func, tuple(walk(a) for a in node.args))
            for attr in ("left", "right", "operand"):
                if hasattr(node, attr):
                    kwargs = {k: walk(getattr(node, k)) if k in ("left", "right", "operand") else getattr(node, k)
                              for k in node.__dataclass_fields__}
                    return type(node)(**kwargs)
            return node

        return Expression(expr.source, walk(expr.tree))

    def evaluate_grid(self, x, fixed=None, s_values=None):
        """Per-sample quantities (rows x samples) at design x on the scene's grid."""
        s_values = self.s_grid if s_values is None else np.asarray(s_values, float)
        return self._quantity_many(s_values, self.full_parameters(x, fixed))[0]

    def nlp_parameters(self, fixed, s_points, x_ref=None, tracking=None):
        """The NLP's parameter vector: fixed parameters, sample points, tracking of the points."""
        nd = len(self.design_names)
        x_ref = self.start if x_ref is None else x_ref
        tracking = np.zeros((self.n_points, nd)) if tracking is None else tracking
        return np.r_[fixed, s_points, x_ref, tracking.ravel(order="F")]

    def tracking_gradient(self, s, x, fixed, row):
        """ds*/dx of the extremum of ``row`` at sweep value s and design x (0 where the row's
        curvature in s vanishes: no extremum to follow)."""
        p = self.full_parameters(x, fixed)
        out = self.quantity_tracking(s, p)
        d2v = float(out[0][row])
        dvdp = np.asarray(out[1])[row, self.design_index]
        if abs(d2v) <= 1e-12 * max(float(np.max(np.abs(dvdp))), 1e-300):
            return np.zeros(len(self.design_names))
        return -dvdp / d2v

    def _k_ref_start(self):
        """Median |k| = |dq/ds| over the stroke at the start design (a scale, not a bound)."""
        f = self.mech.function("k", {"k": self.model.k})
        k = np.asarray(f.map(len(self.s_grid))(self.s_grid[None, :], self.mech.parameter_values)).ravel()
        return max(float(np.median(np.abs(k))), 1e-12)

    def _row_name(self, row):
        """What a per-sample quantity row is, in the scene's words."""
        names = {b.index: b.name for b in self.blocks}
        names.update({a.index: a.inner.source for a in self.aggregates})
        if self.objective_fraction is not None:
            names.update(dict(zip(self.objective_fraction, ("the drive load times k^4", "k^4"))))
        names[self.k_row] = "k = dq/ds"
        return names.get(row, f"row {row}")

    # --- scaling from the start design ---
    def _scales(self):
        v = self.evaluate_grid(self.start)
        if not np.all(np.isfinite(v)):
            bad = [r for r in range(v.shape[0]) if not np.all(np.isfinite(v[r]))]
            first = int(np.flatnonzero(~np.all(np.isfinite(v), axis=0))[0])
            raise SceneError(
                f"{self.scene.path}: the start design does not assemble over the whole stroke: "
                f"{', '.join(self._row_name(r) for r in bad)} not finite, first at "
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
        self.f_ref = self.blocks[0].scale if self.objective_kind in ("peak", "rms") else 1.0
        self.start_quantities = v

    # --- the NLP ---
    def _nlp(self):
        st = self.settings
        if self.objective_kind == "rms":
            self.rms_panels = self._rms_panels()
        # an rms objective needs the whole stroke: MX with mapped calls keeps its graph small
        # (inlining hundreds of quadrature nodes into SX takes seconds to build)
        sym = ca.MX if self.objective_kind == "rms" else self.mech.sym
        nd = len(self.design_names)
        z = sym.sym("z", nd)
        fixed = sym.sym("fixed", len(self.fixed_names))
        self.n_points = st.grid + st.slots
        s_pts = sym.sym("s_points", self.n_points)
        # each sample point follows its extremum to first order in the design:
        # s_j(x) = s_j + G_j . (x - x_ref), G_j = -(d2v/ds dx) / (d2v/ds2) at the last solution
        x_ref = sym.sym("x_ref", nd)
        G = sym.sym("tracking", self.n_points, nd)
        x = ca.DM(self.z_offset) + ca.DM(self.z_scale) * z
        p = self.full_parameters(x, fixed)
        t = sym.sym("t", 1 if self.objective_kind == "peak" else 0)
        # each stroke aggregate's variable is scaled by its size at the start design (a length
        # of 1e-4 m must not become a column 1e4 times larger than the others)
        self.a_scale = np.array([ag.scale for ag in self.aggregates])
        a_hat = sym.sym("a", len(self.aggregates))
        a = a_hat * ca.DM(self.a_scale) if self.aggregates else a_hat
        nb = st.grid  # base points stay put: tracking only the slots keeps the Hessian small
        moved = s_pts[nb:] + ca.mtimes(G[nb:, :], x - x_ref)
        s_eff = ca.vertcat(s_pts[:nb], ca.fmin(ca.fmax(moved, self.s_grid[0]), self.s_grid[-1]))
        if sym is ca.MX:
            Q = self.quantity.map(self.n_points)(s_eff.T, p)  # rows x points
        else:
            Q = ca.horzcat(*[self.quantity(s_eff[j], p) for j in range(self.n_points)])
        g, lbg, ubg, self.g_blocks = [], [], [], []
        # the sample points each per-point block is imposed at (g_points: name -> index into
        # the points, one per row): the epigraph and the scene's per-sample constraints at every
        # point; a stroke aggregate and the dead-centre guard, whose extrema lie mostly at the
        # stroke's ends, only at the ends and the slots (the exchange puts a slot wherever one
        # of them is exceeded, on a base point too: see row_bounds).  Fewer rows make each IPOPT
        # iteration cheaper (truck crane: 115 -> 82 rows, 1082 -> 720 iterations for 20 starts)
        every = np.arange(self.n_points)
        sparse = np.r_[0, nb - 1, np.arange(nb, self.n_points)]
        self.g_points, self.g_scale, self.stroke_outer = {}, {}, {}

        def add(name, kind, expr, lo, hi, scale=1.0, points=None):
            self.g_scale[name] = scale
            if points is not None:
                self.g_points[name] = points
            start = sum(int(e.numel()) for e in g)
            g.append(expr)
            n = int(expr.numel())
            lbg.extend([lo] * n)
            ubg.extend([hi] * n)
            self.g_blocks.append((name, kind, start, n))

        if self.objective_kind == "peak":
            if self.objective_fraction is not None:  # |N| <= t K: no division by k = dq/ds
                num, den = (Q[i, :].T for i in self.objective_fraction)
                v, bound = num / self.f_ref, t * den
            else:
                v, bound = Q[self.objective_quantity, :].T / self.f_ref, t
            add(self.objective_text, "peak", ca.vertcat(v - bound, -v - bound), -math.inf, 0.0, points=np.r_[every, every])
            f = t
        elif self.objective_kind == "rms":
            # the mean square over the continuous stroke by composite Gauss-Legendre quadrature
            nodes, weights = quadrature(self.s_grid[0], self.s_grid[-1], self.rms_panels)
            vals = self.quantity.map(len(nodes))(ca.DM(nodes).T, p)[self.objective_quantity, :]
            f = ca.dot(ca.DM(weights), (vals.T / self.f_ref) ** 2)
        else:
            self.objective_scale = max(abs(float(self._outer_start(self.objective_expr))), 1e-12)
            self._check_monotone(self.objective_expr, "[objective] minimise", self.objective_text, -math.inf, 0.0)
            f = self._outer(self.objective_expr, a, p) / self.objective_scale
        for b in self.blocks:
            if b.kind in ("peak", "rms"):
                continue
            one = b.kind == "design constraint" or b.index in self.constant_margins
            if one:
                add(b.name, b.kind, Q[b.index, 0] / b.scale, b.lower / b.scale, b.upper / b.scale, b.scale)
            else:
                add(b.name, b.kind, Q[b.index, :].T / b.scale, b.lower / b.scale, b.upper / b.scale, b.scale, every)
        for i, ag in enumerate(self.aggregates):
            diff = Q[ag.index, sparse].T / ag.scale - a_hat[i]
            lo, hi = (-math.inf, 0.0) if ag.func == "max" else (0.0, math.inf)
            add(ag.name, "aggregate", diff, lo, hi, points=sparse)
        self.stroke_bounds = {}   # name -> (lower, upper) in physical units
        for c, outer in self.stroke_constraints:
            scale = max(abs(float(self._outer_start(outer))), 1e-12)
            self.stroke_bounds[c.name] = self._bounds(c)
            lo, hi = (v / scale for v in self.stroke_bounds[c.name])
            self._check_monotone(outer, f"[[constraints]] {c.name!r}", c.expr.source, lo, hi)
            self.stroke_outer[c.name] = outer
            add(c.name, "stroke constraint", self._outer(outer, a, p) / scale, lo, hi, scale)
        add("dead centre", "dead centre", self.k_sign * Q[self.k_row, sparse].T / self.k_ref, st.dead_centre_margin,
            math.inf, points=sparse)
        # the quantity rows imposed only at the stroke's ends and the slots
        self.sparse_rows = frozenset([ag.index for ag in self.aggregates] + [self.k_row])
        w = ca.vertcat(z, t, a_hat)
        self.nw = int(w.numel())
        self.n_t = int(t.numel())
        nlp = {"x": w, "p": ca.vertcat(fixed, s_pts, x_ref, ca.vec(G)), "f": f, "g": ca.vertcat(*g)}
        opts = {"ipopt.print_level": st.print_level, "print_time": False, "ipopt.sb": "yes",
                "ipopt.tol": st.tol, "ipopt.constr_viol_tol": st.tol, "ipopt.max_iter": st.max_iter, "ipopt.mu_strategy": "adaptive",
                # constraint multipliers from the least dual infeasibility: starts that begin
                # far from feasible (transmission angle against length ratio) otherwise
                # stall with exploding multipliers (truck crane: 17 -> 20 of 20 starts)
                "ipopt.alpha_for_y": "min-dual-infeas",
                # initial constraint multipliers zero: fewer iterations from infeasible starts
                "ipopt.constr_mult_init_max": 0.0,
                # a start far from feasible can make the constraint multipliers grow without
                # bound while the line search takes ever shorter steps: switch to the
                # restoration phase once they exceed 1e8 (truck crane: four starts took about
                # 100 iterations each; 20 starts 720 -> 621 iterations, all at the optimum)
                "ipopt.expect_infeasible_problem": "yes",
                # no MUMPS scaling: our rows are scaled to order one already, and on a KKT
                # system of a few hundred rows computing the scaling costs more than the
                # factorisation (about 18 % of the time per start, same iterations)
                "ipopt.mumps_scaling": 0, "ipopt.mumps_permuting_scaling": 0,
                # no iterative refinement unless the residual asks for it
                "ipopt.min_refinement_steps": 0,
                # IPOPT steps back from a trial design that does not assemble (NaN rows): a
                # normal event of the line search, not a warning for the user
                "show_eval_warnings": False,
                "error_on_fail": False}
        if self.objective_kind == "rms":
            # the exact Hessian of hundreds of mapped quadrature nodes costs more than the
            # iterations it saves (crank press: 2.6 times faster per start, same iterations)
            opts["ipopt.hessian_approximation"] = "limited-memory"
        self._nlp_dict = nlp
        self.solver = ca.nlpsol("design", "ipopt", nlp, opts)
        self.solver_options = opts  # IPOPT options (the warm solver and the benchmark reuse them)
        self.lbg, self.ubg = np.array(lbg), np.array(ubg)
        # an aggregate keeps the sign it has at the start design: this keeps outer expressions
        # such as max(L)/min(L) regular and monotone (a min(...) cannot run to zero or below)
        a_start = np.array([self.aggregate_start(ag) for ag in self.aggregates])
        a_lo = np.where(a_start > 0, 1e-3 * a_start, -np.inf)
        a_hi = np.where(a_start < 0, 1e-3 * a_start, np.inf)
        self.lbw = np.r_[np.where(np.isfinite(self.lower), 0.0, -np.inf), np.zeros(self.n_t), a_lo / self.a_scale]
        self.ubw = np.r_[np.where(np.isfinite(self.upper), 1.0, np.inf), np.full(self.n_t, np.inf), a_hi / self.a_scale]
        base = np.linspace(self.s_grid[0], self.s_grid[-1], st.grid)
        mids = 0.5 * (base[:-1] + base[1:])
        self.base_points = base
        self.initial_slots = mids[np.linspace(0, len(mids) - 1, st.slots).round().astype(int)] if st.slots else np.zeros(0)

    def row_bounds(self, s_points):
        """The bounds of the NLP's rows (lbg, ubg) for the sample points ``s_points``.

        A slot on a base point (put there for a block imposed only at the ends and the slots)
        repeats the rows of every block that is imposed at that base point: those copies are
        left free, since a repeated row makes the constraint Jacobian rank-deficient."""
        nb = len(self.base_points)
        on_base = {j: int(np.argmin(np.abs(self.base_points - s_points[j]))) for j in range(nb, self.n_points)
                   if np.min(np.abs(self.base_points - s_points[j])) <= 1e-9}
        if not on_base:
            return self.lbg, self.ubg
        lbg, ubg = self.lbg.copy(), self.ubg.copy()
        for name, _, start, n in self.g_blocks:
            points = self.g_points.get(name)
            if points is None:
                continue
            imposed = set(points.tolist())
            for i, point in enumerate(points):
                if point in on_base and on_base[point] in imposed:
                    lbg[start + i], ubg[start + i] = -math.inf, math.inf
        return lbg, ubg

    @property
    def warm_solver(self):
        """IPOPT for an exchange step, which moves a few sample points and solves again from
        the last solution: started there with its multipliers and a small barrier parameter it
        needs a third of the iterations of a cold start (truck crane: 6 instead of 16).  Built
        on first use (once for this problem and those derived by with_bounds): with the sample
        points learned from earlier starts most runs need none."""
        return self._once("warm solver", self._build_warm_solver)

    def _build_warm_solver(self):
        warm = dict(self.solver_options, **{"ipopt.warm_start_init_point": "yes", "ipopt.mu_strategy": "monotone",
                                   "ipopt.mu_init": 1e-6, **{f"ipopt.warm_start_{k}": 1e-8 for k in (
                                       "bound_push", "bound_frac", "slack_bound_push", "slack_bound_frac",
                                       "mult_bound_push")}})
        return ca.nlpsol("design_warm", "ipopt", self._nlp_dict, warm)

    # --- other bounds on the same NLP ---
    def with_bounds(self, bounds) -> DesignProblem:
        """This problem with other bounds on some of the scene's constraints, without a rebuild.

        ``bounds``: ((constraint name, 'min'|'max', value), ...), values in physical units:
        numbers, or expressions such as "30 deg" (which may name parameters); +-inf opens a
        side.  The new problem is a shallow copy: it shares the built NLP, its solvers and
        functions with this one (and what either builds on first use); its own are ``lbg``,
        ``ubg``, the constraint blocks' bounds (read by the continuous check),
        ``stroke_bounds`` and ``scene`` (its constraints carry the new bounds).  Every named
        constraint keeps its rows in g whether a side is open or not, so any side may change.

        Scales stay this build's.  A per-sample constraint is scaled by the larger of its range
        at the start design and the bounds *of the scene that was built*, where a fresh build of
        the new scene takes the new bounds; the two scaled problems then differ by a constant
        factor in that constraint's rows, and their optima agree within IPOPT's tolerance on
        the scaled problem, not bit for bit (bit for bit where the new bound does not change
        that maximum, and always for stroke constraints, scaled by their start value alone).
        Multipliers are reported per unit of the physical bound, so their meaning is the same.

        A stroke constraint (max(...)/min(...) over the stroke) is exact only on a side where
        its bound is conservative (it limits a max from above or a min from below); a new
        finite side that is not raises SceneError, as a fresh build of the new scene would.
        """
        new_bounds, requested = self._requested_bounds(bounds)
        if not new_bounds:
            return self
        pb = copy.copy(self)
        pb.lbg, pb.ubg = self.lbg.copy(), self.ubg.copy()
        pb.blocks = list(self.blocks)
        pb.stroke_bounds = dict(self.stroke_bounds)
        rows = {name: (start, n) for name, kind, start, n in self.g_blocks
                if kind in ("constraint", "design constraint", "stroke constraint")}
        for name, (lo, hi) in new_bounds.items():
            start, n = rows[name]
            scale = self.g_scale[name]
            if name in self.stroke_bounds:
                self._check_monotone(self.stroke_outer[name], f"with_bounds: [[constraints]] {name!r} "
                                     f"(min = {lo:.6g}, max = {hi:.6g})", self._constraint(name).expr.source,
                                     lo / scale, hi / scale)
                pb.stroke_bounds[name] = (lo, hi)
            else:
                i = next(i for i, b in enumerate(self.blocks)
                         if b.name == name and b.kind in ("constraint", "design constraint"))
                pb.blocks[i] = dataclasses.replace(self.blocks[i], lower=lo, upper=hi)
            # the same arithmetic as the build's (bound / scale): bit for bit what a fresh
            # build with the same scale passes to IPOPT
            pb.lbg[start:start + n] = lo / scale
            pb.ubg[start:start + n] = hi / scale
        pb.scene = scene_with_bounds(self.scene, requested)
        return pb

    def constraint_bounds(self, name) -> tuple:
        """(lower, upper) of the scene's constraint ``name`` in physical units (+-inf when open)."""
        if name in self.stroke_bounds:
            return self.stroke_bounds[name]
        self._constraint(name)
        return next((b.lower, b.upper) for b in self.blocks
                    if b.name == name and b.kind in ("constraint", "design constraint"))

    def _constraint(self, name):
        c = next((c for c in self.scene.constraints if c.name == name), None)
        if c is None:
            names = [c.name for c in self.scene.constraints]
            raise SceneError(f"{self.scene.path}: with_bounds: the scene has no constraint {name!r}"
                             + near_miss(name, names) + f" (its constraints: {', '.join(names) or 'none'})")
        return c

    def _requested_bounds(self, bounds) -> tuple:
        """({constraint: (lower, upper)} after applying ``bounds`` to this problem's bounds,
        [(constraint, side, value as a number), ...])."""
        from ..scene.expressions import constant_value, parse

        out, seen, requested = {}, set(), []
        for item in bounds:
            try:
                name, side, value = item
            except (TypeError, ValueError):
                raise SceneError(f"with_bounds: expected (constraint name, 'min' or 'max', value), found {item!r}") from None
            where = f"{self.scene.path}: with_bounds: [[constraints]] {name!r} {side}"
            self._constraint(name)
            if side not in ("min", "max"):
                raise SceneError(f"{where}: the side must be 'min' or 'max', found {side!r}")
            if (name, side) in seen:
                raise SceneError(f"{where}: given twice; give each bound once")
            seen.add((name, side))
            if isinstance(value, str):
                value = constant_value(parse(value, where), self.scene.parameter_values(), where)
            try:
                value = float(value)
            except (TypeError, ValueError):
                raise SceneError(f"{where}: expected a number or an expression, found {value!r}") from None
            if math.isnan(value) or value == (-math.inf if side == "max" else math.inf):
                raise SceneError(f"{where} = {value}: expected a finite number (or {'+' if side == 'max' else '-'}inf "
                                 "to open the side)")
            lo, hi = out.get(name, self.constraint_bounds(name))
            out[name] = (value, hi) if side == "min" else (lo, value)
            requested.append((name, side, value))
        for name, (lo, hi) in out.items():
            where = f"{self.scene.path}: with_bounds: [[constraints]] {name!r}"
            if not (math.isfinite(lo) or math.isfinite(hi)):
                raise SceneError(f"{where}: both sides would be open; a constraint needs min, max or both "
                                 "(remove it from the scene to drop it)")
            if lo > hi:
                raise SceneError(f"{where}: min = {lo:.6g} exceeds max = {hi:.6g}; no design can satisfy it")
        return out, requested

    def aggregates_of(self, w) -> np.ndarray:
        """The stroke aggregates' values (physical units) in an NLP solution vector ``w``."""
        nd = len(self.design_names)
        return np.asarray(w[nd + self.n_t:], float) * self.a_scale

    def _outer(self, expr, a, p):
        values = self._parameter_values(p)
        values.update({ag.name: a[i] for i, ag in enumerate(self.aggregates)})
        return evaluate(expr, values, {}, expr.source)

    def _outer_start(self, expr):
        values = self._parameter_values()
        for ag in self.aggregates:
            values[ag.name] = self.aggregate_start(ag)
        return evaluate(expr, values, {}, expr.source)

    def _rms_panels(self):
        """Panels for the rms quadrature: doubled from the settings' count until the start
        design's rms agrees with twice as many panels within ``rms_tol``."""
        panels = self.settings.rms_panels
        while panels < 1024:
            a, b = self.rms(self.start, panels=panels), self.rms(self.start, panels=2 * panels)
            if abs(a - b) <= self.settings.rms_tol * max(abs(b), 1e-300):
                return panels
            panels *= 2
        return panels

    def rms(self, x, fixed=None, panels=None) -> float:
        """RMS of the objective's quantity over the continuous stroke at design x (composite
        Gauss-Legendre, ``panels`` x 4 nodes)."""
        nodes, weights = quadrature(self.s_grid[0], self.s_grid[-1], panels or self.rms_panels)
        v = self.evaluate_grid(x, fixed, nodes)[self.objective_quantity]
        return float(np.sqrt(np.dot(weights, v**2)))

    def rms_sampled(self, x, fixed=None) -> float:
        """RMS on the scene's samples (trapezoid rule)."""
        v = self.evaluate_grid(x, fixed)[self.objective_quantity]
        return float(np.sqrt(np.trapezoid(v**2, self.s_grid) / (self.s_grid[-1] - self.s_grid[0])))

    def aggregate_start(self, ag) -> float:
        """The aggregate's value on the scene's samples at the start design."""
        row = self.start_quantities[ag.index]
        return float(np.max(row) if ag.func == "max" else np.min(row))

    def stroke_value(self, outer, extremes) -> float:
        """A stroke expression evaluated with its aggregates taken from ``extremes``
        ((aggregate name, 'max'|'min') -> value, as found by the continuous check)."""
        values = self._parameter_values()
        for ag in self.aggregates:
            values[ag.name] = extremes.get((ag.name, ag.func), math.nan)
        return float(evaluate(outer, values, {}, outer.source))

    def _parameter_values(self, p=None):
        names, p = self.mech.parameter_names, self.mech.parameter_values if p is None else p
        values = {n: p[i] for i, n in enumerate(names)}
        for prm in self.scene.parameters:
            if prm.value.names():
                values[prm.name] = evaluate(prm.value, values, {}, prm.name)
        return values

    def _check_monotone(self, outer, where, source, lo, hi):
        """The epigraph of an aggregate is conservative only if the bound pushes the outer
        expression the right way: an upper bound needs it increasing in each max(...) and
        decreasing in each min(...), a lower bound the reverse."""
        if not self.aggregates:
            return
        a = ca.SX.sym("a", len(self.aggregates))
        values = self._parameter_values()
        values.update({ag.name: a[i] for i, ag in enumerate(self.aggregates)})
        expr = evaluate(outer, values, {}, outer.source)
        grad = ca.Function("g", [a], [ca.gradient(expr, a)])
        start = [self.aggregate_start(ag) for ag in self.aggregates]
        grad_v = np.asarray(grad(start)).ravel()
        for i, ag in enumerate(self.aggregates):
            if grad_v[i] == 0:  # this aggregate belongs to another expression
                continue
            increasing = grad_v[i] > 0
            ok_upper = increasing == (ag.func == "max")
            if (math.isfinite(hi) and not ok_upper) or (math.isfinite(lo) and ok_upper):
                raise SceneError(
                    f"{self.scene.path}: {where}: a {'lower' if ok_upper else 'upper'} "
                    f"bound on {source!r} is not conservative in its {ag.func}(...) over the stroke; "
                    "write it so that the bound limits a max from above or a min from below "
                    "(e.g. max(L)/min(L) <= r, or max(L) - r*min(L) <= 0)"
                )


def scene_with_bounds(scene: Scene, bounds) -> Scene:
    """A copy of ``scene`` with constraint bounds replaced: ((name, 'min'|'max', value), ...),
    values as numbers (+-inf: the side is open)."""
    new = {}
    for name, side, value in bounds:
        value = float(value)
        new.setdefault(name, {})["lower" if side == "min" else "upper"] = repr(value) if math.isfinite(value) else None
    constraints = tuple(dataclasses.replace(c, **new[c.name]) if c.name in new else c for c in scene.constraints)
    return dataclasses.replace(scene, constraints=constraints)


def quadrature(a, b, panels, order=4):
    """Nodes and weights of composite Gauss-Legendre quadrature for the mean over [a, b]."""
    x, w = np.polynomial.legendre.leggauss(order)
    edges = np.linspace(a, b, panels + 1)
    half = 0.5 * np.diff(edges)
    mid = 0.5 * (edges[:-1] + edges[1:])
    nodes = (mid[:, None] + half[:, None] * x[None, :]).ravel()
    weights = (half[:, None] * w[None, :]).ravel() / (b - a)
    return nodes, weights


def _parse(text, where):
    from ..scene.expressions import parse

    return parse(text, where)
