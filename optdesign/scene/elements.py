"""The items of a scene besides its points: parameters, stroke, bodies, gravity, drive,
simulation, constraints and objective.

These frozen dataclasses (with those of :mod:`optdesign.scene.points`) are what a TOML scene
file loads into (see :mod:`optdesign.scene.file` and ``docs/scenes.md``) and what a script
builds or changes directly.  Expressions may be given as numbers, strings or parsed
:class:`~optdesign.scene.expressions.Expression` objects; they are parsed on construction,
where each object also checks what it can check alone (types, counts, a body with mass but no
centre of mass).  :class:`~optdesign.scene.scene.Scene` then checks every cross reference
(:mod:`optdesign.scene.validate`).

Errors are :class:`~optdesign.errors.SceneError` (or its subclass
:class:`~optdesign.errors.ExpressionError` for expressions).  Each names its place as a
:class:`~optdesign.scene.where.Where` (table, item, key, spelled as in the TOML file) in its
``where`` attribute, so that the file reader can add the line number.
"""
from __future__ import annotations

from dataclasses import dataclass

from .expressions import Expression
from .values import (check_label, check_name, check_point, parse_bound, parse_optional, parse_required,
                     parse_vector, set_field)
from .where import Where, fail, near_miss, show


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
        check_name(self.name, where, "parameter")
        set_field(self, "value", parse_required(self.value, where.at("value") if self.is_design else where))
        set_field(self, "lower", parse_bound(self.lower, where.at("min")))
        set_field(self, "upper", parse_bound(self.upper, where.at("max")))

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
            fail(where.at("name"), "missing key 'name': expected the sweep variable's name, e.g. \"alpha\"")
        check_name(self.name, where.at("name"), "sweep variable")
        set_field(self, "start", parse_required(self.start, where.at("from"), "the start of the stroke"))
        set_field(self, "stop", parse_required(self.stop, where.at("to"), "the end of the stroke"))
        n = self.samples
        if n is None:
            fail(where.at("samples"), "missing key 'samples': expected the number of samples, a whole number >= 2")
        if isinstance(n, bool) or not isinstance(n, int) or n < 2:
            fail(where.at("samples"), f"expected a whole number >= 2, found {show(n)}")
        set_field(self, "rate", parse_optional(self.rate, where.at("rate")))
        set_field(self, "acceleration", parse_optional(self.acceleration, where.at("acceleration")))


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
        check_label(self.name, where, "body")
        frame = self.frame
        if frame is None:
            fail(where.at("frame"), "missing key 'frame': expected [origin, toward], two point names")
        if not isinstance(frame, (list, tuple)) or len(frame) != 2:
            fail(where.at("frame"), f"expected [origin, toward], two point names, found {show(frame)}")
        set_field(self, "frame", tuple(check_point(p, where.at("frame")) for p in frame))
        for key in ("mass", "inertia", "torque"):
            set_field(self, key, parse_optional(getattr(self, key), where.at(key)))
        for key, what in (("com", "[a, b] in the body frame"), ("force", "[Fx, Fy] in global components")):
            if getattr(self, key) is not None:
                set_field(self, key, parse_vector(getattr(self, key), where.at(key), 2, what))
        if self.mass is not None and self.com is None:
            fail(where.at("com"), "a body with mass needs its centre of mass: missing key 'com', "
                                  "expected com = [a, b] in the body frame (a body without mass, e.g. a "
                                  "flywheel given by its inertia alone: leave out 'mass', not mass = 0)")
        if self.force is not None and self.com is None:
            fail(where.at("com"), "the force acts at the centre of mass: missing key 'com', "
                                  "expected com = [a, b] in the body frame")
        if all(getattr(self, k) is None for k in ("mass", "inertia", "force", "torque")):
            fail(where, "the body has no mass, inertia, force or torque; give one or remove the body")


@dataclass(frozen=True)
class Gravity:
    """Uniform gravity g along -y."""

    g: Expression

    def __post_init__(self):
        set_field(self, "g", parse_required(self.g, Where("gravity", key="g"), "the acceleration of gravity, e.g. 9.81"))


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
            fail(where.at("type"), "missing key 'type': expected 'rotary' or 'linear'")
        if self.kind not in DRIVE_PINS:
            fail(where.at("type"), f"expected 'rotary' or 'linear', found {show(self.kind)}"
                                   + near_miss(self.kind, DRIVE_PINS))
        key = DRIVE_PINS[self.kind]
        what = "[S, A], the crank's pivot and pin" if self.kind == "rotary" else "[P, Q], the actuator's two pins"
        pins = self.pins
        if pins is None:
            fail(where.at(key), f"missing key {key!r}: expected {what}")
        if not isinstance(pins, (list, tuple)) or len(pins) != 2:
            fail(where.at(key), f"expected {what}, found {show(pins)}")
        set_field(self, "pins", tuple(check_point(p, where.at(key)) for p in pins))
        unit = ("rad/s", "rad/s^2") if self.kind == "rotary" else ("m/s", "m/s^2")
        set_field(self, "speed", parse_required(self.speed, where.at("speed"), f"the drive speed in {unit[0]}"))
        set_field(self, "acceleration", parse_required(self.acceleration, where.at("acceleration"),
                                                       f"the drive acceleration in {unit[1]}"))
        set_field(self, "efficiency", parse_optional(self.efficiency, where.at("efficiency")))
        # for `optdesign simulate`: the drive torque or force as a law of (q, qd), and the
        # drive's own inertia (rotor, kg m^2; or moving piston and rod, kg)
        set_field(self, "law", parse_optional(self.law, where.at("law")))
        set_field(self, "inertia", parse_optional(self.inertia, where.at("inertia")))


LAW_NAMES = ("q", "qd")  # the names a drive law may use besides parameters
INTEGRATORS = ("bdf", "adams", "rk4")


@dataclass(frozen=True)
class Simulation:
    """The initial state and span of a motion in time (``optdesign simulate``): the sweep value
    ``start`` and the drive speed ``speed`` (omega_S [rad/s] or v_S [m/s]) at t = 0, the end
    time ``t_end`` [s], the number of output ``samples`` over [0, t_end], the ``integrator``
    ('bdf' implicit, 'adams' non-stiff, 'rk4' explicit fixed-step) and its relative
    ``tolerance``.  The run also stops where the sweep reaches an end of the stroke.  With
    ``phases`` the run is a sequence of phases, each with its own drive law and end, driven by
    ``motor`` (:mod:`optdesign.scene.simulation`)."""

    start: Expression
    speed: Expression
    t_end: Expression
    samples: int = 201
    integrator: str = "bdf"
    tolerance: Expression | None = None
    phases: tuple = ()          # a duty cycle in time (:mod:`optdesign.scene.simulation`); () : one [drive] law
    motor: str | None = None    # the [[motors]] entry that drives the phases (needed with a catalogue)

    def __post_init__(self):
        where = Where("simulation")
        set_field(self, "start", parse_required(self.start, where.at("start"),
                                                "the sweep value at t = 0 (inside the stroke [sweep] from .. to)"))
        set_field(self, "speed", parse_required(self.speed, where.at("speed"),
                                                "the drive speed at t = 0 (omega_S in rad/s or v_S in m/s)"))
        set_field(self, "t_end", parse_required(self.t_end, where.at("t_end"), "the end time in s (> 0)"))
        n = self.samples
        if isinstance(n, bool) or not isinstance(n, int) or n < 2:
            fail(where.at("samples"), f"expected a whole number >= 2 (output samples over 0 .. t_end), "
                                      f"found {show(n)}")
        if self.integrator not in INTEGRATORS:
            fail(where.at("integrator"), f"expected one of {', '.join(map(repr, INTEGRATORS))} ('bdf': "
                                         "implicit, for stiff cases; 'adams': non-stiff; 'rk4': explicit, "
                                         f"fixed step), found {show(self.integrator)}"
                 + near_miss(self.integrator, INTEGRATORS))
        set_field(self, "tolerance", parse_optional(self.tolerance, where.at("tolerance")))


@dataclass(frozen=True)
class Constraint:
    """A named ``lower <= expr <= upper`` (TOML ``min``/``max``), per sample or, with an
    aggregate (one-argument min/max), per stroke.  In a scene with [[cases]] a per-sample
    constraint may use a case's columns (``drive``, ``motor_torque``, ...: see
    :data:`optdesign.scene.cases.CASE_COLUMNS`) and hold in every case or in ``case`` alone."""

    name: str
    expr: Expression
    lower: Expression | None = None
    upper: Expression | None = None
    case: str | None = None   # with [[cases]]: the one case it holds in (absent: every case)

    def __post_init__(self):
        where = Where("constraints", str(self.name))
        check_label(self.name, where, "constraint")
        if self.case is not None:
            check_label(self.case, where.at("case"), "case")
        set_field(self, "expr", parse_required(self.expr, where.at("expr"), "the constrained quantity, e.g. \"angle(D, B, A)\""))
        set_field(self, "lower", parse_optional(self.lower, where.at("min")))
        set_field(self, "upper", parse_optional(self.upper, where.at("max")))
        if self.lower is None and self.upper is None:
            fail(where, "expected min, max or both; found neither")


@dataclass(frozen=True)
class Objective:
    """What to minimise, e.g. ``peak(drive)``; interpreted by the design layer."""

    minimise: str

    def __post_init__(self):
        where = Where("objective", key="minimise")
        if not isinstance(self.minimise, str) or not self.minimise.strip():
            fail(where, f"expected a string such as \"peak(drive)\", found {show(self.minimise)}")
