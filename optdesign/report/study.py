"""Figures of a study: each result quantity against the innermost axis, and the Pareto front."""
from __future__ import annotations

from pathlib import Path

from .output import save_figure


def _label(name):
    return name + (" [deg]" if "angle" in name else "")


def _conv(name, values):
    import numpy as np

    v = np.asarray(values, float)
    return np.degrees(v) if "angle" in name else v


def figures(study, rows, folder, fronts=None) -> list:
    """Figures of a finished study (one per result quantity group) in ``folder``.

    The innermost axis is the abscissa; each combination of the outer axes is one line.  A
    Pareto axis is drawn as the front: the first goal (the objective) against the achieved
    value of the second (the bounded constraint), the bound values marked; ``fronts`` are its
    non-dominated points (:func:`optdesign.study.table.front`)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    if not study.axes or not rows:
        return []
    x_axis = study.axes[-1]
    outer = study.axes[:-1]
    goal = "objective" if study.mode == "optimise" else "peak:drive"
    quantities = [goal]
    if study.mode == "optimise":
        quantities += [k for k in rows.names() if k.startswith("design:")]
    else:
        quantities += [k for k in ("rms:drive", "peak:power") if rows.has(k)]
    # the rows' columns as arrays (rows: optdesign.study.rows.Rows; a million rows are not built as dicts)
    x_all = rows.column(x_axis.column)
    success = rows.column("success") == 1
    ok_all = success & ~np.isnan(rows.column(goal))
    values = {q: rows.column(q) for q in quantities}
    groups = {}
    keys = zip(*(rows.column(a.column) for a in outer)) if outer else [()] * len(rows)   # one axis: one line
    for i, key in enumerate(keys):
        groups.setdefault(key, []).append(i)
    drive = "torque [N m]" if study.scene.drive and study.scene.drive.kind == "rotary" else "force [N]"
    written = []
    fig, axes = plt.subplots(len(quantities), 1, figsize=(7, 2.2 * len(quantities) + 0.9), squeeze=False, sharex=True)
    for key, index in groups.items():
        first = rows[index[0]]
        label = ", ".join(f"{a.label}={_fmt(first.get(a.column))}" for a in outer) or None
        index = np.asarray(index)
        ok, bad = index[ok_all[index]], index[~success[index]]
        x = _conv(x_axis.label, x_all[ok])
        for ax, q in zip(axes[:, 0], quantities):
            ax.plot(x, flat(_conv(q, values[q][ok])), "o-", ms=3, label=label)
        if bad.size:
            axes[0, 0].plot(_conv(x_axis.label, x_all[bad]), [float("nan")] * bad.size, "x")
    for ax, q in zip(axes[:, 0], quantities):
        ax.set_ylabel(f"{'optimal ' if study.mode == 'optimise' and q == goal else ''}"
                      + (f"peak drive {drive}" if q in ("objective", "peak:drive") and _is_peak_drive(study)
                         else _label(q.replace("design:", "optimal "))), fontsize=9)
        ax.grid(alpha=0.3)
    if outer:
        axes[0, 0].legend(fontsize=7, ncol=2)
    for ax in axes[:, 0]:
        ax.ticklabel_format(axis="y", useOffset=False)   # no offset: a flat line reads as its value
    axes[-1, 0].set_xlabel(_label(x_axis.label))
    axes[0, 0].set_title(f"{study.scene.title[:90]}\n{study.mode} study: {len(rows)} cases", fontsize=9)
    written.append(Path(folder) / "study.png")
    save_figure(fig, written[-1])
    plt.close(fig)
    if x_axis.kind == "pareto" and study.mode == "optimise":
        written.append(pareto_figure(study, fronts or [], outer, folder, drive))
    return written


NOISE = 1e-8   # the optimiser's relative agreement of a certified peak (design.problem.Settings.peak_tol)


def flat(values):
    """``values`` drawn flat (their mean) where they differ by less than the optimiser's
    tolerance relative to their size: a quantity a study's axis does not change plotted as
    1e-11 noise read as a trend."""
    import numpy as np

    v = np.asarray(values, float)
    finite = v[np.isfinite(v)]
    if finite.size > 1 and np.ptp(finite) <= NOISE * max(float(np.max(np.abs(finite))), 1e-300):
        return np.where(np.isfinite(v), float(np.mean(finite)), v)
    return v


def _is_peak_drive(study):
    return study.mode == "analyse" or (study.scene.objective is not None
                                       and study.scene.objective.minimise.replace(" ", "") == "peak(drive)")


def _fmt(v):
    return f"{v:.4g}" if isinstance(v, float) else str(v)


def pareto_figure(study, fronts, outer, folder, drive):
    import matplotlib.pyplot as plt

    axis = study.axes[-1]
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for key, pts in fronts:
        label = ", ".join(f"{a.label}={_fmt(v)}" for a, v in zip(outer, key)) or "front"
        ax.plot(_conv(axis.constraint, [p[0] for p in pts]), [p[1] for p in pts], "o-", ms=4, label=label)
    ax.set_xlabel(f"{_label(axis.constraint)} ({axis.side} over the stroke, at the optimum)")
    ax.set_ylabel(f"optimal peak drive {drive}" if _is_peak_drive(study) else "optimal objective")
    ax.set_title(f"Pareto front by the epsilon-constraint method: {study.scene.objective.minimise} vs "
                 f"{axis.constraint} ({axis.side} bound swept)", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    path = Path(folder) / "pareto.png"
    save_figure(fig, path)
    plt.close(fig)
    return path
