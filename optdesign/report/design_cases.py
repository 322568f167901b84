"""The load cases in the report of an optimisation (issue 16): the governing case and stroke
position of the peak and of each active constraint, the duty cycle and the drive train at the
optimum (the scene analysed again at the optimal design), and a motor catalogue's outcome.
Adds nothing for a scene without [[cases]]."""
from __future__ import annotations

import math
import re

import numpy as np

from .cases import UNITS, inertia_ratio_text, unresolved_lines
from .drive_train import analyse_at, catalogue_analysis, catalogue_at_optimum, train_summary
from .units import sweep_scale

_IN_CASE = re.compile(r"^(?P<what>.*?) in cases? '(?P<case>[^']*)'(?P<more>(, '[^']*')*)$")
_COLUMN = {"motor peak torque": "motor_torque", "motor speed": "motor_speed", "rod buckling": "rod_buckling"}


_LAST = [None, None]   # (result, its analysis): its JSON, summary and figures share one analysis


def optimum_analysis(result, catalogue=None):
    """The scene analysed at the optimal design (an AnalysisResult of :func:`~optdesign.model.
    analysis.analyse`), or None without one; the last result's kept (results do not change),
    so that its JSON, its summary and its figures analyse it once.  With the motor ``catalogue``
    whose chosen motor's result it is, taken from the catalogue's analysis at that design
    (:func:`.drive_train.catalogue_analysis`: the same numbers, one analysis for both tables)."""
    if not result.success:
        return None
    if _LAST[0] is not result:
        _LAST[:] = [result, _chosen_motor_analysis(result, catalogue)]
    return _LAST[1]


def _chosen_motor_analysis(result, catalogue):
    import dataclasses

    from ..model.case_runs import one_motor

    whole = catalogue_analysis(catalogue) if catalogue is not None and catalogue.best is result else None
    motors = result.scene.motors
    if whole is None or whole.cases is None or len(motors) != 1 or motors[0].name not in whole.cases.train.get("motors", {}):
        return analyse_at(result.scene, result.design)
    return dataclasses.replace(whole, scene=dataclasses.replace(whole.scene, motors=motors),
                               cases=one_motor(whole.cases, motors[0].name))


def keep_optimum_analysis(result, analysis):
    """``analysis`` is :func:`optimum_analysis` of ``result`` (made by another process: the
    figure process gets the command's)."""
    _LAST[:] = [result, analysis]


def cases_at_optimum(result):
    """The scene's cases analysed at the optimal design (a CasesResult), or None."""
    if not result.success or not result.scene.cases:
        return None
    return optimum_analysis(result).cases


def governing(result, cases) -> dict:
    """{'peak': {case, s, value} of the objective's quantity, 'constraints': {name: {case, s}}
    for each active constraint of a case}."""
    out = {"constraints": {}}
    m = re.match(r"^\s*(?:[\d.eE+-]+\s*\*\s*)?peak\s*\(\s*(\w+)", result.scene.objective.minimise)
    if m and m.group(1) in cases.governing:
        out["peak"] = dict(cases.governing[m.group(1)], quantity=m.group(1))
        governing_case = cases.cases[out["peak"]["case"]]
        sampled = governing_case.peaks_sampled.get(m.group(1))
        if sampled is not None:   # the analysis's case peaks are certified; the samples' own beside them
            out["peak"]["value_sampled"] = sampled
        if result.objective_kind == "peak" and result.peak_certified is not None:
            # the optimiser's certified peak over the cases, at its design
            out["peak"]["value"] = result.peak_certified
    for name, c in result.constraints.items():
        hit = _IN_CASE.match(name)
        if not hit or not c.get("active"):
            continue
        which = [hit["case"]] + re.findall(r"'([^']*)'", hit["more"] or "")
        best = None
        for case_name in which:   # cases merged into one row: the one where it is most extreme
            case = cases.cases.get(case_name)
            if case is None:
                continue
            column = case.columns.get(_COLUMN.get(hit["what"])) if hit["what"] in _COLUMN else case.constraints.get(hit["what"])
            if column is None:
                continue
            bound = c["upper"] if c["active"] == "upper" else c["lower"]
            i = int(np.argmin(np.abs(column - bound))) if bound is not None else int(np.argmax(np.abs(column)))
            if best is None or abs(column[i] - bound) < abs(best[2] - bound):
                best = (case_name, float(case.columns["s"][i]), float(column[i]))
        if best is not None:
            out["constraints"][name] = {"case": best[0], "s": best[1], "value": best[2]}
    return out


def cases_json(result) -> dict:
    """The keys an optimisation's JSON gains with [[cases]]: ``cases`` {governing, duty,
    drive_train} at the optimum."""
    cases = cases_at_optimum(result)
    if cases is None:
        return {}
    return {"cases": {"governing": governing(result, cases), "governing_cases": cases.governing,
                      "duty": {k: v for k, v in cases.duty.items() if k != "integrals"},
                      "drive_train": cases.train, "unresolved": unresolved(cases)}}


def unresolved(cases) -> dict:
    """Case name -> the integrals over time its samples do not resolve (model/cases.py), for
    the cases that have any."""
    return {name: c.integrals["unresolved"] for name, c in cases.cases.items() if c.integrals.get("unresolved")}


def cases_summary(result, catalogue=None) -> str:
    """Lines for the summary: where the peak and each active constraint lie, the cycle, the
    drive train at the optimum (with a ``catalogue``, every motor of it at the chosen design)."""
    cases = cases_at_optimum(result)
    if cases is None:
        return ""
    sweep = result.scene.sweep.name
    sf, su = sweep_scale(result.scene)
    su_ = f" {su}" if su else ""
    g = governing(result, cases)
    lines = ["load cases at the optimum:"]
    if result.objective_kind in ("rms_time", "mix"):
        lines.append("  (the RMS over time, energy and mean power below: adaptive quadrature to 1e-10 of each case's "
                     "stroke, model/time_integrals.py; the optimiser's own is the rule on the samples)")
    if "peak" in g:
        p = g["peak"]
        unit = UNITS[result.scene.drive.kind].get(p["quantity"], "")
        unit = f" {unit}" if unit not in ("", "1") else ""
        lines.append(f"  peak |{p['quantity']}| = {p['value']:.9g}{unit}: case {p['case']!r} at {sweep} = "
                     f"{p['s'] * sf:.6g}{su_}")
    for name, c in g["constraints"].items():
        lines.append(f"  active {name}: case {c['case']!r} at {sweep} = {c['s'] * sf:.6g}{su_} (value {c['value']:.6g})")
    duty = cases.duty
    if "reason" not in duty:
        units = UNITS[result.scene.drive.kind]
        rms = ", ".join(f"{k} {v:.6g} {units.get(k, '')}".rstrip() for k, v in duty["rms_time"].items())
        lines.append(f"  duty cycle {duty['cycle_time']:.6g} s: RMS over time {rms}; energy {duty['energy']:.6g} J, "
                     f"mean power {duty['mean_power']:.6g} W")
    for name, u in unresolved(cases).items():
        lines += [f"  case {name!r}:{line[1:]}" for line in unresolved_lines(u, UNITS[result.scene.drive.kind])]
    train = cases.train
    for name, m in train.get("motors", {}).items():
        lines.append(f"  motor {name!r} at i = {train['ratio']:.6g}: {inertia_ratio_text(m, '', 'classical optimal ratio')}")
    doc = {"cases": {"drive_train": train, "governing_cases": cases.governing}}
    if catalogue is not None:
        doc.update(chosen_motor=catalogue.chosen, catalogue_at_optimum=catalogue_at_optimum(catalogue))
    lines += train_summary(doc, (sf, su, sweep))
    return "\n".join(lines)


def catalogue_json(catalogue, result_json) -> dict:
    """The JSON of a catalogue's optimisations: each motor's result, the chosen motor, each
    motor's outcome (``motors``: name -> "fits", "does not fit", "interrupted" or "not tried",
    in the order tried); interrupted by Ctrl-C, ``interrupted`` is true and
    ``interrupted_motor`` says which motor after how many of its starts."""
    stopped = catalogue.interrupted
    return {"chosen_motor": catalogue.chosen, "catalogue_at_optimum": catalogue_at_optimum(catalogue),
            "catalogue": {name: result_json(r) for name, r in catalogue.results.items()},
            "not_tried": list(catalogue.not_tried),
            "motors": {name: outcome for name, outcome, _ in motor_outcomes(catalogue)},
            "proofs": {name: p.to_dict() for name, p in catalogue.proofs.items()},
            "interrupted": stopped is not None,
            "interrupted_motor": None if stopped is None else {
                "name": stopped, "starts_finished": catalogue.interrupted_starts[0],
                "starts_total": catalogue.interrupted_starts[1], "fits": catalogue.chosen == stopped}}


def motor_outcomes(catalogue) -> list:
    """(name, outcome, what) of each motor in the order tried: outcome "fits", "does not fit",
    "interrupted" (Ctrl-C while it was optimised) or "not tried"; ``what`` in words."""
    out = []
    for name, r in catalogue.results.items():
        if name == catalogue.interrupted:
            continue
        what = f"objective {r.objective:.9g}" if r.success else f"no feasible optimum ({r.status})"
        proof = catalogue.proofs.get(name)
        if proof is not None:   # decided before its starts (design/energy_bound.py)
            out.append((name, "does not fit", proof.message()))
            continue
        least = getattr(r, "least_violating", None)
        if not r.success and least and least.get("violated"):   # what the least-violating design breaks
            what += "; the least-violating design exceeds " + ", ".join(
                f"{c} by {by:.4g}" for c, by in least["violated"].items()) + " (in their units)"
        out.append((name, "fits" if r.success else "does not fit", what))
    if catalogue.interrupted is not None:
        done, total = catalogue.interrupted_starts
        starts = f"after {done} of {total} starts" if total else "before its starts were planned"
        r = catalogue.results.get(catalogue.interrupted)
        what = (f"INTERRUPTED by Ctrl-C {starts}: fits, objective {r.objective:.9g}, the best design of those "
                "starts (a feasible design; a search of all its starts may find a better one)" if r is not None
                and r.success else f"INTERRUPTED by Ctrl-C {starts}, none with a feasible design: undecided")
        out.append((catalogue.interrupted, "interrupted", what))
    out += [(name, "not tried", "") for name in catalogue.not_tried]
    return out


def catalogue_summary(catalogue) -> str:
    stopped = catalogue.interrupted is not None
    lines = [f"motor catalogue{' INTERRUPTED by Ctrl-C' if stopped else ''} (each motor optimised with its limits, "
             "smallest rated torque first, until one fits):"]
    lines += [f"  {name}: {what}" for name, outcome, what in motor_outcomes(catalogue) if outcome != "not tried"]
    if catalogue.not_tried:
        why = "a smaller motor fits" if catalogue.chosen else "interrupted before them"
        lines.append(f"  not optimised ({why}): {', '.join(catalogue.not_tried)}")
    if catalogue.chosen is None and stopped:
        lines.append("smallest motor that fits: none found (the catalogue was interrupted before a motor was found "
                     "to fit)")
    else:
        lines.append(f"smallest motor that fits: {catalogue.chosen or 'none'}")
    if catalogue.best is not None:   # what the rest of the summary is
        name = catalogue.best.scene.motors[0].name
        why = "the smallest that fits" if name == catalogue.chosen else "the last motor decided; it does not fit"
        lines.append(f"below: the optimisation with motor {name!r} ({why})")
    return "\n".join(lines)
