"""The result of a simulation: the motion over the output samples (with every event's instant),
how it stopped, its events, and the integrator's statistics and timings."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..scene import Scene


@dataclass(frozen=True)
class SimulationResult:
    """A motion in time (arrays over the output samples and the events' instants, the last one
    at the stop).

    ``q``, ``qd``, ``qdd``: drive coordinate (crank angle alpha [rad] or actuator length x [m]),
    its rate and acceleration; ``s``, ``sd``, ``sdd``: the sweep coordinate and its rates;
    ``drive``: the law's torque/force T_m; ``transmitted``: T_m - J_d qdd, what reaches the
    mechanism (the seed's T_S or F_S); ``kinetic_energy``: 1/2 M_s sd^2 + 1/2 J_d qd^2 (mechanism
    and drive); ``power``: T_m qd; ``efficiency_factor`` (only with eta < 1).  At an event's
    sample the columns are those of the branch after it.  ``stop`` is 'stroke end', 't_end' or
    'stalled' (a self-locking drive under eta < 1 brought the mechanism to rest, where it stays);
    ``stop_end`` 'from' or 'to' (which end of [sweep]) or None.  ``events``: one dict per located
    non-smooth instant (:func:`event_record`).  ``stats``: integrator counts (steps,
    rhs_evaluations, error_test_failures, nonlinear_iterations, integrator_calls, failed_calls)
    summed over every integrator call of the run, failed ones included, and ``timings``.  A duty
    cycle (``[[simulation.phases]]``, :mod:`.phases`) stops at 'cycle end' and has ``phases``:
    per phase its name, kind, end, case, start and end times and its integrals over time
    (motor_squared = int T_m^2 dt, motor_work = int T_m omega_m dt, drive_work = int T_S qd
    dt); its columns add ``motor_torque`` and ``motor_speed``, its events 'phase' (a phase
    change: the phase that follows, the ``previous`` one, its ``end``); at a phase change the
    samples hold the instant twice, the last of the phase before and the first of the next."""

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
    events: list = field(default_factory=list)
    phases: list = field(default_factory=list)

    def __getattr__(self, name):
        columns = self.__dict__.get("columns", {})
        if name in columns:
            return columns[name]
        raise AttributeError(name)

    @property
    def t_stop(self) -> float:
        return float(self.t[-1])

    def __repr__(self):
        return (f"SimulationResult({self.scene.path!r}: {len(self.t)} samples, t = 0 .. {self.t_stop:.6g} s, "
                f"stop {self.stop!r}, {self.integrator})")

    def to_dict(self) -> dict:
        """Plain data in SI (numbers, lists, dicts: ready for json.dumps)."""
        from ..scene.plain import result_dict

        return result_dict(self, "simulation")

    def event_times(self, kind: str | None = None) -> np.ndarray:
        """The times of the events (of one ``kind``)."""
        return np.array([e["t"] for e in self.events if kind is None or e["kind"] == kind])


def event_record(event, eq, p) -> dict:
    """An event as the result holds it: ``t``, ``kind`` ('reversal', 'rest', 'stall', 'power
    flow', 'stroke end'), ``state`` {s, sd, q, qd}, ``before`` and ``after`` {direction,
    efficiency_factor} (absent at the start and at a stop), ``end`` for a stroke end and the
    one-sided accelerations at a rest."""
    x = event.x
    rec = {"t": float(event.t), "kind": event.kind,
           "state": {"s": float(x[0]), "sd": float(x[1]), "q": eq.output("q", x, p), "qd": eq.output("qd", x, p)}}
    for name, branch in (("before", event.before), ("after", event.after)):
        if branch is not None and not branch.held:
            rec[name] = {"direction": int(branch.d), "efficiency_factor": float(branch.c)}
    if event.end is not None:
        rec["end"] = event.end
    if "one_sided_accelerations" in event.extra:
        rec["one_sided_accelerations"] = event.extra["one_sided_accelerations"]
    return rec
