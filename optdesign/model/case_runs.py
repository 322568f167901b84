"""A scene's load cases at many parameter vectors at once (:meth:`~.cases.CaseAnalysis.run_many`:
an analyse study's batch of cases, :meth:`~.analysis.Analysis.run_many`).

Each load case's columns are evaluated for every parameter vector in one call (a parameter row
per point: :class:`~optdesign.kinematics.mapped.MappedFunction`, the same numbers point by point as a call per
vector), and its peaks located and certified for all of them in one branch and bound
(:meth:`~.certified.CertifiedPeaks.many`).  The rest (the law's checks, the times, the integrals
over time, the duty cycle and the drive train) runs per vector on its own numbers.  Every
decision is taken per vector, so a vector's result is the same bit for bit in any batch; one
that fails carries its error and the others are unaffected."""
from __future__ import annotations

import copy
import dataclasses

import numpy as np

from ..errors import OptdesignError
from ..scene.expressions import evaluate
from .case_results import LOAD, CaseResult, CasesResult, _motor_key, case_nodes
from .duty import PEAK_KEYS, CaseTimes, case_integrals, motor_report
from .finite import check_cases
from .joints import PEAKED
from .profiles import check_law
from .time_integrals import certified_integrals, columns_at
from .train import cylinder_sizing


def run_many(ca_, P) -> list:
    """Per row of ``P`` the :class:`~.case_results.CasesResult` of the :class:`~.cases.CaseAnalysis`
    ``ca_``, or the OptdesignError that stopped it."""
    P = np.atleast_2d(np.asarray(P, float))
    n = len(P)
    errors = [None] * n
    results, evaluated = [{} for _ in range(n)], [{} for _ in range(n)]
    for c, (cm, (names, function), pin_peaks) in enumerate(zip(ca_.cases, ca_.functions, ca_.pin_peaks)):
        nodes, on_sample = case_nodes(ca_.s_values, cm.profile)
        p_case = {}
        for i in (i for i in range(n) if errors[i] is None):
            try:
                p_case[i] = cm.case_parameters(P[i])
            except OptdesignError as exc:
                errors[i] = exc
        staged = _evaluated(ca_, cm, names, function, nodes, p_case, errors)
        pins = _pin_peaks(pin_peaks, nodes, p_case, staged, errors)
        integrals = _integrals(ca_, cm, c, nodes, p_case, staged, errors)
        for i, (values, times, sampled) in staged.items():
            if errors[i] is not None:
                continue
            try:
                results[i][cm.name], evaluated[i][cm.name] = _case_result(
                    ca_, cm, nodes, on_sample, values, times, sampled, pins.get(i), integrals[i])
            except OptdesignError as exc:
                errors[i] = exc
    out = []
    for i in range(n):
        if errors[i] is None:
            try:
                out.append(_cycle(ca_, results[i], evaluated[i], P[i]))
                continue
            except OptdesignError as exc:
                errors[i] = exc
        out.append(errors[i])
    return out


def _evaluated(ca_, cm, names, function, nodes, p_case, errors) -> dict:
    """Per vector i of ``p_case`` (i -> the load case's parameters) that evaluates: (its columns
    at ``nodes``, q unwrapped for a crank; its times; its columns for the peaks), the columns of
    all of them from one call."""
    live = list(p_case)
    if not live:
        return {}
    m = len(nodes)
    raw = function(np.tile(nodes, len(live)), np.repeat(np.array([p_case[i] for i in live]), m, axis=0))
    raw = [np.asarray(v, float).reshape(-1, len(live), m) for v in raw]
    staged = {}
    for j, i in enumerate(live):
        values = dict(zip(names, (v[:, j].ravel() for v in raw)))
        try:
            staged[i] = finish_columns(ca_, cm, names, function, nodes, p_case[i], values)
        except OptdesignError as exc:
            errors[i] = exc
    return staged


def finish_columns(ca_, cm, names, function, nodes, p_case, values):
    """One vector's columns made whole: q unwrapped for a crank, a law's checks and end limits,
    its times; and its columns for the peaks (the motors' torques, the load inertia)."""
    if ca_.mech.scene.drive.kind == "rotary":
        values["q"] = np.unwrap(values["q"])
    if cm.profile is not None and cm.profile.law_speed is not None:
        check_law(cm.profile, nodes, cm.profile.sigma * values["sd"], cm.name, ca_.mech.scene.path)   # V: a reverse case has sd = -V
        _law_end_limits(cm.profile, nodes, values, lambda s: function(s, p_case), names)
    times = CaseTimes.of(cm, nodes, values)
    values["t"] = times.t
    sampled = dict(values, **{_motor_key(name): values["motor_load_torque"] + J * values["motor_acceleration"]
                              for name, J in ca_.motor_inertias.items()})
    if "reduced_inertia" in values:   # the load inertia sampled as the reduced inertia without its efficiency
        sampled[LOAD] = values["reduced_inertia"] / values.get("efficiency_factor", 1.0)
    return values, times, sampled


def _pin_peaks(pin_peaks, nodes, p_case, staged, errors) -> dict:
    """i -> the certified peaks of vector i (:meth:`~.certified.CertifiedPeaks.many` of all the
    vectors still live in one batch; a batch in which one fails is certified again vector by
    vector: each one's result is the same alone)."""
    live = [i for i in staged if errors[i] is None]
    if pin_peaks is None or not live:
        return {}

    def peaks(which):
        P = np.array([p_case[i] for i in which])
        columns = {} if pin_peaks.in_time is not None else {
            name: np.array([staged[i][2][name] for i in which]) for name in pin_peaks.names}
        return pin_peaks.many(nodes, P, columns)

    return _batch_or_each(peaks, live, errors)


def _integrals(ca_, cm, c, nodes, p_case, staged, errors) -> dict:
    """i -> the integrals over time of vector i's load case ``cm``: on its samples
    (:func:`~.duty.case_integrals`), then to :data:`.time_integrals.TOLERANCE` by the adaptive
    quadrature of all the live vectors at once (:func:`~.time_integrals.certified_integrals`),
    with ``errors``, ``sampled`` (the rule on the samples, as the NLP has them) and
    ``unresolved`` (those the quadrature could not bring within its tolerance)."""
    sigma = cm.profile.sigma if cm.profile is not None else 1.0
    sampled = {}
    for i in (i for i in staged if errors[i] is None):
        values, times, _ = staged[i]
        try:
            sampled[i] = case_integrals(times, {"s": nodes, **values}, sigma, ca_.quantities)
        except OptdesignError as exc:
            errors[i] = exc
    live = [i for i, v in sampled.items() if v]
    if not live:
        return sampled

    names, function = ca_.integrands(c)   # (the columns the quadrature reads)

    def exact(which):
        return certified_integrals(cm, columns_at(function, names, [p_case[i] for i in which]), nodes, sigma,
                                   len(which), quantities=ca_.quantities)

    out = dict(sampled)
    for i, found in _batch_or_each(exact, live, errors).items():
        out[i] = {k: found[k] for k in sampled[i]}
        out[i]["duration"] = found["duration"]   # a law's by the quadrature (tanh-sinh's was 1e-7 off at a square root)
        out[i].update(errors=found["errors"], sampled=dict(sampled[i]), intervals=found["intervals"])
        out[i]["unresolved"] = {k: {"value": found[k], "error": found["errors"][k], "samples": len(ca_.s_values),
                                    "sampled_value": sampled[i][k]}
                                for k in ("energy", "rms_time") if k in found["not_converged"] or (
                                    k == "rms_time" and {"drive_squared", "time"} & set(found["not_converged"]))}
    return out


def _batch_or_each(compute, live, errors) -> dict:
    """i -> compute(live)'s result for each i of ``live`` (one per vector, in order); a batch
    that raises an OptdesignError is computed again vector by vector (each one's result is the
    same alone), a vector that raises alone gets its error in ``errors``."""
    try:
        return dict(zip(live, compute(live)))
    except OptdesignError as exc:
        if len(live) == 1:
            errors[live[0]] = exc
            return {}
    out = {}
    for i in live:
        try:
            out[i] = compute([i])[0]
        except OptdesignError as exc:
            errors[i] = exc
    return out


def _case_result(ca_, cm, nodes, on_sample, values, times, sampled, pins, integrals):
    """One vector's :class:`~.case_results.CaseResult` of the load case ``cm`` and what the duty cycle
    reads of it, from its columns, its certified peaks ``pins`` (None without) and its
    ``integrals`` (:func:`_integrals`)."""
    hold = values.pop("hold_load")
    constraints = {k.split(":", 1)[1]: values.pop(k) for k in list(values) if k.startswith("constraint:")}
    distance = np.abs(nodes - cm.begins_at(np.sign(values["k"][0])))
    at = {"start": int(np.argmin(distance)), "end": int(np.argmax(distance))}
    ends = {k: hold[i] for k, i in at.items()}
    columns = {"s": nodes}
    columns.update(values)
    peaks, peak_at = {}, {}
    for key in PEAK_KEYS + tuple(k for k in columns if k.startswith(PEAKED)):
        if key in columns:
            i = int(np.argmax(np.abs(columns[key])))
            peaks[key] = float(abs(columns[key][i]))
            peak_at[key] = {"s": float(nodes[i]), "value": float(columns[key][i])}
    sampled_pins, certificates = {}, {}
    for name in ca_.motor_inertias:   # each motor's torque, sampled
        torque = sampled[_motor_key(name)]
        i = int(np.argmax(np.abs(torque)))
        peaks[_motor_key(name)] = float(abs(torque[i]))
        peak_at[_motor_key(name)] = {"s": float(nodes[i]), "value": float(torque[i])}
    if pins is not None:   # every peak over the continuous stroke, located and certified
        if LOAD in pins:
            peaks[LOAD] = float(np.max(np.abs(sampled[LOAD])))
        for key, (value, where, certificate) in pins.items():
            sampled_pins[key], peaks[key], peak_at[key] = peaks[key], value, where
            certificates[f"peak |{key}|"] = certificate
    load = None if LOAD not in peaks else {
        "value": peaks.pop(LOAD), "at": peak_at.pop(LOAD), "sampled": sampled_pins.pop(LOAD),
        "certificate": certificates.pop(f"peak |{LOAD}|")}
    motors = {name: {"peak": peaks.pop(_motor_key(name)), "at": peak_at.pop(_motor_key(name)),
                     "peak_sampled": sampled_pins.pop(_motor_key(name), None),
                     "certificate": certificates.pop(f"peak |{_motor_key(name)}|", None)}
              for name in ca_.motor_inertias}
    profile = None if cm.case.profile is None else (cm.case.profile if isinstance(cm.case.profile, str)
                                                    else f"inline {cm.profile.shape.kind}")
    result = CaseResult(cm.name, cm.case.direction, profile, cm.case.efficiency,
                        {k: cm.values[k] for k in cm.case.overrides}, columns, peaks, peak_at,
                        integrals.get("duration", times.duration), integrals, on_sample, constraints,
                        sampled_pins, certificates, motors, _rests(cm.profile), load)
    return result, {"hold": ends, "on_sample": on_sample,   # the quantities at a hold too
                    "quantities": {q: {k: columns[q][i] for k, i in at.items()} for q in ca_.quantities}}


def _cycle(ca_, results, evaluated, p_values) -> CasesResult:
    """One vector's duty cycle, drive train and governing cases from its load cases' results."""
    mech = ca_.mech
    duty = ca_.duty.evaluate(results, evaluated, p_values, mech)
    env = mech.resolved.environment(np.asarray(p_values, float))
    values = {k: float(v) for k, v in env.items()}
    train = {}
    if mech.scene.gearbox is not None:
        ratio = float(evaluate(mech.scene.gearbox.ratio, values, {}, "[gearbox] ratio"))
        train = {"ratio": ratio, **motor_report(mech.scene, values, results, duty, ratio)}
        if train.get("motors"):
            chosen = train["smallest_fitting"] or next(iter(train["motors"]))
            train["shown"] = chosen
            add_motor_torque(results, duty, train["motors"][chosen], chosen)
    if mech.scene.cylinder is not None:
        train = cylinder_report(mech.scene, values, results)
    result = CasesResult(results, governing_cases(results), duty, train)
    check_cases(result, "N m" if mech.scene.drive.kind == "rotary" else "N")
    return result

def _rests(profile) -> tuple:
    """The dwells of a segments profile in time: (t from, t to, sweep value) each."""
    law = profile.shape.motion_law if profile is not None else None
    return tuple((law.time * a, law.time * b, stop) for a, b, stop in getattr(law, "rests", ()))

def _law_end_limits(profile, nodes, values, function, names):
    """A law's columns at a stroke's end where its speed falls to 0 like a square root: its
    acceleration V dV/ds is 0 x inf there in the graph (it printed peak drive = nan), so each
    column that is not finite there is replaced by its limit from inside, extrapolated linearly
    from 1e-6 and 2e-6 of the stroke in (off by O(1e-12) of the column's curvature)."""
    for i in (0, len(nodes) - 1):
        if all(np.isfinite(v[i]) for v in values.values()):
            continue
        inward = 1.0 if nodes[i] == min(nodes[0], nodes[-1]) else -1.0
        h = 1e-6 * profile.length
        inner = dict(zip(names, (np.asarray(v, float).ravel() for v in function(nodes[i] + inward * np.array([h, 2 * h])))))
        for k, v in values.items():
            if k in inner and not np.isfinite(v[i]):
                v[i] = 2 * inner[k][0] - inner[k][1]

def cylinder_report(scene, values, results) -> dict:
    """The [cylinder]'s sizes from the cases' peak forces and speeds (:func:`.train.cylinder_sizing`)."""
    cyl = scene.cylinder

    def number(key):
        expr = getattr(cyl, key)
        return None if expr is None else float(evaluate(expr, values, {}, f"[cylinder] {key}"))

    cols = [r.columns for r in results.values()]
    push = max(float(np.max(c["drive"])) for c in cols)
    pull = max(float(np.max(-c["drive"])) for c in cols)
    length = max(float(np.max(c["full_extension"])) for c in cols)
    extend = max(float(np.max(c["drive_speed"])) for c in cols)
    retract = max(float(np.max(-c["drive_speed"])) for c in cols)
    return cylinder_sizing(number, push, pull, length, max(extend, 0.0), max(retract, 0.0))

def add_motor_torque(results, duty, motor, name):
    """The torque of ``motor`` named ``name`` (its rotor inertia J_r) as a column of every
    case, its peak (over the continuous stroke, as :class:`CaseAnalysis` certified it), and its
    RMS over the cycle: T_m = T_g + J_r eps_m."""
    J = motor["inertia"]
    for r in results.values():
        r.columns["motor_torque"] = r.columns["motor_load_torque"] + J * r.columns["motor_acceleration"]
        own = r.motors[name]
        r.peaks["motor_torque"], r.peak_at["motor_torque"] = own["peak"], own["at"]
        if own["peak_sampled"] is not None:
            r.peaks_sampled["motor_torque"] = own["peak_sampled"]
            r.certificates["peak |motor_torque|"] = own["certificate"]
    if "rms" in motor:
        duty["rms_time"]["motor_torque"] = motor["rms"]
        if "rms_error" in motor and "errors" in duty:
            duty["errors"]["rms_time"]["motor_torque"] = motor["rms_error"]

def one_motor(cases: CasesResult, name) -> CasesResult:
    """``cases`` of a scene with several [[motors]] (each motor's numbers made apart: the
    catalogue at its chosen design) as the scene with motor ``name`` alone gives them: the other
    motors left out, ``name``'s torque as the cases' motor_torque, the governing cases again."""
    results = {k: dataclasses.replace(r, motors={name: r.motors[name]}, columns=dict(r.columns), peaks=dict(r.peaks),
                                      peak_at=dict(r.peak_at), peaks_sampled=dict(r.peaks_sampled),
                                      certificates=dict(r.certificates)) for k, r in cases.cases.items()}
    duty, motor = copy.deepcopy(cases.duty), cases.train["motors"][name]
    train = dict(cases.train, motors={name: motor}, smallest_fitting=name if motor["fits"] else None, shown=name)
    add_motor_torque(results, duty, motor, name)
    return CasesResult(results, governing_cases(results), duty, train)


def governing_cases(results: dict) -> dict:
    """For each peak, the case with the largest one: {case, value, s} (brute force over cases)."""
    out = {}
    pins = dict.fromkeys(k for r in results.values() for k in r.peaks if k.startswith(PEAKED))
    for key in PEAK_KEYS + tuple(pins):
        have = [(r.peaks[key], name) for name, r in results.items() if key in r.peaks]
        if have:
            value, name = max(have, key=lambda v: v[0])
            out[key] = {"case": name, "value": value, "s": results[name].peak_at[key]["s"]}
    return out
