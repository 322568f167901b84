"""The [profiles] table: motions along the stroke, from rest to rest, that load cases run on.

A profile moves the sweep coordinate s over the whole stroke (from one end to the other; the
case says which way) in time.  Its numbers are rates of the sweep coordinate: speed in sweep
units per second (rad/s for an angle sweep, m/s for a length), acceleration per second squared,
jerk per second cubed.  Kinds and their keys:

==============  ===========================================================================
``constant``    ``speed``: a steady motion at one sweep rate (no start-up, no stop)
``trapezoidal`` ``speed``, ``acceleration``, ``deceleration`` (the top speed must be reached
                within the stroke); or ``time``, ``acceleration``, ``deceleration`` (the
                top speed follows from the time for the stroke)
``s-curve``     ``speed``, ``acceleration``, ``deceleration``, ``jerk``: jerk-limited (seven
                phases; the accelerations are lowered to sqrt(speed*jerk) when the speed
                is reached before them)
``law``         ``speed``: the sweep rate as an expression of the sweep variable and
                parameters, > 0 inside the stroke (it may be 0 at its ends)
==============  ===========================================================================

and the motion laws in time (:mod:`optdesign.scene.motion_laws`): ``cycloidal``, ``harmonic``,
``modified-sine``, ``modified-trapezoid``, ``polynomial-345``, ``polynomial-4567``, each from
rest to rest over the stroke in ``time`` [s], or in the shortest time within a peak ``speed``,
a peak ``acceleration`` or both (the time follows: T = C_v h / speed, T = sqrt(C_a h /
acceleration)); and ``polynomial``: the quintic over ``time`` with ``start_speed``,
``end_speed``, ``start_acceleration``, ``end_acceleration`` (sweep rates; absent: 0).
``segments``: laws in time between intermediate positions, with dwells (:mod:`.segments`);
``cycle``: the same both ways, a whole machine cycle (:mod:`.cycles`).

This module holds the item (:class:`Profile`) and the numbers of its phases
(:func:`profile_shape`, used by the validation and by :mod:`optdesign.model.profiles`, which
turns them into CasADi graphs of s).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from .expressions import Expression, constant_value
from .motion_laws import GENERAL, LAWS, MotionLaw, general, standard
from .segments import chain_of, read_segments
from .values import check_name, outside_meaningful, parse_optional, set_field
from .where import Where, fail, near_miss, show

KINDS = {
    "constant": (("speed",),),
    "trapezoidal": (("speed", "acceleration", "deceleration"), ("time", "acceleration", "deceleration")),
    "s-curve": (("speed", "acceleration", "deceleration", "jerk"),),
    "law": (("speed",),),
    **{law: (("time",), ("speed",), ("acceleration",), ("speed", "acceleration")) for law in LAWS},
}
ENDS = ("start_speed", "end_speed", "start_acceleration", "end_acceleration")
KINDS[GENERAL] = tuple(("time",) + tuple(e for i, e in enumerate(ENDS) if mask >> i & 1) for mask in range(16))
KEYS = ("kind", "speed", "acceleration", "deceleration", "jerk", "time") + ENDS
SEGMENTS = "segments"   # a motion of segments (:mod:`.segments`): its one key is the list, ``segments``
CYCLE = "cycle"         # a whole machine cycle (:mod:`.cycles`): the same key
KINDS[SEGMENTS] = KINDS[CYCLE] = ((),)


@dataclass(frozen=True)
class Profile:
    """A motion along the stroke (see the module's table of kinds and keys)."""

    name: str
    kind: str
    speed: Expression | None = None
    acceleration: Expression | None = None
    deceleration: Expression | None = None
    jerk: Expression | None = None
    time: Expression | None = None
    start_speed: Expression | None = None
    end_speed: Expression | None = None
    start_acceleration: Expression | None = None
    end_acceleration: Expression | None = None
    segments: tuple | None = None    # kind = "segments": its :class:`~.segments.Segment` list
    place: Where | None = field(default=None, compare=False)   # an inline profile: where its case has it

    def __post_init__(self):
        where = self.where()
        if self.place is None:
            check_name(self.name, where, "profile")
        if self.kind is None:
            fail(self.where("kind"), f"missing key 'kind': expected one of {', '.join(map(repr, KINDS))}")
        if self.kind not in KINDS:
            fail(self.where("kind"), f"expected one of {', '.join(map(repr, KINDS))}, found {show(self.kind)}"
                 + near_miss(self.kind, KINDS))
        for key in KEYS[1:]:
            set_field(self, key, parse_optional(getattr(self, key), self.where(key)))
        given = tuple(k for k in KEYS[1:] if getattr(self, k) is not None)
        if (self.kind in (SEGMENTS, CYCLE)) != (self.segments is not None):
            fail(self.where(SEGMENTS), f"a {self.kind!r} profile takes segments = [...] (and no other key)" if self.segments
                 is None else f"segments = [...] belong to a profile of kind = \"segments\" or \"cycle\", not {self.kind!r}")
        if self.segments is not None:
            set_field(self, "segments", read_segments(self.segments, self.where(SEGMENTS), self.kind == CYCLE))
        forms = KINDS[self.kind]
        if not any(set(given) == set(form) for form in forms):
            wanted = " or ".join(", ".join(form) for form in forms) if self.kind != GENERAL else \
                f"time, and any of {', '.join(ENDS)}"
            fail(where, f"a {self.kind!r} profile takes {wanted}; found {', '.join(given) or 'nothing'}")

    def where(self, key=None) -> Where:
        """The place of the profile (or of its ``key``) as the file spells it: [profiles] NAME,
        or [[cases]] 'CASE', profile.KEY for a profile written inline in a case."""
        if self.place is None:
            return Where("profiles", str(self.name), key)
        return self.place if key is None else self.place.at(f"{self.place.key}.{key}")

    @property
    def keys(self) -> tuple:
        return tuple(k for k in KEYS[1:] if getattr(self, k) is not None)


@dataclass(frozen=True)
class Phase:
    """The acceleration (or, mirrored, the deceleration) phase of a profile from rest to its
    top speed: ``duration`` [s], ``distance`` [sweep units], the rate ``peak`` it reaches
    (acceleration for an s-curve: at most the given one), and the jerk (0: a trapezoid)."""

    duration: float
    distance: float
    peak: float
    jerk: float


@dataclass(frozen=True)
class Shape:
    """The numbers of a profile on a stroke of ``length`` sweep units: top ``speed``, the
    acceleration and deceleration phases, the cruise between them and the total ``time``.
    A law has none of these (``law`` is its speed expression)."""

    kind: str
    length: float
    speed: float = math.nan
    accelerate: Phase | None = None
    decelerate: Phase | None = None
    time: float = math.nan
    law: Expression | None = None
    motion_law: MotionLaw | None = None   # a motion law in time: its normalised f(tau)

    @property
    def cruise(self) -> float:
        """The distance run at the top speed."""
        return self.length - self.accelerate.distance - self.decelerate.distance


def _number(profile, key, values):
    value = constant_value(getattr(profile, key), values, profile.where(key))
    if not value > 0:
        fail(profile.where(key), f"expected a {key} > 0, found {value:g}")
    if outside_meaningful(value):
        fail(profile.where(key), f"expected a {key} > 0, {outside_meaningful(value)}")
    return value


JERK_RESOLUTION = 1e-6   # an s-curve's jerk phase at least this fraction of its acceleration phase


def _phase(speed, rate, jerk=0.0) -> Phase:
    if jerk == 0.0:
        return Phase(speed / rate, speed**2 / (2 * rate), rate, 0.0)
    peak = min(rate, math.sqrt(speed * jerk))      # the rate reached before the speed is
    duration = peak / jerk + speed / peak          # 2 t_j + t_c with t_j = peak/j, t_c = v/peak - peak/j
    return Phase(duration, 0.5 * speed * duration, peak, jerk)   # point-symmetric: mean speed v/2


def profile_shape(profile: Profile, values: dict, length: float, suffix: str = "", ends=None) -> Shape:
    """The numbers of ``profile`` (its expressions evaluated with ``values``) on a stroke of
    ``length`` > 0 sweep units; raises SceneError naming the profile when its top speed cannot
    be reached in the stroke (or the stroke cannot be run in its time).  ``suffix`` is added
    to such a message (e.g. which case's values were used).  A segments profile needs the
    motion's ``ends`` (begin, end) as sweep values."""
    if profile.kind == SEGMENTS:
        begin, end = ends
        chain = chain_of(profile.segments, values, begin, end, suffix)
        return Shape(SEGMENTS, length, chain.peak_speed * length / chain.time, time=chain.time, motion_law=chain)
    if profile.kind == "law":
        return Shape("law", length, law=profile.speed)
    if profile.kind in LAWS or profile.kind == GENERAL:
        return _law_shape(profile, values, length, suffix)
    if profile.kind == "constant":
        v = _number(profile, "speed", values)
        zero = Phase(0.0, 0.0, 0.0, 0.0)
        return Shape("constant", length, v, zero, zero, length / v)
    a = _number(profile, "acceleration", values)
    d = _number(profile, "deceleration", values)
    j = _number(profile, "jerk", values) if profile.kind == "s-curve" else 0.0
    if profile.time is not None:
        T = _number(profile, "time", values)
        c = 1 / (2 * a) + 1 / (2 * d)          # L = v T - c v^2
        shortest = 2 * math.sqrt(c * length)
        if T < shortest:
            fail(profile.where("time"), f"the stroke of {length:.6g} cannot be run in {T:g} s at acceleration {a:g} "
                                   f"and deceleration {d:g}: it takes at least {shortest:.6g} s; give a longer "
                                   "time or larger accelerations" + suffix)
        v = 2 * length / (T + math.sqrt(max(T * T - 4 * c * length, 0.0)))
    else:
        v = _number(profile, "speed", values)
    up, down = _phase(v, a, j), _phase(v, d, j)
    if j and min(ph.peak / j / ph.duration for ph in (up, down)) < JERK_RESOLUTION:
        ph = min((up, down), key=lambda ph: ph.peak / j / ph.duration)
        fail(profile.where("jerk"), f"the jerk {j:g} makes its jerk phases {ph.peak / j:.3g} s long, less than "
                                    f"{JERK_RESOLUTION:g} of the {ph.duration:.3g} s it takes to reach the top speed: "
                                    "too short for the time law's samples; use kind = \"trapezoidal\" (an unlimited jerk) or a "
                                    "smaller jerk" + suffix)
    if up.distance + down.distance > length * (1 + 1e-12):
        reach = _reachable(length, a, d, j)
        fail(profile.where("speed"), f"the top speed {v:g} cannot be reached in the stroke of {length:.6g}: "
                                f"speeding up and slowing down take {up.distance + down.distance:.6g}; the "
                                f"largest top speed this stroke allows is {reach:.6g}; lower the speed or "
                                "raise the accelerations" + suffix)
    cruise = max(length - up.distance - down.distance, 0.0)
    return Shape(profile.kind, length, v, up, down, up.duration + cruise / v + down.duration)


def _law_shape(profile, values, length, suffix) -> Shape:
    """A motion law in time over the stroke: its duration (given, or the shortest within the
    peak speed and acceleration given), its peak speed, and the normalised law."""
    if profile.kind == GENERAL:
        T = _number(profile, "time", values)
        ends = [0.0 if getattr(profile, k) is None else constant_value(getattr(profile, k), values, profile.where(k))
                for k in ENDS]
        v0, v1, a0, a1 = ends[0] * T / length, ends[1] * T / length, ends[2] * T**2 / length, ends[3] * T**2 / length
        law = general(v0, v1, a0, a1)
        if law.min_speed < 0:
            tau = law.min_speed_at
            x = float(law.evaluate([tau])[0][0]) * length
            fail(profile.where("time"), f"this polynomial reverses: its speed is {law.min_speed * length / T:.6g} at "
                                        f"t = {tau * T:.6g} s ({x:.6g} along the stroke of {length:.6g}); a profile "
                                        "moves one way: give end speeds and accelerations that keep it moving "
                                        "forward, or a longer or shorter time" + suffix)
        return Shape(GENERAL, length, law.peak_speed * length / T, time=T, motion_law=law)
    law = standard(profile.kind)
    times = []
    if profile.time is not None:
        times.append(_number(profile, "time", values))
    if profile.speed is not None:
        times.append(law.peak_speed * length / _number(profile, "speed", values))
    if profile.acceleration is not None:
        times.append(math.sqrt(law.peak_acceleration * length / _number(profile, "acceleration", values)))
    T = max(times)
    return Shape(profile.kind, length, law.peak_speed * length / T, time=T, motion_law=law)


def _reachable(length, a, d, j):
    """The largest top speed whose phases fit in ``length`` (bisection: distance grows with v)."""
    lo, hi = 0.0, 1.0
    while _phase(hi, a, j).distance + _phase(hi, d, j).distance < length:
        hi *= 2
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if _phase(mid, a, j).distance + _phase(mid, d, j).distance <= length:
            lo = mid
        else:
            hi = mid
    return lo
