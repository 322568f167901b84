"""The NLP of the design problem: variables, objective, constraint rows, their bounds, and
the IPOPT solvers (cold, and warm for an exchange step).

Variables w = (z, t, a): the design scaled to [0, 1], the epigraph variable t of a peak
objective, and each stroke aggregate scaled by its start value.  Parameters: the fixed scene
parameters, the sample points, and how each slot follows its extremum to first order in the
design.  Rows: the epigraph of the peak, each per-sample constraint and margin at every
sample point, each aggregate and the dead-centre guard at the stroke's ends and the slots (a
located extreme's at every point), each stroke constraint once (see :mod:`.problem` for the
formulation).

A stroke aggregate max(e) (min(e)) is held in one of two ways:

* an epigraph, e(s_j) <= a at the ends and the slots, where every bound on it limits a max from
  above or a min from below (the optimum then pushes a down onto the largest e(s_j): exact);
* its *located* extreme otherwise (an equality such as max(y) - min(y) == H, a lower bound on
  a stroke, an objective that wants a max large): e(s_j) <= a at every point, and a = e(s_d)
  at the designated point s_d, the point where e is largest at the reference design (after an
  exchange, a slot on the continuous extreme, following it to first order in the design).  At
  a fixed active set a is then a smooth function of the design, exact to first and second
  order at the reference design (the slot's tracking is the extreme's own), and the
  continuous check certifies it as for a peak.  The designation is a matter of row bounds
  (:func:`row_bounds`): the designated row is an equality, rows that tie it within ``TIE`` of
  the aggregate's scale are free (the two ends of a full turn are one point: the same row
  twice would be degenerate, and phase 1 tightens rows, which a tie cannot meet).
  :func:`designation` finds the point when the NLP's parameters are made for a reference
  design; the build's own bounds are the plain epigraph's.

``start(e)`` and ``end(e)`` are e at the stroke's first and last point (base points 0 and
grid - 1), put into the expressions that use them; their variable in w is fixed at 0.

The functions take the problem (``pb``: a :class:`~optdesign.design.problem.DesignProblem`,
which imports this module; hence no annotation) and read or set its attributes.
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

from ..errors import SceneError
from ..model import compiled
from .aggregates import (aggregate_start, located_aggregates, nonlinear_aggregates, outer_start, outer_value,
                         quadrature, rms_panels)
from .bounds import numeric_bounds
from .cases import at_points, case_nlp, needs_mx

TIE = 1e-3  # points within this (times the aggregate's scale) of a located extreme tie it
# the quantities at the sample points are inlined into an SX NLP up to this many instructions
# (the per-point quantities' instructions times the points); beyond, the NLP is MX with the
# per-point Function mapped over the points (:func:`~.cases.at_points`): inlined, issue 27's
# knuckle press (673 instructions x 19 points) has an exact Hessian of 247,000 instructions, 10.4
# MB of C, compiled only without optimisation (model/compiled.py: NLP_OPTIMISED_SOURCE) into 6
# MB of machine code per call; mapped, its NLP compiles optimised (0.4 MB) and a start's CPU
# halves (results/optimiser_knuckle.md)
INLINED_POINTS = 10_000


def build_nlp(pb):
    """Build the NLP and its solver.  Sets on ``pb``: rms_panels (rms objective),
    objective_scale (expression objective), n_points, a_scale, located (indices of the
    aggregates held at their located extreme), the rows (g_blocks: (name,
    kind, first row, rows); g_points, g_scale, lbg, ubg), stroke_bounds, stroke_outer,
    sparse_rows, nw, n_t, the variable bounds lbw, ubw, the sample points base_points and
    initial_slots, solver, solver_options and _nlp_dict."""
    st = pb.settings
    if pb.objective_kind == "rms":
        pb.rms_panels = rms_panels(pb)
    # an rms objective needs the whole stroke: MX with mapped calls keeps its graph small
    # (inlining hundreds of quadrature nodes into SX takes seconds to build)
    sym = ca.MX if pb.objective_kind == "rms" or needs_mx(pb) or mapped_points(pb) else pb.mech.sym
    nd = len(pb.design_names)
    z = sym.sym("z", nd)
    fixed = sym.sym("fixed", len(pb.fixed_names))
    pb.n_points = st.grid + st.slots
    s_pts = sym.sym("s_points", pb.n_points)
    # each sample point follows its extremum to first order in the design:
    # s_j(x) = s_j + G_j . (x - x_ref), G_j = -(d2v/ds dx) / (d2v/ds2) at the last solution
    x_ref = sym.sym("x_ref", nd)
    G = sym.sym("tracking", pb.n_points, nd)
    x = ca.DM(pb.z_offset) + ca.DM(pb.z_scale) * z
    p = pb.full_parameters(x, fixed)
    t = sym.sym("t", 1 if pb.objective_kind in ("peak", "mix") else 0)
    # each stroke aggregate's variable is scaled by its size at the start design (a length
    # of 1e-4 m must not become a column 1e4 times larger than the others)
    pb.a_scale = np.array([ag.scale for ag in pb.aggregates])
    a_hat = sym.sym("a", len(pb.aggregates))
    a = a_hat * ca.DM(pb.a_scale) if pb.aggregates else a_hat
    nb = st.grid  # base points stay put: tracking only the slots keeps the Hessian small
    moved = s_pts[nb:] + ca.mtimes(G[nb:, :], x - x_ref)
    s_eff = ca.vertcat(s_pts[:nb], ca.fmin(ca.fmax(moved, pb.s_grid[0]), pb.s_grid[-1]))
    if sym is ca.MX:
        Q = at_points(pb)(s_eff.T, p)  # rows x points
    else:
        Q = ca.horzcat(*[pb.quantity(s_eff[j], p) for j in range(pb.n_points)])
    g, lbg, ubg, pb.g_blocks = [], [], [], []
    # the sample points each per-point block is imposed at (g_points: name -> index into
    # the points, one per row): the epigraph and the scene's per-sample constraints at every
    # point; a stroke aggregate and the dead-centre guard, whose extrema lie mostly at the
    # stroke's ends, only at the ends and the slots (the exchange puts a slot wherever one
    # of them is exceeded, on a base point too: see row_bounds).  Fewer rows make each IPOPT
    # iteration cheaper (truck crane: 115 -> 82 rows, 1082 -> 720 iterations for 20 starts)
    every = np.arange(pb.n_points)
    sparse = np.r_[0, nb - 1, np.arange(nb, pb.n_points)]
    pb.g_points, pb.g_scale, pb.stroke_outer = {}, {}, {}
    # the aggregates that no epigraph can hold: at their located extreme (see the module's doc)
    pb.stroke_bounds = {}   # name -> (lower, upper) in physical units
    for c, _ in pb.stroke_constraints:
        pb.stroke_bounds[c.name] = numeric_bounds(pb.mech.resolved, c)
    pb.located = located_aggregates(pb, pb.stroke_bounds)
    pb._designations = pb._built.setdefault("designations", {})  # s_points -> designation()
    # each aggregate's value in the expressions: its variable, or (start/end) its row's value
    a = [Q[ag.index, 0 if ag.func == "start" else nb - 1] if ag.func in ("start", "end") else a[i]
         for i, ag in enumerate(pb.aggregates)]

    def add(name, kind, expr, lo, hi, scale=1.0, points=None):
        pb.g_scale[name] = scale
        if points is not None:
            pb.g_points[name] = points
        start = sum(int(e.numel()) for e in g)
        g.append(expr)
        n = int(expr.numel())
        lbg.extend([lo] * n)
        ubg.extend([hi] * n)
        pb.g_blocks.append((name, kind, start, n))

    if pb.objective_kind in ("peak", "mix"):
        if pb.objective_fraction is not None:  # |N| <= t K: no division by k = dq/ds
            num, den = (Q[i, :].T for i in pb.objective_fraction)
            v, bound = num / pb.f_ref, t * den
        else:
            v, bound = Q[pb.objective_quantity, :].T / pb.f_ref, t
        add(pb.objective_text, "peak", ca.vertcat(v - bound, -v - bound), -math.inf, 0.0, points=np.r_[every, every])
        f = t
    elif pb.objective_kind == "rms":
        # the mean square over the continuous stroke by composite Gauss-Legendre quadrature
        nodes, weights = quadrature(pb.s_grid[0], pb.s_grid[-1], pb.rms_panels)
        vals = pb.quantity.map(len(nodes))(ca.DM(nodes).T, p)[pb.objective_quantity, :]
        f = ca.dot(ca.DM(weights), (vals.T / pb.f_ref) ** 2)
    elif pb.objective_kind == "expression":
        pb.objective_scale = max(abs(float(outer_start(pb, pb.objective_expr))), 1e-12)
        f = outer_value(pb, pb.objective_expr, a, p) / pb.objective_scale
    if pb.scene.cases:  # the other cases' epigraphs, cycle constraints, an objective over time (design/cases.py)
        f = case_nlp(pb, Q, p, t, None if pb.objective_kind in ("rms_time",) else f, add, every)
    for b in pb.blocks:
        if b.kind in ("peak", "rms", "rms_time"):
            continue
        one = b.kind == "design constraint" or b.index in pb.constant_margins
        if one:
            add(b.name, b.kind, Q[b.index, 0] / b.scale, b.lower / b.scale, b.upper / b.scale, b.scale)
        else:
            add(b.name, b.kind, Q[b.index, :].T / b.scale, b.lower / b.scale, b.upper / b.scale, b.scale, every)
    for i, ag in enumerate(pb.aggregates):
        if ag.func in ("start", "end"):
            continue
        points = every if i in pb.located else sparse  # a located extreme: rows at every point
        lo, hi = (-math.inf, 0.0) if ag.func == "max" else (0.0, math.inf)
        add(ag.name, "aggregate", Q[ag.index, points].T / ag.scale - a_hat[i], lo, hi, points=points)
    for c, outer in pb.stroke_constraints:
        scale = max(abs(float(outer_start(pb, outer))), 1e-12)
        lo, hi = (v / scale for v in pb.stroke_bounds[c.name])
        pb.stroke_outer[c.name] = outer
        add(c.name, "stroke constraint", outer_value(pb, outer, a, p) / scale, lo, hi, scale)
    add("dead centre", "dead centre", pb.k_sign * Q[pb.k_row, sparse].T / pb.k_ref, st.dead_centre_margin,
        math.inf, points=sparse)
    # the quantity rows imposed only at the stroke's ends and the slots
    pb.sparse_rows = frozenset([ag.index for i, ag in enumerate(pb.aggregates)
                                if ag.func in ("max", "min") and i not in pb.located] + [pb.k_row])
    _objective_uses_design(pb, f, z, t, a_hat, g)
    w = ca.vertcat(z, t, a_hat)
    pb.nw = int(w.numel())
    pb.n_t = int(t.numel())
    nlp = {"x": w, "p": ca.vertcat(fixed, s_pts, x_ref, ca.vec(G)), "f": f, "g": ca.vertcat(*g)}
    opts = ipopt_options(st, pb.objective_kind)
    pb._nlp_dict = nlp
    # the NLP's functions and derivatives from the disk cache of compiled code when it has them
    # (model/compiled.py); the same numbers as CasADi's virtual machine
    pb._nlp_function = ca.Function("nlp", [nlp["x"], nlp["p"]], [nlp["f"], nlp["g"]], ["x", "p"], ["f", "g"])
    pb.solver = compiled.solver("design", "ipopt", pb._nlp_function, opts)
    pb.solver_options = opts  # IPOPT options (the warm solver and the benchmark reuse them)
    pb.lbg, pb.ubg = np.array(lbg), np.array(ubg)
    # an epigraph's aggregate that an outer expression holds non-linearly keeps the sign it has
    # at the start design: this keeps outer expressions such as max(L)/min(L) regular and
    # monotone (a min(...) cannot run to zero or below); a located extreme or an end value is a
    # value of the stroke, and an aggregate held linearly is regular anywhere: free of any such
    # bound (issue 27's crank-rocker: min(angle(A, B, B0) - mu) >= 0 held above 1e-3 of its
    # start value, mu* 3.6e-4 low from mu = 0.3; infeasible from mu = 0.65, where it starts < 0)
    a_start = np.array([aggregate_start(pb, ag) for ag in pb.aggregates])
    kept = nonlinear_aggregates(pb)
    free = np.array([i in pb.located or i not in kept for i in range(len(pb.aggregates))], bool)
    ends = np.array([ag.func in ("start", "end") for ag in pb.aggregates], bool)
    a_lo = np.where(ends, 0.0, np.where((a_start > 0) & ~free, 1e-3 * a_start, -np.inf))
    a_hi = np.where(ends, 0.0, np.where((a_start < 0) & ~free, 1e-3 * a_start, np.inf))
    pb.lbw = np.r_[np.where(np.isfinite(pb.lower), 0.0, -np.inf), np.zeros(pb.n_t), a_lo / pb.a_scale]
    pb.ubw = np.r_[np.where(np.isfinite(pb.upper), 1.0, np.inf), np.full(pb.n_t, np.inf), a_hi / pb.a_scale]
    base = np.linspace(pb.s_grid[0], pb.s_grid[-1], st.grid)
    mids = 0.5 * (base[:-1] + base[1:])
    pb.base_points = base
    pb.initial_slots = mids[np.linspace(0, len(mids) - 1, st.slots).round().astype(int)] if st.slots else np.zeros(0)


def mapped_points(pb) -> bool:
    """Whether the NLP maps its per-point Function over the sample points instead of inlining
    it (see INLINED_POINTS)."""
    return pb.quantity.n_instructions() * (pb.settings.grid + pb.settings.slots) > INLINED_POINTS


def _objective_uses_design(pb, f, z, t, a_hat, g):
    """Refuse an objective that no design variable changes (structurally): every design is then
    an optimum, and the starts would end on as many designs as there are starts, each reported
    as optimal (the loading ramp's rms_time(drive) beside a rod diameter that only the buckling
    constraint sees)."""
    if ca.depends_on(f, z) or (a_hat.numel() and ca.depends_on(f, a_hat)):
        return
    if t.numel() and ca.depends_on(f, t):
        peaks = [g[j] for j, block in enumerate(pb.g_blocks) if block[1] == "peak"]
        if any(ca.depends_on(e, z) for e in peaks):
            return
    names = ", ".join(pb.design_names)
    raise SceneError(
        f"{pb.scene.path}: [objective] minimise = {pb.objective_text!r}: the objective does not depend on "
        f"the design variables ({names}): every design gives it the same value, so there is nothing to "
        "optimise; minimise a quantity the design changes, or make what it depends on a design variable "
        f"(a design variable itself is minimised as \"start({pb.design_names[0]})\")")


def ipopt_options(st, objective_kind) -> dict:
    """IPOPT's options for the design NLP (why each one: below)."""
    opts = {"ipopt.print_level": st.print_level, "print_time": False, "ipopt.sb": "yes",
            "ipopt.tol": st.tol, "ipopt.constr_viol_tol": st.tol, "ipopt.max_iter": st.max_iter, "ipopt.mu_strategy": "adaptive",
            # constraint multipliers from the least dual infeasibility: starts that begin
            # far from feasible (transmission angle against length ratio) otherwise
            # stall with exploding multipliers (truck crane: 17 -> 20 of 20 starts)
            "ipopt.alpha_for_y": "min-dual-infeas",
            # initial constraint multipliers zero: fewer iterations from infeasible starts
            "ipopt.constr_mult_init_max": 0.0,
            # expect_infeasible_problem is left at IPOPT's default (no): it was set for starts
            # far from feasible (truck crane), which phase 1 no longer lets through; over the
            # library it changes nothing but the toggle press, where it costs a start and 4.6x
            # the time (19/20 at 2.2 s per start against 20/20 at 0.48 s:
            # benchmarks/bench_library.py, results/optimise_library.md)
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
    if objective_kind in ("rms", "rms_time", "mix"):
        # the exact Hessian of hundreds of mapped quadrature nodes costs more than the
        # iterations it saves (crank press: 2.6 times faster per start, same iterations)
        opts["ipopt.hessian_approximation"] = "limited-memory"
    return opts


def warm_solver(pb):
    """IPOPT for an exchange step, which moves a few sample points and solves again from
    the last solution: started there with its multipliers and a small barrier parameter it
    needs a third of the iterations of a cold start (truck crane: 6 instead of 16)."""
    warm = dict(pb.solver_options, **{"ipopt.warm_start_init_point": "yes", "ipopt.mu_strategy": "monotone",
                                      "ipopt.mu_init": 1e-6, **{f"ipopt.warm_start_{k}": 1e-8 for k in (
                                          "bound_push", "bound_frac", "slack_bound_push", "slack_bound_frac",
                                          "mult_bound_push")}})
    return compiled.solver("design_warm", "ipopt", pb._nlp_function, warm)


def row_bounds(pb, s_points):
    """The bounds of the NLP's rows (lbg, ubg) for the sample points ``s_points``.

    A slot on a base point (put there for a block imposed only at the ends and the slots)
    repeats the rows of every block that is imposed at that base point: those copies are
    left free, since a repeated row makes the constraint Jacobian rank-deficient.  A located
    extreme's designated row is an equality and its ties are free (:func:`designation`, as
    made by the last :meth:`~.problem.DesignProblem.nlp_parameters` for these points; at the
    start design if there was none)."""
    nb = len(pb.base_points)
    s_points = np.asarray(s_points, float)
    on_base = {j: int(np.argmin(np.abs(pb.base_points - s_points[j]))) for j in range(nb, pb.n_points)
               if np.min(np.abs(pb.base_points - s_points[j])) <= 1e-9}
    if not on_base and not pb.located:
        return pb.lbg, pb.ubg
    lbg, ubg = pb.lbg.copy(), pb.ubg.copy()
    for name, _, start, n in pb.g_blocks:
        points = pb.g_points.get(name)
        if points is None:
            continue
        imposed = set(points.tolist())
        for i, point in enumerate(points):
            if point in on_base and on_base[point] in imposed:
                lbg[start + i], ubg[start + i] = -math.inf, math.inf
    if pb.located:
        key = s_points.tobytes()
        if key not in pb._designations:
            designation(pb, pb.mech.parameter_values[pb.fixed_index], s_points, pb.start)
        starts = {name: start for name, _, start, _ in pb.g_blocks}
        for i, (best, ties) in pb._designations[key].items():
            start = starts[pb.aggregates[i].name]
            lbg[start + ties], ubg[start + ties] = -math.inf, math.inf
            lbg[start + best] = ubg[start + best] = 0.0
    return lbg, ubg


def designation(pb, fixed, s_points, x_ref) -> dict:
    """Where each located extreme is held at the design ``x_ref``: {aggregate index: (the point
    where its quantity is largest (max) or smallest (min), the other points within ``TIE`` of
    its scale of that value)}; the first of equal values is the designated one (a base point
    before a slot on it).  Kept for :func:`row_bounds` (the last one made for these points)."""
    s_points = np.asarray(s_points, float)
    q = pb.evaluate_grid(x_ref, fixed, s_points)
    out = {}
    for i in pb.located:
        ag = pb.aggregates[i]
        sign = 1.0 if ag.func == "max" else -1.0
        v = np.where(np.isfinite(q[ag.index]), sign * q[ag.index], -np.inf)
        best = int(np.argmax(v))
        ties = np.flatnonzero(v >= v[best] - TIE * ag.scale)
        out[i] = (best, ties[ties != best])
    if len(pb._designations) > 64:  # only the last few matter
        pb._designations.clear()
    pb._designations[s_points.tobytes()] = out
    return out
