"""A load case's integrals over its stroke's time, to a stated tolerance (:mod:`.quadrature`).

For a quantity g of the sweep s, int g dt = int g(s) w(s) ds over the stroke with the time
per unit of sweep w = dt/ds:

* along a profile, w = 1/V(s), V the profile's sweep speed, evaluated from the exact distances
  x from the motion's beginning and y to its end (:func:`.profiles.speed_function`), so that the
  weight is right where V vanishes at an end;
* at the constant [drive] speed v, w = |k| / |v| (k = dq/ds; t = |q - q_0| / v).

The stroke is cut at the profile's phase boundaries (where the load jumps or bends), and at
each end where V vanishes the piece is anchored there with the substitution that makes
1/V smooth (:func:`.quadrature.end_power`: m = 2 for a trapezoid's or a square-root law's
start, 3 for an s-curve's).  A power flow that switches the efficiency between samples (a jump
of the drive load at a point no profile knows) is closed in by the quadrature's bisection.
Each integral comes with the quadrature's error estimate; one that does not reach the
tolerance (a load that is not integrable, as at a lock-up) is reported as unresolved.

The energy is int P dt = int T_S k sigma ds along a profile (P = T_S k sigma V and V dt = ds: no
weight), and int P w ds at the constant speed.
"""
from __future__ import annotations

import math

import numpy as np

from .profiles import speed_function
from .quadrature import end_power, integrate_many

TOLERANCE = 1e-10   # relative to the integral of |integrand| over the stroke
FIRST_INTERVALS = 128
# the columns of a case that certified_integrals reads (with the [quantities] integrated)
INTEGRAND_COLUMNS = ("drive", "k", "power", "drive_speed", "motor_load_torque", "motor_acceleration")
KEYS = ("drive_squared", "energy", "energy_driving", "motor_load_squared", "motor_load_acceleration",
        "motor_acceleration_squared", "time")


def columns_at(function, names, P):
    """A function of (sweep values, their cases) -> {name: array} evaluating a load case's
    outputs (``function``: a :class:`~optdesign.kinematics.mapped.MappedFunction`) at each value with its case's
    parameters (a row of ``P``): one call, a parameter row per value (the same numbers, value by
    value, as a call per case)."""
    P = np.atleast_2d(np.asarray(P, float))

    def run(s, case):
        out = function(np.asarray(s, float), P[np.asarray(case, int)])
        return dict(zip(names, (np.asarray(v, float).ravel() for v in out)))
    return run


def certified_integrals(cm, columns, nodes, sigma, cases=1, tol=TOLERANCE, quantities=()) -> list:
    """Per case (``cases`` of them over the same stroke: :func:`.quadrature.integrate_many`,
    every decision the case's own) its integrals over its stroke's time (keys as
    :func:`.duty.case_integrals`'s, with ``errors``: each one's error estimate, and
    ``converged``), from ``columns(s, case)`` -> {name: array} (:func:`columns_at`); ``nodes``:
    the load case's samples (the quadrature's first intervals); ``quantities``: [quantities]
    columns whose squares are integrated too (``squared:NAME``)."""
    nodes = np.asarray(nodes, float)
    lo, hi = float(np.min(nodes)), float(np.max(nodes))
    profile = cm.profile
    if profile is not None and profile.shape.motion_law is not None:
        return _in_time(profile, columns, tol, quantities, cases)
    if profile is None:
        speed = abs(cm.speed)
        V, breaks, m_lo, m_hi = None, np.zeros(0), 1.0, 1.0
    else:
        V = speed_function(profile)
        L = profile.length
        scale = profile.reference_speed
        m_begin = end_power(lambda x: V(x, L - x), L, scale)
        m_end = end_power(lambda y: V(L - y, y), L, scale)
        m_lo, m_hi = (m_begin, m_end) if profile.sigma > 0 else (m_end, m_begin)
        breaks = np.sort(profile.breakpoints())
    cuts = np.unique(np.r_[lo, breaks[(breaks > lo) & (breaks < hi)], hi])
    if len(cuts) == 2 and m_lo > 1 and m_hi > 1:     # one piece, the speed 0 at both ends
        cuts = np.r_[lo, 0.5 * (lo + hi), hi]
    pieces = []
    for j in range(len(cuts) - 1):
        a, b = cuts[j], cuts[j + 1]
        if j == len(cuts) - 2 and m_hi > 1:
            pieces.append((b, a, m_hi))
        else:
            pieces.append((a, b, m_lo if j == 0 else 1.0))
    # the first intervals: the samples and at least FIRST_INTERVALS over the stroke (a load that 3
    # samples cannot see is then found by the quadrature, whatever the sample count)
    grid = np.r_[nodes, np.linspace(lo, hi, FIRST_INTERVALS + 1)]
    starts = [grid[(grid > min(a, b)) & (grid < max(a, b))] for a, b, _ in pieces]
    last = len(pieces) - 1
    anchored_hi = pieces[-1][2] > 1 and pieces[-1][0] == hi
    motor = None

    def f(s, d, piece, case):
        nonlocal motor
        c = columns(s, case)
        from_lo = np.where(piece == 0, d, s - lo) if pieces[0][0] == lo else s - lo
        from_hi = np.where(piece == last, d, hi - s) if anchored_hi else hi - s
        if V is None:
            w = np.abs(c["k"]) / speed
            e = c["power"] * w
        else:
            x, y = (from_lo, from_hi) if profile.sigma > 0 else (from_hi, from_lo)
            with np.errstate(divide="ignore"):
                w = 1.0 / V(x, y)
            e = c["drive"] * c["k"] * sigma
        motor = "motor_load_torque" in c
        return _rows(c, e, w, quantities)

    results = integrate_many(f, pieces, starts, tol, cases=cases)
    closed = profile is not None and profile.law_speed is None
    return [_report(r, motor, profile.duration if closed else None, exact_time=closed, quantities=quantities)
            for r in results]


def _rows(c, e, w, quantities):
    """The integrands at the columns ``c``, in the order of KEYS: drive^2 w, the power e (and
    its driving part), with a motor its load torque^2 w, load torque x acceleration w and
    acceleration^2 w, each quantity^2 w, and the weight w (dt per unit of the variable).  A
    square beyond the largest double is inf here, without numpy's warning: the integral that
    takes it is reported as an error naming the case."""
    with np.errstate(over="ignore", invalid="ignore"):
        rows = [c["drive"] ** 2 * w, e, np.maximum(e, 0.0)]
        if "motor_load_torque" in c:
            tg, acc = c["motor_load_torque"], c["motor_acceleration"]
            rows += [tg**2 * w, tg * acc * w, acc**2 * w]
        return np.vstack(rows + [c[q] ** 2 * w for q in quantities] + [w])


def _report(result, motor, duration, exact_time, quantities=()) -> dict:
    """The integrals' dict from the quadrature's ``result`` (``duration``: the stroke's time in
    closed form, else the quadrature's)."""
    keys = [k for k in KEYS[:-1] if motor or not k.startswith("motor")] + [f"squared:{q}" for q in quantities] + ["time"]
    values = dict(zip(keys, (float(v) for v in result.values)))
    errors = dict(zip(keys, (float(v) for v in result.errors)))
    bad = [k for k, ok in zip(keys, result.converged) if not ok]
    out = {k: values[k] for k in keys if k != "time"}
    if exact_time:   # in closed form: the quadrature's time is a check of the weight (within its error)
        errors["time"] = 0.0
    else:
        duration = values["time"]
    out["duration"] = duration
    out["rms_time"] = math.sqrt(values["drive_squared"] / duration) if duration > 0 else math.nan
    errors["rms_time"] = rms_error(values["drive_squared"], errors["drive_squared"], duration, errors["time"])
    out["errors"] = errors
    out["converged"] = not bad
    out["not_converged"] = bad
    out["intervals"] = result.intervals
    return out


def _in_time(profile, columns, tol, quantities=(), cases=1) -> list:
    """A law in time (s = s_begin + sigma L f(tau), t = T tau): the integrals in tau on each of
    its pieces, dt = T dtau (no weight to invert: the law's inverse is exact only to 2^-16 of
    tau next to a rest), P dt = T_S qd T dtau."""
    law, T = profile.shape.motion_law, profile.shape.time
    edges = (0.0,) + tuple(law.breaks) + (1.0,)
    pieces = [(a, b, 1.0) for a, b in zip(edges[:-1], edges[1:])]
    starts = [np.linspace(a, b, FIRST_INTERVALS // len(pieces) + 1)[1:-1] for a, b, _ in pieces]
    motor = None

    def f(tau, d, piece, case):
        nonlocal motor
        c = columns(profile.law_sweep(tau), case)
        motor = "motor_load_torque" in c
        return _rows(c, c["drive"] * c["drive_speed"] * T, np.full(len(tau), T), quantities)
    return [_report(r, motor, T, exact_time=True, quantities=quantities)
            for r in integrate_many(f, pieces, starts, tol, cases=cases)]


def rms_error(squared, squared_error, duration, duration_error) -> float:
    """The error of sqrt(squared / duration) from those of its two integrals (first order)."""
    if not (squared > 0 and duration > 0):
        return math.sqrt(max(squared_error, 0.0) / duration) if duration > 0 else math.nan
    rms = math.sqrt(squared / duration)
    return 0.5 * rms * (squared_error / squared + duration_error / duration)
