"""What a load case's evaluation gives (:class:`CaseResult`, one case over the stroke;
:class:`CasesResult`, every case with the governing ones, the duty cycle and the drive train)
and a case's samples (:func:`case_nodes`): shared by :mod:`.cases`, which builds the cases'
graphs, and :mod:`.case_runs`, which evaluates them."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


LOAD = "load_inertia"   # the load inertia's row among a case's certified peaks


def _motor_key(name) -> str:
    """The key of a motor's torque among a case's peaks."""
    return f"motor_torque[{name}]"


def case_nodes(s, profile):
    """A case's samples: the scene's ``s``, plus each phase boundary of its ``profile`` from both
    sides (0.5e-9 of the stroke apart) and an s-curve's jerk nodes; and which of them are the
    scene's samples."""
    s = np.asarray(s, float)
    breaks = profile.breakpoints() if profile is not None else np.zeros(0)
    for stop in getattr(getattr(profile, "shape", None) and profile.shape.motion_law, "stops", ()):
        s = np.where(np.abs(s - stop) <= 1e-13 * abs(s[-1] - s[0]), stop, s)   # a sample at a stop: the stop exactly
    if not breaks.size and (profile is None or profile.shape.motion_law is None):   # (a law in time: its time nodes)
        return s.copy(), np.ones(len(s), bool)
    delta = 0.5e-9 * abs(s[-1] - s[0])
    gaps = np.diff(np.sort(breaks))
    if np.any(gaps > 0):   # phases shorter than that (a slow s-curve's jerk phases): each side inside its phase
        delta = min(delta, 0.25 * float(np.min(gaps[gaps > 0])))
    extra = np.r_[breaks - delta, breaks + delta]
    for lo, hi, inner in profile.jerk_segments():  # an s-curve's jerk segments, evenly in time
        extra = np.r_[extra, inner]
    # a node in time that falls on a sample (a law's middle on an odd grid) is that sample
    extra = np.unique(extra[np.min(np.abs(extra[:, None] - s[None, :]), axis=1) > 1e-13 * abs(s[-1] - s[0])])
    nodes = np.r_[s, extra]
    order = np.argsort(nodes, kind="stable")
    if s[-1] < s[0]:
        order = order[::-1]
    on_sample = np.r_[np.ones(len(s), bool), np.zeros(len(extra), bool)][order]
    return nodes[order], on_sample


@dataclass(frozen=True)
class CaseResult:
    """One case over the stroke: ``columns`` (arrays over the case's samples: the scene's samples
    plus, with a profile, each phase boundary twice, once from each side), ``peaks`` (peak |value|
    of drive, static_load, reduced_inertia, power, motor quantities), ``peak_at`` ({s, value} of
    each), ``duration`` [s] of the stroke, ``integrals`` over the stroke's time (rule: see
    :mod:`.duty`), and how the case is set (``direction``, ``profile``, ``efficiency``,
    ``overrides``)."""

    name: str
    direction: str
    profile: str | None
    efficiency: str
    overrides: dict
    columns: dict
    peaks: dict
    peak_at: dict
    duration: float
    integrals: dict = field(default_factory=dict)
    on_samples: np.ndarray | None = None   # which of the case's samples are the scene's
    constraints: dict = field(default_factory=dict)   # name -> values of the constraints per case
    # the peaks are certified over the continuous stroke (``peaks``, ``peak_at``): their
    # samples' largest values and the enclosures' certificates {bound, note}
    peaks_sampled: dict = field(default_factory=dict)
    certificates: dict = field(default_factory=dict)
    # each motor's peak torque |T_g + J_r eps_m| in this case: name -> {peak, at {s, value},
    # peak_sampled, certificate} (the peak certified as the others' unless certify is False)
    motors: dict = field(default_factory=dict)
    rests: tuple = ()   # a segments profile's dwells: (time from, time to, sweep value) each
    # with [[motors]]: the load inertia J_load = max |I_zS| (the reduced inertia without the
    # efficiency) over the continuous stroke: {value, at {s, value}, sampled, certificate}
    load_inertia: dict | None = None


@dataclass(frozen=True)
class CasesResult:
    """What :class:`CaseAnalysis` gives: ``cases`` (name -> :class:`CaseResult`), ``governing``
    (peak name -> {case, value, s}: the case with the largest peak), ``duty`` (the cycle's time,
    RMS over time, energy, mean power, steps; or {reason} when a case has no motion in time)
    and ``train`` (with a gearbox: the ratio, each motor against the cycle, the smallest that
    fits; with a cylinder: bore, rod, buckling, pump flow)."""

    cases: dict
    governing: dict
    duty: dict
    train: dict
