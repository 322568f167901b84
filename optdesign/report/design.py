"""The report of an optimisation: JSON, a text summary, and before/after figures."""
from __future__ import annotations

import dataclasses

from .design_cases import cases_json, cases_summary
from . import design_figures
from .design_figures import FIGURES, write_figures
from .output import SCHEMA, to_json, write_atomic


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
        "starts": [dataclasses.asdict(s) for s in result.starts],
        "timings": result.timings, "settings": dataclasses.asdict(result.settings),
        **cases_json(result),   # with [[cases]]: governing case, duty cycle, drive train (report/design_cases.py)
    }


def summary(result) -> str:
    lines = [f"{result.scene.title}", f"minimise {result.scene.objective.minimise}: "
             + ("OPTIMAL" if result.success else "FAILED") + f" ({result.status})", result.message]
    if result.success:
        lines.append("design:")
        lines += [f"  {k} = {v:.9g}" for k, v in result.design.items()]
        if result.objective_kind in ("rms_time", "mix"):  # load cases over time (report/design_cases.py)
            lines.append(f"objective = {result.objective:.9g} (the RMS over the duty cycle's time on the cases' samples)")
        else:
            lines.append(f"objective = {result.objective:.9g} (certified over the continuous stroke; "
                         f"{result.objective_sampled:.9g} on the scene's samples)")
        if result.peak_certified is not None:
            lines.append(f"peak |drive| certified = {result.peak_certified:.9g}, sampled = {result.peak_sampled:.9g}")
        lines.append("constraints (value, bounds, multiplier = d objective / d active bound):")
        for name, c in result.constraints.items():
            lines.append(f"  {name}: {_fmt(c['value'])} in [{_fmt(c['lower'])}, {_fmt(c['upper'])}]"
                         f"  multiplier {_fmt(c['multiplier'])}" + (f" ({c['active']} active)" if c["active"] else ""))
        if result.sensitivities:
            lines.append("sensitivities d objective / d parameter:")
            lines += [f"  {k}: {v:.6g}" for k, v in result.sensitivities.items()]
        lines += [cases_summary(result)] if result.scene.cases else []   # report/design_cases.py
    lines.append(f"starts: {result.starts_at_best} of {result.starts_total} reached the best value within 0.1 %")
    for s in result.starts:
        obj = "-" if s.objective is None else f"{s.objective:.9g}"
        lines.append(f"  start {s.index:2d}: {s.status}{' (repaired)' if s.repaired else ''}, objective {obj}, "
                     f"{s.iterations} iterations, {s.exchanges} exchanges, {s.time_s * 1e3:.1f} ms")
    lines.append(f"time: {result.timings.get('total_s', float('nan')):.3f} s "
                 f"(build {result.timings.get('build_s', float('nan')):.3f} s)")
    return "\n".join(lines)


def _fmt(v):
    return "-" if v is None else f"{v:.6g}"


FILES = ("result.json", "summary.txt") + FIGURES


def write_results(result, folder, workers=1, label="results folder", animate=True) -> list:
    """Replace ``folder`` as a whole (:func:`optdesign.report.folder.replace_folder`) by one
    holding result.json, summary.txt, the figures, the optimum's animation (unless not
    ``animate``) and report.html (:mod:`.design_figures`); returns the paths."""
    from .folder import replace_folder

    return replace_folder(folder, lambda tmp: _write_results(result, tmp, workers, animate), FILES, label=label)


def _write_results(result, folder, workers, animate=True) -> list:
    written = [folder / "result.json", folder / "summary.txt"]
    write_atomic(written[0], to_json(optimisation_json(result)) + "\n")
    write_atomic(written[1], summary(result) + "\n")
    return written + write_figures(result, folder, workers, animate)


load_figure, mechanism_figure = design_figures.load_figure, design_figures.mechanism_figure
