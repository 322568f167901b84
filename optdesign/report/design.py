"""The report of an optimisation: JSON, a text summary, and before/after figures."""
from __future__ import annotations

import dataclasses
import multiprocessing
import textwrap
from pathlib import Path

import numpy as np

from .design_cases import cases_json, cases_summary
from .output import SCHEMA, new_figure, save_figure, to_json, write_atomic


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


FILES = ("result.json", "summary.txt", "drive_and_constraints.png", "mechanism.png", "mechanism.svg")


def write_results(result, folder, workers=1, label="results folder") -> list:
    """Replace ``folder`` as a whole (:func:`optdesign.report.folder.replace_folder`) by one
    holding result.json, summary.txt and the figures; returns the paths.  With ``workers`` > 1
    the mechanism figure is drawn by a forked process while this one draws the other (each
    figure takes ~0.3 s of rasterising)."""
    from .folder import replace_folder

    return replace_folder(folder, lambda tmp: _write_results(result, tmp, workers), FILES, label=label)


def _write_results(result, folder, workers) -> list:
    written = [folder / "result.json", folder / "summary.txt"]
    write_atomic(written[0], to_json(optimisation_json(result)) + "\n")
    write_atomic(written[1], summary(result) + "\n")
    if workers > 1 and "fork" in multiprocessing.get_all_start_methods():
        import matplotlib.backends.backend_agg  # noqa: F401  (imported once, before the fork)

        child = multiprocessing.get_context("fork").Process(target=mechanism_figure, args=(result, folder))
        child.start()
        written.append(load_figure(result, folder))
        child.join()
        # the child writes atomically; should it have failed, draw the figure here
        written.append(mechanism_figure(result, folder) if child.exitcode != 0 else folder / "mechanism.png")
    else:
        written += [load_figure(result, folder), mechanism_figure(result, folder)]
    written.append(folder / "mechanism.svg")
    return written


def load_figure(result, folder) -> Path:
    """Drive load and per-sample constraints over the stroke, start and optimum on one figure, in
    the units the scene wrote (report/stroke_plots.py): bounds drawn with the feasible side
    shaded, violations red, the peaks and their positions marked."""
    from ..model.analysis import Analysis
    from .stroke_plots import stroke_figure

    scene = result.scene
    after = scene.with_parameters(**result.design)
    runs = [("start", Analysis(scene).run()), ("optimum", Analysis(after).run())]
    path = Path(folder) / "drive_and_constraints.png"
    stroke_figure(runs, path, title=f"{scene.title}\n{scene.objective.minimise}: start and optimum")
    return path


def mechanism_figure(result, folder) -> Path:
    """The engineering drawing of the start and the optimum side by side at one scale
    (mechanism.png and mechanism.svg); returns the PNG's path."""
    from .mechanism import mechanism_figure as draw

    scene = result.scene
    folder = Path(folder)
    draw([("start", scene), ("optimum", scene.with_parameters(**result.design))],
         [folder / "mechanism.png", folder / "mechanism.svg"], suptitle=scene.title)
    return folder / "mechanism.png"
