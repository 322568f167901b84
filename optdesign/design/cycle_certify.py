"""The duty cycle's integrals of a solve, certified (issue 27).

The NLP integrates over time with a fixed rule on the case's samples (:func:`.cases.cycle_integrals`:
linear in the sweep between samples, second order, the power-flow switch smoothed): on the servo
press 1.5e-6 of the RMS above the cycle's (-6e-7 from the rule, +2.2e-6 from the smoothing).  So
every solve a start accepts is analysed again with the adaptive quadrature of
:mod:`optdesign.model.time_integrals` (to 1e-10, with its error estimate, the loads unsmoothed
as ``analyse`` has them: :func:`cycle_rms`), and that is the start's objective: the starts are
ranked by the certified value, and the result's objective is the same quantity.  Before a
start may count, each certified RMS is checked by another path (:func:`recheck_cycle`: the
rule on 16 and 8 times denser samples, Richardson-extrapolated).  At the best start the
optimum is refused when the samples do not resolve the integrals (the NLP's RMS differs from
the certified one by more than RESOLVED of it: a design optimised for the rule, not for the
cycle; the servo press on 3 samples reported an RMS of 34.5 where the cycle's is 107.8) or when
a cycle constraint (the motor's rated torque against its RMS) that held on the samples is
violated by the cycle's.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from ..model.case_results import case_nodes
from ..model.case_runs import finish_columns
from ..model.cases import CaseAnalysis
from ..model.duty import case_integrals
from ..model.train import motor_numbers

RESOLVED = 1e-4     # the NLP's RMS within this fraction of the certified one
RECHECK_REL = 1e-9  # the recheck's floor: certified and dense rule agree within this fraction


CERTIFIED = ("drive", "motor_load_torque", "motor_torque")   # with [quantities] names: RMS over time certified


def uncertified(scene) -> list:
    """The names of the scene's rms_time(NAME) objective terms whose RMS over the cycle has no
    certified value (the cycle's quadrature, ``analyse``'s duty, gives one for CERTIFIED and the
    [quantities] names): the NLP's rule on the samples stands for them, and the report says so."""
    import re

    names = re.findall(r"rms_time\s*\(\s*([A-Za-z_]\w*)", scene.objective.minimise or "") if scene.cases else []
    own = {q.name for q in scene.quantities}
    return [n for n in dict.fromkeys(names) if n not in CERTIFIED and n not in own]


def integrated(pb) -> list:
    """The quantities whose RMS over the duty cycle's time the problem integrates: its
    objective's rms_time terms' and its cycle constraints'."""
    return sorted({w for _, _, w, _ in getattr(pb, "time_terms", ())} |
                  {k for _, k, _ in getattr(pb, "cycle_constraints", ())})


def rms_key(what) -> tuple:
    """The key of a cycle's certified RMS in a solution's ``certified`` values."""
    return (f"rms_time({what})", "rms_time")


def cycle_cases(pb):
    """The cases without their peaks' certificates (their integrals are certified), built once."""
    # compiled: every start's certificate runs the cases at the adaptive quadrature's nodes and
    # its recheck on grids 16 and 8 times the scene's (crane_luffing_drive: ~1 s of a 2.5 s start
    # on the virtual machine)
    return pb._once("cycle integrals", lambda: CaseAnalysis(pb.mech, pb.mech.stroke(), certify=False, compile=True))


RECHECK_GRIDS = (16, 8)   # the rule's grids of recheck_cycle, these times denser than the scene's


def warm_cycle(pb):
    """Build what certifying a start's cycle builds on first use: the cases (:func:`cycle_cases`)
    and their time weights on the recheck's dense grids, which depend on the grids and the cases'
    profiles alone (model/duty.CaseTimes.of keeps them), by the recheck's rule at the start design."""
    if integrated(pb):
        rule_rms_grids(pb, pb.start, None)


def cycle_duty(pb, x, fixed=None) -> dict:
    """The duty cycle of the cases at design ``x`` (``analyse``'s: the adaptive quadrature's
    integrals), the last one kept: a start's certificate and the summary's of the same design
    (the best start, polished) are one evaluation."""
    p = pb.full_parameters(np.clip(np.asarray(x, float), pb.lower, pb.upper), fixed)
    key, kept = p.tobytes(), pb._built.get("last duty")
    if kept is None or kept[0] != key:
        kept = pb._built["last duty"] = (key, cycle_cases(pb).run(p).duty)
    return kept[1]


def cycle_rms(pb, x, fixed=None) -> dict:
    """{name: (RMS over the duty cycle's time, its error estimate)} of each integrated quantity
    at design ``x``: the adaptive quadrature of :mod:`optdesign.model.time_integrals` (to 1e-10),
    as ``analyse`` reports it; {} when the cycle has no motion in time."""
    if not integrated(pb):
        return {}
    duty = cycle_duty(pb, x, fixed)
    if "reason" in duty:
        return {}
    rms, errors = duty["rms_time"], duty.get("errors", {}).get("rms_time", {})
    return {k: (float(rms[k]), float(errors.get(k, 0.0))) for k in integrated(pb) if k in rms}


def rule_rms_grids(pb, x, fixed) -> list:
    """:func:`rule_rms` on each of RECHECK_GRIDS, densest first, in one evaluation where a
    coarser grid's samples are the denser one's (linspace's points of a grid 8 times denser are
    every second point of the one 16 times denser, bit for bit, and each sample's columns are
    its own evaluation: the same numbers as evaluated apart)."""
    outputs = {}
    return [rule_rms(pb, x, fixed, factor, outputs) for factor in sorted(RECHECK_GRIDS, reverse=True)]


def _case_columns(function, names, nodes, p_case, outputs, c):
    """Case c's columns at ``nodes`` (as :meth:`CaseAnalysis._evaluate` has them before
    finishing), taken from ``outputs[c]`` (nodes, columns) of a denser grid when ``nodes`` are
    among its nodes, else evaluated (and kept there)."""
    if c in outputs:
        denser, columns = outputs[c]
        order = np.argsort(denser, kind="stable")
        at = np.minimum(np.searchsorted(denser[order], nodes), len(denser) - 1)
        if np.array_equal(denser[order][at], nodes):
            return {k: v[order[at]] for k, v in columns.items()}
    columns = dict(zip(names, (np.asarray(v, float).ravel() for v in function(nodes, p_case))))
    outputs[c] = (nodes, columns)
    return {k: v.copy() for k, v in columns.items()}   # (finishing may change a column in place)


def rule_rms(pb, x, fixed, factor, outputs=None) -> dict:
    """{name: RMS over the duty cycle's time} of each integrated quantity at design ``x`` by
    another path than :func:`cycle_rms`: the rule on the samples of :mod:`optdesign.model.duty`
    (linear in the sweep between samples against the exact time law, second order) on a grid
    ``factor`` times denser than the scene's, the cases' loads unsmoothed (as analysed).
    ``outputs``: each case's columns on a denser grid at this design (:func:`rule_rms_grids`)."""
    a = cycle_cases(pb)
    grid = pb.mech.stroke()
    dense = np.linspace(grid[0], grid[-1], factor * (len(grid) - 1) + 1)
    p = pb.full_parameters(np.clip(np.asarray(x, float), pb.lower, pb.upper), fixed)
    results, evaluated = {}, {}
    for c, (cm, (names, function)) in enumerate(zip(a.cases, a.functions)):
        nodes, _ = case_nodes(dense, cm.profile)
        p_case = cm.case_parameters(p)
        columns = _case_columns(function, names, nodes, p_case, {} if outputs is None else outputs, c)
        values, times = finish_columns(a, cm, names, function, nodes, p_case, columns)[:2]
        sigma = cm.profile.sigma if cm.profile is not None else 1.0
        distance = np.abs(nodes - cm.begins_at(np.sign(values["k"][0])))
        at = {"start": int(np.argmin(distance)), "end": int(np.argmax(distance))}
        results[cm.name] = SimpleNamespace(integrals=case_integrals(times, values, sigma, a.quantities),
                                           duration=times.duration)
        evaluated[cm.name] = {"hold": {k: values["hold_load"][i] for k, i in at.items()},
                              "quantities": {q: {k: values[q][i] for k, i in at.items()} for q in a.quantities}}
    duty = a.duty.evaluate(results, evaluated, p, pb.mech)
    if "reason" in duty:
        return {}
    rms = dict(duty["rms_time"])
    if "integrals" in duty and "motor_load_squared" in duty["integrals"] and len(pb.scene.motors) == 1:
        J = motor_numbers(pb.scene.motors[0], pb.mech.resolved.values)["inertia"]
        sq, cross, acc = (duty["integrals"][k] for k in ("motor_load_squared", "motor_load_acceleration",
                                                         "motor_acceleration_squared"))
        rms["motor_torque"] = float(np.sqrt(max(sq + 2 * J * cross + J * J * acc, 0.0) / duty["cycle_time"]))
    return {k: float(rms[k]) for k in integrated(pb) if k in rms}


def recheck_cycle(pb, x, fixed, certified) -> str | None:
    """None when every certified RMS over the cycle in ``certified`` agrees with the dense rule
    (:func:`rule_rms` 16 and 8 times denser, Richardson-extrapolated), within the rule's own
    error estimate (a third of their difference), the quadrature's and RECHECK_REL; else why not."""
    keys = [k for k in integrated(pb) if rms_key(k) in certified]
    if not keys:
        return None
    fine, coarse = rule_rms_grids(pb, x, fixed)
    for k in keys:
        mine, error = certified[rms_key(k)], certified.get((rms_key(k)[0], "error"), 0.0)
        if k not in fine:
            return f"the RMS over the cycle of {k} has no second evaluation on a denser grid"
        other, estimate = fine[k] + (fine[k] - coarse[k]) / 3, abs(fine[k] - coarse[k]) / 3
        if not abs(mine - other) <= max(estimate, RECHECK_REL * abs(other)) + error:
            return (f"the RMS over the cycle of {k} is {other:.10g} by the rule on {16}x denser samples "
                    f"(Richardson, +- {estimate:.2g}), against its certified {mine:.10g} +- {error:.2g}")
    return None


def certify_cycle(pb, sol, value, rule_value, fixed=None):
    """(objective, refusal, cycle constraints) at the best start's ``sol``: its certified
    objective ``value`` (:func:`.sensitivities.objective_value`: the cycle's integrals by the
    adaptive quadrature), '' or why the optimum cannot stand (the NLP's rule on the samples,
    ``rule_value``, too far from it, or a cycle constraint violated by the certified RMS), and
    each cycle constraint's certified value {name: {value, error}}.  Problems without the
    cycle's integrals: (value, '', {})."""
    time_terms = getattr(pb, "time_terms", ())
    cycle_constraints = getattr(pb, "cycle_constraints", ())
    if not time_terms and not cycle_constraints:
        return value, "", {}
    duty = cycle_duty(pb, sol.x, fixed)
    if "reason" in duty:
        return value, duty["reason"], {}
    rms, errors = duty["rms_time"], duty.get("errors", {}).get("rms_time", {})
    samples = len(pb.mech.stroke())
    reasons = []
    if pb.objective_kind == "rms_time":
        what = time_terms[0][2]
        if what in rms and abs(rule_value - rms[what]) > RESOLVED * abs(rms[what]):
            reasons.append(f"the RMS over time of {what} on the {samples} samples is {rule_value:.6g}, the "
                           f"cycle's (adaptive quadrature) {rms[what]:.6g} +- {errors.get(what, 0.0):.2g}")
    for name, key, limit in cycle_constraints:
        if key in rms and rms[key] > limit * (1 + RESOLVED) + errors.get(key, 0.0):
            reasons.append(f"{name}: the cycle's RMS {key} {rms[key]:.6g} exceeds {limit:.6g} (it held on the "
                           f"{samples} samples)")
    constraints = {name: {"value": rms[key], "error": errors.get(key, 0.0)}
                   for name, key, _ in cycle_constraints if key in rms}
    if not reasons:
        return value, "", constraints
    return value, ("the samples do not resolve the duty cycle's integrals: " + "; ".join(reasons)
                   + ": the optimum is the rule's on the samples, not the cycle's; use more samples "
                   "(--samples, [sweep] samples)"), constraints
