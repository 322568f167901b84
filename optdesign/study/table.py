"""cases.csv and pareto.csv: a study's merged rows as tables, and the Pareto front of its rows."""
from __future__ import annotations

import csv
import io
import math
from pathlib import Path

from ..report.files import write_file

CSV = "cases.csv"
LEADING = ("status", "success", "objective", "objective_sampled", "peak_certified", "starts_total",
           "starts_at_best", "warm", "iterations")
GROUPS = ("design:", "constraint:", "multiplier:", "sensitivity:", "peak:", "peak_at:", "peak_sampled:", "rms:")


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
    write_file(path, csv_text(rows, input_names))
    return path


def read_csv(path) -> list:
    """Rows of a study CSV as dicts of strings (for scripts: float(row['objective']))."""
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


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
    write_file(path, buf.getvalue())
    return path
