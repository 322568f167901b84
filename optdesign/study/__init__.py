"""Many designs of one scene: grids, lists and Pareto fronts (axes), the cases they make, their
execution in this process, a process pool or on Dask, and the append-only journal that keeps
every finished case.  May import: errors, scene, kinematics, model, design and report (a study
writes its figures through report); never cli."""
from .axes import Axis, grid, pareto, together, values
from .results import StudyInterrupted, StudyResult
from .study import Case, Study
from .table import read_csv

__all__ = ["Study", "StudyResult", "StudyInterrupted", "Axis", "Case", "grid", "values", "together", "pareto",
           "read_csv"]
