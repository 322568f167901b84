"""The forces at the pins drawn where they act (issue 30): an arrow at each pin of the
mechanism's joint structure (:mod:`optdesign.model.joints`) at the drawn position, the force
on the ground (or on the first body that meets there), all arrows on one scale, each labelled
with its value there and its peak over the stroke."""
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
