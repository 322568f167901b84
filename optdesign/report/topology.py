"""What an engineering drawing of a scene shows, read from its constructions, bodies and drive:
ground pivots, revolute joints, sliders on their guides, links as bars, the drive, and the
helper points that only construct others (not drawn).

The scene says how its points are built, not which of them are pins; the roles follow from
the constructions:

* a polar's centre, a dyad's two centres, a slider's centre, a loop's base and closing point,
  an attach's origin, a body frame's origin and both drive pins are **pins** (revolute
  joints); so are the points a dyad, slider or loop places (two links meet there);
* a slider's (or semi-closed loop's) line origin is a **guide** reference, an attach's x-axis
  point and a body frame's x-axis point only give a **direction**;
* a point used only for directions or guides, built as a polar at a constant angle from a
  moving centre (a point above a piston, 1 m along a platform) is a **helper**: no bar, no
  joint.  The optional ``[drawing] helpers`` list names helpers the rule misses.

Bars join a polar's centre to its point, a dyad's and slider's centres to theirs, a loop's
joints in order, a body frame's two points, and an attach's origin to its foot on the frame
line and the foot to the point (a lug); a linear drive is drawn as a cylinder instead of a bar.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from ..scene import Attach, Dyad, Fixed, Loop, Polar, Slider


@dataclass
class Topology:
    """The roles of a scene's points for drawing (names; ``bars`` hold point names or
    ``'foot:NAME'`` for the foot of attach point NAME on its frame's x axis)."""

    ground: list = field(default_factory=list)      # fixed pivots: ground hatching
    joints: list = field(default_factory=list)      # revolute joints: circles
    sliders: list = field(default_factory=list)     # (point, guide key, ground guide?)
    guides: list = field(default_factory=list)      # fixed points that only anchor a guide
    bars: list = field(default_factory=list)        # (a, b) pairs drawn as bars
    helpers: set = field(default_factory=set)
    tips: list = field(default_factory=list)        # real points that are neither pins nor helpers
    drive: tuple | None = None                      # (kind, (pin, pin))
    fixed: set = field(default_factory=set)         # points that never move


def _moves_with_sweep(expr, sweep, unknowns=()):
    names = expr.names()
    return sweep in names or bool(names & set(unknowns))


def topology(scene) -> Topology:
    """The drawing roles of ``scene``'s points (see the module's docstring)."""
    sweep = scene.sweep.name
    roles: dict = {n: set() for n in scene.point_names()}
    built_by = {}
    fixed = set()
    for c in scene.points:
        for name in c.defines:
            built_by[name] = c
        if isinstance(c, Fixed):
            fixed.add(c.name)
        elif isinstance(c, Polar):
            roles[c.centre].add("pin")
            if c.centre in fixed and not _moves_with_sweep(c.angle, sweep) and not _moves_with_sweep(c.length, sweep):
                fixed.add(c.name)
        elif isinstance(c, Dyad):
            roles[c.p].add("pin")
            roles[c.q].add("pin")
            roles[c.name].add("pin")
        elif isinstance(c, Slider):
            roles[c.p].add("pin")
            roles[c.origin].add("guide")
            roles[c.name].add("pin")
        elif isinstance(c, Attach):
            roles[c.origin].add("pin")
            roles[c.toward].add("direction")
            if c.origin in fixed and c.toward in fixed:
                fixed.add(c.name)
        elif isinstance(c, Loop):
            roles[c.base].add("pin")
            for j in c.joints:
                roles[j].add("pin")
            if c.closure is not None:
                roles[c.closure.fixed or c.closure.origin].add("pin" if c.closure.fixed else "guide")
    for b in scene.bodies:
        roles[b.frame[0]].add("pin")
        roles[b.frame[1]].add("direction")
    drive = None
    if scene.drive is not None:
        drive = (scene.drive.kind, tuple(scene.drive.pins))
        for p in scene.drive.pins:
            roles[p].add("pin")

    helpers = set(scene.drawing.helpers) if scene.drawing is not None else set()
    for name, r in roles.items():
        c = built_by[name]
        if r and r <= {"direction", "guide"} and isinstance(c, Polar) and c.centre not in fixed \
                and not _moves_with_sweep(c.angle, sweep):
            helpers.add(name)

    top = Topology(helpers=helpers, drive=drive, fixed=fixed)
    for name, r in roles.items():
        if name in helpers:
            continue
        if "pin" in r:
            (top.ground if name in fixed else top.joints).append(name)
        elif name in fixed and "guide" in r:
            top.guides.append(name)
        else:
            top.tips.append(name)

    bars = []

    def bar(a, b):
        if a in helpers or b in helpers or a == b:
            return
        if drive is not None and drive[0] == "linear" and {a, b} == set(drive[1]):
            return  # the cylinder is drawn instead
        if a in fixed and b in fixed:
            return  # both on the ground: the ground is not a bar
        if (a, b) not in bars and (b, a) not in bars:
            bars.append((a, b))

    for c in scene.points:
        if isinstance(c, Polar):
            bar(c.centre, c.name)
        elif isinstance(c, Dyad):
            bar(c.p, c.name)
            bar(c.q, c.name)
        elif isinstance(c, Slider):
            bar(c.p, c.name)
            ground_guide = c.origin in fixed and not _moves_with_sweep(c.angle, sweep)
            top.sliders.append((c.name, c.name, ground_guide))
        elif isinstance(c, Attach):
            if c.name not in helpers:
                bar(c.origin, f"foot:{c.name}")
                bar(f"foot:{c.name}", c.name)
        elif isinstance(c, Loop):
            chain = [c.base, *c.joints]
            for a, b in zip(chain[:-1], chain[1:]):
                bar(a, b)
            if c.closure is not None and c.closure.origin is not None:
                ground_guide = c.closure.origin in fixed and not _moves_with_sweep(c.closure.angle, sweep, c.unknowns)
                top.sliders.append((c.closure.point, c.name, ground_guide))
    for b in scene.bodies:
        bar(*b.frame)
    if drive is not None and drive[0] == "rotary":
        bar(*drive[1])
    top.bars = bars
    return top
