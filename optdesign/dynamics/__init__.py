"""Motion in time under the drive law: the equation of motion from the reduced model, integrated
(CVODES BDF/Adams, RK4) branch by branch, every non-smooth instant (reversal, power-flow switch,
rest, stall, stroke end) located and the integrator restarted there, to the end time, a stroke
end or a stall.
May import: errors, scene, kinematics, model; never design, report, study or cli."""
from .result import SimulationResult
from .simulator import Simulator, simulate

__all__ = ["simulate", "Simulator", "SimulationResult"]
