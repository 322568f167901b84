"""Forces drawn where they act (issue 30): an arrow at each pin of the mechanism's joint
structure (:mod:`optdesign.model.joints`) at the drawn position, the force on the ground (or
on the first body that meets there), all arrows on one scale, each labelled with its value
there and its peak over the stroke; and the force elements ([[forces]]) between their points
(a spring as a zigzag, a gas spring, damper or constant force as a bar), with their names."""
from __future__ import annotations

import numpy as np

from ..kinematics.mechanism import Mechanism
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
    if scene.drive is None:
        return {}
    try:
        mech = Mechanism(ResolvedScene(scene))
        joints = JointForces(ReducedModel(mech))
    except JointStructureError:
        return {}
    s_values = np.asarray(s_values, float)
    f = mech.function("pin_forces", joints.pins).map(len(s_values))
    out = f(s=s_values[None, :], p=mech.parameter_values)
    return {p: np.asarray(out[p], float) for p in joints.pins}


def draw_pin_forces(ax, scene, frames, index, ctx):
    """Arrows of the pin forces at sample ``index`` of ``frames`` (their largest over the
    stroke as long as a fifth of the mechanism), each labelled 'A 10.4 kN (peak 13.7 kN)'."""
    forces = pin_forces(scene, frames.s)
    if not forces:
        return
    peak = {p: float(np.max(np.hypot(*f))) for p, f in forces.items()}
    top = max(peak.values())
    if not top > 0:
        return
    scale = 0.2 * ctx.extent / top
    for p, f in forces.items():
        where = frames.at(index).points[p][0]
        vec = f[:, index]
        arrow(ax, where, vec * scale, PIN, f"{p} {quantity(float(np.hypot(*vec)), 'N', 3)} "
                                           f"(peak {quantity(peak[p], 'N', 3)})", ctx.w, ctx=ctx)


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
