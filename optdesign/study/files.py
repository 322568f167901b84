"""Files of a study: the append-only journal of finished cases, the merged CSV, the figures.

Loss-free by construction:

* ``journal.jsonl`` gets one line per finished case, written with a single ``write`` and made
  durable with ``fsync`` before the next case is recorded.  A process killed at any instant
  leaves at most one torn last line (no newline, or not valid JSON); :meth:`Journal.open`
  ignores it and cuts it off before appending.  Lines are keyed by the case's id, a digest of
  everything its result depends on, so a resumed study (or a changed one in the same folder)
  takes a finished case only when it is the very same computation.
* ``cases.csv`` and every other file are written whole through a temporary file and a rename
  (:func:`optdesign.report.common.write_atomic`): never half-written.
* An exclusive lock on the journal stops two runs from writing the same folder at once.
"""
from __future__ import annotations

import csv
import fcntl
import io
import json
import math
import os
from pathlib import Path

from ..errors import OptdesignError
from ..report.common import save_figure, write_atomic

JOURNAL = "journal.jsonl"
CSV = "cases.csv"
LEADING = ("status", "success", "objective", "objective_sampled", "peak_certified", "starts_total",
           "starts_at_best", "warm", "iterations")
GROUPS = ("design:", "constraint:", "multiplier:", "sensitivity:", "peak:", "rms:")


class Journal:
    """The append-only record of finished cases in ``folder`` (use as a context manager)."""

    def __init__(self, folder):
        self.path = Path(folder) / JOURNAL
        self.records: dict = {}
        self._fh = None

    def __enter__(self):
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._fh = open(self.path, "a+b")
        try:
            fcntl.flock(self._fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            self._fh.close()
            raise OptdesignError(f"{self.path.parent}: another study is running in this folder "
                                 "(its journal is locked); wait for it or choose another --out") from None
        self._read()
        return self

    def __exit__(self, *exc):
        self._fh.close()
        self._fh = None

    def _read(self):
        """Load every complete line; cut a torn last line off the file."""
        fh = self._fh
        fh.seek(0)
        data = fh.read()
        good = 0
        for line in data.splitlines(keepends=True):
            if not line.endswith(b"\n"):
                break
            try:
                record = json.loads(line)
            except ValueError:
                break
            self.records[record["id"]] = record
            good += len(line)
        if good < len(data):
            fh.truncate(good)
            os.fsync(fh.fileno())
        fh.seek(0, os.SEEK_END)

    def add(self, record: dict):
        """Append one finished case, durably (one write, then fsync)."""
        line = json.dumps(record, separators=(",", ":")).encode() + b"\n"
        self._fh.write(line)
        self._fh.flush()
        os.fsync(self._fh.fileno())
        self.records[record["id"]] = record


def columns(input_names, rows) -> list:
    """The CSV's columns: case identification, the inputs, then the results (leading ones in a
    fixed order, the others grouped by prefix in order of first appearance)."""
    seen = []
    for row in rows:
        seen += [k for k in row if k not in seen]
    out = ["case", "id", "chain", "link", *input_names]
    out += [k for k in LEADING if k in seen]
    for prefix in GROUPS:
        out += [k for k in seen if k.startswith(prefix)]
    out += [k for k in seen if k not in out]
    return out


def cell(value) -> str:
    """A CSV cell: floats in their shortest exact form (repr), None as empty."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else ("nan" if math.isnan(value) else repr(value))
    return str(value)


def csv_text(rows, input_names) -> str:
    """The study's CSV from its merged rows (case identification, inputs, results)."""
    cols = columns(input_names, rows)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(cols)
    for r in rows:
        w.writerow([cell(r.get(k)) for k in cols])
    return buf.getvalue()


def write_csv(folder, rows, input_names) -> Path:
    """Write cases.csv atomically."""
    path = Path(folder) / CSV
    write_atomic(path, csv_text(rows, input_names))
    return path


def read_csv(path) -> list:
    """Rows of a study CSV as dicts of strings (for scripts: float(row['objective']))."""
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


# --- figures --------------------------------------------------------------------------------
def _label(name):
    return name + (" [deg]" if "angle" in name else "")


def _conv(name, values):
    import numpy as np

    v = np.asarray(values, float)
    return np.degrees(v) if "angle" in name else v


def figures(study, rows, folder) -> list:
    """Figures of a finished study (one per result quantity group) in ``folder``.

    The innermost axis is the abscissa; each combination of the outer axes is one line.  A
    Pareto axis is drawn as the front: the first goal (the objective) against the achieved
    value of the second (the bounded constraint), the bound values marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if not study.axes or not rows:
        return []
    x_axis = study.axes[-1]
    outer = study.axes[:-1]
    goal = "objective" if study.mode == "optimise" else "peak:drive"
    quantities = [goal]
    if study.mode == "optimise":
        quantities += [k for k in rows[0] if k.startswith("design:")] if rows else []
        quantities = list(dict.fromkeys(quantities + [k for r in rows for k in r if k.startswith("design:")]))
    else:
        quantities += [k for k in ("rms:drive", "peak:power") if any(k in r for r in rows)]
    groups = {}
    for r in rows:
        groups.setdefault(tuple(r.get(a.column) for a in outer), []).append(r)
    drive = "torque [N m]" if study.scene.drive and study.scene.drive.kind == "rotary" else "force [N]"
    written = []
    fig, axes = plt.subplots(len(quantities), 1, figsize=(7, 2.2 * len(quantities) + 0.9), squeeze=False, sharex=True)
    for key, rs in groups.items():
        label = ", ".join(f"{a.label}={_fmt(v)}" for a, v in zip(outer, key)) or None
        ok = [r for r in rs if r.get("success") and r.get(goal) is not None]
        x = _conv(x_axis.label, [r[x_axis.column] for r in ok])
        for ax, q in zip(axes[:, 0], quantities):
            ax.plot(x, _conv(q, [r.get(q, float("nan")) for r in ok]), "o-", ms=3, label=label)
        bad = [r for r in rs if not r.get("success")]
        if bad:
            axes[0, 0].plot(_conv(x_axis.label, [r[x_axis.column] for r in bad]), [float("nan")] * len(bad), "x")
    for ax, q in zip(axes[:, 0], quantities):
        ax.set_ylabel(f"{'optimal ' if study.mode == 'optimise' and q == goal else ''}"
                      + (f"peak drive {drive}" if q in ("objective", "peak:drive") and _is_peak_drive(study)
                         else _label(q.replace("design:", "optimal "))), fontsize=9)
        ax.grid(alpha=0.3)
    if outer:
        axes[0, 0].legend(fontsize=7, ncol=2)
    axes[-1, 0].set_xlabel(_label(x_axis.label))
    axes[0, 0].set_title(f"{study.scene.title[:90]}\n{study.mode} study: {len(rows)} cases", fontsize=9)
    written.append(Path(folder) / "study.png")
    save_figure(fig, written[-1])
    plt.close(fig)
    if x_axis.kind == "pareto" and study.mode == "optimise":
        written.append(pareto_figure(study, groups, outer, folder, drive))
    return written


def _is_peak_drive(study):
    return study.mode == "analyse" or (study.scene.objective is not None
                                       and study.scene.objective.minimise.replace(" ", "") == "peak(drive)")


def _fmt(v):
    return f"{v:.4g}" if isinstance(v, float) else str(v)


def pareto_columns(axis):
    """The columns holding the second goal's achieved value for a Pareto axis."""
    return [f"constraint:{axis.constraint}:{axis.side}", f"constraint:{axis.constraint}"]


def front(study, rows):
    """The non-dominated points of a Pareto axis, per combination of the outer axes:
    [(outer key, [(achieved goal 2, goal 1, row), ...] sorted by goal 2)].  Goal 2 is
    minimised for a 'max' bound and maximised for a 'min' bound."""
    axis = study.axes[-1]
    sign = 1.0 if axis.side == "max" else -1.0
    out = {}
    for r in rows:
        if not r.get("success") or r.get("objective") is None:
            continue
        g2 = next((r[c] for c in pareto_columns(axis) if r.get(c) is not None), None)
        if g2 is None:
            continue
        out.setdefault(tuple(r.get(a.column) for a in study.axes[:-1]), []).append((g2, r["objective"], r))
    fronts = []
    for key, pts in out.items():
        pts.sort(key=lambda p: (sign * p[0], p[1]))
        kept, best = [], math.inf
        for p in pts:   # in order of a worse second goal, keep those that improve the first
            if p[1] < best * (1 - 1e-9):
                kept.append(p)
                best = p[1]
        fronts.append((key, kept))
    return fronts


def pareto_figure(study, groups, outer, folder, drive):
    import matplotlib.pyplot as plt

    axis = study.axes[-1]
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for key, pts in front(study, [r for rs in groups.values() for r in rs]):
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


def pareto_csv(study, rows, folder) -> Path:
    """pareto.csv: the non-dominated points (outer axes, bound, achieved goal 2, goal 1, case)."""
    axis = study.axes[-1]
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow([a.column for a in study.axes[:-1]] + [axis.column, f"{axis.constraint}:{axis.side}", "objective", "case"])
    for key, pts in front(study, rows):
        for g2, g1, r in pts:
            w.writerow([cell(v) for v in key] + [cell(r[axis.column]), cell(g2), cell(g1), r["case"]])
    path = Path(folder) / "pareto.csv"
    write_atomic(path, buf.getvalue())
    return path
