"""The scene: one mechanism with its masses, loads, drive, stroke and design problem.

These frozen dataclasses are what a TOML scene file loads into (see :mod:`optdesign.scenefile`)
and what a script builds or changes directly.  Expressions may be given as numbers, strings or
parsed :class:`~optdesign.expressions.Expression` objects; they are parsed on construction.
:meth:`Scene.validate` checks every cross reference and names the offending item.
"""
from __future__ import annotations

import dataclasses
import difflib
import math
from dataclasses import dataclass, field

from .errors import SceneError
from .expressions import Expression, constant_value, parse


def _expr(value, where):
    if value is None or isinstance(value, Expression):
        return value
    return parse(value, where)


def _set(obj, name, value):
    object.__setattr__(obj, name, value)


def _parse_fields(obj, names, where):
    for name in names:
        value = getattr(obj, name)
        if isinstance(value, tuple):
            _set(obj, name, tuple(_expr(v, f"{where}.{name}[{i}]") for i, v in enumerate(value)))
        elif isinstance(value, list):
            _set(obj, name, tuple(_expr(v, f"{where}.{name}[{i}]") for i, v in enumerate(value)))
        else:
            _set(obj, name, _expr(value, f"{where}.{name}"))


# --- parameters and stroke -----------------------------------------------------------------
@dataclass(frozen=True)
class Parameter:
    """A named value; with ``lower``/``upper`` it is a design variable and ``value`` its start."""

    name: str
    value: Expression
    lower: float | None = None
    upper: float | None = None

    def __post_init__(self):
        _parse_fields(self, ["value"], f"[parameters] {self.name}")

    @property
    def is_design(self) -> bool:
        return self.lower is not None or self.upper is not None


@dataclass(frozen=True)
class Sweep:
    """The stroke: one position coordinate ``name`` from ``start`` to ``stop``, sampled
    ``samples`` times.  ``rate`` and ``acceleration`` (ds/dt, d2s/dt2) set the motion for a
    scene without a drive."""

    name: str
    start: Expression
    stop: Expression
    samples: int
    rate: Expression | None = None
    acceleration: Expression | None = None

    def __post_init__(self):
        _parse_fields(self, ["start", "stop", "rate", "acceleration"], "[sweep]")


# --- constructions -------------------------------------------------------------------------
@dataclass(frozen=True)
class Fixed:
    """A ground point (x, y)."""

    name: str
    x: Expression
    y: Expression

    def __post_init__(self):
        _parse_fields(self, ["x", "y"], f"[points] {self.name}")

    def uses(self):
        return ()


@dataclass(frozen=True)
class Polar:
    """``centre`` + ``length`` * (cos ``angle``, sin ``angle``): one transmission matrix."""

    name: str
    centre: str
    length: Expression
    angle: Expression

    def __post_init__(self):
        _parse_fields(self, ["length", "angle"], f"[points] {self.name}")

    def uses(self):
        return (self.centre,)


@dataclass(frozen=True)
class Dyad:
    """The RRR dyad: the point at ``length_p`` from ``p`` and ``length_q`` from ``q``, on the
    ``side`` ('left' or 'right') of the directed line p -> q."""

    name: str
    p: str
    length_p: Expression
    q: str
    length_q: Expression
    side: str

    def __post_init__(self):
        _parse_fields(self, ["length_p", "length_q"], f"[points] {self.name}")

    def uses(self):
        return (self.p, self.q)


@dataclass(frozen=True)
class Slider:
    """The RRP dyad: the point at ``length`` from ``p`` on the line through ``origin`` at
    ``angle``; ``side`` 'ahead' or 'behind' picks the solution further along or further back
    along the line's direction."""

    name: str
    p: str
    length: Expression
    origin: str
    angle: Expression
    side: str

    def __post_init__(self):
        _parse_fields(self, ["length", "angle"], f"[points] {self.name}")

    def uses(self):
        return (self.p, self.origin)


@dataclass(frozen=True)
class Attach:
    """The point with local coordinates (a, b) in the frame with origin ``origin`` and x axis
    towards ``toward`` (a body-fixed point, seed 2's transmission matrix)."""

    name: str
    origin: str
    toward: str
    a: Expression
    b: Expression

    def __post_init__(self):
        _parse_fields(self, ["a", "b"], f"[points] {self.name}")

    def uses(self):
        return (self.origin, self.toward)


@dataclass(frozen=True)
class Closure:
    """How a loop closes: its point ``point`` (one of the loop's joints) coincides with the
    ground point ``fixed`` (closed loop, 2 equations), or lies on the line through ``origin``
    at ``angle`` (semi-closed loop, 1 equation)."""

    point: str
    fixed: str | None = None
    origin: str | None = None
    angle: Expression | None = None

    def __post_init__(self):
        _parse_fields(self, ["angle"], "closure")

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

    def __post_init__(self):
        where = f"[points] {self.name}"
        _parse_fields(self, ["lengths", "angles"], where)
        _set(self, "joints", tuple(self.joints))
        _set(self, "unknowns", {k: _expr(v, f"{where}.unknowns.{k}") for k, v in self.unknowns.items()})

    def uses(self):
        refs = [self.base]
        if self.closure is not None:
            refs += [r for r in (self.closure.fixed, self.closure.origin) if r is not None]
        return tuple(refs)

    @property
    def defines(self):
        return self.joints


CONSTRUCTIONS = (Fixed, Polar, Dyad, Slider, Attach, Loop)


# --- bodies, loads, drive ------------------------------------------------------------------
@dataclass(frozen=True)
class Body:
    """A rigid body with frame origin ``frame[0]`` and x axis towards ``frame[1]``.

    ``com`` is the centre of mass in the body frame, ``inertia`` the moment of inertia about
    it; ``force`` (global components, at the centre of mass) and ``torque`` are extra loads.
    What is not given is not there (no inertia: no rotational term)."""

    name: str
    frame: tuple
    mass: Expression | None = None
    com: tuple | None = None
    inertia: Expression | None = None
    force: tuple | None = None
    torque: Expression | None = None

    def __post_init__(self):
        where = f"[[bodies]] {self.name}"
        _set(self, "frame", tuple(self.frame))
        _parse_fields(self, ["mass", "inertia", "torque"], where)
        for name in ("com", "force"):
            if getattr(self, name) is not None:
                _parse_fields(self, [name], where)


@dataclass(frozen=True)
class Gravity:
    """Uniform gravity g along -y."""

    g: Expression

    def __post_init__(self):
        _parse_fields(self, ["g"], "[gravity]")


@dataclass(frozen=True)
class Drive:
    """The driving element: ``kind`` 'rotary' (``pins`` = crank [S, A], drive coordinate the
    crank angle) or 'linear' (``pins`` = the actuator's two pins, drive coordinate their
    distance).  ``speed`` and ``acceleration`` are the drive's rate and its derivative at which
    the drive load is evaluated; ``efficiency`` is eta_m."""

    kind: str
    pins: tuple
    speed: Expression
    acceleration: Expression
    efficiency: Expression | None = None

    def __post_init__(self):
        _set(self, "pins", tuple(self.pins))
        _parse_fields(self, ["speed", "acceleration", "efficiency"], "[drive]")


@dataclass(frozen=True)
class Constraint:
    """A named ``lower <= expr <= upper``, per sample or, with an aggregate, per stroke."""

    name: str
    expr: Expression
    lower: Expression | None = None
    upper: Expression | None = None

    def __post_init__(self):
        _parse_fields(self, ["expr", "lower", "upper"], f"[[constraints]] {self.name}")


@dataclass(frozen=True)
class Objective:
    """What to minimise, e.g. ``peak(drive)``; interpreted by the design layer."""

    minimise: str


# --- the scene -----------------------------------------------------------------------------
@dataclass(frozen=True)
class Scene:
    title: str
    parameters: tuple
    sweep: Sweep
    points: tuple
    bodies: tuple = ()
    gravity: Gravity | None = None
    drive: Drive | None = None
    constraints: tuple = ()
    objective: Objective | None = None
    source: str = ""
    reference: dict = field(default_factory=dict)
    path: str = "<python>"

    def __post_init__(self):
        for name in ("parameters", "points", "bodies", "constraints"):
            _set(self, name, tuple(getattr(self, name)))
        self.validate()

    # --- lookups ---
    def parameter(self, name) -> Parameter:
        for p in self.parameters:
            if p.name == name:
                return p
        raise SceneError(_unknown(self.path, "parameter", name, [p.name for p in self.parameters]))

    def point_names(self):
        out = []
        for c in self.points:
            out += list(c.defines) if isinstance(c, Loop) else [c.name]
        return out

    def parameter_values(self) -> dict:
        """Every parameter's number, derived parameters evaluated in order."""
        values = {}
        for p in self.parameters:
            values[p.name] = constant_value(p.value, values, f"{self.path}: [parameters] {p.name}")
        return values

    def with_parameters(self, **values) -> "Scene":
        """A copy with the given parameters set to new values (numbers or expressions)."""
        names = [p.name for p in self.parameters]
        for name in values:
            if name not in names:
                raise SceneError(_unknown(self.path, "parameter", name, names))
        params = tuple(
            dataclasses.replace(p, value=parse(values[p.name], f"[parameters] {p.name}"))
            if p.name in values else p
            for p in self.parameters
        )
        return dataclasses.replace(self, parameters=params)

    # --- validation ---
    def validate(self):
        where = self.path
        seen = set()
        values = {}
        for p in self.parameters:
            if p.name in seen or p.name in ("pi", "deg"):
                raise SceneError(f"{where}: [parameters] {p.name}: the name is used twice or is reserved")
            seen.add(p.name)
            values[p.name] = constant_value(p.value, values, f"{where}: [parameters] {p.name}")
            if p.is_design:
                _check_design(where, p, values[p.name])
        sweep = self.sweep
        if sweep.name in seen or sweep.name in ("pi", "deg"):
            raise SceneError(f"{where}: [sweep] name {sweep.name!r} is already a parameter or reserved")
        if not isinstance(sweep.samples, int) or isinstance(sweep.samples, bool) or sweep.samples < 2:
            raise SceneError(f"{where}: [sweep] samples: expected a whole number >= 2, found {sweep.samples!r}")
        for key in ("start", "stop", "rate", "acceleration"):
            if getattr(sweep, key) is not None:
                constant_value(getattr(sweep, key), values, f"{where}: [sweep] {key}")
        names = set(values) | {sweep.name}
        built = []
        for c in self.points:
            self._check_construction(c, names, built)
        for b in self.bodies:
            self._check_body(b, names, built)
        if self.gravity is not None:
            _check_names(where, "[gravity] g", self.gravity.g, set(values), [])
        if self.drive is not None:
            self._check_drive(values, built)
        for c in self.constraints:
            for key in ("expr", "lower", "upper"):
                e = getattr(c, key)
                if e is not None:
                    _check_names(where, f"[[constraints]] {c.name!r} {key}", e,
                                 names if key == "expr" else set(values),
                                 built if key == "expr" else [])

    def _check_construction(self, c, names, built):
        where = f"{self.path}: [points] {c.name}"
        kind = type(c).__name__.lower()
        defined = list(c.defines) if isinstance(c, Loop) else [c.name]
        for name in defined:
            if name in built:
                raise SceneError(f"{where}: point {name!r} is constructed twice; rename one of them")
            if name in names or name in ("pi", "deg"):
                raise SceneError(f"{where}: point {name!r} has the name of a parameter or of the sweep")
        for ref in c.uses():
            if ref not in built:
                later = ref in self.point_names()
                raise SceneError(
                    f"{where}: the {kind} uses point {ref!r} before it is built"
                    + ("; move its line above this one" if later else
                       "" if not built else _suggest(ref, built))
                )
        if isinstance(c, Dyad) and c.side not in ("left", "right"):
            raise SceneError(f"{where}: side must be 'left' or 'right', found {c.side!r}")
        if isinstance(c, Slider) and c.side not in ("ahead", "behind"):
            raise SceneError(f"{where}: side must be 'ahead' or 'behind', found {c.side!r}")
        local = set(names)
        if isinstance(c, Loop):
            self._check_loop(c, where, names)
            local |= set(c.unknowns)
        for f in dataclasses.fields(c):
            value = getattr(c, f.name)
            items = value if isinstance(value, tuple) and f.name not in ("joints",) else (value,)
            for e in items:
                if isinstance(e, Expression):
                    _check_names(self.path, f"[points] {c.name}.{f.name}", e, local, built)
        built.extend(defined)

    def _check_loop(self, c, where, names):
        k = len(c.angles)
        if k == 0 or len(c.lengths) != k or len(c.joints) != k:
            raise SceneError(
                f"{where}: a loop needs as many lengths and joints as angles (one per link); "
                f"found {len(c.angles)} angles, {len(c.lengths)} lengths, {len(c.joints)} joints"
            )
        used = set().union(*(a.names() for a in c.angles))
        for u in c.unknowns:
            if u in names:
                raise SceneError(f"{where}: unknown angle {u!r} has the name of a parameter or of the sweep")
            if u not in used:
                raise SceneError(f"{where}: unknown {u!r} appears in none of the angles")
        needed = 0 if c.closure is None else c.closure.equations
        if len(c.unknowns) != needed:
            raise SceneError(
                f"{where}: the closure gives {needed} equation(s) but {len(c.unknowns)} unknown "
                "angle(s) are declared; a closed loop (fixed) needs 2, a semi-closed one (line) 1, "
                "an open chain none"
            )
        if c.closure is not None:
            cl = c.closure
            if cl.point not in c.joints:
                raise SceneError(f"{where}: closure point {cl.point!r} is not one of the loop's joints {list(c.joints)}")
            if (cl.fixed is None) == (cl.origin is None) or (cl.origin is not None and cl.angle is None):
                raise SceneError(
                    f"{where}: closure needs either fixed = POINT (closed loop) or line = [POINT, angle] "
                    "(semi-closed loop)"
                )

    def _check_body(self, b, names, built):
        where = f"{self.path}: [[bodies]] {b.name}"
        if len(b.frame) != 2:
            raise SceneError(f"{where}: frame takes two point names [origin, toward], found {list(b.frame)}")
        for ref in b.frame:
            if ref not in built:
                raise SceneError(f"{where}: frame point {ref!r} is not constructed{_suggest(ref, built)}")
        if b.mass is not None and b.com is None:
            raise SceneError(f"{where}: a body with mass needs com = [a, b] (its centre of mass in the body frame)")
        if b.force is not None and b.com is None:
            raise SceneError(f"{where}: force acts at the centre of mass: give com = [a, b]")
        for key in ("com", "force"):
            v = getattr(b, key)
            if v is not None and len(v) != 2:
                raise SceneError(f"{where}: {key} takes two components, found {len(v)}")
        if all(getattr(b, k) is None for k in ("mass", "inertia", "force", "torque")):
            raise SceneError(f"{where}: the body has no mass, inertia, force or torque; remove it or give one")
        for key in ("mass", "inertia", "torque"):
            if getattr(b, key) is not None:
                _check_names(self.path, f"[[bodies]] {b.name}.{key}", getattr(b, key), names, built)
        for key in ("com", "force"):
            for e in getattr(b, key) or ():
                _check_names(self.path, f"[[bodies]] {b.name}.{key}", e, names, built)

    def _check_drive(self, values, built):
        d = self.drive
        where = f"{self.path}: [drive]"
        if d.kind not in ("rotary", "linear"):
            raise SceneError(f"{where} type: expected 'rotary' or 'linear', found {d.kind!r}")
        key = "crank" if d.kind == "rotary" else "between"
        if len(d.pins) != 2:
            raise SceneError(f"{where} {key}: takes two point names, found {list(d.pins)}")
        for ref in d.pins:
            if ref not in built:
                raise SceneError(f"{where} {key}: point {ref!r} is not constructed{_suggest(ref, built)}")
        for name in ("speed", "acceleration", "efficiency"):
            if getattr(d, name) is not None:
                constant_value(getattr(d, name), values, f"{where} {name}")
        if d.efficiency is not None:
            eta = constant_value(d.efficiency, values, f"{where} efficiency")
            if not 0.0 < eta <= 1.0:
                raise SceneError(f"{where} efficiency: expected 0 < eta <= 1, found {eta}")
            if eta < 1.0 and constant_value(d.speed, values, f"{where} speed") == 0.0:
                raise SceneError(
                    f"{where}: efficiency {eta} < 1 needs the direction of power flow, which a zero "
                    "speed does not give; set a nonzero speed (its sign is the direction of motion)"
                )


def _check_design(where, p, value):
    lo = -math.inf if p.lower is None else p.lower
    hi = math.inf if p.upper is None else p.upper
    if p.value.names():
        raise SceneError(f"{where}: [parameters] {p.name}: a design variable needs a number as its start")
    if not lo < hi:
        raise SceneError(f"{where}: [parameters] {p.name}: min {lo} must be below max {hi}")
    if not lo <= value <= hi:
        raise SceneError(
            f"{where}: [parameters] {p.name}: the start value {value:g} lies outside its bounds "
            f"[{lo:g}, {hi:g}]; move the start inside or widen the bounds"
        )


def _check_names(path, where, expr, names, built):
    from .errors import ExpressionError

    for name in sorted(expr.names()):
        if name not in names and name not in ("pi", "deg"):
            if name in built:
                msg = f"{path}: {where}: {name!r} is a point; use x({name}), y({name}) or length(...)"
            else:
                msg = _unknown(path, "name", name, sorted(names), context=f"{where} ({expr.source!r})")
            raise ExpressionError(msg)
    for name in sorted(expr.points()):
        if name not in built:
            raise ExpressionError(
                f"{path}: {where}: point {name!r} in {expr.source!r} is not constructed before this"
                + _suggest(name, built)
            )


def _suggest(name, known):
    hint = difflib.get_close_matches(name, list(known), n=1)
    return f"; did you mean {hint[0]!r}?" if hint else ""


def _unknown(path, kind, name, known, context=""):
    where = f"{context}: " if context else ""
    hint = _suggest(name, known)
    return f"{path}: {where}unknown {kind} {name!r}" + (hint or (f"; known: {', '.join(known)}" if known else ""))
