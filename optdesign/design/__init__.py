"""design: the design problem as an NLP (problem, rows, nlp, bounds, aggregates), solved from many starts
(multistart, solver, certify, repair) into results with multipliers and sensitivities (sensitivities).
May import optdesign.errors, .scene, .kinematics and .model; never .dynamics, .report, .study or .cli."""
from .multistart import optimise
from .problem import DesignProblem, SolverSettings
from .results import OptimisationResult

__all__ = ["optimise", "DesignProblem", "SolverSettings", "OptimisationResult"]
