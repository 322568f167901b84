"""The result of a simulation: the motion over the output samples, how it stopped, and the
integrator's statistics and timings."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..scene import Scene


@dataclass(frozen=True)
class SimulationResult:
    """A motion in time (arrays over the output samples, the last one at the stop).

    ``q``, ``qd``, ``qdd``: drive coordinate (crank angle alpha [rad] or actuator length x [m]),
    its rate and acceleration; ``s``, ``sd``, ``sdd``: the sweep coordinate and its rates;
    ``drive``: the law's torque/force T_m; ``transmitted``: T_m - J_d qdd, what reaches the
    mechanism (the seed's T_S or F_S); ``kinetic_energy``: 1/2 M_s sd^2 + 1/2 J_d qd^2 (mechanism
    and drive); ``power``: T_m qd; ``efficiency_factor`` (only with eta < 1).  ``stop`` is
    'stroke end', 't_end' or 'stalled' (a self-locking drive under eta < 1 brought the
    mechanism to rest, where it stays); ``stop_end`` 'from' or 'to' (which end of [sweep]) or None.
    ``stats``: integrator counts (steps, rhs_evaluations, error_test_failures,
    nonlinear_iterations) summed over every integrator call of the run, and ``timings``."""

    scene: Scene
    drive_kind: str
    integrator: str
    tolerance: float
    steps_per_sample: int | None
    t: np.ndarray
    columns: dict
    stop: str
    stop_end: str | None
    stats: dict
    timings: dict = field(default_factory=dict)
    error_estimate: float | None = None

    def __getattr__(self, name):
        columns = self.__dict__.get("columns", {})
        if name in columns:
            return columns[name]
        raise AttributeError(name)

    @property
    def t_stop(self) -> float:
        return float(self.t[-1])
