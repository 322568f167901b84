"""Forces drawn where they act (issue 30): an arrow at each pin of the mechanism's joint
structure (:mod:`optdesign.model.joints`) at the drawn position, the force on the ground (or
on the first body that meets there), all arrows on one scale, each labelled with its value
there and its peak over the stroke; and the force elements ([[forces]]) between their points
(a spring as a zigzag, a gas spring, damper or constant force as a bar), with their names.
Where the scene has [[cases]], the forces drawn are those of the case with the largest pin force
(:func:`governing_pin_forces`), here and in the animation (report/animate.py: each frame's, on
one scale)."""
from __future__ import annotations

import numpy as np

from ..kinematics.mechanism import Mechanism
from ..model.cse import cse_function
from ..model.joint_structure import JointStructureError
from ..model.joints import JointForces
from ..model.reduction import ReducedModel
from ..scene.resolved import ResolvedScene
from .drawing import arrow
from .units import quantity

PIN = "#6a1b9a"
ELEMENT = "#a0522d"


def pin_forces(scene, s_values):
    """{pin: (2, n) force} at the sweep values ``s_values``, or {} when the scene has no drive or
    its joint structure cannot be derived."""
    return governing_pin_forces(scene, s_values, cases=False)[0]


def governing_pin_forces(scene, s_values, cases=True):
    """({pin: (2, n) force} at the sweep values ``s_values``, case): the scene's pin forces, or
    with [[cases]] (and ``cases``) those of the case whose largest pin force over ``s_values`` is
    the largest, and its name (None without cases); ({}, None) when the scene has no drive or its
    joint structure cannot be derived.  The graphs are built once for a scene and its designs
    (:func:`_built`): the start and the optimum of a figure share one build."""
    if scene.drive is None:
        return {}, None
    s_values = np.asarray(s_values, float)
    runs, p = _built(scene, bool(cases and scene.cases))
    if runs is None:
        return {}, None
    best = (-np.inf, {}, None)
    for name, pins, function, parameters in runs:
        out = function.map(len(s_values))(s=s_values[None, :], p=parameters(p))
        forces = {pin: np.asarray(out[pin], float) for pin in pins}
        top = max((float(np.nanmax(np.hypot(*f))) for f in forces.values()), default=-np.inf)
        if top > best[0]:
            best = (top, forces, name)
    return best[1], best[2]


_BUILT = []   # the last build in this process: (scene, cases, runs or None when its structure has no forces)


def build_ahead(scene):
    """Build the pin forces' graphs of ``scene`` (and its designs) now, in this process, so that
    processes forked from it afterwards share the build (an optimisation's drawing and its
    animation, each 0.3 s of CPU on its own: report/design_figures.write_figures); nothing where
    the build fails (each drawing then makes it, and meets its error, as before)."""
    if scene.drive is None:
        return
    try:
        _built(scene, bool(scene.cases))
    except Exception:   # noqa: BLE001
        _BUILT.clear()


def _built(scene, cases):
    """(runs, p): the pin forces' graphs of ``scene`` as (case name, pins, Function of (s, p), the
    case's p from the scene's), runs None where the joint structure cannot be derived; made once
    and reused for a scene that differs only in the values of design variables (leaf parameters,
    inputs of the graphs, never folded into constants: the same numbers as a build of its own,
    as report/drive_train.analyse_at), p then that scene's leaf values."""
    resolved = ResolvedScene(scene)
    if _BUILT and _BUILT[1] == cases and _serves(_BUILT[0], scene):
        return _BUILT[2], resolved.leaf_values.copy()
    mech = Mechanism(resolved)
    mech.cse_function = cse_function
    try:
        if cases:
            from ..model.cases import CaseModel

            models = [(cm.name, cm.model, cm.case_parameters) for cm in (CaseModel(mech, c) for c in scene.cases)]
        else:
            models = [(None, ReducedModel(mech), lambda p: p)]
        runs = []
        for name, model, parameters in models:
            joints = JointForces(model)
            runs.append((name, list(joints.pins), mech.function("pin_forces", joints.pins), parameters))
    except JointStructureError:
        runs = None
    _BUILT[:] = [scene, cases, runs]
    return runs, mech.parameter_values


def _serves(built, scene) -> bool:
    """Whether the build of scene ``built`` serves ``scene``: the same scene but for the values of
    some design variables."""
    if built is scene:
        return True
    if [p.name for p in built.parameters] != [p.name for p in scene.parameters]:
        return False
    changed = {q.name: q.value for p, q in zip(built.parameters, scene.parameters) if p != q}
    design = {p.name for p in built.parameters if p.is_design and not p.value.names()}
    return set(changed) <= design and all(not scene.parameter(n).value.names() for n in changed) and (
        built.with_parameters(**changed) == scene)


def draw_pin_arrows(ax, frame, forces, scale, w, peaks=None, ctx=None):
    """An arrow of each pin force ``forces`` {pin: (2,) force} at its pin of ``frame`` (one
    position), ``scale`` [m/N] long, labelled 'A 10.4 kN' (with ``peaks``: ' (peak 13.7 kN)')."""
    for p, vec in forces.items():
        tail = f" (peak {quantity(peaks[p], 'N', 3)})" if peaks else ""
        arrow(ax, frame.points[p][0], vec * scale, PIN, f"{p} {quantity(float(np.hypot(*vec)), 'N', 3)}{tail}", w,
              ctx=ctx)


def arrow_scale(forces, extent) -> float | None:
    """The arrows' common scale: the largest force over all pins as long as a fifth of the
    mechanism's ``extent`` (None where there is no force)."""
    top = max((float(np.nanmax(np.hypot(*f))) for f in forces.values()), default=0.0)
    return 0.2 * extent / top if top > 0 else None


def draw_pin_forces(ax, scene, frames, index, ctx):
    """Arrows of the pin forces at sample ``index`` of ``frames`` (their largest over the
    stroke as long as a fifth of the mechanism), each labelled 'A 10.4 kN (peak 13.7 kN)'; with
    [[cases]] those of the case with the largest pin force, named in a note at the foot."""
    forces, case = governing_pin_forces(scene, frames.s)
    scale = arrow_scale(forces, ctx.extent)
    if scale is None:
        return
    peak = {p: float(np.max(np.hypot(*f))) for p, f in forces.items()}
    draw_pin_arrows(ax, frames.at(index), {p: f[:, index] for p, f in forces.items()}, scale, ctx.w, peak, ctx)
    if case is not None:
        ax.text(0.01, 0.01, f"pin forces: case '{case}' (the largest pin force)", transform=ax.transAxes,
                fontsize=6.5, color=PIN, ha="left", va="bottom", zorder=9)


def draw_force_elements(ax, scene, frame, w):
    """The [[forces]] between two points at ``frame`` (one position): a spring as a zigzag of
    eight turns, the other kinds as a thick line, each named at its middle."""
    for f in scene.forces:
        if f.between is None:
            continue
        p, q = (np.asarray(frame.points[n][0], float) for n in f.between)
        if not (np.all(np.isfinite(p)) and np.all(np.isfinite(q))) or np.hypot(*(q - p)) == 0:
            continue
        d = q - p
        if f.kind == "spring":
            t = np.linspace(0, 1, 34)
            wave = np.r_[0, 0, np.tile([1, -1], 15), 0, 0] * 0.6 * w
            normal = np.array([-d[1], d[0]]) / np.hypot(*d)
            xy = p[None, :] + t[:, None] * d[None, :] + wave[:, None] * normal[None, :]
            ax.plot(xy[:, 0], xy[:, 1], "-", color=ELEMENT, lw=0.9, zorder=4)
        else:
            ax.plot([p[0], q[0]], [p[1], q[1]], "-", color=ELEMENT, lw=2.2, alpha=0.8, zorder=4,
                    solid_capstyle="round")
        mid = p + 0.5 * d
        ax.text(mid[0] + 0.6 * w, mid[1], f.name, fontsize=6.5, color=ELEMENT, ha="left", va="center", zorder=9)
