"""The duty cycle's integrals at an optimum, certified (issue 27).

The NLP integrates over time with a fixed rule on the case's samples (:func:`.cases.cycle_integrals`:
linear in the sweep between samples, second order).  At the optimum the cycle is analysed again
with the adaptive quadrature of :mod:`optdesign.model.time_integrals` (to 1e-10, with its error
estimate): the reported RMS objective is the certified one, and an optimum is refused when
the samples do not resolve the integrals (the NLP's RMS differs from the certified one by more
than RESOLVED of it: a design optimised for the rule, not for the cycle; the servo press on 3
samples reported an RMS of 34.5 where the cycle's is 107.8) or when a cycle constraint (the
motor's rated torque against its RMS) that held on the samples is violated by the cycle's.
"""
from __future__ import annotations

import numpy as np

RESOLVED = 1e-4     # the NLP's RMS within this fraction of the certified one


def cycle_at(pb, x, fixed=None):
    """The cases analysed at design ``x`` (a CasesResult, its integrals certified)."""
    from ..model.cases import CaseAnalysis

    analysis = pb._once("certified cycle", lambda: CaseAnalysis(pb.mech, pb.mech.stroke()))   # the NLP's rule's samples
    return analysis.run(pb.full_parameters(np.clip(np.asarray(x, float), pb.lower, pb.upper), fixed))


def certify_cycle(pb, sol, nlp_value, fixed=None):
    """(objective, refusal, cycle constraints): the certified objective of an 'rms_time'
    problem at ``sol`` (else ``nlp_value``), '' or why the optimum cannot stand, and each cycle
    constraint's certified value {name: {value, error}}.  Problems without the cycle's
    integrals: (nlp_value, '', {})."""
    time_terms = getattr(pb, "time_terms", ())
    cycle_constraints = getattr(pb, "cycle_constraints", ())
    if not time_terms and not cycle_constraints:
        return nlp_value, "", {}
    duty = cycle_at(pb, sol.x, fixed).duty
    if "reason" in duty:
        return nlp_value, duty["reason"], {}
    rms, errors = duty["rms_time"], duty.get("errors", {}).get("rms_time", {})
    samples = len(pb.mech.stroke())
    value, reasons = nlp_value, []
    if pb.objective_kind == "rms_time":
        what = time_terms[0][2]
        if what in rms:
            value = rms[what]
            if abs(nlp_value - value) > RESOLVED * abs(value):
                reasons.append(f"the RMS over time of {what} on the {samples} samples is {nlp_value:.6g}, the "
                               f"cycle's (adaptive quadrature) {value:.6g} +- {errors.get(what, 0.0):.2g}")
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
