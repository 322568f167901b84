"""What solving the design problem gives: one start's report, one converged solve, and the
result of :func:`~optdesign.design.multistart.optimise` (frozen dataclasses, fixed fields)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..scene import Scene
from .problem import SolverSettings


@dataclass(frozen=True)
class StartReport:
    """What one start did."""

    index: int
    start: dict            # the point the start was drawn at
    status: str            # IPOPT's return status, 'phase 1 failed: ...' or 'skipped: ...'
    success: bool          # IPOPT converged and the continuous check agreed
    objective: float | None
    repaired: bool         # a point did not assemble and was projected onto designs that do
    iterations: int        # IPOPT iterations of the objective phase
    exchanges: int
    time_s: float
    tried: tuple = ()      # every point tried (the start, then retries): its phase 1's status and violation
    feasible_start: dict | None = None  # the design phase 1 gave (the least-violating one if it failed)
    end: dict | None = None             # where the objective phase ended
    phase1_iterations: int = 0
    violation: float | None = None      # phase 1's remaining violation (scaled; 0 when feasible)
    optimum: int | None = None          # index of the local optimum it reached in OptimisationResult.optima


@dataclass(frozen=True)
class Solution:
    """One converged solve (internal, with what the reports need)."""

    x: np.ndarray
    w: np.ndarray
    lam_g: np.ndarray
    lam_x: np.ndarray
    lam_p: np.ndarray
    g: np.ndarray
    f: float
    s_points: np.ndarray
    status: str
    success: bool
    iterations: int
    exchanges: int
    certified: dict        # (block name, sense) -> worst continuous value (physical units)
    sampled: dict          # (block name, sense) -> worst value on the scene's samples
    converged: bool
    notes: dict = field(default_factory=dict)   # (block name, sense) -> why its value has no enclosure's proof


@dataclass(frozen=True)
class OptimisationResult:
    """The result of :func:`~optdesign.design.multistart.optimise` (frozen; fixed fields)."""

    scene: Scene
    design: dict
    objective: float | None          # certified (continuous stroke) value of the objective
    objective_sampled: float | None  # the same on the scene's samples only
    objective_kind: str
    peak_certified: float | None     # continuous peak |drive| (or |objective quantity|)
    peak_sampled: float | None
    success: bool
    status: str
    message: str
    constraints: dict                # name -> {value, lower, upper, multiplier, active}
    sensitivities: dict              # fixed parameter -> d objective / d parameter
    starts_total: int
    starts_at_best: int
    starts: tuple
    timings: dict = field(default_factory=dict)
    settings: SolverSettings = field(default_factory=SolverSettings)
    optima: tuple = ()               # distinct local optima (clusters.LocalOptimum), best first
    least_violating: dict | None = None  # when infeasible: {design, violated: {constraint: amount}}
    start_plan: dict = field(default_factory=dict)  # how the starts were drawn: method, candidates screened
    interrupted: bool = False        # Ctrl-C stopped the starts: the best of those that finished
    sensitivity_notes: dict = field(default_factory=dict)  # parameter -> why its sensitivity is partial or none

    def __repr__(self):
        state = "optimum" if self.success else f"failed ({self.status})"
        value = "" if self.objective is None else f" {self.objective:.7g}"
        design = ", ".join(f"{k}={v:.5g}" for k, v in self.design.items())
        return (f"OptimisationResult({self.scene.path!r}: {state}{value}, design {design}, "
                f"{self.starts_at_best}/{self.starts_total} starts at the best)")

    def to_dict(self) -> dict:
        """Plain data in SI (numbers, lists, dicts: ready for json.dumps)."""
        from ..scene.plain import result_dict

        return result_dict(self, "optimisation")
