"""Reports of kinematics and of the reduced model (analyse): JSON, tables and figures, with the
seed's names and SI units of each column."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .cases import FIGURES as CASE_FIGURES
from .cases import cases_json, cases_table
from .checks import violation_text, violations, violations_json
from .output import SCHEMA, Rows, table_chunks
from .units import ColumnUnits

UNITS = {
    "rotary": ColumnUnits({"q": "rad", "reduced_inertia": "kg m^2", "reduced_inertia_dq": "kg m^2/rad",
                           "static_load": "N m", "damping_load": "N m", "inertia_term": "N m", "velocity_term": "N m",
                           "drive": "N m", "power": "W", "k": "rad/unit of s"}),
    "linear": ColumnUnits({"q": "m", "reduced_inertia": "kg", "reduced_inertia_dq": "kg/m", "static_load": "N",
                           "damping_load": "N", "inertia_term": "N", "velocity_term": "N", "drive": "N", "power": "W",
                           "k": "m/unit of s"}),
}
SEED_NAMES = {
    "rotary": {"reduced_inertia": "I_zS", "reduced_inertia_dq": "dI_zS/dalpha", "static_load": "T_Su",
               "inertia_term": "I_zS*eps_S", "velocity_term": "dT_S", "drive": "T_S"},
    "linear": {"reduced_inertia": "m_zS", "reduced_inertia_dq": "dm_zS/dx", "static_load": "F_Su",
               "inertia_term": "m_zS*a_S", "velocity_term": "dF_S", "drive": "F_S"},
}
COLUMN_ORDER = ("s", "q", "k", "reduced_inertia", "reduced_inertia_dq", "static_load", "damping_load", "inertia_term",
                "velocity_term", "drive", "power", "efficiency_factor")


def ordered(columns: dict) -> list:
    return [c for c in COLUMN_ORDER if c in columns] + [c for c in columns if c not in COLUMN_ORDER]


# --- kinematics ------------------------------------------------------------------------------
def kinematics_json(result) -> dict:
    """The --json document; its samples are made one by one as they are written (:class:`Rows`)."""
    def sample(i):
        return {
            "s": result.s[i], "q": result.q[i], "sd": result.sd[i], "sdd": result.sdd[i],
            "points": {p: {k: v[i] for k, v in d.items()} for p, d in result.points.items()},
            "bodies": {b: {k: v[i] for k, v in d.items()} for b, d in result.bodies.items()},
        }

    samples = Rows(len(result.s), sample)
    return {"schema": SCHEMA, "kind": "kinematics", "title": result.scene.title,
            "file": result.scene.path, "sweep": result.scene.sweep.name, "samples": samples}


def kinematics_table(result) -> str:
    return "".join(kinematics_table_chunks(result))


def kinematics_table_chunks(result):
    """:func:`kinematics_table` in pieces of rows (for standard output)."""
    cols = {"s": result.s, "q": result.q}
    for p, d in result.points.items():
        for k in ("x", "y", "vx", "vy", "ax", "ay"):
            cols[f"{p}.{k}"] = d[k]
    for b, d in result.bodies.items():
        for k in ("angle", "omega", "epsilon"):
            cols[f"{b}.{k}"] = d[k]
    return table_chunks(cols)


# --- the reduced model -------------------------------------------------------------------------
def analysis_json(result) -> dict:
    """The --json document; its samples are made one by one as they are written (:class:`Rows`)."""
    cols = result.columns
    n = len(cols["s"])
    per_sample = {k: v for k, v in result.constraints.items() if np.ndim(v)}
    names = ordered(cols)

    def sample(i):
        row = {k: cols[k][i] for k in names}
        if result.bodies:
            row["bodies"] = {b: {k: v[i] for k, v in d.items()} for b, d in result.bodies.items()}
        if per_sample:
            row["constraints"] = {k: v[i] for k, v in per_sample.items()}
        if result.quantities:
            row["quantities"] = {k: v[i] for k, v in result.quantities.items()}
        return row

    samples = Rows(n, sample)
    kind = result.drive_kind
    return {
        "schema": SCHEMA, "kind": "analysis", "title": result.scene.title, "file": result.scene.path,
        "sweep": result.scene.sweep.name, "drive": kind,
        "units": {k: UNITS[kind][k] for k in cols if k in UNITS[kind]},
        "seed_names": {k: SEED_NAMES[kind][k] for k in cols if k in SEED_NAMES[kind]},
        "peaks": result.peaks,
        "peaks_sampled": result.peaks_sampled,
        "peak_at": result.peak_at,
        "constraints": {k: v for k, v in result.constraints.items() if not np.ndim(v)},
        "constraints_sampled": result.constraints_sampled,
        "constraint_extremes": result.constraint_extremes,
        "certificates": result.certificates,   # the enclosures' bounds, or why there is none
        "quantity_units": {q.name: q.unit for q in result.scene.quantities},   # [quantities]
        "joints_note": result.joints_note,   # why no joint forces (pin_force(P), ...) are given, or None
        "joints_routes": result.joints_routes,   # the two routes' relative differences (model/joints.py)
        "violations": violations_json(result),   # violated scene constraints: how far, where (report/checks.py)
        "samples": samples,
        **cases_json(result),   # with [[cases]]: cases, governing, duty, drive_train (report/cases.py)
    }


def certificate_lines(result) -> list:
    """What the enclosures proved: one line for all certified figures, one per figure without
    a certificate (docs/certification.md)."""
    certs = getattr(result, "certificates", {}) or {}
    missing = [(k, c["note"]) for k, c in certs.items() if c["note"]]
    lines = []
    if certs and len(missing) < len(certs):
        lines.append("(certified by interval enclosures: no value between the samples exceeds these by more than "
                     "1e-9 of the quantity's largest sampled value)" if not missing else
                     f"(certified by interval enclosures, but for the {len(missing)} below)")
    lines += [f"{k}: {note}" for k, note in missing]
    return lines


def analysis_table(result) -> str:
    return "".join(analysis_table_chunks(result))


def analysis_table_chunks(result):
    """:func:`analysis_table` in pieces: the rows a few thousand at a time, then the peaks."""
    cols = dict(result.columns)
    for name, v in result.constraints.items():
        if np.ndim(v):
            cols[name.replace(" ", "_")] = v
    for name, v in result.quantities.items():   # [quantities], by name (quantity_NAME where a column has it)
        cols[name if name not in cols else f"quantity_{name}"] = v
    yield from table_chunks(cols, ordered(result.columns) + [c for c in cols if c not in result.columns])
    yield from analysis_peaks_chunks(result)


def analysis_peaks_chunks(result, case_samples: bool = True):
    """The lines after the table (peaks, constraints, violations, cases), also printed alone
    (the summary: then without the cases' samples, ``case_samples`` false)."""
    lines = [""]
    sweep = result.scene.sweep.name
    for k, v in result.peaks.items():
        unit = UNITS[result.drive_kind].get(k, "")
        at = result.peak_at.get(k, {}).get("s")
        where = f" at {sweep} = {at:.10g}" if at is not None else ""
        sampled = result.peaks_sampled.get(k)
        tail = f" (samples alone: {sampled:.8g})" if sampled is not None and sampled != v else ""
        lines.append(f"peak |{k}| = {v:.8g}{' ' + unit if unit else ''}{where}{tail}")
    for k, e in result.constraint_extremes.items():
        lines.append(f"{k}: min {e['min']:.8g} at {sweep} = {e['min_s']:.10g}, "
                     f"max {e['max']:.8g} at {sweep} = {e['max_s']:.10g}")
    for k, v in result.constraints.items():
        if not np.ndim(v):
            sampled = result.constraints_sampled.get(k)
            tail = f" (samples alone: {sampled:.8g})" if sampled is not None and sampled != v else ""
            lines.append(f"{k} = {v:.8g}{tail}")
    lines.append(f"(peaks and extremes over the continuous stroke, located between the samples where "
                 f"they lie there; the drive load at every {sweep} is the load at the drive speed and "
                 "acceleration given in [drive])")
    lines += certificate_lines(result)
    lines += [f"violated: {violation_text(result, v)}" for v in violations(result)]   # report/checks.py
    if result.joints_note:
        lines.append(f"joint forces: none ({result.joints_note})")
    if result.joints_routes:   # model/joints.py: the two routes inside the tool
        lines.append(f"joint forces: the drive load from them differs from the virtual-work one by "
                     f"{result.joints_routes['drive']:.1e} of its peak; the reactions' power sums to "
                     f"{result.joints_routes['power']:.1e} of its terms' sizes (9 samples, the scene's parameters)")
    yield "\n" + "\n".join(lines)
    yield cases_table(result, case_samples)   # with [[cases]] (report/cases.py)


FIGURES = ("drive.png", "reduced_inertia.png", "constraints.png", "quantities.png", "joints.png") + CASE_FIGURES


def analysis_figures(result, folder, label="folder") -> list:
    """Figures of the reduced model over the drive coordinate; they replace ``folder`` as a
    whole (:func:`optdesign.report.folder.replace_folder`).  Returns the paths written."""
    from .folder import replace_folder

    return replace_folder(folder, lambda tmp: _analysis_figures(result, tmp), FIGURES, label=label)


def _analysis_figures(result, folder) -> list:
    """drive.png, reduced_inertia.png and constraints.png over the sweep in the scene's units, bounds
    shaded and violations red (report/stroke_plots.py), and the cases' figures: drawn by this
    process and one forked from it at once (report/forked.py), listed in this order."""
    from .cases import cases_figure_jobs
    from .forked import prepare, run_jobs
    from .stroke_plots import inertia_figure, joints_figure, quantities_figure, stroke_figure

    folder = Path(folder)
    # with [[cases]] these are the nominal state's (the cases' own: cases.png), and say so
    note = " (the nominal [drive] state; the load cases: cases.png)" if result.scene.cases else ""
    jobs = [lambda: [stroke_figure([("", result)], folder / "drive.png", components=True, constraints=False,
                                   title=f"{result.scene.title}\ndrive load and its components{note}")]]
    if "reduced_inertia" in result.columns:
        jobs.append(lambda: [inertia_figure(result, folder / "reduced_inertia.png", note)])
    if any(np.ndim(v) for v in result.constraints.values()):
        jobs.append(lambda: [stroke_figure([("", result)], folder / "constraints.png", drive=False,
                                           title=f"{result.scene.title}\nconstraints over the stroke{note}")])
    if result.quantities:   # [quantities]
        jobs.append(lambda: [quantities_figure(result, folder / "quantities.png", note)])
    if any(k.startswith("pin_force(") for k in result.columns):   # analyse --joints
        jobs.append(lambda: [joints_figure(result, folder / "joints.png", note)])
    jobs += cases_figure_jobs(result, folder)
    prepare()
    return run_jobs(jobs)
