"""optdesign: optimisation-based design of planar mechanisms with a variable drive ratio.

Front doors: :func:`load` (a scene file), :func:`kinematics`, :func:`analyse`, :func:`simulate`,
:func:`optimise` and :class:`Study`.

The names below are imported when first used (``optdesign.analyse``, ``from optdesign import
Study``): ``import optdesign`` and the command line start without CasADi, numpy or scipy, so a
Ctrl-C while ``optdesign`` starts up is handled like any other (exit 130, nothing written).
"""
from .errors import (ArgumentError, AssemblyError, DeadCentreError, ExpressionError, OptdesignError,  # noqa: F401
                     ResultError, SceneError, SolverError)

_LAZY = {
    **dict.fromkeys(("analyse", "AnalysisResult"), ".model.analysis"),
    **dict.fromkeys(("optimise", "OptimisationResult"), ".design"),
    **dict.fromkeys(("simulate", "SimulationResult"), ".dynamics.simulator"),
    **dict.fromkeys(("Study", "StudyResult"), ".study"),
    **dict.fromkeys(("KinematicsResult", "Mechanism"), ".kinematics.mechanism"),
    "ReducedModel": ".model.reduction",
    **dict.fromkeys(("Attach", "Body", "Closure", "Constraint", "Drive", "Dyad", "Fixed", "Gravity", "Loop",
                     "Objective", "Parameter", "Polar", "Scene", "Slider", "Sweep", "load", "loads"), ".scene"),
}


# the subpackage optdesign.kinematics shares its name with the front door kinematics(): it is
# imported first (it is cheap), so that the function below keeps the name once it is bound
from . import kinematics as _kinematics_subpackage  # noqa: E402, F401


def kinematics(*args, **kwargs):
    """Points and body angles with their rates over the stroke, at the scene's motion (front
    door; :func:`optdesign.kinematics.mechanism.kinematics`)."""
    from .kinematics.mechanism import kinematics as front_door

    return front_door(*args, **kwargs)


def __getattr__(name):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'optdesign' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value
    _rich_display()
    return value


def _rich_display():
    """Jupyter's rich display of the results (report/notebook.py): ``_repr_html_`` set on the
    classes of the layers below the report, here where every layer may be imported."""
    from .design.results import OptimisationResult
    from .dynamics.result import SimulationResult
    from .model.analysis import AnalysisResult
    from .report import notebook
    from .scene.scene import Scene
    from .study.results import StudyResult

    for cls, show in ((Scene, notebook.scene_html), (AnalysisResult, notebook.analysis_html),
                      (OptimisationResult, notebook.optimisation_html),
                      (SimulationResult, notebook.simulation_html), (StudyResult, notebook.study_html)):
        cls._repr_html_ = show


def __dir__():
    return sorted(set(globals()) | set(_LAZY))


__all__ = [
    "load", "loads", "kinematics", "analyse", "simulate", "optimise", "Study", "StudyResult",
    "SimulationResult", "OptimisationResult", "Mechanism", "ReducedModel", "KinematicsResult",
    "AnalysisResult", "Scene", "Parameter", "Sweep", "Fixed", "Polar", "Dyad", "Slider", "Attach",
    "Loop", "Closure", "Body", "Gravity", "Drive", "Constraint", "Objective", "OptdesignError",
    "SceneError", "ExpressionError", "AssemblyError", "DeadCentreError", "SolverError", "ArgumentError",
    "ResultError",
]
__version__ = "0.1.0"
