"""Motion in time under the drive law: the equation of motion from the reduced model, integrated
(CVODES BDF/Adams, RK4) to the end time, a located stroke end or a stall.
May import: errors, scene, kinematics, model; never design, report, study or cli."""
from .result import SimulationResult
from .simulator import Simulator, simulate

__all__ = ["simulate", "Simulator", "SimulationResult"]
