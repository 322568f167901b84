"""Quantities of the whole stroke: stroke aggregates max(e)/min(e) and the rms.

A stroke aggregate (max(e), min(e), start(e), end(e)) is a variable of the NLP (:mod:`.rows`
takes it out of its expression, leaving an *outer* expression of named aggregates);
:func:`outer_value` evaluates such an expression, and :func:`needs_location` says which max/min
aggregates a bound on it cannot hold by an epigraph (the NLP then holds them at their located
extreme, :mod:`.nlp`).  The rms of the objective's quantity is a composite Gauss-Legendre
:func:`quadrature` over the continuous stroke.

The functions take the problem (``pb``: a :class:`~optdesign.design.problem.DesignProblem`,
which imports this module; hence no annotation) and read or set its attributes.
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

from ..scene.expressions import evaluate


# --- stroke aggregates ---
def sampled_extreme(ag, q) -> float:
    """The aggregate ``ag`` (its max, min, first or last value) of the per-sample quantities
    ``q`` (rows x samples; for start/end the first and last columns are the stroke's ends)."""
    row = q[ag.index]
    if ag.func in ("start", "end"):
        return float(row[0] if ag.func == "start" else row[-1])
    return float(np.max(row) if ag.func == "max" else np.min(row))


def aggregate_start(pb, ag) -> float:
    """The aggregate's value on the scene's samples at the start design."""
    return sampled_extreme(ag, pb.start_quantities)


def aggregates_of(pb, w) -> np.ndarray:
    """The stroke aggregates' values (physical units) in an NLP solution vector ``w``."""
    nd = len(pb.design_names)
    return np.asarray(w[nd + pb.n_t:], float) * pb.a_scale


def parameter_values(pb, p=None) -> dict:
    """Every scene parameter's value by name, from the leaf parameter vector ``p`` (numbers or
    CasADi symbols; default: the scene's values)."""
    return pb.mech.resolved.environment(pb.mech.parameter_values if p is None else p)


def outer_value(pb, expr, a, p=None):
    """A stroke expression (its aggregates replaced by their names) with the aggregates'
    values ``a`` (in the order of ``pb.aggregates``) and the parameters ``p``."""
    values = parameter_values(pb, p)
    values.update({ag.name: a[i] for i, ag in enumerate(pb.aggregates)})
    return evaluate(expr, values, {}, expr.source)


def outer_start(pb, expr):
    """A stroke expression at the start design (its aggregates on the scene's samples)."""
    return outer_value(pb, expr, [aggregate_start(pb, ag) for ag in pb.aggregates])


def stroke_value(pb, outer, extremes, x=None) -> float:
    """A stroke expression evaluated with its aggregates taken from ``extremes``
    ((aggregate name, 'max'|'min') -> value, as found by the continuous check) and its
    parameters at the design ``x`` (default: the scene's values; a design variable in the
    outer expression is read at the design reported, never at its start value)."""
    p = None if x is None else pb.full_parameters(x)
    return float(outer_value(pb, outer, [extremes.get((ag.name, ag.func), math.nan) for ag in pb.aggregates], p))


def nonlinear_aggregates(pb) -> set:
    """Indices (in ``pb.aggregates``) of the max/min aggregates that some outer expression (the
    objective's or a stroke constraint's) holds non-linearly: max(L)/min(L), sqrt(max(e)).
    Only those need the sign they have at the start design kept (:mod:`.nlp`): an outer
    expression affine in an aggregate is regular at any value of it, and an aggregate of an
    expression with a design variable in it (min(angle(A, B, B0) - mu) >= 0) must be free
    to reach 0, whatever its sign at the start."""
    a = ca.SX.sym("a", len(pb.aggregates))
    p = ca.SX.sym("p", len(pb.mech.parameter_values))
    outers = [outer for _, outer in pb.stroke_constraints]
    if pb.objective_kind == "expression":
        outers.append(pb.objective_expr)
    out = set()
    for outer in outers:
        expr = outer_value(pb, outer, a, p)
        for i, ag in enumerate(pb.aggregates):
            if ag.func in ("max", "min") and ca.depends_on(expr, a[i]) and not ca.is_linear(expr, a[i]):
                out.add(i)
    return out


def needs_location(pb, outer, lo, hi) -> set:
    """Indices (in ``pb.aggregates``) of the max/min aggregates of the stroke expression
    ``outer`` that the bounds ``lo <= outer <= hi`` (+-inf: open) cannot hold by an epigraph.

    An epigraph a >= e(s_j) (a <= e(s_j) for a min) is exact only where the bound pushes a
    down onto the largest e(s_j): an upper bound needs the outer expression increasing in each
    max(...) and decreasing in each min(...), a lower bound the reverse, so an equality
    (max(y) - min(y) == H) or a lower bound on a stroke needs the located extreme.  So does
    an aggregate whose direction the start design does not tell (zero derivative there)."""
    names = outer.names()
    members = [i for i, ag in enumerate(pb.aggregates) if ag.name in names and ag.func in ("max", "min")]
    if not members:
        return set()
    a = ca.SX.sym("a", len(pb.aggregates))
    expr = outer_value(pb, outer, a)
    grad = ca.Function("g", [a], [ca.gradient(expr, a)])
    grad_v = np.asarray(grad([aggregate_start(pb, ag) for ag in pb.aggregates])).ravel()
    out = set()
    for i in members:
        ag = pb.aggregates[i]
        if grad_v[i] == 0 or not np.isfinite(grad_v[i]):
            out.add(i)
            continue
        ok_upper = (grad_v[i] > 0) == (ag.func == "max")  # an upper bound is conservative
        if (math.isfinite(hi) and not ok_upper) or (math.isfinite(lo) and ok_upper):
            out.add(i)
    return out


def located_aggregates(pb, stroke_bounds) -> list:
    """Indices (in ``pb.aggregates``, increasing) of the max/min aggregates held at their
    located extreme, not by an epigraph: those of the objective or of a stroke constraint
    whose bound there is not conservative (:func:`needs_location`), under the
    stroke constraints' bounds ``stroke_bounds`` (name -> (lower, upper), physical units)."""
    located = set()
    if pb.objective_kind == "expression":
        located |= needs_location(pb, pb.objective_expr, -math.inf, 0.0)
    for c, outer in pb.stroke_constraints:
        located |= needs_location(pb, outer, *stroke_bounds[c.name])
    return sorted(located)


# --- rms ---
def rms(pb, x, fixed=None, panels=None) -> float:
    """RMS of the objective's quantity over the continuous stroke at design x (composite
    Gauss-Legendre, ``panels`` x 4 nodes; default: the problem's ``rms_panels``)."""
    nodes, weights = quadrature(pb.s_grid[0], pb.s_grid[-1], panels or pb.rms_panels)
    v = pb.evaluate_grid(x, fixed, nodes)[pb.objective_quantity]
    return float(np.sqrt(np.dot(weights, v**2)))


def rms_sampled(pb, x, fixed=None) -> float:
    """RMS on the scene's samples (trapezoid rule)."""
    v = pb.evaluate_grid(x, fixed)[pb.objective_quantity]
    return float(np.sqrt(np.trapezoid(v**2, pb.s_grid) / (pb.s_grid[-1] - pb.s_grid[0])))


def rms_panels(pb) -> int:
    """Panels for the rms quadrature: doubled from the settings' count until the start
    design's rms agrees with twice as many panels within ``rms_tol``."""
    panels = pb.settings.rms_panels
    while panels < 1024:
        a, b = rms(pb, pb.start, panels=panels), rms(pb, pb.start, panels=2 * panels)
        if abs(a - b) <= pb.settings.rms_tol * max(abs(b), 1e-300):
            return panels
        panels *= 2
    return panels


def quadrature(a, b, panels, order=4):
    """Nodes and weights of composite Gauss-Legendre quadrature for the mean over [a, b]."""
    x, w = np.polynomial.legendre.leggauss(order)
    edges = np.linspace(a, b, panels + 1)
    half = 0.5 * np.diff(edges)
    mid = 0.5 * (edges[:-1] + edges[1:])
    nodes = (mid[:, None] + half[:, None] * x[None, :]).ravel()
    weights = (half[:, None] * w[None, :]).ravel() / (b - a)
    return nodes, weights
