"""Which bodies meet at which pin: the joint structure of a mechanism, derived from its
constructions and bodies (issue 30; docs/scenes.md, "Joint forces").

Derived, at the scene's parameter values over seven positions of the stroke:

- **parts**: the ground (the points that do not move) and the rigid bodies that move.  A point
  belongs to a part when its coordinates in the part's frame stay the same over the stroke.
  Each [[bodies]] entry is a part, entries that move as one rigid body are one part (their
  loads and masses add), and one that does not move belongs to the ground.  A rotary drive's
  crank [S, A] that no body carries is a massless part, and so is the frame of an ``attach``
  that no body carries.
- **members**: the links the constructions imply (a polar's centre to its point, a dyad's two
  centres to its point, a slider's centre to its point, a loop's consecutive joints) that no
  part carries: massless two-force members (one axial force each), provided their length does
  not change; a linear drive's actuator is one too, its axial force the drive load.
- **pins**: points that coincide over the whole stroke are one pin (a loop's closing joint and
  the fixed point it closes on); each point where two or more parts or members meet is a pin.
- **sliders**: a slider construction's point runs on a line fixed to the ground: the guide
  pushes across the line (a normal force) and, where the point is on a part that does not turn
  (a piston), holds its turning (a moment); on a part that turns it is a roller (no moment).
- **cylinders**: two bodies whose frames run between the same two points (in either direction)
  while their distance changes are a cylinder's barrel and rod, sliding on each other along
  that line (a normal force and a moment); the drive's push acts between the two points.

What cannot be derived is reported, with its reason, in :class:`JointStructureError`: a slider
on a moving guide, a loop closed on a line, a polar of varying length that no body carries, a
structure whose equations and unknowns do not match (a mechanism with more or fewer degrees of
freedom than its drive).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from ..errors import SceneError
from ..scene.points import Attach, Dyad, Fixed, Loop, Polar, Slider


class JointStructureError(SceneError):
    """The joint structure cannot be derived from the scene (see the module's doc)."""


@dataclass
class Part:
    """The ground (``moving`` False) or a moving rigid part: its [[bodies]] entries (none for a
    massless link), its frame (two point names) and the points it carries."""

    name: str
    frame: tuple | None
    bodies: list = field(default_factory=list)
    points: set = field(default_factory=set)
    moving: bool = True


@dataclass
class Structure:
    """parts (the ground first), members ((P, Q) pairs), sliders ({point: (origin, angle
    expression)}), ``same`` (point -> the pin it is: the first of the points that coincide
    with it), ``crank`` (the part the rotary drive turns, or None)."""

    parts: list
    members: list
    sliders: dict
    same: dict
    crank: Part | None
    telescopes: list = field(default_factory=list)   # (barrel part, rod part, P, Q): a cylinder
    turning: set = field(default_factory=set)         # names of the parts that turn


def derive(mech) -> Structure:
    """The joint structure of ``mech``'s scene (raises :class:`JointStructureError`)."""
    scene = mech.scene
    names = list(mech.points)
    f = ca.Function("joint_points", [mech.s, mech.p], [ca.horzcat(*[mech.points[n] for n in names])])
    s0, s1 = (float(v) for v in mech.resolved.stroke(2))
    r = np.array([np.asarray(f(s, mech.parameter_values), float) for s in np.linspace(s0, s1, 7)])  # (7, 2, N)
    if not np.all(np.isfinite(r)):
        raise JointStructureError(f"{scene.path}: the mechanism does not assemble over the stroke at the parameters' "
                                  "values, so its joint structure cannot be derived")
    scale = max(1.0, float(np.max(np.abs(r))))
    tol = 1e-9 * scale
    index = {n: i for i, n in enumerate(names)}
    same = {}
    for n in names:  # coinciding points are one pin: the first of them names it
        same[n] = next(m for m in names if np.max(np.abs(r[:, :, index[m]] - r[:, :, index[n]])) <= tol)

    def rigid(frame):
        o, x = (r[:, :, index[p]] for p in frame)
        e = (x - o) / np.linalg.norm(x - o, axis=1, keepdims=True)
        out = set()
        for n in names:
            d = r[:, :, index[n]] - o
            local = np.stack([e[:, 0] * d[:, 0] + e[:, 1] * d[:, 1], e[:, 0] * d[:, 1] - e[:, 1] * d[:, 0]], axis=1)
            if np.max(np.ptp(local, axis=0)) <= tol:
                out.add(same[n])
        return out

    ground = Part("ground", None, points={same[n] for n in names if np.max(np.ptp(r[:, :, index[n]], axis=0)) <= tol},
                  moving=False)
    parts = [ground]

    def carrier(a, b, moving_only=False):
        return next((p for p in parts if same[a] in p.points and same[b] in p.points
                     and (p.moving or not moving_only)), None)

    for b in scene.bodies:
        o, x = b.frame
        if same[o] in ground.points and same[x] in ground.points:
            ground.bodies.append(b)
            continue
        part = carrier(o, x, moving_only=True)
        if part is None:
            part = Part(b.name, b.frame, points=rigid(b.frame))
            parts.append(part)
        part.bodies.append(b)
    crank = None
    if scene.drive is not None and scene.drive.kind == "rotary":
        crank = carrier(*scene.drive.pins, moving_only=True)
        if crank is None:
            crank = Part("crank " + "-".join(scene.drive.pins), scene.drive.pins, points=rigid(scene.drive.pins))
            parts.append(crank)
    for c in scene.points:
        if isinstance(c, Attach) and carrier(c.origin, c.toward) is None:
            parts.append(Part(f"link {c.origin}-{c.toward}", (c.origin, c.toward), points=rigid((c.origin, c.toward))))
    members, sliders = [], {}
    for c, (a, b) in _links(scene):
        if carrier(a, b) is not None or same[a] == same[b]:
            continue
        length = np.linalg.norm(r[:, :, index[a]] - r[:, :, index[b]], axis=1)
        if np.ptp(length) > tol:
            raise JointStructureError(f"{scene.path}: [points] {c.name}: the link {a}-{b} changes its length over the "
                                      "stroke and no body carries both ends, so the joint forces cannot be derived; "
                                      f"give the link as a [[bodies]] entry with frame = [{a!r}, {b!r}]")
        members.append((same[a], same[b]))
    for c in scene.points:
        if isinstance(c, Slider):
            angle = mech.value(c.angle)
            turning = not isinstance(angle, (int, float)) and ca.depends_on(angle, mech.s)
            if same[c.origin] not in ground.points or turning:
                raise JointStructureError(f"{scene.path}: [points] {c.name}: a slider on a moving guide; joint forces "
                                          "need the guide fixed to the ground")
            sliders[same[c.name]] = c
        if isinstance(c, Loop) and c.closure is not None and c.closure.fixed is None:
            raise JointStructureError(f"{scene.path}: [points] {c.name}: a loop closed on a line; joint forces need a "
                                      "closed loop (closure fixed = POINT)")
    telescopes = []
    for i, a in enumerate(parts):
        for b in parts[i + 1:]:
            if a.moving and b.moving and set(a.frame) == set(b.frame):
                telescopes.append((a, b) + tuple(a.frame))   # a cylinder's barrel and rod
    turning = set()
    for part in parts:
        if part.moving:
            o, x = (r[:, :, index[p]] for p in part.frame)
            d = x - o
            if np.ptp(np.unwrap(np.arctan2(d[:, 1], d[:, 0]))) > 1e-9:
                turning.add(part.name)
    return Structure(parts, members, sliders, same, crank, telescopes, turning)


def _links(scene):
    """(construction, (P, Q)) for each link the constructions imply."""
    for c in scene.points:
        if isinstance(c, Polar):
            yield c, (c.centre, c.name)
        elif isinstance(c, Dyad):
            yield c, (c.p, c.name)
            yield c, (c.q, c.name)
        elif isinstance(c, Slider):
            yield c, (c.p, c.name)
        elif isinstance(c, Loop):
            chain = (c.base,) + tuple(c.joints)
            for a, b in zip(chain, chain[1:]):
                yield c, (a, b)
        elif not isinstance(c, (Fixed, Attach)):  # pragma: no cover - the scene validates kinds
            raise TypeError(c)
