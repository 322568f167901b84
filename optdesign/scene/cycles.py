"""A whole machine cycle as one profile: ``kind = "cycle"``.

A cycle profile lists its segments as a segments profile does (:mod:`.segments`: motion laws in
time to positions, dwells), but in both directions and closed: it starts where its last motion
ends, e.g. a squeeze in two stages, a return and a rest::

    [profiles.breath]
    kind = "cycle"
    segments = [
      { law = "cycloidal", to = "115 deg", time = 0.5 },
      { dwell = 0.3 },                                   # holding the bag half squeezed
      { law = "modified-sine", to = "130 deg", time = 0.4 },
      { law = "modified-sine", to = "100 deg", time = 0.8, set = { T0 = 0, kbag = 0 } },
      { dwell = 1.2 },                                   # the rest: the motor holds the arm
    ]

A case that runs it (``profile = "breath"``, no direction) stands for the whole cycle.  As the
scene is made (:func:`expanded_cycles`), the cycle is cut where its motion turns back, which
must be at an end of the stroke ([sweep] from or to: sweep the range the motion covers): each
way is a case of its own over the whole stroke (named ``"CASE 1"``, ``"CASE 2"``, ... in the
cycle's order, with the case's ``set`` and its segments' ``set``, which must agree within one
way), its segments (and the dwells inside it) a segments profile; a dwell at an end of the
stroke is a hold there, the motor carrying that way's static load (1/eta).  Those cases and
holds are the duty cycle ([duty] may name the cycle's case as a step: its steps go there).
"""
from __future__ import annotations

import dataclasses

from .cases import Case, Duty, DutyStep
from .expressions import constant_value
from .profiles import CYCLE, Profile
from .where import Where, fail


def expanded_cycles(scene) -> dict:
    """The scene's cases and duty with each case that runs a cycle profile replaced by its ways
    and holds (see the module's docstring); {} when no case runs one."""
    profiles = {p.name: p for p in scene.profiles if getattr(p, "kind", None) == CYCLE}
    runs = {c.name: profiles.get(c.profile) if isinstance(c.profile, str) else c.profile for c in scene.cases
            if isinstance(c, Case) and (profiles.get(c.profile) if isinstance(c.profile, str) else
                                        getattr(c.profile, "kind", None) == CYCLE)}
    if not runs:
        return {}
    values = scene.parameter_values()
    cases, expanded = [], {}
    for c in scene.cases:
        if isinstance(c, Case) and c.name in runs:
            if c.direction is not None:
                fail(Where("cases", c.name, "direction"), f"the case runs the cycle {runs[c.name].name!r}, which goes both "
                     "ways: leave out its direction (each way of the cycle is a case of its own)")
            ways, steps = ways_of(scene, c, runs[c.name], values)
            cases += ways
            expanded[c.name] = steps
        else:
            cases.append(c)
    if scene.duty is not None:
        steps = []
        for st in scene.duty.steps:
            if st.case in expanded and st.kind == "hold":
                fail(Where("duty", key=f"cycle[{st.index}]"), f"case {st.case!r} runs a whole cycle, with its holds; "
                     "hold at an end of one of its ways, named \"CASE 1\", \"CASE 2\", ..., or give the dwell in the cycle")
            steps += expanded[st.case] * st.repeat if st.case in expanded else [st]
    else:
        if any(getattr(c, "weight", None) is not None for c in scene.cases):
            fail(Where("cases", next(iter(runs))), "a case that runs a cycle is the whole cycle: without [duty], give "
                 "no case a weight (write the cycle's steps in [duty] instead)")
        steps = [s for c in scene.cases for s in (expanded[c.name] if c.name in expanded else [DutyStep("case", c.name)])]
    steps = [dataclasses.replace(s, index=i) for i, s in enumerate(steps)]
    return {"cases": tuple(cases), "duty": Duty(tuple(steps))}


def ways_of(scene, case, profile, values):
    """The cases (one per way over the stroke) and the duty steps of ``case`` running the cycle
    ``profile``, its positions evaluated with ``values``."""
    start, stop = (constant_value(e, values, Where("sweep", key=k)) for e, k in ((scene.sweep.start, "from"),
                                                                                 (scene.sweep.stop, "to")))
    segments = profile.segments
    span = abs(stop - start)

    def position(seg):
        return constant_value(seg.to, values, seg.where.at(f"{seg.where.key}.to"))

    def at_end(x):
        return abs(x - start) <= 1e-12 * span or abs(x - stop) <= 1e-12 * span

    here = position(next(s for s in reversed(segments) if s.dwell is None))
    if not at_end(here):
        last = next(s for s in reversed(segments) if s.dwell is None)
        fail(last.where.at(f"{last.where.key}.to"), f"the cycle starts where its last motion ends, {here:.10g}, inside the "
             f"stroke from {start:.10g} to {stop:.10g}; a cycle starts and turns back at the stroke's ends (sweep the "
             "range its motion covers)")
    ways, current, sign = [], [], 0.0     # current: the segments of the way under way
    steps = []
    for seg in segments:
        if seg.dwell is not None:
            if current and not at_end(here):
                current.append(seg)       # a stop inside a way
            else:
                steps.append(("hold", seg, len(ways) if current else None))   # after the way under way, or first
            continue
        to = position(seg)
        direction = 1.0 if to > here else -1.0
        if current and direction != sign:
            if not at_end(here):
                fail(seg.where.at(f"{seg.where.key}.to"), f"the cycle turns back at {here:.10g}, inside the stroke from "
                     f"{start:.10g} to {stop:.10g}; a cycle turns back only at the stroke's ends (each way is a case "
                     "over the whole stroke): sweep the range the motion covers")
            ways.append((sign, current))
            current = []
        if not current:
            steps.append(("case", None, len(ways)))
        current.append(seg)
        sign, here = direction, to
    ways.append((sign, current))
    out = []
    for k, (sign, segs) in enumerate(ways):
        overrides = dict(segs[0].set or {})   # (a way begins with a motion)
        for s in segs:
            if s.dwell is None and dict(s.set or {}) != overrides:
                fail(s.where.at(f"{s.where.key}.set"), f"the segments of one way of the cycle carry one load: this set "
                     f"differs from that of the way's first segment ({', '.join(overrides) or 'none'}); give each of "
                     "its segments the same set")
        inline = Profile(case.name, "segments", segments=tuple(segs), place=Where("cases", case.name, "profile"))
        out.append(Case(f"{case.name} {k + 1}", "forward" if sign * (stop - start) > 0 else "reverse",
                        {**case.overrides, **overrides}, case.efficiency, inline))
    duty = []
    for kind, seg, k in steps:
        if kind == "case":
            duty.append(DutyStep("case", out[k].name))
        else:   # a dwell at an end: a hold at the end of the way before it (before any: the first one's start)
            duty.append(DutyStep("hold", out[0 if k is None else k].name, seg.dwell, at="start" if k is None else "end"))
    return out, duty
