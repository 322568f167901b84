"""A motor catalogue in the design problem (issue 16): the motors of [[motors]] in turn,
smallest rated torque first, the design optimised with each one's constraints (peak torque,
maximum speed, rated torque against the RMS over the duty cycle: :mod:`.cases`), until one
has a feasible optimum: the smallest motor that fits.  The larger motors are not optimised
(the question a catalogue answers is the smallest that fits; each motor is a whole multistart,
and crane_luffing_drive's 11 kW motor alone took 2-3 minutes of 20 starts).

A Ctrl-C keeps what finished: :func:`optimise_catalogue` raises
:class:`~optdesign.errors.OptimisationInterrupted` with the catalogue so far
(:func:`interrupted_catalogue`)."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from ..errors import OptimisationInterrupted, interrupt_pending, interruptible
from ..model.train import motor_numbers
from .multistart import optimise
from .results import OptimisationResult


@dataclass(frozen=True)
class CatalogueResult:
    """Each motor's optimisation (``results``: name -> :class:`OptimisationResult`, in the order
    tried: by rated torque), the smallest that fits (``chosen``, or None) and its result
    (``best``: the chosen one's; without one, the last motor's, unsuccessful, or None when
    interrupted before any motor was decided); ``not_tried``:
    the larger motors left out once a smaller one fits (or, interrupted, not reached).

    Interrupted by Ctrl-C (:func:`interrupted_catalogue`): ``interrupted`` names the motor being
    optimised and ``interrupted_starts`` is (its starts finished, its starts planned; 0 planned
    when the Ctrl-C came before they were); ``results`` holds the motors decided before it and,
    when one of its finished starts found a feasible design, its result (marked interrupted:
    the best design of those starts).  That design proves the motor fits, so it is ``chosen``
    (all smaller motors were decided not to fit), though a better design of it may exist."""

    results: dict
    chosen: str | None
    best: OptimisationResult | None
    not_tried: tuple = ()
    interrupted: str | None = None
    interrupted_starts: tuple = ()
    motors: tuple = ()   # every motor of the catalogue, in the order tried (smallest rated torque first)


def optimise_catalogue(scene, progress=None, **options) -> CatalogueResult:
    """Optimise ``scene`` once per motor of its catalogue, smallest first, until one fits
    (``options`` go to :func:`.multistart.optimise`); ``progress(label, done, total)`` per start
    of each motor, the label naming the motor and its place ("5.5 kW, motor 2 of 4").

    Ctrl-C raises :class:`~optdesign.errors.OptimisationInterrupted` (a KeyboardInterrupt) whose
    ``catalogue`` is the :class:`CatalogueResult` so far (the motors decided, the interrupted
    one with the best design of its finished starts, the motors not tried: see there; its
    ``best`` is None when nothing was decided: no motor finished and no start of the first
    found a feasible design); ``result``, ``finished`` and ``total`` are the interrupted
    motor's, as from :func:`.multistart.optimise`."""
    values = scene.parameter_values()
    motors = sorted(scene.motors, key=lambda m: (motor_numbers(m, values)["rated_torque"], m.name))
    results, chosen = {}, None
    with interruptible():   # a Ctrl-C between two motors' starts (a motor's build) is kept too
        for k, motor in enumerate(motors):
            one = with_motor(scene, motor)
            label = f"{motor.name}, motor {k + 1} of {len(motors)}"
            step = None if progress is None else (lambda done, total, label=label: progress(label, done, total))
            try:
                results[motor.name] = optimise(one, progress=step, **options)
            except KeyboardInterrupt as stop:
                raise interrupted_catalogue(motors, results, stop) from None
            except RuntimeError as exc:   # a Ctrl-C that CasADi reported as a failed call (errors.py)
                if not interrupt_pending() and "KeyboardInterrupt" not in str(exc):
                    raise
                raise interrupted_catalogue(motors, results, OptimisationInterrupted()) from None
            if results[motor.name].success:
                chosen = motor.name
                break
    best = results[chosen] if chosen else results[motors[-1].name]
    return CatalogueResult(results, chosen, best, tuple(m.name for m in motors[len(results):]), motors=tuple(motors))


def with_motor(scene, motor):
    """``scene`` with ``motor`` alone for its catalogue; a duty cycle in time
    ([simulation] motor naming another motor of the catalogue) then runs that motor too: the
    catalogue is optimised with each motor in turn, the phases with the one being optimised
    (``simulate --design`` runs the motor the result chose)."""
    sim = scene.simulation
    if sim is not None and sim.motor is not None and sim.motor != motor.name:
        sim = dataclasses.replace(sim, motor=motor.name)
    return dataclasses.replace(scene, motors=(motor,), simulation=sim)


def interrupted_catalogue(motors, results, stop) -> OptimisationInterrupted:
    """Ctrl-C while the motor after those of ``results`` (decided, none fits) was optimised:
    ``stop`` (its :class:`~optdesign.errors.OptimisationInterrupted`, or a plain
    KeyboardInterrupt from before its starts) with ``catalogue``, the catalogue so far (its
    ``best`` None when nothing was decided)."""
    if not isinstance(stop, OptimisationInterrupted):
        stop = OptimisationInterrupted()
    motor = motors[len(results)].name
    results = dict(results)
    if stop.result is not None:   # the best design of its finished starts: feasible, so it fits
        results[motor] = stop.result
    chosen = motor if stop.result is not None and stop.result.success else None
    decided = [r for name, r in results.items() if name != motor]
    best = results[chosen] if chosen else (decided[-1] if decided else None)
    stop.catalogue = CatalogueResult(results, chosen, best, tuple(m.name for m in motors[len(decided) + 1:]),
                                     motor, (stop.finished, stop.total), tuple(motors))
    return stop
