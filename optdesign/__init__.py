"""optdesign: optimisation-based design of planar mechanisms with a variable drive ratio.

Front doors: :func:`load` (a scene file), :func:`kinematics`, :func:`analyse`, :func:`simulate`,
:func:`optimise` and :class:`Study`.
"""
from .model.analysis import AnalysisResult, analyse
from .errors import (AssemblyError, DeadCentreError, ExpressionError, OptdesignError, SceneError,
                     SolverError)
from .design import OptimisationResult, optimise
from .dynamics.simulator import SimulationResult, simulate
from .study import Study, StudyResult
from .kinematics.mechanism import KinematicsResult, Mechanism, kinematics
from .model.reduction import ReducedModel
from .scene import (Attach, Body, Closure, Constraint, Drive, Dyad, Fixed, Gravity, Loop, Objective, Parameter,
                    Polar, Scene, Slider, Sweep, load, loads)

__all__ = [
    "load", "loads", "kinematics", "analyse", "simulate", "optimise", "Study", "StudyResult",
    "SimulationResult", "OptimisationResult", "Mechanism", "ReducedModel", "KinematicsResult",
    "AnalysisResult", "Scene", "Parameter", "Sweep", "Fixed", "Polar", "Dyad", "Slider", "Attach",
    "Loop", "Closure", "Body", "Gravity", "Drive", "Constraint", "Objective", "OptdesignError",
    "SceneError", "ExpressionError", "AssemblyError", "DeadCentreError", "SolverError",
]
__version__ = "0.1.0"
