"""Motion in time under a drive law: seed 1's "motion from drive" (eqs. 17, 38) integrated.

:class:`Simulator` compiles a scene's equation of motion once (:mod:`.equations`: the equation in
the sweep coordinate on each branch of its efficiency switch, the checks of its inertia and
start) and :meth:`Simulator.run` integrates it branch by branch over the output grid
(:mod:`.motion`, :mod:`.integrate`), locating every non-smooth instant and deciding what follows
(:mod:`.events`: reversals, power-flow switches, rests, stalls, stroke ends); :func:`simulate`
is the front door.  The scene's numbers are read here, once: the parameter values and the
constants of ``[simulation]`` and ``[sweep]``, from the mechanism's resolved scene.
"""
from __future__ import annotations

import math
import time

import numpy as np

from ..errors import SceneError, SolverError, casadi_messages_hidden, interruptible
from ..kinematics.mechanism import Mechanism
from ..model.reduction import ReducedModel
from ..scene import Scene
from ..scene.arguments import scene_argument, simulation_arguments
from ..scene.elements import INTEGRATORS
from .equations import Equations, check_inertia, initial_state
from .integrate import DEFAULT_TOLERANCE, Integration, state_scales
from .motion import run_motion
from .time_peaks import locate_peaks
from .result import SimulationResult, event_record

DEFAULT_RK4_STEPS = 20


class Simulator:
    """The compiled equation of motion of one scene; :meth:`run` integrates it (a class under
    :func:`simulate`, reusable over integrators and tolerances)."""

    def __init__(self, scene: Scene):
        t0 = time.perf_counter()
        if scene.drive is None or scene.drive.law is None:
            raise SceneError(f"{scene.path}: [drive] law: the scene gives no drive law, so there is no motion "
                             "to simulate; add law = \"...\" to [drive] (a torque or force in q, qd and "
                             "parameters, e.g. law = \"T0*(1 - qd/omega0)\" or law = 50)")
        if scene.simulation is None:
            raise SceneError(f"{scene.path}: [simulation]: missing table: expected [simulation] with start "
                             "(sweep value at t = 0), speed (drive speed at t = 0) and t_end [s]")
        self.scene = scene
        self.mech = mech = Mechanism(scene)
        self.model = model = ReducedModel(mech)
        self.rotary = model.rotary
        self.resolved = res = mech.resolved
        self.equations = eq = Equations(mech, model, scene.drive)
        sim = scene.simulation
        self.s_start = res.constant(sim.start, "[simulation] start")
        self.qd_start = res.constant(sim.speed, "[simulation] speed")
        self.t_end = res.constant(sim.t_end, "[simulation] t_end")
        lo, hi = res.start, res.stop
        self.ends = {"from": lo, "to": hi}
        self.lo, self.hi = min(lo, hi), max(lo, hi)
        self.stroke_grid = np.linspace(self.lo, self.hi, max(scene.sweep.samples, 2001))
        mech.check_assembly(self.stroke_grid)
        check_inertia(eq, scene, self.stroke_grid, mech.parameter_values)
        self.x0 = initial_state(eq, scene, self.s_start, self.qd_start, mech.parameter_values)
        # tolerances are relative to the stroke length and a reference sweep rate (the scene's t_end)
        self.scale = state_scales(self.x0, self.lo, self.hi, self.t_end, self.rotary)
        self.where = (scene.path, scene.sweep.name, scene)
        self._integrators = {}  # compiled integrators, by method, tolerance and output points
        self.build_time = time.perf_counter() - t0

    def run(self, integrator: str | None = None, tolerance: float | None = None, steps: int | None = None,
            samples: int | None = None, t_end: float | None = None, error_check: bool = True) -> SimulationResult:
        """Integrate from the scene's start over [0, t_end], to a stroke end or to a stall.
        ``error_check`` False skips RK4's half-step error estimate (for work-precision studies
        only).  A Ctrl-C stops it within milliseconds, even inside an integrator call."""
        with interruptible(), casadi_messages_hidden():
            return self._run(integrator, tolerance, steps, samples, t_end, error_check)

    def _run(self, integrator, tolerance, steps, samples, t_end, error_check):
        sim = self.scene.simulation
        method = integrator or sim.integrator
        if method not in INTEGRATORS:
            raise SceneError(f"integrator {method!r}: expected one of {', '.join(INTEGRATORS)}")
        tol = tolerance if tolerance is not None else (
            self.resolved.constant(sim.tolerance, "[simulation] tolerance") if sim.tolerance is not None
            else DEFAULT_TOLERANCE)
        n = samples or sim.samples
        t_end = self.t_end if t_end is None else float(t_end)
        steps = (steps or DEFAULT_RK4_STEPS) if method == "rk4" else None
        if method == "rk4" and steps < 2:
            raise SceneError(f"rk4 needs at least 2 steps per output sample (found {steps}): the error "
                             "estimate compares the run with one at half the steps")
        tol, n, t_end, steps = simulation_arguments(tol, n, t_end, steps)
        t0 = time.perf_counter()
        grid = np.linspace(0.0, t_end, n)
        run = self._integration(method, tol, steps)
        motion = run_motion(run, grid, self.where)
        error = None
        if method == "rk4" and error_check:
            half = self._integration(method, tol, steps // 2)
            error = rk4_error(run, motion, run_motion(half, grid, self.where), self.scene.path)
            run.counts.merge(half.counts)
        motion = locate_peaks(run, motion)
        wall = time.perf_counter() - t0
        p = self.mech.parameter_values
        cols = self.equations.columns(motion.X, p, motion.c, motion.held)
        events = [event_record(e, self.equations, p) for e in motion.events]
        return SimulationResult(self.scene, self.scene.drive.kind, method, tol, steps, motion.t, cols, motion.stop,
                                motion.stop_end, run.statistics(),
                                {"build_s": self.build_time, "integrate_s": wall}, error, events)

    def _integration(self, method, tol, steps):
        return Integration(self.equations, self.mech.parameter_values, self.x0, self.ends, self.scale, method, tol,
                           steps, cache=self._integrators)


def rk4_error(run, motion, half, where):
    """RK4's global error, estimated by Richardson from the run with half the steps: err ~ max
    |x_N - x_{N/2}| / 15 (scaled states) at the output times both runs reach, and at the stop
    when both stop alike.  ``where``: the scene's path, for the message."""
    tol, steps, scale = run.tol, run.steps, run.scale
    common = np.intersect1d(motion.t, half.t)
    a = motion.X[:, np.searchsorted(motion.t, common)]
    b = half.X[:, np.searchsorted(half.t, common)]
    diff = [np.abs(a - b) / scale[:, None]]
    if motion.stop == half.stop and motion.stop_end == half.stop_end and len(motion.events) == len(half.events):
        diff.append(np.abs(motion.X[:, -1:] - half.X[:, -1:]) / scale[:, None])
        # the stop's time, as a distance: at the largest speed of the run
        diff.append(np.array([[abs(motion.t[-1] - half.t[-1]) * np.max(np.abs(motion.X[1])) / scale[0]]]))
    else:
        diff.append(np.array([[math.inf]]))
    diff = np.concatenate([d.ravel() for d in diff])
    error = float(np.max(diff)) / 15 if np.isfinite(diff).all() else math.inf
    if not error <= tol:
        need = steps * max(2.0, (error / tol) ** 0.25) if math.isfinite(error) else 10 * steps
        raise SolverError(
            f"{where}: the rk4 integrator with {steps} steps per output sample is not accurate "
            f"enough: its estimated error {error:.3g} (relative to the stroke length and the reference "
            f"rate; from a run with half the steps) exceeds the tolerance {tol:.3g}. Use about "
            f"{math.ceil(need)} steps per sample (--steps), or the implicit integrator (bdf).")
    return error


def simulate(scene: Scene, integrator: str | None = None, tolerance: float | None = None,
             steps: int | None = None, samples: int | None = None, t_end: float | None = None) -> SimulationResult:
    """The motion of ``scene`` in time under its ``[drive] law`` from its ``[simulation]`` start
    (front door).  ``integrator`` ('bdf', 'adams', 'rk4'), ``tolerance``, ``samples`` and
    ``t_end`` override the scene's; ``steps`` is RK4's steps per output sample."""
    scene = scene_argument("simulate", scene)
    if scene.simulation is not None and scene.simulation.phases:
        from .phases import PhasedSimulator

        return PhasedSimulator(scene).run(integrator, tolerance, samples, t_end)
    return Simulator(scene).run(integrator, tolerance, steps, samples, t_end)
