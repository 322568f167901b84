"""A motor catalogue in the design problem (issue 16): the motors of [[motors]] in turn,
smallest rated torque first, the design optimised with each one's constraints (peak torque,
maximum speed, rated torque against the RMS over the duty cycle: :mod:`.cases`), until one
has a feasible optimum: the smallest motor that fits.  The larger motors are not optimised
(the question a catalogue answers is the smallest that fits; each motor is a whole multistart,
and crane_luffing_drive's 11 kW motor alone took 2-3 minutes of 20 starts)."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from ..model.train import motor_numbers
from .multistart import optimise
from .results import OptimisationResult


@dataclass(frozen=True)
class CatalogueResult:
    """Each motor's optimisation (``results``: name -> :class:`OptimisationResult`, in the order
    tried: by rated torque), the smallest that fits (``chosen``, or None) and its result
    (``best``: the chosen one's; without one, the last motor's, unsuccessful); ``not_tried``:
    the larger motors left out once a smaller one fits."""

    results: dict
    chosen: str | None
    best: OptimisationResult
    not_tried: tuple = ()


def optimise_catalogue(scene, progress=None, **options) -> CatalogueResult:
    """Optimise ``scene`` once per motor of its catalogue, smallest first, until one fits
    (``options`` go to :func:`.multistart.optimise`); ``progress(label, done, total)`` per start
    of each motor, the label naming the motor and its place ("5.5 kW, motor 2 of 4")."""
    values = scene.parameter_values()
    motors = sorted(scene.motors, key=lambda m: (motor_numbers(m, values)["rated_torque"], m.name))
    results, chosen = {}, None
    for k, motor in enumerate(motors):
        one = dataclasses.replace(scene, motors=(motor,))
        label = f"{motor.name}, motor {k + 1} of {len(motors)}"
        step = None if progress is None else (lambda done, total, label=label: progress(label, done, total))
        results[motor.name] = optimise(one, progress=step, **options)
        if results[motor.name].success:
            chosen = motor.name
            break
    best = results[chosen] if chosen else results[motors[-1].name]
    return CatalogueResult(results, chosen, best, tuple(m.name for m in motors[len(results):]))
