"""The scene: one mechanism with its masses, loads, drive, stroke and design problem.

:class:`Scene` holds the items (:mod:`optdesign.scene.elements`, :mod:`optdesign.scene.points`),
validates them against each other on construction, looks items up and makes copies with other
parameter values.  Numbers for the pipeline below come from its resolution,
:class:`~optdesign.scene.resolved.ResolvedScene`.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

from ..errors import SceneError
from .cases import Duty
from .drawing import Drawing
from .elements import Drive, Gravity, Objective, Parameter, Simulation, Sweep
from .expressions import constant_value
from .cycles import expanded_cycles
from .quantities import expanded_items
from .train import Cylinder, Gearbox
from .validate import Validator
from .values import set_field
from .where import Where, fail, located_error, near_miss


@dataclass(frozen=True)
class Scene:
    """One mechanism with its masses, loads, drive, stroke and design problem: the items of a
    scene file, checked against each other on construction (:mod:`optdesign.scene.validate`)."""

    title: str
    parameters: tuple
    sweep: Sweep
    points: tuple
    bodies: tuple = ()
    forces: tuple = ()   # [[forces]]: springs, gas springs, dampers, torsion springs (scene/forces.py)
    gravity: Gravity | None = None
    drive: Drive | None = None
    constraints: tuple = ()
    objective: Objective | None = None
    source: str = ""
    reference: dict = field(default_factory=dict)
    path: str = "<python>"
    simulation: Simulation | None = None
    # sizing the drive (scene/cases.py, profiles.py, train.py; docs/scenes.md)
    profiles: tuple = ()
    cases: tuple = ()
    duty: Duty | None = None
    gearbox: Gearbox | None = None
    motors: tuple = ()
    cylinder: Cylinder | None = None
    drawing: Drawing | None = None   # the optional [drawing] table (drawings only)
    quantities: tuple = ()           # [quantities]: named per-sample expressions (scene/quantities.py)

    def __post_init__(self):
        for name in ("parameters", "points", "bodies", "forces", "constraints", "profiles", "cases", "motors",
                     "quantities"):
            set_field(self, name, tuple(getattr(self, name)))
        for name, value in expanded_items(self).items():   # the quantities' names replaced by their expressions
            set_field(self, name, value)
        for name, value in expanded_cycles(self).items():  # a case running a cycle: a case per way, holds
            set_field(self, name, value)
        self.validate()

    # --- lookups ---
    def parameter(self, name) -> Parameter:
        for p in self.parameters:
            if p.name == name:
                return p
        names = [p.name for p in self.parameters]
        fail(Where("parameters", str(name)), f"unknown parameter {name!r}" + near_miss(name, names),
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
                fail(None, f"cannot set parameter {name!r}: {what}" + near_miss(name, names)
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


    def without_bounds(self, *names) -> "Scene":
        """A copy in which the parameters ``names`` are plain parameters, their min/max (the
        design box) dropped: an analysis has no box, so an analyse-mode study may set them to
        any value.  Unknown names are an error, as in :meth:`with_parameters`."""
        unknown = [n for n in names if n not in {p.name for p in self.parameters}]
        if unknown:
            self.with_parameters(**{unknown[0]: 0.0})  # raises the usual error, with the near miss
        params = tuple(dataclasses.replace(p, lower=None, upper=None) if p.name in names else p
                       for p in self.parameters)
        return dataclasses.replace(self, parameters=params)

    def validate(self):
        """Check every cross reference, in the order of the file; raise SceneError on the first
        problem, naming its place."""
        Validator(self).run()
        if self.drawing is not None:
            self.drawing.check(self.point_names(), self.path)
