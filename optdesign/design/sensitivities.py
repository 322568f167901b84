"""What a solution says in physical units: the objective (certified or sampled), each
constraint's extreme values, bounds and multiplier, and the optimal objective's sensitivity
to each fixed parameter (from IPOPT's multipliers of the NLP parameters)."""
from __future__ import annotations

import math

import numpy as np

from .cases import time_rms
from .cycle_certify import rms_key
from .problem import DesignProblem
from .results import Solution


def objective_value(pb: DesignProblem, sol: Solution, certified=True) -> float:
    """The objective in physical units: certified (continuous) or on the scene's samples."""
    values = sol.certified if certified else sol.sampled
    if pb.objective_kind == "peak":  # with load cases: the largest of their peaks
        return max(abs(values[(b.name, "abs")]) for b in pb.blocks if b.kind == "peak")
    if pb.objective_kind == "rms":
        return values[(pb.objective_text, "rms")]
    if pb.objective_kind in ("rms_time", "mix"):
        return time_objective(pb, sol) if certified else time_rms(pb, sol)
    return pb.stroke_value(pb.objective_expr, values, sol.x)


def time_objective(pb: DesignProblem, sol: Solution) -> float:
    """An 'rms_time' or 'mix' objective from the solution's certified values: each RMS over the
    duty cycle by the adaptive quadrature (:func:`.cycle_certify.cycle_rms`), each peak over the
    continuous stroke; the NLP's value (:func:`.cases.time_rms`) where one has no certified value."""
    total = 0.0
    for coef, kind, what, _ in pb.case_terms:
        if kind == "peak":
            peaks = [abs(sol.certified.get((b.name, "abs"), math.nan)) for b in pb.blocks if b.kind == "peak"]
            if not peaks or any(not math.isfinite(v) for v in peaks):
                return time_rms(pb, sol)
            total += coef * max(peaks)
        elif rms_key(what) in sol.certified:
            total += coef * sol.certified[rms_key(what)]
        else:
            return time_rms(pb, sol)
    return total


def objective_gradient_factor(pb: DesignProblem, sol: Solution) -> float:
    """dJ/df: the physical objective J per unit of the NLP's objective f."""
    if pb.objective_kind == "peak":
        return pb.f_ref
    if pb.objective_kind in ("rms", "rms_time"):
        return pb.f_ref / (2 * math.sqrt(max(sol.f, 1e-300)))
    if pb.objective_kind == "mix":
        return pb.f_ref
    return pb.objective_scale


def sensitivities(pb: DesignProblem, sol: Solution, factor: float, constraints: dict | None = None) -> dict:
    """d objective / d parameter for each fixed parameter (``factor``: dJ/df): through the
    NLP's parameters (IPOPT's multipliers of them) plus, for a parameter named in a
    constraint's bound, the bound's multiplier times d bound / d parameter (``constraints``:
    :func:`constraint_report`'s, made here when not given).  A parameter used only in bounds
    (a stroke length H in ``min = "H - Lb"``) enters the NLP as a number in lbg/ubg, which
    lam_p does not see."""
    # CasADi's lam_p is minus the gradient of the Lagrangian in p: dJ*/dp = -lam_p (scaled)
    out = {name: float(-factor * sol.lam_p[j]) for j, name in enumerate(pb.fixed_names)}
    constraints = constraint_report(pb, sol, factor) if constraints is None else constraints
    for (name, side), gradient in bound_gradients(pb).items():
        entry = constraints.get(name)
        if entry is None or entry["active"] != side or not entry["multiplier"]:
            continue
        for j, fixed_name in enumerate(pb.fixed_names):
            out[fixed_name] += float(entry["multiplier"] * gradient[j])
    return out


def sensitivity_notes(pb: DesignProblem) -> dict:
    """{fixed parameter: why its sensitivity is not the whole story} for the parameters that
    load cases set ([[cases]] set): the NLP's parameter is the scene's value, which a case
    that sets its own does not use, so d objective / d parameter holds only the cases that
    keep the scene's value (none: no sensitivity exists, the reported 0 is not one)."""
    cases = getattr(pb.scene, "cases", None) or ()
    resolved = pb.mech.resolved
    out = {}
    for name in pb.fixed_names:
        # a case whose value is an expression of the scene's (mP = "1.25*mP") keeps it: counted
        setting = [c.name for c in cases if name in c.overrides and not (
            hasattr(c.overrides[name], "names") and resolved.depends_on(c.overrides[name], [name]))]
        if not setting:
            continue
        if len(setting) == len(cases):
            out[name] = (f"every load case sets its own {name} ({', '.join(setting)}): the scene's value enters no "
                         "case, so no sensitivity to it exists; to see one case's, change that case's value "
                         "and optimise again")
        else:
            out[name] = (f"only the cases that keep the scene's {name}; the cases that set their own "
                         f"({', '.join(setting)}) are not in this value")
    return out


def bound_gradients(pb: DesignProblem) -> dict:
    """{(constraint name, 'lower'|'upper'): d bound / d fixed parameter (one per fixed
    parameter, in the order of ``pb.fixed_names``)} for every bound of the scene's
    constraints that names a parameter (through derived parameters too), by CasADi."""
    import casadi as ca

    from ..scene.expressions import evaluate

    mech = pb.mech
    p = ca.SX.sym("p", len(mech.parameter_values))
    env = mech.resolved.environment(p)
    out = {}
    for c in pb.scene.constraints:   # the problem's own (a Pareto point's with_bounds has its own)
        for side, expr in (("lower", c.lower), ("upper", c.upper)):
            if expr is None or not expr.names():
                continue
            bound = evaluate(expr, env, {}, f"[[constraints]] {c.name}")
            if not isinstance(bound, ca.SX) or not ca.depends_on(bound, p):
                continue
            gradient = ca.Function("g", [p], [ca.gradient(bound, p)])(mech.parameter_values)
            out[(c.name, side)] = np.asarray(gradient, float).ravel()[pb.fixed_index]
    return out


def constraint_report(pb: DesignProblem, sol: Solution, factor: float) -> dict:
    """Each named constraint: its extreme values over the continuous stroke (min and max, each
    located and refined, active or not: :meth:`~.certify.ContinuousCheck.extremes`), its bounds,
    and its multiplier as dJ*/d(active bound) in physical units (0 when inactive).  ``value``
    is the extreme at the active bound, else the one on the bounded side (when both sides are
    bounded, the extreme nearer its bound: a motor's speed in [-300, 300] that runs 0 .. 200 rad/s
    is reported as 200, not 0); a stroke constraint's value is its expression with every max(...)/min(...)
    at its continuous extreme."""
    out = {}
    for name, kind, start, n in pb.g_blocks:
        if kind in ("peak", "aggregate"):
            continue
        scale = pb.g_scale[name]
        lam = float(np.sum(_active(sol.lam_g[start:start + n], sol.g[start:start + n],
                                   pb.lbg[start:start + n], pb.ubg[start:start + n])))
        entry = {"kind": kind, "lower": _finite(pb.lbg[start] * scale), "upper": _finite(pb.ubg[start] * scale),
                 "multiplier": -lam * factor / scale + 0.0,
                 "active": _side(lam)}
        if kind == "stroke constraint":
            entry["value"] = pb.stroke_value(pb.stroke_outer[name], sol.certified, sol.x)
        elif kind == "cycle constraint":  # its row, in physical units (design/cases.py)
            entry["value"] = float(sol.g[start] * scale)
        else:
            lo, hi = sol.certified.get((name, "min")), sol.certified.get((name, "max"))
            if kind == "dead centre":  # reported as sigma * k / k_ref, the guarded quantity
                lo, hi = [None if v is None else pb.k_sign * v / pb.k_ref for v in (lo, hi)]
                lo, hi = (hi, lo) if pb.k_sign < 0 else (lo, hi)
            entry.update({"min": lo, "max": hi})
            upper_side = entry["active"] == "upper" or (entry["active"] is None and entry["lower"] is None)
            if entry["active"] is None and None not in (entry["lower"], entry["upper"], lo, hi):
                upper_side = entry["upper"] - hi < lo - entry["lower"]   # the extreme nearer its bound
            entry["value"] = hi if lo is None or (upper_side and hi is not None) else lo
        out[name] = entry
    for j, name in enumerate(pb.design_names):
        lam = float(_active(sol.lam_x[j:j + 1], sol.w[j:j + 1], pb.lbw[j:j + 1], pb.ubw[j:j + 1])[0])
        out[f"bounds of {name}"] = {
            "kind": "bound", "value": float(np.clip(sol.x[j], pb.lower[j], pb.upper[j])), "lower": _finite(pb.lower[j]), "upper": _finite(pb.upper[j]),
            "multiplier": float(-lam * factor / pb.z_scale[j]) + 0.0,
            "active": _side(lam)}
    return out


def _active(lam, value, lower, upper, tol=1e-6):
    """Multipliers of constraints at their bounds (within tol, scaled); 0 for the others,
    whose interior-point multipliers are of the order of IPOPT's barrier parameter."""
    at_bound = (np.abs(value - lower) <= tol) | (np.abs(value - upper) <= tol)
    return np.where(at_bound, lam, 0.0)


def _side(lam):
    """Which bound a multiplier belongs to: 'upper' (> 0), 'lower' (< 0) or None (inactive)."""
    return None if lam == 0 else ("upper" if lam > 0 else "lower")


def _finite(v):
    return float(v) if math.isfinite(v) else None
