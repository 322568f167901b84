"""Force elements ([[forces]]): springs, gas springs, dampers and constant forces between two
points, and torsion springs between two bodies (or a body and the ground).

Each element is one ``kind`` with its own numbers (expressions of the parameters, so that a
design variable may set a spring's rate, preload or, through its points, its anchors):

- ``spring``: a linear spring between ``between = [P, Q]``; tension = ``preload`` + ``rate`` *
  (length - ``length``), or with ``free_length`` in place of ``length`` and ``preload``: rate *
  (length - free_length).  Positive tension pulls P and Q together; a compression spring has a
  negative tension where it is shorter than its free length.
- ``gas_spring``: a gas strut pushing P and Q apart; push = ``extended_force`` at
  ``extended_length``, rising linearly to ``progression`` * extended_force at
  ``compressed_length``; or, with ``table = [[compression, push], ...]`` (compression = extended
  length - length, ascending), the push interpolated linearly between the table's rows.
- ``damper``: tension = ``rate`` * d(length)/dt (a viscous damper resisting the motion).
- ``constant``: tension = ``tension`` (negative: a constant push).
- ``torsion``: a torsion spring between ``bodies = [A, B]`` (one body: between the ground and
  it); torque = ``preload`` + ``rate`` * (theta - ``angle``), theta the angle of B's frame
  relative to A's (wrapped to within half a turn of ``angle``), or ``free_angle`` in place of
  ``angle`` and ``preload``.  The torque turns B back towards ``angle`` (and A the other way).

The loads enter the reduced model by virtual work (:mod:`optdesign.model.forces`).  Each item
checks what it can alone; :func:`check_forces` checks it against the scene.
"""
from __future__ import annotations

from dataclasses import dataclass

from .expressions import Expression
from .values import check_label, check_point, parse_optional, set_field
from .where import Where, fail, near_miss, show

# kind -> (required keys, optional keys) besides name and kind; the numbers are expressions
KINDS = {
    "spring": (("between", "rate"), ("free_length", "length", "preload")),
    "gas_spring": (("between", "extended_length"), ("extended_force", "compressed_length", "progression", "table")),
    "damper": (("between", "rate"), ()),
    "constant": (("between", "tension"), ()),
    "torsion": (("bodies", "rate"), ("free_angle", "angle", "preload")),
}
FORCE_KEYS = ("name", "kind", "between", "bodies", "rate", "free_length", "length", "preload", "extended_length",
              "extended_force", "compressed_length", "progression", "table", "tension", "free_angle", "angle")
NUMBERS = ("rate", "free_length", "length", "preload", "extended_length", "extended_force", "compressed_length",
           "progression", "tension", "free_angle", "angle")


@dataclass(frozen=True)
class ForceElement:
    """One [[forces]] entry: ``kind`` (see the module's doc), ``between`` (two point names) or
    ``bodies`` (one or two body names), ``numbers`` (key -> Expression) and ``table``
    (((compression, push), ...) for a gas spring given by its force-stroke table)."""

    name: str
    kind: str
    between: tuple | None = None
    bodies: tuple | None = None
    numbers: dict | None = None
    table: tuple | None = None

    def __post_init__(self):
        where = Where("forces", str(self.name))
        check_label(self.name, where, "force element")
        if self.kind not in KINDS:
            fail(where.at("kind"), f"expected one of {', '.join(map(repr, KINDS))}, found {show(self.kind)}"
                 + near_miss(self.kind, KINDS))
        required, optional = KINDS[self.kind]
        numbers = dict(self.numbers or {})
        given = set(numbers) | {k for k in ("between", "bodies", "table") if getattr(self, k) is not None}
        for key in sorted(given - set(required) - set(optional)):
            fail(where.at(key), f"a {self.kind} has no key {key!r}; its keys: "
                                f"{', '.join(required + optional)}" + near_miss(key, required + optional))
        for key in required:
            if key not in given:
                fail(where.at(key), f"missing key {key!r}: a {self.kind} needs {', '.join(required)}")
        set_field(self, "numbers", {k: parse_optional(v, where.at(k)) for k, v in numbers.items()})
        if self.between is not None:
            if not isinstance(self.between, (list, tuple)) or len(self.between) != 2:
                fail(where.at("between"), f"expected [P, Q], two point names, found {show(self.between)}")
            set_field(self, "between", tuple(check_point(p, where.at("between")) for p in self.between))
            if self.between[0] == self.between[1]:
                fail(where.at("between"), f"[{self.between[0]!r}, {self.between[1]!r}] names one point twice: "
                                          "expected two distinct points")
        if self.bodies is not None:
            bodies = [self.bodies] if isinstance(self.bodies, str) else self.bodies
            if not isinstance(bodies, (list, tuple)) or not 1 <= len(bodies) <= 2:
                fail(where.at("bodies"), f"expected [A, B] (two bodies) or [B] (the ground and B), found {show(self.bodies)}")
            for b in bodies:
                check_label(b, where.at("bodies"), "body")
            set_field(self, "bodies", tuple(bodies))
        self._check_alternatives(where)

    def _check_alternatives(self, where):
        n = self.numbers
        if self.kind in ("spring", "torsion"):
            free, ref = ("free_length", "length") if self.kind == "spring" else ("free_angle", "angle")
            if (free in n) == (ref in n):
                fail(where.at(free), f"expected either {free} (where the {self._what()} is 0) or {ref} with preload "
                                     f"(the {self._what()} there), found {'both' if free in n else 'neither'}")
            if free in n and "preload" in n:
                fail(where.at("preload"), f"preload is the {self._what()} at {ref}; with {free} the {self._what()} "
                                          f"there is 0: give {ref} = ... and preload = ..., or {free} alone")
        if self.kind == "gas_spring":
            linear = [k for k in ("extended_force", "compressed_length", "progression") if k in n]
            if self.table is None and len(linear) != 3:
                missing = [k for k in ("extended_force", "compressed_length", "progression") if k not in n]
                fail(where.at(missing[0]), f"missing key {missing[0]!r}: a gas spring needs extended_force, "
                                           "compressed_length and progression (or a table = [[compression, push], ...])")
            if self.table is not None:
                if linear:
                    fail(where.at("table"), f"a table gives the push over the whole stroke: leave out {', '.join(linear)}")
                set_field(self, "table", _table(self.table, where.at("table")))

    def _what(self):
        return "tension" if self.kind == "spring" else "torque"

    def number(self, key) -> Expression | None:
        return self.numbers.get(key)


def _table(table, where):
    """((compression, push), ...): at least two rows of two numbers, compression ascending."""
    rows = []
    if not isinstance(table, (list, tuple)) or len(table) < 2:
        fail(where, f"expected at least two rows [[compression, push], ...], found {show(table)}")
    for row in table:
        if (not isinstance(row, (list, tuple)) or len(row) != 2
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in row)):
            fail(where, f"expected rows of two numbers [compression (m), push (N)], found {show(row)}")
        rows.append((float(row[0]), float(row[1])))
    if any(b[0] <= a[0] for a, b in zip(rows, rows[1:])):
        fail(where, "the compressions must ascend (the first column: extended length - length, in m)")
    return tuple(rows)


def read_force(item: dict) -> ForceElement:
    """A [[forces]] table (keys checked by the file reader) as a :class:`ForceElement`."""
    numbers = {k: item[k] for k in NUMBERS if k in item}
    return ForceElement(item.get("name"), item.get("kind"), item.get("between"), item.get("bodies"), numbers,
                        item.get("table"))


def check_forces(scene, values, check_expression, fail_at):
    """The force elements against the scene: unique names, their points and bodies exist,
    their numbers are expressions of the parameters (``check_expression(where, expr, names,
    built)`` and ``fail_at(where, detail)`` are the validator's)."""
    seen = set()
    points = scene.point_names()
    bodies = [b.name for b in scene.bodies]
    for f in scene.forces:
        where = Where("forces", f.name)
        if not isinstance(f, ForceElement):
            fail_at(where, f"expected a ForceElement, found {show(f)}")
        if f.name in seen:
            fail_at(where, f"the force element name {f.name!r} is used twice; rename one of them")
        seen.add(f.name)
        for p in f.between or ():
            if p not in points:
                fail_at(where.at("between"), f"no point {p!r} is constructed" + near_miss(p, points))
        for b in f.bodies or ():
            if b not in bodies:
                fail_at(where.at("bodies"), f"no body {b!r} in [[bodies]]" + (near_miss(b, bodies) or
                                            f"; the bodies: {', '.join(bodies) or 'none'}"))
        if f.bodies is not None and len(f.bodies) == 2 and f.bodies[0] == f.bodies[1]:
            fail_at(where.at("bodies"), f"{list(f.bodies)} names one body twice: a torsion spring acts between "
                                        "two bodies, or between the ground and one body ([B])")
        for key, expr in f.numbers.items():
            check_expression(where.at(key), expr, set(values), [])
