"""What a solution says in physical units: the objective (certified or sampled), each
constraint's extreme values, bounds and multiplier, and the optimal objective's sensitivity
to each fixed parameter (from IPOPT's multipliers of the NLP parameters)."""
from __future__ import annotations

import math

import numpy as np

from .cases import time_rms
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
        return time_rms(pb, sol)
    return pb.stroke_value(pb.objective_expr, values, sol.x)


def objective_gradient_factor(pb: DesignProblem, sol: Solution) -> float:
    """dJ/df: the physical objective J per unit of the NLP's objective f."""
    if pb.objective_kind == "peak":
        return pb.f_ref
    if pb.objective_kind in ("rms", "rms_time"):
        return pb.f_ref / (2 * math.sqrt(max(sol.f, 1e-300)))
    if pb.objective_kind == "mix":
        return pb.f_ref
    return pb.objective_scale


def sensitivities(pb: DesignProblem, sol: Solution, factor: float) -> dict:
    """d objective / d parameter for each fixed parameter (``factor``: dJ/df)."""
    # CasADi's lam_p is minus the gradient of the Lagrangian in p: dJ*/dp = -lam_p (scaled)
    return {name: float(-factor * sol.lam_p[j]) for j, name in enumerate(pb.fixed_names)}


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
