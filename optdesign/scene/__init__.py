"""The scene: the file format (TOML), its expressions, the items and their validation, and the
scene resolved to numbers and CasADi symbols for the pipeline below.  May import only
optdesign.errors; everything below the scene (kinematics, model, ...) imports it."""
from .cases import Case, Duty, DutyStep
from .elements import (Body, Constraint, Drive, Gravity, Objective, Parameter, Simulation, Sweep)
from .expressions import Expression, parse
from .file import load, loads
from .profiles import Profile
from .points import Attach, Closure, Dyad, Fixed, Loop, Polar, Slider
from .resolved import ResolvedScene
from .scene import Scene
from .train import Cylinder, Gearbox, Motor
from .where import Where

__all__ = ["load", "loads", "Scene", "Parameter", "Sweep", "Fixed", "Polar", "Dyad", "Slider", "Attach",
           "Loop", "Closure", "Body", "Gravity", "Drive", "Simulation", "Constraint", "Objective",
           "Expression", "parse", "Where", "ResolvedScene", "Case", "Duty", "DutyStep", "Profile", "Gearbox",
           "Motor", "Cylinder"]
