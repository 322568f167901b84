"""cases.csv and pareto.csv: a study's merged rows as tables, and the Pareto front of its rows."""
from __future__ import annotations

import csv
import io
import math
import os
from pathlib import Path

from ..report.files import write_file
from .parquet import PARQUET, ParquetWriter
from .blocks import csv_cell as _csv_cell
from .rows import Rows, cell

CSV = "cases.csv"
PARTIAL = f".{CSV}.partial.tmp"   # cases.csv while the study runs (a produced file's temporary name)
LEADING = ("status", "success", "not_certified", "objective", "objective_sampled", "peak_certified", "starts_total",
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


class CsvWriter:
    """cases.csv written while the study runs, into ``PARTIAL`` in the study's folder: a case's row
    is appended once every case before it has finished (case order, whatever order they finish
    in), so that the file is the same, byte for byte, however the cases were run, and it is not
    rebuilt at the end.  Finished cases come in as blocks (:meth:`add_blocks`: a batch's rows
    column by column, written as a whole where they are consecutive), as journal records read
    when the study resumes (:meth:`offer`), or from ``finished(case)`` (a finished case's merged
    row, else None: the journal's record read back) for the cases neither brought; at most
    ``FRESH`` cases wait here for an earlier one.  The rows written are kept in ``rows`` (the
    study's result: a :class:`~optdesign.study.rows.Rows`, column by column).  No file is made
    before the first row is written (the journal's lock is taken first).
    The columns are those of the rows written so far (:func:`columns`); a row bringing a new
    column (the first successful case after failed ones) has the file rewritten once with it, so
    the end result is the table of every finished row whatever came first.  A write that fails
    (a full disk) stops the writing; :func:`write_tables` raises it at the end, when the results
    are written (the journal keeps every case).  The same rows go to cases.parquet
    (:class:`~optdesign.study.parquet.ParquetWriter`), in row groups as they are written."""

    FRESH = 10_000   # finished cases kept while an earlier case runs (more are read back from the journal)
    GATHER = 64      # journal records gathered into one block when they come in case order

    def __init__(self, folder, input_names, cases, finished):
        self.path = Path(folder) / PARTIAL
        self.inputs, self.cases, self.finished = list(input_names), cases, finished
        self.seen, self.cols, self.next, self.rows, self.error = {}, None, 0, Rows(), None
        self.fh = self.writer = None
        self.done, self.waiting, self.gathered = False, {}, []
        self.parquet = ParquetWriter(folder, self.rows)
        axes = getattr(cases, "axes", None)
        # the inputs' cells of each axis point, made once (a Cases sequence; a list of Case: per row)
        self.points = None if axes is None else [[[_csv_cell(v) for _, v in p] for p in a.points] for a in axes]

    # --- finished cases in ---
    def add_blocks(self, blocks):
        """Finished cases of this run (:class:`~optdesign.study.blocks.Block`), then the rows
        that can be written."""
        waiting = self.waiting
        for block in blocks:
            for j, i in enumerate(block.index):
                if i >= self.next and len(waiting) < self.FRESH:
                    waiting[i] = (block, j)
        self.advance()

    def offer(self, record):
        """A journal record read when the study resumes: kept if it is this study's case (its
        index and id) and comes in case order with the ones before it (else read back later).
        Gathered column by column (the record's dicts let go at once)."""
        i, row = record.get("case"), record["row"]
        if type(i) is not int or not self.next <= i < len(self.cases) or self.cases.id(i) != record["id"]:
            return
        got = self.gathered
        if got and (i != got[0][-1] + 1 or tuple(row) != got[2] or len(got[0]) >= self.GATHER):
            self.flush_offered()
            got = self.gathered
        if not got:
            keys = tuple(row)
            got[:] = [[], [], keys, [[] for _ in keys], [], []]   # index, ids, keys, values, x, time_s
        got[0].append(i)
        got[1].append(record["id"])
        for column, value in zip(got[3], row.values()):
            column.append(value)
        got[4].append(record.get("x"))
        got[5].append(record.get("time_s"))

    def flush_offered(self):
        """The records gathered by :meth:`offer` handed on as a block."""
        if self.gathered:
            from .blocks import Block

            got, self.gathered = self.gathered, []
            self.add_blocks([Block(*got)])

    def advance(self):
        """Append the rows from the first case not written up to the first unfinished one."""
        waiting = self.waiting
        while self.next < len(self.cases):
            entry = waiting.pop(self.next, None)
            if entry is not None:
                block, j = entry
                k = j + 1
                while k < len(block) and block.index[k] == self.next + k - j and \
                        waiting.get(block.index[k], (None,))[0] is block:
                    del waiting[block.index[k]]
                    k += 1
                self._add_block(block, j, k)
                self.next += k - j
                continue
            row = self.finished(self.cases[self.next])
            if row is None:
                return
            self._add(row)
            self.next += 1

    def finish(self) -> Rows:
        """Append the finished cases after the first unfinished one too, and close the file;
        returns the rows (once finished, it stays so)."""
        if self.done:
            return self.rows   # finished (and its cases let go: execute)
        self.flush_offered()
        self.advance()
        for i in range(self.next, len(self.cases)):
            entry = self.waiting.pop(i, None)
            if entry is not None:
                self._add_block(entry[0], entry[1], entry[1] + 1)
                continue
            row = self.finished(self.cases[i])
            if row is not None:
                self._add(row)
        self.next, self.done = len(self.cases), True
        if self.cols is None:
            self._write(lambda: self._rewrite(columns(self.inputs, [])))
        self.parquet.finish(self.cols or columns(self.inputs, []))
        self.close()
        return self.rows

    def close(self):
        if self.fh is not None and not self.fh.closed:
            self._write(self.fh.close)
        self.parquet.close()

    def discard(self):
        """The files in progress removed (moved into the folder already, or not to be left there)."""
        self.close()
        self.path.unlink(missing_ok=True)
        self.parquet.path.unlink(missing_ok=True)

    # --- rows out ---
    def _open(self, mode):
        self.fh = open(self.path, mode, newline="")
        self.writer = csv.writer(self.fh, lineterminator="\n")

    def _add(self, row):
        """One merged row (a dict: identification, inputs, results)."""
        self._add_columns(tuple(row), [[v] for v in row.values()], [[_csv_cell(v)] for v in row.values()])

    def _add_block(self, block, j, k):
        """Rows j to k of ``block`` (consecutive cases), merged with their identification and inputs."""
        cases, idx = self.cases, block.index[j:k]
        if self.points is None or set(block.keys) & set(self.inputs):
            for m in range(j, k):   # a list of Case (or a result named as an input): row by row
                case = cases[block.index[m]]
                self._add({"case": case.index, "id": case.id, "chain": case.chain, "link": case.link,
                           **dict(case.inputs), **block.row(m)})
            return
        places = [cases.place(i) for i in idx] if cases.chain else None
        keys = ["case", "id", "chain", "link"]
        values = [idx, block.ids[j:k], [c for c, _ in places] if places else idx,
                  [link for _, link in places] if places else [0] * len(idx)]
        cells = [list(map(str, values[0])), values[1], list(map(str, values[2])), list(map(str, values[3]))]
        for a, (axis, points) in enumerate(zip(cases.axes, self.points)):
            at = cases.column(a, idx)
            for p, (name, _) in enumerate(axis.points[0]):
                keys.append(name)
                values.append([axis.points[q][p][1] for q in at])
                cells.append([points[q][p] for q in at])
        keys += block.keys
        values += [v[j:k] for v in block.values]
        cells += [block.cells(key)[j:k] for key in block.keys]
        self._add_columns(tuple(keys), values, cells)

    def _add_columns(self, keys, values, cells):
        self.rows.extend(keys, values)
        new = [k for k in keys if k not in self.seen]
        if new or self.cols is None:
            self.seen.update(dict.fromkeys(new))
            cols = columns(self.inputs, [self.seen])
            if cols != self.cols:
                self._write(lambda: self._rewrite(cols))
        by_key, blank = dict(zip(keys, cells)), [""] * len(values[0])
        text = "\n".join(map(",".join, zip(*[by_key.get(k, blank) for k in self.cols]))) + "\n"
        self._write(lambda: self.fh.write(text))
        self.parquet.add(self.cols)

    def _write(self, action):
        if self.error is None:
            try:
                action()
            except OSError as exc:
                self.error = exc

    def _rewrite(self, cols):
        """The file again with columns ``cols``: the cells written keep their text, the new
        columns are empty in the rows before (a missing value's cell)."""
        old, self.cols = self.cols, cols
        if self.fh is not None:
            self.fh.close()
        if old is None:
            self._open("w")
            self.writer.writerow(cols)
            return
        tmp = self.path.with_name(f".{CSV}.rewrite.tmp")   # a produced file's temporary: a kill's is dropped
        with open(self.path, newline="") as src, open(tmp, "w", newline="") as dst:
            reader, writer = csv.reader(src), csv.writer(dst, lineterminator="\n")
            next(reader)
            writer.writerow(cols)
            where = [old.index(k) if k in old else None for k in cols]
            for r in reader:
                writer.writerow(["" if j is None else r[j] for j in where])
        os.replace(tmp, self.path)
        self._open("a")


def write_tables(folder, writer: CsvWriter) -> list:
    """cases.csv (and cases.parquet, where pyarrow is installed) in ``folder``: the study's
    :class:`CsvWriter` finished and its files moved there."""
    writer.finish()
    for error in (writer.error, writer.parquet.error):
        if error is not None:
            raise error
    paths = [Path(folder) / CSV]
    os.replace(writer.path, paths[0])
    if writer.parquet.note is None:
        paths.append(Path(folder) / PARQUET)
        os.replace(writer.parquet.path, paths[1])
    return paths


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
