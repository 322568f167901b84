"""cases.csv and pareto.csv: a study's merged rows as tables, and the Pareto front of its rows."""
from __future__ import annotations

import csv
import io
import math
import os
from pathlib import Path

from ..report.files import write_file

CSV = "cases.csv"
PARTIAL = f".{CSV}.partial.tmp"   # cases.csv while the study runs (a produced file's temporary name)
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


class CsvWriter:
    """cases.csv written while the study runs, into ``PARTIAL`` in the study's folder: a case's row
    is appended once every case before it has finished (case order, whatever order they finish
    in), so that the file is the same, byte for byte, however the cases were run, and nothing but
    the file grows with the study.  ``finished(case)`` gives a finished case's merged row, else
    None.  The columns are those of the rows written so far (:func:`columns`); a row bringing a
    new column (the first successful case after failed ones) has the file rewritten once with it,
    so the end result is the table of every finished row whatever came first."""

    def __init__(self, folder, input_names, cases, finished):
        self.path = Path(folder) / PARTIAL
        self.inputs, self.cases, self.finished = list(input_names), cases, finished
        self.seen, self.cols, self.next = {}, None, 0
        self.fh = open(self.path, "w", newline="")
        self.writer = csv.writer(self.fh, lineterminator="\n")

    def advance(self):
        """Append the rows from the first case not written up to the first unfinished one."""
        while self.next < len(self.cases):
            row = self.finished(self.cases[self.next])
            if row is None:
                return
            self._write(row)
            self.next += 1

    def finish(self) -> Path:
        """Append the finished cases after the first unfinished one too, and close the file."""
        for i in range(self.next, len(self.cases)):
            row = self.finished(self.cases[i])
            if row is not None:
                self._write(row)
        self.next = len(self.cases)
        if self.cols is None:
            self.writer.writerow(columns(self.inputs, []))
        self.close()
        return self.path

    def close(self):
        if not self.fh.closed:
            self.fh.close()

    def _write(self, row):
        new = [k for k in row if k not in self.seen]
        if new or self.cols is None:
            self.seen.update(dict.fromkeys(new))
            cols = columns(self.inputs, [self.seen])
            if cols != self.cols:
                self._rewrite(cols)
        self.writer.writerow([cell(row.get(k)) for k in self.cols])

    def _rewrite(self, cols):
        """The file again with columns ``cols``: the cells written keep their text, the new
        columns are empty in the rows before (a missing value's cell)."""
        old, self.cols = self.cols, cols
        self.fh.close()
        if old is not None:
            tmp = self.path.with_name(self.path.name + ".new")
            with open(self.path, newline="") as src, open(tmp, "w", newline="") as dst:
                reader, writer = csv.reader(src), csv.writer(dst, lineterminator="\n")
                next(reader)
                writer.writerow(cols)
                where = [old.index(k) if k in old else None for k in cols]
                for r in reader:
                    writer.writerow(["" if j is None else r[j] for j in where])
            os.replace(tmp, self.path)
            self.fh = open(self.path, "a", newline="")
        else:
            self.fh = open(self.path, "w", newline="")
        self.writer = csv.writer(self.fh, lineterminator="\n")
        if old is None:
            self.writer.writerow(cols)


def write_csv(folder, writer: CsvWriter) -> Path:
    """cases.csv in ``folder``: the study's :class:`CsvWriter` finished and moved there."""
    path = Path(folder) / CSV
    os.replace(writer.finish(), path)
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
