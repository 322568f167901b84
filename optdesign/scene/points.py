"""The [points] table: the constructions that place a mechanism's points, in order.

Closed-form constructions (:class:`Fixed`, :class:`Polar`, :class:`Dyad`, :class:`Slider`,
:class:`Attach`) place one point each; a :class:`Loop` places the joints of a chain of
transmission matrices, closed by Newton's method when it has a :class:`Closure`.  Each checks
what it can check alone on construction (names, counts, a dyad's side); the references between
points are checked by :mod:`optdesign.scene.validate`.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

from .expressions import Expression
from .values import check_label, check_name, check_point, check_side, parse_required, set_field
from .where import Where, fail, near_miss, show


class _Construction:
    """Shared checks of the closed-form constructions.  ``ROLES`` lists the items of the TOML
    list ``KIND = [...]`` in order: (attribute, label, 'point' or 'expr'); ``SIDES``, for a
    construction with two solutions, the choices of its key ``side`` and what they mean."""

    KIND = ""
    ROLES: tuple = ()
    SIDES: tuple | None = None

    def __post_init__(self):
        check_name(self.name, Where("points", str(self.name)), "point")
        for attr, label, kind in self.ROLES:
            where = Where("points", self.name, f"{self.KIND} {label}")
            value = getattr(self, attr)
            set_field(self, attr, check_point(value, where) if kind == "point" else parse_required(value, where))
        if self.SIDES is not None:
            check_side(self.side, Where("points", self.name, "side"), *self.SIDES)

    def uses(self):
        """The points this construction needs, in order."""
        return tuple(getattr(self, a) for a, _, kind in self.ROLES if kind == "point")

    @property
    def defines(self):
        return (self.name,)

    @classmethod
    def form(cls) -> str:
        """The TOML list this construction takes, e.g. '[centre, length, angle]'."""
        return "[" + ", ".join(label for _, label, _ in cls.ROLES) + "]"


@dataclass(frozen=True)
class Fixed(_Construction):
    """A ground point (x, y)."""

    name: str
    x: Expression
    y: Expression
    KIND = "fixed"
    ROLES = (("x", "x", "expr"), ("y", "y", "expr"))


@dataclass(frozen=True)
class Polar(_Construction):
    """``centre`` + ``length`` * (cos ``angle``, sin ``angle``): one transmission matrix."""

    name: str
    centre: str
    length: Expression
    angle: Expression
    KIND = "polar"
    ROLES = (("centre", "centre", "point"), ("length", "length", "expr"), ("angle", "angle", "expr"))


@dataclass(frozen=True)
class Dyad(_Construction):
    """The RRR dyad: the point at ``length_p`` from ``p`` and ``length_q`` from ``q``, on the
    ``side`` ('left' or 'right') of the directed line p -> q."""

    name: str
    p: str
    length_p: Expression
    q: str
    length_q: Expression
    side: str
    KIND = "dyad"
    ROLES = (("p", "P", "point"), ("length_p", "length from P", "expr"), ("q", "Q", "point"),
             ("length_q", "length from Q", "expr"))
    SIDES = (("left", "right"), "of the directed line P -> Q")


@dataclass(frozen=True)
class Slider(_Construction):
    """The RRP dyad: the point at ``length`` from ``p`` on the line through ``origin`` at
    ``angle``; ``side`` 'ahead' or 'behind' picks the solution further along or further back
    along the line's direction."""

    name: str
    p: str
    length: Expression
    origin: str
    angle: Expression
    side: str
    KIND = "slider"
    ROLES = (("p", "P", "point"), ("length", "length", "expr"), ("origin", "line origin", "point"),
             ("angle", "line angle", "expr"))
    SIDES = (("ahead", "behind"), "further along or further back along the line's direction")


@dataclass(frozen=True)
class Attach(_Construction):
    """The point with local coordinates (a, b) in the frame with origin ``origin`` and x axis
    towards ``toward`` (a body-fixed point, seed 2's transmission matrix)."""

    name: str
    origin: str
    toward: str
    a: Expression
    b: Expression
    KIND = "attach"
    ROLES = (("origin", "origin", "point"), ("toward", "toward", "point"), ("a", "a", "expr"),
             ("b", "b", "expr"))


@dataclass(frozen=True)
class Closure:
    """How a loop closes: its joint ``point`` coincides with the point ``fixed`` (closed loop,
    2 equations), or lies on the line through ``origin`` at ``angle`` (semi-closed loop, 1
    equation; TOML ``line = [origin, angle]``).  The loop that holds it parses ``angle``."""

    point: str
    fixed: str | None = None
    origin: str | None = None
    angle: Expression | None = None

    @property
    def equations(self) -> int:
        return 2 if self.fixed is not None else 1


@dataclass(frozen=True)
class Loop:
    """Seed 2's chain of transmission matrices T_1 ... T_k, starting at joint ``base``.

    Link i turns by the relative angle ``angles[i]`` from link i-1 (link 1 from the global x
    axis) and joint A_{i+1} = A_i + ``lengths[i]`` along it; ``joints`` names A_2 ... A_{k+1}.
    Angles named in ``unknowns`` (name -> initial guess) are solved by Newton from the
    ``closure``; without a closure the chain is open.
    """

    name: str
    base: str
    lengths: tuple
    angles: tuple
    joints: tuple
    unknowns: dict = field(default_factory=dict)
    closure: Closure | None = None
    KIND = "loop"

    def __post_init__(self):
        where = Where("points", str(self.name))
        check_label(self.name, where, "loop")
        set_field(self, "base", check_point(self.base, where.at("loop")))
        for key in ("lengths", "angles", "joints"):
            value = getattr(self, key)
            if not isinstance(value, (list, tuple)) or not value:
                fail(where.at(key), f"expected a list with one entry per link, found {show(value)}")
        k = len(self.angles)
        if len(self.lengths) != k or len(self.joints) != k:
            fail(where, f"a loop needs as many lengths and joints as angles (one of each per link); "
                        f"found {k} angles, {len(self.lengths)} lengths, {len(self.joints)} joints")
        set_field(self, "lengths", tuple(parse_required(v, where.at(f"lengths[{i}]")) for i, v in enumerate(self.lengths)))
        set_field(self, "angles", tuple(parse_required(v, where.at(f"angles[{i}]")) for i, v in enumerate(self.angles)))
        set_field(self, "joints", tuple(check_name(v, where.at(f"joints[{i}]"), "point") for i, v in enumerate(self.joints)))
        if not isinstance(self.unknowns, dict):
            fail(where.at("unknowns"), f"expected a table name = initial guess, found {show(self.unknowns)}")
        set_field(self, "unknowns", {check_name(u, where.at("unknowns"), "unknown angle"): parse_required(v, where.at(f"unknowns.{u}"))
                                          for u, v in self.unknowns.items()})
        self._check_closure(where.at("closure"))

    def _check_closure(self, where):
        cl = self.closure
        if cl is None:
            return
        if not isinstance(cl, Closure):
            fail(where, f"expected a Closure, found {show(cl)}")
        if cl.point not in self.joints:
            fail(where, f"the closure point {cl.point!r} is not one of the loop's joints "
                        f"{list(self.joints)}" + near_miss(cl.point, self.joints))
        if (cl.fixed is None) == (cl.origin is None):
            fail(where, "expected either fixed = POINT (closed loop) or line = [POINT, angle] "
                        "(semi-closed loop), not " + ("both" if cl.fixed is not None else "neither"))
        check_point(cl.fixed if cl.fixed is not None else cl.origin, where)
        if cl.origin is not None:
            set_field(self, "closure", dataclasses.replace(cl, angle=parse_required(cl.angle, where.at("closure line angle"))))

    def uses(self):
        refs = [self.base]
        if self.closure is not None:
            refs += [r for r in (self.closure.fixed, self.closure.origin) if r is not None]
        return tuple(refs)

    @property
    def defines(self):
        return self.joints


CONSTRUCTIONS = (Fixed, Polar, Dyad, Slider, Attach, Loop)
