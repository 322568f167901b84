"""A motor catalogue in the design problem (issue 16): each motor of [[motors]] in turn, the
design optimised with its constraints (peak torque, maximum speed, rated torque against the RMS
over the duty cycle: :mod:`.cases`), and the smallest motor (by rated torque) whose optimum is
feasible."""
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
    (``best``: the chosen one's; without one, the last motor's, unsuccessful)."""

    results: dict
    chosen: str | None
    best: OptimisationResult


def optimise_catalogue(scene, progress=None, **options) -> CatalogueResult:
    """Optimise ``scene`` once per motor of its catalogue, smallest first (``options`` go to
    :func:`.multistart.optimise`); ``progress(motor name, done, total)`` per start."""
    values = scene.parameter_values()
    motors = sorted(scene.motors, key=lambda m: (motor_numbers(m, values)["rated_torque"], m.name))
    results = {}
    for motor in motors:
        one = dataclasses.replace(scene, motors=(motor,))
        step = None if progress is None else (lambda done, total, name=motor.name: progress(name, done, total))
        results[motor.name] = optimise(one, progress=step, **options)
    chosen = next((name for name, r in results.items() if r.success), None)
    return CatalogueResult(results, chosen, results[chosen] if chosen else results[motors[-1].name])
