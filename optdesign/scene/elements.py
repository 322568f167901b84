"""The scene: one mechanism with its masses, loads, drive, stroke and design problem.

These frozen dataclasses are what a TOML scene file loads into (see :mod:`optdesign.scene.file`
and ``docs/scenes.md``) and what a script builds or changes directly.  Expressions may be given
as numbers, strings or parsed :class:`~optdesign.scene.expressions.Expression` objects; they are
parsed on construction, where each object also checks what it can check alone (types, counts,
a dyad's side, a body with mass but no centre of mass).  :meth:`Scene.validate` then checks
every cross reference (names, points built before use, bounds) in the order of the file.

Errors are :class:`~optdesign.errors.SceneError` (or its subclass
:class:`~optdesign.errors.ExpressionError` for expressions).  Each names its place as a
:class:`Where` (table, item, key, spelled as in the TOML file) in its ``where`` attribute, so
that the file reader can add the line number.
"""
from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import dataclass, field

from ..errors import ExpressionError, SceneError
from .expressions import (CONSTANTS, Expression, constant_value, located_error, near_miss,
                          parse)

ARRAY_TABLES = ("bodies", "constraints")
RESERVED = tuple(CONSTANTS)
_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z_0-9]*\Z")


@dataclass(frozen=True)
class Where:
    """The place of an item in a scene, spelled as in the TOML file: ``table`` ('sweep',
    'points', 'bodies', ...; '' for the top level), ``item`` (a parameter, point, body or
    constraint name), ``key`` (e.g. 'samples', 'mass', 'polar angle', 'lengths[1]') and, for an
    array of tables whose item has no usable name, its ``index``."""

    table: str
    item: str | None = None
    key: str | None = None
    index: int | None = None

    def __str__(self):
        if not self.table:
            return self.key or "top level"
        array = self.table in ARRAY_TABLES
        text = f"[[{self.table}]]" if array else f"[{self.table}]"
        if self.item is not None:
            text += f" {self.item!r}" if array else f" {self.item}"
        elif self.index is not None:
            text += f" #{self.index + 1}"
        if self.key:
            text += f", {self.key}" if (self.item is not None or self.index is not None) else f" {self.key}"
        return text

    def at(self, key) -> "Where":
        return dataclasses.replace(self, key=key)


def _fail(where, detail, cls=SceneError, path=None):
    raise located_error(cls, where, detail, path)


def _show(value):
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value)


# --- checking single values ----------------------------------------------------------------
def _set(obj, name, value):
    object.__setattr__(obj, name, value)


def _expr(value, where, expectation="a number or an expression"):
    """A required expression (parsed)."""
    if value is None:
        _fail(where, f"missing key {where.key.split()[0]!r}: expected {expectation}")
    return parse(value, where)


def _optional_expr(value, where):
    return None if value is None else parse(value, where)


def _vector(value, where, n, expectation):
    """A list of ``n`` expressions, parsed; ``where.key`` names it."""
    if not isinstance(value, (list, tuple)) or len(value) != n:
        _fail(where, f"expected {expectation} (a list of {n} numbers or expressions), found {_show(value)}")
    return tuple(parse(v, where.at(f"{where.key}[{i}]")) for i, v in enumerate(value))


def _name(value, where, what):
    """A name that expressions can refer to (letters, digits, _; not a constant)."""
    if not isinstance(value, str) or not _IDENTIFIER.match(value):
        _fail(where, f"expected a {what} name (letters, digits and _, not starting with a digit), "
                     f"found {_show(value)}")
    if value in RESERVED:
        _fail(where, f"{value!r} is reserved for a constant (pi, deg); choose another {what} name")
    return value


def _label(value, where, what):
    """A free-text name (bodies, constraints): a non-empty string."""
    if not isinstance(value, str) or not value.strip():
        _fail(where, f"expected the {what}'s name as a non-empty string, found {_show(value)}")
    return value


def _point_ref(value, where):
    if not isinstance(value, str):
        _fail(where, f"expected a point name (a string such as \"A\"), found {_show(value)}")
    return value


def _bound(value, where):
    """A design bound: a number, or an expression of numbers, pi and deg."""
    if value is None:
        return None
    return constant_value(parse(value, where), {}, where)


# --- parameters and stroke -----------------------------------------------------------------
@dataclass(frozen=True)
class Parameter:
    """A named value; with ``lower``/``upper`` (TOML ``min``/``max``) it is a design variable
    and ``value`` its start."""

    name: str
    value: Expression
    lower: float | None = None
    upper: float | None = None

    def __post_init__(self):
        where = Where("parameters", str(self.name))
        _name(self.name, where, "parameter")
        _set(self, "value", _expr(self.value, where.at("value") if self.is_design else where))
        _set(self, "lower", _bound(self.lower, where.at("min")))
        _set(self, "upper", _bound(self.upper, where.at("max")))

    @property
    def is_design(self) -> bool:
        return self.lower is not None or self.upper is not None


@dataclass(frozen=True)
class Sweep:
    """The stroke: one position coordinate ``name`` from ``start`` to ``stop`` (TOML ``from``,
    ``to``), sampled ``samples`` times.  ``rate`` and ``acceleration`` (ds/dt, d2s/dt2) set the
    motion for a scene without a drive."""

    name: str
    start: Expression
    stop: Expression
    samples: int
    rate: Expression | None = None
    acceleration: Expression | None = None

    def __post_init__(self):
        where = Where("sweep")
        if self.name is None:
            _fail(where.at("name"), "missing key 'name': expected the sweep variable's name, e.g. \"alpha\"")
        _name(self.name, where.at("name"), "sweep variable")
        _set(self, "start", _expr(self.start, where.at("from"), "the start of the stroke"))
        _set(self, "stop", _expr(self.stop, where.at("to"), "the end of the stroke"))
        n = self.samples
        if n is None:
            _fail(where.at("samples"), "missing key 'samples': expected the number of samples, a whole number >= 2")
        if isinstance(n, bool) or not isinstance(n, int) or n < 2:
            _fail(where.at("samples"), f"expected a whole number >= 2, found {_show(n)}")
        _set(self, "rate", _optional_expr(self.rate, where.at("rate")))
        _set(self, "acceleration", _optional_expr(self.acceleration, where.at("acceleration")))


# --- constructions -------------------------------------------------------------------------
class _Construction:
    """Shared checks of the closed-form constructions.  ``ROLES`` lists the items of the TOML
    list ``KIND = [...]`` in order: (attribute, label, 'point' or 'expr')."""

    KIND = ""
    ROLES: tuple = ()

    def __post_init__(self):
        _name(self.name, Where("points", str(self.name)), "point")
        for attr, label, kind in self.ROLES:
            where = Where("points", self.name, f"{self.KIND} {label}")
            value = getattr(self, attr)
            _set(self, attr, _point_ref(value, where) if kind == "point" else _expr(value, where))

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


def _side(value, where, choices, meaning):
    if value is None:
        _fail(where, f"missing key 'side': expected {' or '.join(map(repr, choices))} ({meaning})")
    if value not in choices:
        _fail(where, f"expected {' or '.join(map(repr, choices))} ({meaning}), found {_show(value)}"
                     + near_miss(value, choices))
    return value


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

    def __post_init__(self):
        super().__post_init__()
        _side(self.side, Where("points", self.name, "side"), ("left", "right"), "of the directed line P -> Q")


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

    def __post_init__(self):
        super().__post_init__()
        _side(self.side, Where("points", self.name, "side"), ("ahead", "behind"),
              "further along or further back along the line's direction")


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
        _label(self.name, where, "loop")
        _set(self, "base", _point_ref(self.base, where.at("loop")))
        for key in ("lengths", "angles", "joints"):
            value = getattr(self, key)
            if not isinstance(value, (list, tuple)) or not value:
                _fail(where.at(key), f"expected a list with one entry per link, found {_show(value)}")
        k = len(self.angles)
        if len(self.lengths) != k or len(self.joints) != k:
            _fail(where, f"a loop needs as many lengths and joints as angles (one of each per link); "
                         f"found {k} angles, {len(self.lengths)} lengths, {len(self.joints)} joints")
        _set(self, "lengths", tuple(_expr(v, where.at(f"lengths[{i}]")) for i, v in enumerate(self.lengths)))
        _set(self, "angles", tuple(_expr(v, where.at(f"angles[{i}]")) for i, v in enumerate(self.angles)))
        _set(self, "joints", tuple(_name(v, where.at(f"joints[{i}]"), "point") for i, v in enumerate(self.joints)))
        if not isinstance(self.unknowns, dict):
            _fail(where.at("unknowns"), f"expected a table name = initial guess, found {_show(self.unknowns)}")
        _set(self, "unknowns", {_name(u, where.at("unknowns"), "unknown angle"): _expr(v, where.at(f"unknowns.{u}"))
                                for u, v in self.unknowns.items()})
        self._check_closure(where.at("closure"))

    def _check_closure(self, where):
        cl = self.closure
        if cl is None:
            return
        if not isinstance(cl, Closure):
            _fail(where, f"expected a Closure, found {_show(cl)}")
        if cl.point not in self.joints:
            _fail(where, f"the closure point {cl.point!r} is not one of the loop's joints "
                         f"{list(self.joints)}" + near_miss(cl.point, self.joints))
        if (cl.fixed is None) == (cl.origin is None):
            _fail(where, "expected either fixed = POINT (closed loop) or line = [POINT, angle] "
                         "(semi-closed loop), not " + ("both" if cl.fixed is not None else "neither"))
        _point_ref(cl.fixed if cl.fixed is not None else cl.origin, where)
        if cl.origin is not None:
            _set(self, "closure", dataclasses.replace(cl, angle=_expr(cl.angle, where.at("closure line angle"))))

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
    it; ``force`` (global components, at the centre of mass) and ``torque`` are applied loads
    (positive work when the body moves along them).  What is not given is not there (no
    inertia: no rotational term)."""

    name: str
    frame: tuple
    mass: Expression | None = None
    com: tuple | None = None
    inertia: Expression | None = None
    force: tuple | None = None
    torque: Expression | None = None

    def __post_init__(self):
        where = Where("bodies", str(self.name))
        _label(self.name, where, "body")
        frame = self.frame
        if frame is None:
            _fail(where.at("frame"), "missing key 'frame': expected [origin, toward], two point names")
        if not isinstance(frame, (list, tuple)) or len(frame) != 2:
            _fail(where.at("frame"), f"expected [origin, toward], two point names, found {_show(frame)}")
        _set(self, "frame", tuple(_point_ref(p, where.at("frame")) for p in frame))
        for key in ("mass", "inertia", "torque"):
            _set(self, key, _optional_expr(getattr(self, key), where.at(key)))
        for key, what in (("com", "[a, b] in the body frame"), ("force", "[Fx, Fy] in global components")):
            if getattr(self, key) is not None:
                _set(self, key, _vector(getattr(self, key), where.at(key), 2, what))
        if self.mass is not None and self.com is None:
            _fail(where.at("com"), "a body with mass needs its centre of mass: missing key 'com', "
                                   "expected com = [a, b] in the body frame")
        if self.force is not None and self.com is None:
            _fail(where.at("com"), "the force acts at the centre of mass: missing key 'com', "
                                   "expected com = [a, b] in the body frame")
        if all(getattr(self, k) is None for k in ("mass", "inertia", "force", "torque")):
            _fail(where, "the body has no mass, inertia, force or torque; give one or remove the body")


@dataclass(frozen=True)
class Gravity:
    """Uniform gravity g along -y."""

    g: Expression

    def __post_init__(self):
        _set(self, "g", _expr(self.g, Where("gravity", key="g"), "the acceleration of gravity, e.g. 9.81"))


DRIVE_PINS = {"rotary": "crank", "linear": "between"}


@dataclass(frozen=True)
class Drive:
    """The driving element: ``kind`` 'rotary' (``pins`` = crank [S, A], drive coordinate the
    crank angle) or 'linear' (``pins`` = the actuator's two pins, drive coordinate their
    distance).  ``speed`` and ``acceleration`` are the drive's rate and its derivative at which
    the drive load is evaluated; ``efficiency`` is eta_m (absent: 1).  For a simulation in
    time (``optdesign simulate``) ``law`` gives the drive torque or force T_S (F_S) as an
    expression of the drive coordinate ``q``, its rate ``qd`` and parameters, and ``inertia``
    the drive's own inertia (rotor [kg m^2] or moving piston mass [kg]; absent: 0)."""

    kind: str
    pins: tuple
    speed: Expression
    acceleration: Expression
    efficiency: Expression | None = None
    law: Expression | None = None
    inertia: Expression | None = None

    def __post_init__(self):
        where = Where("drive")
        if self.kind is None:
            _fail(where.at("type"), "missing key 'type': expected 'rotary' or 'linear'")
        if self.kind not in DRIVE_PINS:
            _fail(where.at("type"), f"expected 'rotary' or 'linear', found {_show(self.kind)}"
                                    + near_miss(self.kind, DRIVE_PINS))
        key = DRIVE_PINS[self.kind]
        what = "[S, A], the crank's pivot and pin" if self.kind == "rotary" else "[P, Q], the actuator's two pins"
        pins = self.pins
        if pins is None:
            _fail(where.at(key), f"missing key {key!r}: expected {what}")
        if not isinstance(pins, (list, tuple)) or len(pins) != 2:
            _fail(where.at(key), f"expected {what}, found {_show(pins)}")
        _set(self, "pins", tuple(_point_ref(p, where.at(key)) for p in pins))
        unit = ("rad/s", "rad/s^2") if self.kind == "rotary" else ("m/s", "m/s^2")
        _set(self, "speed", _expr(self.speed, where.at("speed"), f"the drive speed in {unit[0]}"))
        _set(self, "acceleration", _expr(self.acceleration, where.at("acceleration"),
                                         f"the drive acceleration in {unit[1]}"))
        _set(self, "efficiency", _optional_expr(self.efficiency, where.at("efficiency")))
        # for `optdesign simulate`: the drive torque or force as a law of (q, qd), and the
        # drive's own inertia (rotor, kg m^2; or moving piston and rod, kg)
        _set(self, "law", _optional_expr(self.law, where.at("law")))
        _set(self, "inertia", _optional_expr(self.inertia, where.at("inertia")))


LAW_NAMES = ("q", "qd")  # the names a drive law may use besides parameters
INTEGRATORS = ("bdf", "adams", "rk4")


@dataclass(frozen=True)
class Simulation:
    """The initial state and span of a motion in time (``optdesign simulate``): the sweep value
    ``start`` and the drive speed ``speed`` (omega_S [rad/s] or v_S [m/s]) at t = 0, the end
    time ``t_end`` [s], the number of output ``samples`` over [0, t_end], the ``integrator``
    ('bdf' implicit, 'adams' non-stiff, 'rk4' explicit fixed-step) and its relative
    ``tolerance``.  The run also stops where the sweep reaches an end of the stroke."""

    start: Expression
    speed: Expression
    t_end: Expression
    samples: int = 201
    integrator: str = "bdf"
    tolerance: Expression | None = None

    def __post_init__(self):
        where = Where("simulation")
        _set(self, "start", _expr(self.start, where.at("start"),
                                  "the sweep value at t = 0 (inside the stroke [sweep] from .. to)"))
        _set(self, "speed", _expr(self.speed, where.at("speed"),
                                  "the drive speed at t = 0 (omega_S in rad/s or v_S in m/s)"))
        _set(self, "t_end", _expr(self.t_end, where.at("t_end"), "the end time in s (> 0)"))
        n = self.samples
        if isinstance(n, bool) or not isinstance(n, int) or n < 2:
            _fail(where.at("samples"), f"expected a whole number >= 2 (output samples over 0 .. t_end), "
                                       f"found {_show(n)}")
        if self.integrator not in INTEGRATORS:
            _fail(where.at("integrator"), f"expected one of {', '.join(map(repr, INTEGRATORS))} ('bdf': "
                                          "implicit, for stiff cases; 'adams': non-stiff; 'rk4': explicit, "
                                          f"fixed step), found {_show(self.integrator)}"
                  + near_miss(self.integrator, INTEGRATORS))
        _set(self, "tolerance", _optional_expr(self.tolerance, where.at("tolerance")))


@dataclass(frozen=True)
class Constraint:
    """A named ``lower <= expr <= upper`` (TOML ``min``/``max``), per sample or, with an
    aggregate (one-argument min/max), per stroke."""

    name: str
    expr: Expression
    lower: Expression | None = None
    upper: Expression | None = None

    def __post_init__(self):
        where = Where("constraints", str(self.name))
        _label(self.name, where, "constraint")
        _set(self, "expr", _expr(self.expr, where.at("expr"), "the constrained quantity, e.g. \"angle(D, B, A)\""))
        _set(self, "lower", _optional_expr(self.lower, where.at("min")))
        _set(self, "upper", _optional_expr(self.upper, where.at("max")))
        if self.lower is None and self.upper is None:
            _fail(where, "expected min, max or both; found neither")


@dataclass(frozen=True)
class Objective:
    """What to minimise, e.g. ``peak(drive)``; interpreted by the design layer."""

    minimise: str

    def __post_init__(self):
        where = Where("objective", key="minimise")
        if not isinstance(self.minimise, str) or not self.minimise.strip():
            _fail(where, f"expected a string such as \"peak(drive)\", found {_show(self.minimise)}")


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
    simulation: Simulation | None = None

    def __post_init__(self):
        for name in ("parameters", "points", "bodies", "constraints"):
            _set(self, name, tuple(getattr(self, name)))
        self.validate()

    # --- lookups ---
    def parameter(self, name) -> Parameter:
        for p in self.parameters:
            if p.name == name:
                return p
        names = [p.name for p in self.parameters]
        _fail(Where("parameters", str(name)), f"unknown parameter {name!r}" + near_miss(name, names),
              path=self.path)

    def point_names(self):
        out = []
        for c in self.points:
            out += list(c.defines)
        return out

    def parameter_values(self) -> dict:
        """Every parameter's number, derived parameters evaluated in order."""
        values = {}
        for p in self.parameters:
            values[p.name] = constant_value(p.value, values, f"{self.path}: [parameters] {p.name}")
        return values

    def with_parameters(self, **values) -> "Scene":
        """A copy with the given parameters set to new values (numbers or expressions).
        An unknown name is an error that suggests the near miss."""
        names = [p.name for p in self.parameters]
        for name in values:
            if name not in names:
                what = (f"{name!r} is the sweep variable, not a parameter (the stroke is set in [sweep])"
                        if name == self.sweep.name else f"the scene has no parameter {name!r}")
                _fail(None, f"cannot set parameter {name!r}: {what}" + near_miss(name, names)
                      + f" (its parameters: {', '.join(names) or 'none'})", path=self.path)
        try:
            params = tuple(dataclasses.replace(p, value=values[p.name]) if p.name in values else p
                           for p in self.parameters)
            return dataclasses.replace(self, parameters=params)
        except SceneError as exc:
            where = getattr(exc, "where", None)
            if not (isinstance(where, Where) and where.table == "parameters" and where.item in values):
                raise
            raise located_error(type(exc), where, f"{exc.detail} (a value set by an override such as "
                                                  f"--set {where.item}=...)", self.path) from None

    # --- validation ---
    def validate(self):
        """Check every cross reference, in the order of the file; raise SceneError on the first
        problem, naming its place."""
        if not isinstance(self.title, str):
            self._fail(Where("", key="title"), f"expected a string, found {_show(self.title)}")
        if not isinstance(self.source, str):
            self._fail(Where("", key="source"), f"expected a string, found {_show(self.source)}")
        if not isinstance(self.reference, dict):
            self._fail(Where("reference"), f"expected a table of free data, found {_show(self.reference)}")
        self._check_types()
        values = self._check_parameters()
        names = set(values) | {self.sweep.name}
        built = self._check_points(names)
        self._check_bodies(names, built)
        if self.gravity is not None:
            self._check_expression(Where("gravity", key="g"), self.gravity.g, set(values), [])
        if self.drive is not None:
            self._check_drive(values, built)
        self._check_constraints(values, names, built)
        if self.simulation is not None:
            self._check_simulation(values)

    def _fail(self, where, detail, cls=SceneError):
        _fail(where, detail, cls, self.path)

    def _check_types(self):
        for table, items, kinds in (("parameters", self.parameters, (Parameter,)),
                                    ("points", self.points, CONSTRUCTIONS),
                                    ("bodies", self.bodies, (Body,)),
                                    ("constraints", self.constraints, (Constraint,))):
            for i, item in enumerate(items):
                if not isinstance(item, kinds):
                    self._fail(Where(table, index=i), f"expected {' or '.join(k.__name__ for k in kinds)}, "
                                                      f"found {_show(item)}")
        for attr, kind in (("sweep", Sweep), ("gravity", Gravity), ("drive", Drive), ("objective", Objective),
                           ("simulation", Simulation)):
            value = getattr(self, attr)
            if not isinstance(value, kind) and not (value is None and attr != "sweep"):
                self._fail(Where(attr), f"expected a {kind.__name__}, found {_show(value)}")

    def _check_parameters(self):
        values = {}
        all_names = [p.name for p in self.parameters]
        for p in self.parameters:
            where = Where("parameters", p.name)
            if p.name in values:
                self._fail(where, f"the parameter name {p.name!r} is used twice; rename one of them")
            if p.name == self.sweep.name:
                self._fail(where, f"{p.name!r} is also the sweep variable's name; rename one of them")
            later = all_names[all_names.index(p.name) + 1:]
            self._check_expression(where, p.value, set(values), [], later=later)
            values[p.name] = constant_value(p.value, values, where)
            if p.is_design:
                self._check_design(p, values[p.name])
        sweep = self.sweep
        for key, attr in (("from", "start"), ("to", "stop"), ("rate", "rate"), ("acceleration", "acceleration")):
            expr = getattr(sweep, attr)
            if expr is not None:
                self._check_expression(Where("sweep", key=key), expr, set(values), [])
                constant_value(expr, values, Where("sweep", key=key))
        if constant_value(sweep.start, values, "") == constant_value(sweep.stop, values, ""):
            self._fail(Where("sweep", key="to"), "the stroke is empty: from and to are equal; "
                                                 "expected two different values")
        return values

    def _check_design(self, p, value):
        where = Where("parameters", p.name)
        lo = -math.inf if p.lower is None else p.lower
        hi = math.inf if p.upper is None else p.upper
        if p.value.names():
            self._fail(where.at("value"), f"a design variable's start must be a number, found {p.value.source!r} "
                                          "(which depends on other parameters)")
        if not lo < hi:
            self._fail(where.at("min"), f"min {lo:g} must be below max {hi:g}")
        if not lo <= value <= hi:
            self._fail(where.at("value"), f"the start value {value:g} lies outside its bounds "
                                          f"[{lo:g}, {hi:g}]; move the start inside or widen the bounds")

    def _check_points(self, names):
        if not self.points:
            self._fail(Where("points"), "no points: expected at least one construction, e.g. A = { fixed = [0, 0] }")
        built, first = [], {}
        for c in self.points:
            where = Where("points", c.name)
            for name in c.defines:
                if name in first:
                    self._fail(where, f"point {name!r} is constructed twice (also at [points] {first[name]}); "
                                      "rename one of them")
                if name in names:
                    self._fail(where, f"point {name!r} has the name of a parameter or of the sweep; rename one")
            for ref, key in zip(c.uses(), self._use_keys(c)):
                if ref not in built:
                    self._missing_point(where.at(key), ref, built, SceneError)
            local = set(names)
            if isinstance(c, Loop):
                self._check_loop(c, where, names, built)
                local |= set(c.unknowns)
            for key, expr in self._expressions_of(c):
                self._check_expression(where.at(key), expr, local, built)
            for name in c.defines:
                first[name] = c.name
            built.extend(c.defines)
        return built

    @staticmethod
    def _use_keys(c):
        if isinstance(c, Loop):
            return ["loop"] + ["closure"] * (len(c.uses()) - 1)
        return [f"{c.KIND} {label}" for _, label, kind in c.ROLES if kind == "point"]

    @staticmethod
    def _expressions_of(c):
        if isinstance(c, Loop):
            out = [(f"lengths[{i}]", e) for i, e in enumerate(c.lengths)]
            out += [(f"angles[{i}]", e) for i, e in enumerate(c.angles)]
            if c.closure is not None and c.closure.angle is not None:
                out.append(("closure line angle", c.closure.angle))
            return out
        return [(f"{c.KIND} {label}", getattr(c, attr)) for attr, label, kind in c.ROLES if kind == "expr"]

    def _check_loop(self, c, where, names, built):
        used = set().union(*(a.names() for a in c.angles))
        for u, guess in c.unknowns.items():
            if u in names:
                self._fail(where.at("unknowns"), f"unknown angle {u!r} has the name of a parameter or of the sweep")
            if u not in used:
                self._fail(where.at("unknowns"), f"the unknown {u!r} appears in none of the angles "
                                                 f"{[a.source for a in c.angles]}" + near_miss(u, used - names))
            self._check_expression(where.at(f"unknowns.{u}"), guess, names, built)
        needed = 0 if c.closure is None else c.closure.equations
        if len(c.unknowns) != needed:
            kind = ("no closure (an open chain)" if c.closure is None else
                    "a closed loop (closure fixed = POINT)" if needed == 2 else
                    "a semi-closed loop (closure line = [POINT, angle])")
            self._fail(where.at("unknowns"),
                       f"found {len(c.unknowns)} unknown angle(s) {sorted(c.unknowns)}, but {kind} gives "
                       f"{needed} equation(s): expected {needed} unknown(s) (a closed loop needs 2, a "
                       "semi-closed one 1, an open chain none)")

    def _check_bodies(self, names, built):
        seen = set()
        for b in self.bodies:
            where = Where("bodies", b.name)
            if b.name in seen:
                self._fail(where, f"the body name {b.name!r} is used twice; rename one of them")
            seen.add(b.name)
            for ref in b.frame:
                if ref not in built:
                    self._missing_point(where.at("frame"), ref, built, SceneError)
            for key in ("mass", "inertia", "torque"):
                if getattr(b, key) is not None:
                    self._check_expression(where.at(key), getattr(b, key), names, built)
            for key in ("com", "force"):
                for i, e in enumerate(getattr(b, key) or ()):
                    self._check_expression(where.at(f"{key}[{i}]"), e, names, built)

    def _check_drive(self, values, built):
        d = self.drive
        where = Where("drive")
        key = DRIVE_PINS[d.kind]
        for ref in d.pins:
            if ref not in built:
                self._missing_point(where.at(key), ref, built, SceneError)
        for name in ("speed", "acceleration", "efficiency"):
            if getattr(d, name) is not None:
                self._check_expression(where.at(name), getattr(d, name), set(values), [])
                constant_value(getattr(d, name), values, where.at(name))
        if d.efficiency is not None:
            eta = constant_value(d.efficiency, values, where.at("efficiency"))
            if not 0.0 < eta <= 1.0:
                self._fail(where.at("efficiency"), f"expected 0 < eta <= 1, found {eta:g}")
            if eta < 1.0 and constant_value(d.speed, values, where.at("speed")) == 0.0:
                self._fail(where.at("speed"), f"efficiency {eta:g} < 1 needs the direction of power flow, "
                                              "which a zero speed does not give; set a nonzero speed (its "
                                              "sign is the direction of motion)")
        for key in ("rate", "acceleration"):
            if getattr(self.sweep, key) is not None:
                self._fail(Where("sweep", key=key), f"the scene has a [drive], whose speed and acceleration "
                                                    f"set the motion; remove {key} from [sweep]")
        self._check_drive_law(values)

    def _check_drive_law(self, values):
        """The simulation keys of [drive]: ``law`` uses parameters, q and qd; ``inertia`` is a
        number >= 0 of parameters."""
        d, where = self.drive, Where("drive")
        if d.law is not None:
            for name in LAW_NAMES:
                if name in values or name == self.sweep.name:
                    what = "parameter" if name in values else "sweep variable"
                    self._fail(where.at("law"), f"the {what} {name!r} has the name the law uses for the drive "
                                                f"coordinate (q) or its rate (qd); rename the {what}")
            self._check_expression(where.at("law"), d.law, set(values) | set(LAW_NAMES), [])
        if d.inertia is not None:
            self._check_expression(where.at("inertia"), d.inertia, set(values), [])
            value = constant_value(d.inertia, values, where.at("inertia"))
            if value < 0:
                unit = "kg m^2, the rotor's moment of inertia" if d.kind == "rotary" else "kg, the moving mass"
                self._fail(where.at("inertia"), f"expected a drive inertia >= 0 ({unit}), found {value:g}")

    def _check_simulation(self, values):
        """[simulation]: needs a [drive] with a law; start inside the stroke, t_end > 0,
        tolerance in (0, 0.1]."""
        sim, where = self.simulation, Where("simulation")
        if self.drive is None or self.drive.law is None:
            self._fail(where, "a simulation needs the drive's law: add law = \"...\" to [drive] (a torque "
                              "or force in q, qd and parameters, e.g. \"T0*(1 - qd/omega0)\")")
        numbers = {}
        for key in ("start", "speed", "t_end", "tolerance"):
            expr = getattr(sim, key)
            if expr is not None:
                self._check_expression(where.at(key), expr, set(values), [])
                numbers[key] = constant_value(expr, values, where.at(key))
        lo, hi = sorted((constant_value(self.sweep.start, values, ""), constant_value(self.sweep.stop, values, "")))
        if not lo <= numbers["start"] <= hi:
            self._fail(where.at("start"), f"the start {numbers['start']:g} lies outside the stroke "
                                          f"[{lo:g}, {hi:g}] of [sweep] {self.sweep.name}; start inside it")
        if not numbers["t_end"] > 0:
            self._fail(where.at("t_end"), f"expected an end time > 0 s, found {numbers['t_end']:g}")
        if "tolerance" in numbers and not 0 < numbers["tolerance"] <= 0.1:
            self._fail(where.at("tolerance"), f"expected a relative tolerance in (0, 0.1], e.g. 1e-8, "
                                              f"found {numbers['tolerance']:g}")

    def _check_constraints(self, values, names, built):
        seen = set()
        for c in self.constraints:
            where = Where("constraints", c.name)
            if c.name in seen:
                self._fail(where, f"the constraint name {c.name!r} is used twice; rename one of them")
            seen.add(c.name)
            self._check_expression(where.at("expr"), c.expr, names, built, aggregate=True)
            if c.expr.is_aggregate:
                varying_names, varying_points = c.expr.outside_aggregates()
                varying = sorted(varying_names & {self.sweep.name}) + sorted(varying_points)
                if varying:
                    self._fail(where.at("expr"),
                               f"{c.expr.source!r} mixes one value per stroke (min/max with one argument) "
                               f"with values per sample ({', '.join(map(repr, varying))} outside min/max); "
                               "expected every sweep-dependent part inside min(...) or max(...)",
                               ExpressionError)
            bounds = []
            for key, attr in (("min", "lower"), ("max", "upper")):
                e = getattr(c, attr)
                if e is not None:
                    self._check_expression(where.at(key), e, set(values), [])
                    bounds.append(constant_value(e, values, where.at(key)))
            if len(bounds) == 2 and bounds[0] > bounds[1]:
                self._fail(where, f"min {bounds[0]:g} is above max {bounds[1]:g}; nothing can satisfy it")

    # --- names in expressions ---
    def _check_expression(self, where, expr, names, built, aggregate=False, later=()):
        """Every name and point of ``expr`` must be known here; aggregates only where allowed."""
        if expr.is_aggregate and not aggregate:
            self._fail(where, f"{expr.source!r}: min() or max() with one argument is the extreme over "
                              "the whole stroke, which only a [[constraints]] expr may use; for the "
                              "smaller or larger of two values give two arguments, e.g. max(a, b)",
                       ExpressionError)
        for name in sorted(expr.names()):
            if name not in names:
                self._unknown_name(where, expr, name, names, built, later)
        for point in sorted(expr.points()):
            if point not in built:
                self._missing_point(where, point, built, ExpressionError, expr)

    def _unknown_name(self, where, expr, name, names, built, later):
        src = expr.source
        if name in built or name in self.point_names():
            detail = (f"{name!r} is a point, not a number; use x({name}), y({name}), "
                      f"length({name}, Q) or angle(P, {name}, Q)")
        elif name == self.sweep.name:
            detail = (f"the sweep variable {name!r} cannot be used here: expected a value that is the "
                      "same over the whole stroke (numbers, parameters, pi, deg)")
        elif name in later:
            detail = (f"{name!r} is defined further down; a parameter may use only the parameters "
                      "above it: move its line")
        elif where.table == "parameters" and name == where.item:
            detail = f"the parameter {name!r} refers to itself; expected a number or earlier parameters"
        else:
            known = sorted(names) + list(RESERVED)
            detail = f"unknown name {name!r}" + (near_miss(name, known) or f"; expected one of: {', '.join(known)}")
        self._fail(where, f"{src!r}: {detail}", ExpressionError)

    def _missing_point(self, where, ref, built, cls, expr=None):
        src = f"{expr.source!r}: " if expr is not None else ""
        if ref in self.point_names():
            detail = (f"point {ref!r} is used before it is built (it is constructed further down in "
                      "[points]); move its line above this one")
        else:
            detail = f"no point {ref!r} is constructed" + (
                near_miss(ref, self.point_names()) or
                (f"; points built so far: {', '.join(built)}" if built else "; no point is built before this"))
        self._fail(where, src + detail, cls)
