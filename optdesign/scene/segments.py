"""A profile of segments: one way along the stroke, with stops between intermediate positions.

``kind = "segments"`` lists the motion as designers state it: each segment a motion law in time
(:data:`optdesign.scene.motion_laws.LAWS`) from rest at the previous position to rest at its
``to`` position (a sweep value: the angle or length of the output), in its ``time`` [s] or the
shortest time within a peak ``speed`` and/or ``acceleration`` (as a law profile's); or a
``dwell`` [s] at the position reached, where the motor holds the mechanism (its load is the
static load there, with the case's efficiency rule).  E.g. a rise to an intermediate position,
a dwell, a further rise::

    [profiles.index]
    kind = "segments"
    segments = [
      { law = "cycloidal", to = "115 deg", time = 0.5 },
      { dwell = 0.3 },
      { law = "modified-sine", to = "130 deg", time = 0.4 },
    ]

The positions run one way, each beyond the last, and the last ``to`` is the end of the stroke
the case runs to ([sweep] to for 'forward', from for 'reverse'): a case runs the whole stroke.
:func:`chain_of` turns the segments into the :class:`~.motion_laws.Chain` of the case's motion.
"""
from __future__ import annotations

from dataclasses import dataclass

from .expressions import Expression, constant_value
from .motion_laws import LAWS, Chain, standard
from .values import outside_meaningful, parse, set_field
from .where import Where, fail, near_miss, show

SEGMENT_KEYS = ("law", "to", "time", "speed", "acceleration", "dwell", "set")
TIMINGS = (("time",), ("speed",), ("acceleration",), ("speed", "acceleration"))


@dataclass(frozen=True)
class Segment:
    """A motion law to a position (``law``, ``to`` and its timing), or a ``dwell`` [s]."""

    where: Where
    law: str | None = None
    to: Expression | None = None
    time: Expression | None = None
    speed: Expression | None = None
    acceleration: Expression | None = None
    dwell: Expression | None = None
    set: dict | None = None     # a cycle's segment (:mod:`.cycles`): the parameters its way sets

    @property
    def timing(self) -> tuple:
        return tuple(k for k in ("time", "speed", "acceleration") if getattr(self, k) is not None)


def read_segments(data, where: Where, cycle=False) -> tuple:
    """The ``segments`` list of a segments profile (``cycle``: of a cycle profile, whose motion
    segments may carry a ``set``), each entry checked alone; Segments already read pass."""
    if isinstance(data, (list, tuple)) and data and all(isinstance(s, Segment) for s in data):
        return tuple(data)
    if not isinstance(data, (list, tuple)) or not data:
        fail(where, "expected a list of segments, e.g. [{ law = \"cycloidal\", to = \"30 deg\", time = 0.5 }, "
                    f"{{ dwell = 0.2 }}], found {show(data)}")
    out = []
    for i, item in enumerate(data):
        here = where.at(f"{where.key}[{i}]")
        if not isinstance(item, dict):
            fail(here, f"expected a table {{ law = ..., to = ..., time = ... }} or {{ dwell = SECONDS }}, found {show(item)}")
        for key in item:
            if key not in SEGMENT_KEYS:
                fail(here.at(f"{here.key}.{key}"), f"unknown key {key!r}" + (near_miss(key, SEGMENT_KEYS) or
                                                                          f"; expected one of {', '.join(SEGMENT_KEYS)}"))
        seg = Segment(here, **{k: item[k] for k in item})
        if seg.set is not None:
            if not cycle or seg.dwell is not None:
                fail(here.at(f"{here.key}.set"), "a set belongs to a motion segment of a cycle profile (kind = \"cycle\"), "
                                                 "the load of its way; a case's set gives the load of a segments profile")
            if not isinstance(seg.set, dict):
                fail(here.at(f"{here.key}.set"), f"expected a table of parameter values, e.g. {{ T0 = 0 }}, found {show(seg.set)}")
            set_field(seg, "set", {k: parse(v, here.at(f"{here.key}.set.{k}")) for k, v in seg.set.items()})
        if seg.dwell is not None:
            if len(item) != 1:
                fail(here, f"a dwell takes only its time, {{ dwell = SECONDS }}; found {', '.join(item)}")
            set_field(seg, "dwell", parse(seg.dwell, here.at(f"{here.key}.dwell")))
        else:
            if seg.law not in LAWS:
                fail(here.at(f"{here.key}.law"), f"expected one of {', '.join(map(repr, LAWS))}, found {show(seg.law)}"
                     + near_miss(seg.law, LAWS))
            if seg.to is None:
                fail(here, f"missing key 'to': the position (a sweep value) the {seg.law} segment rises or returns to")
            for key in ("to", "time", "speed", "acceleration"):
                if getattr(seg, key) is not None:
                    set_field(seg, key, parse(getattr(seg, key), here.at(f"{here.key}.{key}")))
            if seg.timing not in TIMINGS:
                fail(here, f"a {seg.law} segment takes time, or speed, or acceleration, or speed and acceleration; "
                           f"found {', '.join(seg.timing) or 'none of them'}")
        out.append(seg)
    if all(s.dwell is not None for s in out):
        fail(where, "the segments only dwell: give at least one motion law, e.g. { law = \"cycloidal\", to = ..., time = ... }")
    return tuple(out)


def _positive(seg, key, values):
    where = seg.where.at(f"{seg.where.key}.{key}")
    value = constant_value(getattr(seg, key), values, where)
    if not value > 0:
        fail(where, f"expected a {key} > 0, found {value:g}")
    if outside_meaningful(value):
        fail(where, f"expected a {key} > 0, {outside_meaningful(value)}")
    return value


def segment_ends(segments, values, start, stop) -> tuple:
    """(begin, end) of the motion of ``segments`` on the stroke [start, stop] checked alone (no
    case): it ends at the stroke's end its last position names, and begins at the other."""
    last = next(s for s in reversed(segments) if s.dwell is None)
    where = last.where.at(f"{last.where.key}.to")
    to = constant_value(last.to, values, where)
    span = 1e-12 * abs(stop - start)
    if abs(to - stop) <= span:
        return start, stop
    if abs(to - start) <= span:
        return stop, start
    fail(where, f"the last segment ends at {to:.10g}, inside the stroke from {start:.10g} to {stop:.10g}; end it at "
                "one of the stroke's ends (a case runs the whole stroke)")


def chain_of(segments, values: dict, begin: float, end: float, suffix: str = "") -> Chain:
    """The segments' :class:`~.motion_laws.Chain` on the motion from sweep value ``begin`` to
    ``end`` (their numbers evaluated with ``values``): each law's height and duration, each
    dwell's duration.  Raises SceneError naming the segment when a position does not lie
    beyond the previous one along the motion, or the last is not ``end``."""
    sigma, length = (1.0 if end > begin else -1.0), abs(end - begin)
    parts, here = [], begin
    last = max(i for i, s in enumerate(segments) if s.dwell is None)
    for i, seg in enumerate(segments):
        if seg.dwell is not None:
            parts.append(("dwell", None, here, _positive(seg, "dwell", values)))
            continue
        where = seg.where.at(f"{seg.where.key}.to")
        to = constant_value(seg.to, values, where)
        if i == last:
            if abs(to - end) > 1e-12 * length:
                fail(where, f"the last segment ends at {to:.10g}, but the motion runs from {begin:.10g} to {end:.10g}; "
                            f"end the last segment at {end:.10g} (a case runs the whole stroke; give the other way as a "
                            "case with direction reversed)" + suffix)
            to = end
        if not sigma * (end - to) >= 0:
            fail(where, f"{to:.10g} lies beyond the end of the motion, {end:.10g}: the segments' positions lie on the "
                        f"stroke from {begin:.10g} to {end:.10g}" + suffix)
        if not sigma * (to - here) > 0:
            fail(where, f"{to:.10g} does not lie beyond {here:.10g} towards {end:.10g}: the segments of one profile "
                        "run one way along the stroke, each to a position beyond the last" + suffix)
        h = abs(to - here)
        law = standard(seg.law)
        times = []
        if seg.time is not None:
            times.append(_positive(seg, "time", values))
        if seg.speed is not None:
            times.append(law.peak_speed * h / _positive(seg, "speed", values))
        if seg.acceleration is not None:
            times.append((law.peak_acceleration * h / _positive(seg, "acceleration", values)) ** 0.5)
        parts.append(("law", law, to, max(times)))
        here = to
    return Chain(parts, begin, end)
