"""Constraint bounds: as numbers, and other bounds on an already built problem.

Bounds are only the NLP's lbg/ubg (passed at solve time), so :func:`with_bounds` gives a
problem with other bounds on some of the scene's constraints that shares the built NLP and
its solvers (a Pareto front by the epsilon-constraint method needs no rebuild per point);
:func:`scene_with_bounds` is the scene that such a problem stands for.

The functions take the problem (``pb``: a :class:`~optdesign.design.problem.DesignProblem`,
which imports this module; hence no annotation) and read or set its attributes.
"""
from __future__ import annotations

import copy
import dataclasses
import math

from ..errors import SceneError
from ..scene import ResolvedScene, Scene
from ..scene.expressions import near_miss, parse
from .aggregates import located_aggregates


def numeric_bounds(resolved: ResolvedScene, c) -> tuple:
    """A constraint's (lower, upper) as numbers (they may name fixed parameters)."""
    where = f"{resolved.scene.path}: [[constraints]] {c.name!r}"
    lo = -math.inf if c.lower is None else resolved.constant(c.lower, f"{where} min")
    hi = math.inf if c.upper is None else resolved.constant(c.upper, f"{where} max")
    return lo, hi


def with_bounds(pb, bounds):
    """``pb`` with other bounds on some of the scene's constraints, without a rebuild.

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

    A stroke constraint's max(...)/min(...) is held by an epigraph where its bound is
    conservative (it limits a max from above or a min from below) and at its located extreme
    otherwise (:mod:`.nlp`); the two have different rows.  New bounds that need the located
    extreme of an aggregate this build holds by an epigraph (a lower bound on a stroke whose
    build had an upper one) give a fresh build of the new scene, with its own NLP, solvers and
    scales (the result of that build, not a shared one).
    """
    new_bounds, requested = _requested_bounds(pb, bounds)
    if not new_bounds:
        return pb
    stroke_bounds = dict(pb.stroke_bounds)
    stroke_bounds.update({k: v for k, v in new_bounds.items() if k in stroke_bounds})
    if not set(located_aggregates(pb, stroke_bounds)) <= set(pb.located):
        return type(pb)(scene_with_bounds(pb.scene, requested), pb.settings)
    new = copy.copy(pb)
    new.lbg, new.ubg = pb.lbg.copy(), pb.ubg.copy()
    new.blocks = list(pb.blocks)
    new.stroke_bounds = dict(pb.stroke_bounds)
    rows = {name: (start, n) for name, kind, start, n in pb.g_blocks
            if kind in ("constraint", "design constraint", "stroke constraint")}
    for name, (lo, hi) in new_bounds.items():
        start, n = rows[name]
        scale = pb.g_scale[name]
        if name in pb.stroke_bounds:
            new.stroke_bounds[name] = (lo, hi)
        else:
            i = _block_of(pb, name)
            new.blocks[i] = dataclasses.replace(pb.blocks[i], lower=lo, upper=hi)
        # the same arithmetic as the build's (bound / scale): bit for bit what a fresh
        # build with the same scale passes to IPOPT
        new.lbg[start:start + n] = lo / scale
        new.ubg[start:start + n] = hi / scale
    new.scene = scene_with_bounds(pb.scene, requested)
    return new


def constraint_bounds(pb, name) -> tuple:
    """(lower, upper) of the scene's constraint ``name`` in physical units (+-inf when open)."""
    if name in pb.stroke_bounds:
        return pb.stroke_bounds[name]
    find_constraint(pb, name)
    b = pb.blocks[_block_of(pb, name)]
    return b.lower, b.upper


def _block_of(pb, name) -> int:
    """Index in ``pb.blocks`` of the per-sample (or design) constraint ``name``."""
    return next(i for i, b in enumerate(pb.blocks) if b.name == name and b.kind in ("constraint", "design constraint"))


def find_constraint(pb, name):
    """The scene's constraint ``name``; SceneError (naming the near misses) if it has none."""
    c = next((c for c in pb.scene.constraints if c.name == name), None)
    if c is None:
        names = [c.name for c in pb.scene.constraints]
        raise SceneError(f"{pb.scene.path}: with_bounds: the scene has no constraint {name!r}"
                         + near_miss(name, names) + f" (its constraints: {', '.join(names) or 'none'})")
    return c


def _requested_bounds(pb, bounds) -> tuple:
    """({constraint: (lower, upper)} after applying ``bounds`` to this problem's bounds,
    [(constraint, side, value as a number), ...])."""
    out, seen, requested = {}, set(), []
    for item in bounds:
        try:
            name, side, value = item
        except (TypeError, ValueError):
            raise SceneError(f"with_bounds: expected (constraint name, 'min' or 'max', value), found {item!r}") from None
        where = f"{pb.scene.path}: with_bounds: [[constraints]] {name!r} {side}"
        find_constraint(pb, name)
        if side not in ("min", "max"):
            raise SceneError(f"{where}: the side must be 'min' or 'max', found {side!r}")
        if (name, side) in seen:
            raise SceneError(f"{where}: given twice; give each bound once")
        seen.add((name, side))
        if isinstance(value, str):
            value = pb.mech.resolved.constant(parse(value, where), where)
        try:
            value = float(value)
        except (TypeError, ValueError):
            raise SceneError(f"{where}: expected a number or an expression, found {value!r}") from None
        if math.isnan(value) or value == (-math.inf if side == "max" else math.inf):
            raise SceneError(f"{where} = {value}: expected a finite number (or {'+' if side == 'max' else '-'}inf "
                             "to open the side)")
        lo, hi = out.get(name, constraint_bounds(pb, name))
        out[name] = (value, hi) if side == "min" else (lo, value)
        requested.append((name, side, value))
    for name, (lo, hi) in out.items():
        where = f"{pb.scene.path}: with_bounds: [[constraints]] {name!r}"
        if not (math.isfinite(lo) or math.isfinite(hi)):
            raise SceneError(f"{where}: both sides would be open; a constraint needs min, max or both "
                             "(remove it from the scene to drop it)")
        if lo > hi:
            raise SceneError(f"{where}: min = {lo:.6g} exceeds max = {hi:.6g}; no design can satisfy it")
    return out, requested


def scene_with_bounds(scene: Scene, bounds) -> Scene:
    """A copy of ``scene`` with constraint bounds replaced: ((name, 'min'|'max', value), ...),
    values as numbers (+-inf: the side is open)."""
    new = {}
    for name, side, value in bounds:
        value = float(value)
        new.setdefault(name, {})["lower" if side == "min" else "upper"] = repr(value) if math.isfinite(value) else None
    constraints = tuple(dataclasses.replace(c, **new[c.name]) if c.name in new else c for c in scene.constraints)
    return dataclasses.replace(scene, constraints=constraints)
