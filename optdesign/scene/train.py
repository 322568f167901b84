"""The drive train of a scene: [gearbox] and [[motors]] behind a rotary drive, [cylinder] for a
linear one.

- :class:`Gearbox`: the ratio i = motor speed / drive speed (> 0; it may be a design variable)
  and its efficiency (power-flow switched like the drive's: divides while the motor drives,
  multiplies while power flows back).
- :class:`Motor`: one motor (one [[motors]] entry) or, with several, a catalogue: rotor
  inertia, rated (continuous, thermal) torque, peak torque, maximum speed.
- :class:`Cylinder`: a hydraulic cylinder sized from the system pressure and the peak forces,
  with the Euler buckling of its rod at full extension.

Each checks what it can alone; :mod:`optdesign.scene.validate_cases` checks them against the
scene (a rotary drive for a gearbox, a linear one for a cylinder, positive values).
"""
from __future__ import annotations

from dataclasses import dataclass

from .expressions import Expression
from .values import check_label, parse_optional, parse_required, set_field
from .where import Where

GEARBOX_KEYS = ("ratio", "efficiency")
MOTOR_KEYS = ("name", "inertia", "rated_torque", "peak_torque", "max_speed")
CYLINDER_KEYS = ("pressure", "modulus", "buckling_safety", "length_factor", "rod", "bore")


@dataclass(frozen=True)
class Gearbox:
    """Between a rotary drive and its motor: motor speed = ``ratio`` * drive speed."""

    ratio: Expression
    efficiency: Expression | None = None

    def __post_init__(self):
        where = Where("gearbox")
        set_field(self, "ratio", parse_required(self.ratio, where.at("ratio"),
                                                "the gear ratio i = motor speed / drive speed (> 0)"))
        set_field(self, "efficiency", parse_optional(self.efficiency, where.at("efficiency")))


MOTOR_UNITS = {"inertia": "kg m^2, the rotor's moment of inertia", "rated_torque": "N m, continuous (thermal)",
               "peak_torque": "N m", "max_speed": "rad/s"}


@dataclass(frozen=True)
class Motor:
    """A motor: rotor ``inertia`` [kg m^2], ``rated_torque`` (continuous, compared with the
    time RMS of the motor torque) and ``peak_torque`` [N m], ``max_speed`` [rad/s]."""

    name: str
    inertia: Expression
    rated_torque: Expression
    peak_torque: Expression
    max_speed: Expression

    def __post_init__(self):
        where = Where("motors", str(self.name))
        check_label(self.name, where, "motor")
        for key, what in MOTOR_UNITS.items():
            set_field(self, key, parse_required(getattr(self, key), where.at(key), f"a number in {what}"))


@dataclass(frozen=True)
class Cylinder:
    """A hydraulic cylinder as the linear drive: system ``pressure`` [Pa], the rod's Young's
    ``modulus`` [Pa], the Euler ``buckling_safety`` factor, the ``length_factor`` K (buckling
    length / pin-to-pin length: 1 for a cylinder pinned at both ends), and optionally the
    ``rod`` and ``bore`` diameters [m] (without them the report gives the ones needed)."""

    pressure: Expression
    modulus: Expression
    buckling_safety: Expression
    length_factor: Expression
    rod: Expression | None = None
    bore: Expression | None = None

    def __post_init__(self):
        where = Where("cylinder")
        for key, what in (("pressure", "the system pressure in Pa"), ("modulus", "the rod's Young's modulus in Pa"),
                          ("buckling_safety", "the Euler buckling safety factor (> 1)"),
                          ("length_factor", "the buckling length factor K (pinned at both ends: 1)")):
            set_field(self, key, parse_required(getattr(self, key), where.at(key), what))
        for key in ("rod", "bore"):
            set_field(self, key, parse_optional(getattr(self, key), where.at(key)))
