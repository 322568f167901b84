"""The report of an optimisation: JSON, a text summary, and before/after figures."""
from __future__ import annotations

import dataclasses

from .design_cases import cases_json, cases_summary
from . import design_figures
from .design_figures import FIGURES, write_figures
from .files import write_file
from .output import SCHEMA, to_json
from .units import ROUND_OFF, constraint_scale, objective_kind_text, peak_quantity


def optimisation_json(result) -> dict:
    """The documented keys (README: "optdesign optimise --json")."""
    return {
        "schema": SCHEMA, "kind": "optimisation", "title": result.scene.title, "file": result.scene.path,
        "objective_kind": result.objective_kind, "minimise": result.scene.objective.minimise,
        "design": result.design, "objective": result.objective, "objective_sampled": result.objective_sampled,
        "peak_certified": result.peak_certified, "peak_sampled": result.peak_sampled,
        "success": result.success, "status": result.status, "message": result.message,
        "starts_total": result.starts_total, "starts_at_best": result.starts_at_best,
        "constraints": result.constraints, "sensitivities": result.sensitivities,
        "sensitivity_notes": getattr(result, "sensitivity_notes", {}),
        "starts": [dataclasses.asdict(s) for s in result.starts],
        "optima": [o.as_dict() for o in result.optima], "least_violating": result.least_violating,
        "start_plan": result.start_plan, "interrupted": getattr(result, "interrupted", False),
        "timings": result.timings, "settings": dataclasses.asdict(result.settings),
        **cases_json(result),   # with [[cases]]: governing case, duty cycle, drive train (report/design_cases.py)
    }


def summary(result, catalogue=None) -> str:
    lines = [f"{result.scene.title}", f"minimise {result.scene.objective.minimise}: {headline(result)}", result.message]
    if result.success:
        lines.append("design:")
        lines += [f"  {k} = {v:.9g}" for k, v in result.design.items()]
        what = objective_kind_text(result)   # a certified peak, or an integral: said so
        sampled = f"; {result.objective_sampled:.9g} on the scene's samples" if result.objective_kind == "peak" else ""
        lines.append(f"objective = {result.objective:.9g} ({what}{sampled})")
        if result.peak_certified is not None:
            lines.append(f"peak |{peak_quantity(result)}| certified = {result.peak_certified:.9g}, "
                         f"sampled = {result.peak_sampled:.9g}")
        lines.append("constraints (value, bounds, multiplier = d objective / d active bound):")
        by_name = {c.name: c for c in result.scene.constraints}
        for name, c in result.constraints.items():
            # in the unit the scene wrote the bounds in (deg), the multiplier per that unit
            f, unit = constraint_scale(by_name[name]) if name in by_name else (1.0, "")
            per = f" per {unit}" if unit else ""
            size = max([abs(c[k]) for k in ("value", "lower", "upper") if c.get(k) is not None], default=0.0) * f
            lines.append(f"  {name}: {_fmt(c['value'], f, size)} in [{_fmt(c['lower'], f)}, {_fmt(c['upper'], f)}]"
                         f"{' ' + unit if unit else ''}  multiplier {_fmt(c['multiplier'], 1 / f)}{per}"
                         + (f" ({c['active']} active)" if c["active"] else ""))
        lines += _lockup_notes(result)
        if result.sensitivities:
            lines.append("sensitivities d objective / d parameter:")
            notes = getattr(result, "sensitivity_notes", {})
            lines += [f"  {k}: {v:.6g}" + (f" ({notes[k]})" if k in notes else "")
                      for k, v in result.sensitivities.items()]
        lines += [cases_summary(result, catalogue)] if result.scene.cases else []   # report/design_cases.py
    lines += starts_lines(result)
    lines.append(f"time: {result.timings.get('total_s', float('nan')):.3f} s "
                 f"(build {result.timings.get('build_s', float('nan')):.3f} s)")
    return "\n".join(lines)


def _lockup_notes(result) -> list:
    """A note per active assembly margin: the optimum takes that construction to its limit
    position (its two links in line), where the mechanism locks or toggles and its velocities
    are infinite; the peak is then only as good as the model next to a singularity."""
    out = []
    for name, c in result.constraints.items():
        if c.get("kind") == "margin" and c.get("active") and name.startswith("assembly of "):
            point = name[len("assembly of "):]
            out.append(f"  note: the optimum takes {point} to its limit position (its links in line, margin "
                       f"{c['value']:.3g}) in the stroke: a lock-up or toggle, where its velocities are infinite; "
                       f"keep it clear with a constraint (a transmission angle at {point}) or narrow the sweep")
    return out


def headline(result) -> str:
    """What the run found, in one phrase: never a plain OPTIMAL for a single start (a local
    optimum), nor a failure where phase 1 found no feasible design (infeasible)."""
    if getattr(result, "interrupted", False) and result.success:
        return (f"INTERRUPTED (the best of the {result.starts_total} starts that finished before Ctrl-C; "
                f"{result.status})")
    if not result.success:
        return "INFEASIBLE (no start could be made feasible)" if result.status == "infeasible" else f"FAILED ({result.status})"
    if result.starts_total == 1:
        return f"local optimum (1 start; {result.status})"
    reached = len(result.optima[0].starts) if result.optima else result.starts_at_best
    return f"OPTIMAL (best of {result.starts_total} starts, reached by {reached}; {result.status})"


def starts_lines(result) -> list:
    """The starts: how many reached the best, the distinct local optima, each start's path."""
    from ..design.clusters import DESIGN_TOL, VALUE_REL, few

    n = result.starts_total
    lines = [f"starts: {result.starts_at_best} of {n} reached the best value within 0.1 %"]
    if result.success and result.optima:
        best = len(result.optima[0].starts)
        if few(best, n):
            lines.append(f"best reached by {best} of {n} starts: run more starts (--starts) to search for a better one")
        lines.append(f"local optima ({len(result.optima)} distinct: objective within {VALUE_REL:g} relative, "
                     f"design within {DESIGN_TOL:g} of each range):")
        for j, o in enumerate(result.optima[:10]):
            design = ", ".join(f"{k} = {v:.6g}" for k, v in o.design.items())
            lines.append(f"  #{j + 1}: {o.value:.9g} from {len(o.starts)} start{'s' if len(o.starts) > 1 else ''} "
                         f"({_indices(o.starts)}): {design}")
        if len(result.optima) > 10:
            lines.append(f"  ... and {len(result.optima) - 10} more (result.json: optima)")
    if result.least_violating:
        lv = result.least_violating
        lines.append("least-violating design: " + ", ".join(f"{k} = {v:.6g}" for k, v in lv["design"].items()))
        lines += [f"  violates {k} by {v:.6g}" for k, v in lv["violated"].items()]
    plan = result.start_plan or {}
    if plan.get("method") == "given":
        lines.append("starts given (retries from screened candidates)")
    elif plan.get("screened"):
        lines.append(f"starts drawn: the scene's start, then the best of {plan['screened']} screened "
                     f"candidates ({plan.get('method')})")
    for s in result.starts:
        obj = "-" if s.objective is None else f"{s.objective:.9g}"
        where = "" if s.optimum is None else f" (optimum #{s.optimum + 1})"
        retries = f", {len(s.tried) - 1} retr{'ies' if len(s.tried) > 2 else 'y'}" if len(s.tried) > 1 else ""
        phase1 = f", phase 1 {s.phase1_iterations} iterations" if s.phase1_iterations else ""
        lines.append(f"  start {s.index:2d}: {s.status}{' (repaired)' if s.repaired else ''}, objective {obj}{where}"
                     f"{retries}{phase1}, {s.iterations} iterations, {s.exchanges} exchanges, {s.time_s * 1e3:.1f} ms")
    return lines


def _indices(starts) -> str:
    shown = ", ".join(map(str, starts[:8]))
    return f"starts {shown}" + (", ..." if len(starts) > 8 else "")


def _fmt(v, factor=1.0, scale=0.0):
    """6 significant digits; 0 where round-off beside values of size ``scale`` (units.ROUND_OFF)."""
    return "-" if v is None else "0" if abs(v * factor) <= ROUND_OFF * scale else f"{v * factor:.6g}"


FILES = ("result.json", "summary.txt") + FIGURES


def write_results(result, folder, workers=1, label="results folder", animate=True, catalogue=None,
                  figures=None) -> list:
    """Replace ``folder`` as a whole (:func:`optdesign.report.folder.replace_folder`) by one
    holding result.json, summary.txt, the figures, the optimum's animation (unless not
    ``animate``) and report.html (:mod:`.design_figures`); returns the paths.  With a motor
    ``catalogue`` (design/catalogue.py) its outcome (each motor tried, the chosen one, those not
    tried) heads the summary and is in result.json, as the command prints them; an unsuccessful
    ``result`` (a catalogue interrupted before a motor was found to fit) has no design to draw:
    result.json and summary.txt alone.  ``figures``: a
    :class:`~.figure_process.FigureProcess` made ready while the result was computed, to draw
    the figures (when it cannot, they are drawn here)."""
    from .folder import replace_folder

    return replace_folder(folder, lambda tmp: _write_results(result, tmp, workers, animate, catalogue, figures),
                          FILES, label=label)


def result_json(result, catalogue=None) -> dict:
    """The JSON document of an optimisation, with its motor catalogue's outcome if any."""
    if catalogue is None:
        return optimisation_json(result)
    from .design_cases import catalogue_json

    return {**optimisation_json(result), **catalogue_json(catalogue, optimisation_json)}


def result_summary(result, catalogue=None) -> str:
    """The summary of an optimisation, headed by its motor catalogue's outcome if any."""
    if catalogue is None:
        return summary(result)
    from .design_cases import catalogue_summary

    return catalogue_summary(catalogue) + "\n\n" + summary(result, catalogue)


def _write_results(result, folder, workers, animate=True, catalogue=None, figures=None) -> list:
    from .design_cases import keep_optimum_analysis, optimum_analysis
    from .drive_train import keep_catalogue_analysis

    written = [folder / "result.json", folder / "summary.txt"]
    # the optimum's analysis made once (with a catalogue, from the catalogue's at the design), by
    # the figure process from the build it made while the motors were optimised when it is there,
    # for the JSON, the summary and (sent with the result) the figure process, which draws while
    # this process writes the JSON and the summary
    made = figures.analysis(result, catalogue) if figures is not None and result.success else None
    if made is not None:
        (keep_catalogue_analysis if catalogue is not None else keep_optimum_analysis)(catalogue or result, made)
    optimum = optimum_analysis(result, catalogue)
    sent = figures is not None and result.success and figures.send(result, folder, workers, animate, optimum)
    try:
        write_file(written[0], to_json(result_json(result, catalogue)) + "\n")
        write_file(written[1], result_summary(result, catalogue) + "\n")
    except BaseException:
        if sent:
            figures.close()   # stopped: nothing more is written into the folder
        raise
    if not result.success:   # no design to draw
        return written
    drawn = figures.receive() if sent else None
    return written + (drawn if drawn is not None else write_figures(result, folder, workers, animate))


load_figure, mechanism_figure = design_figures.load_figure, design_figures.mechanism_figure
