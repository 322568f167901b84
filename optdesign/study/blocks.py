"""Finished cases handled a batch at a time (:class:`Block`): the client's work per case in
calls over a batch's columns, not in Python per value.

A batch of cases that comes back from an executor is cut into blocks of cases whose rows have
the same keys (most batches: one block).  A block holds its rows column by column; each value
is turned into text once (a float's ``repr``) and that text serves both the journal's lines
(:meth:`Block.journal`: the very bytes ``json.dumps(record, separators=(",", ":"))`` gives, one
line per case) and cases.csv's cells (:meth:`Block.cells`: :func:`~optdesign.study.rows.cell`'s
text, quoted as the csv module quotes).

A block travels from the process that computed it to the client (a pool's pipe, Dask) as what
the client needs and nothing twice: the journal's lines as one bytes object with each line's
length, the CSV cells per column, a column of floats as an array of doubles (the values
:class:`~optdesign.study.rows.Rows` and cases.parquet keep), not the JSON texts the lines were
made from (:meth:`Block.__reduce__`)."""
from __future__ import annotations

import csv
import io
import json
import math
import re
from array import array

from .rows import cell

_HEX_IDS = re.compile(r"(?:[0-9a-f]{16})*")
_JSON_SPECIAL = {"nan": "NaN", "inf": "Infinity", "-inf": "-Infinity"}
_ENCODE = json.JSONEncoder(separators=(",", ":")).encode


class Block:
    """Finished cases (``index``, ``ids``) whose rows have the keys ``keys``: ``values[k]`` the
    k-th key's values, one per case (a list, or an array of doubles where they are all floats);
    ``x`` and ``time_s`` per case (the journal's); ``cpu_s`` the processor time per case of the
    batch that computed them where it was measured (not journalled: it sizes the next batches,
    whatever else runs on the machine), else None."""

    __slots__ = ("index", "ids", "keys", "values", "x", "time_s", "cpu_s", "_json", "_cells", "_floats",
                 "_journal")

    def __init__(self, index, ids, keys, values, x, time_s, cpu_s=None):
        self.index, self.ids, self.keys, self.values = list(index), list(ids), tuple(keys), list(values)
        self.x, self.time_s, self.cpu_s = list(x), list(time_s), cpu_s
        self._json = self._cells = self._floats = self._journal = None

    def __len__(self):
        return len(self.ids)

    def __reduce__(self):
        """Pickled as the client needs it (the module's docstring): the journal's bytes and the
        CSV cells made first, a column of floats as an array of doubles."""
        data, lengths = self.journal()
        values = [array("d", v) if f and type(v) is list else v for v, f in zip(self.values, self._floats)]
        return _unpickled, (self.index, self.ids, self.keys, values, self.x, self.time_s, self.cpu_s, self._cells,
                            self._floats, data, lengths)

    def row(self, j) -> dict:
        return {k: v[j] for k, v in zip(self.keys, self.values)}

    def _texts(self):
        """Per key, the values' JSON texts and their CSV cells (the same strings where they agree)."""
        if self._cells is None:
            made = [_column_text(v) for v in self.values]
            self._json = [t for t, _, _ in made]
            self._cells = [c for _, c, _ in made]
            self._floats = [f for _, _, f in made]

    def journal(self) -> tuple:
        """The journal's lines of these cases (record: id, case, row, x, time_s; newlines
        included) as one bytes object, and each line's length in bytes (ASCII: its characters)."""
        if self._journal is None:
            lines = self._make_lines()
            self._journal = "".join(lines).encode(), array("I", map(len, lines))
        return self._journal

    def lines(self) -> list:
        """:meth:`journal`'s lines, one string each."""
        data, lengths = self.journal()
        text, out, at = data.decode(), [], 0
        for n in lengths:
            out.append(text[at:at + n])
            at += n
        return out

    def _make_lines(self) -> list:
        if not _HEX_IDS.fullmatch("".join(self.ids)):   # ids are 16 hex digits: no escapes
            raise ValueError(f"study journal: case ids must be 16 hex digits, found {self.ids[:3]}")
        self._texts()
        keys = [_ENCODE(k) + ":" for k in self.keys]
        pairs = [[key + t for t in text] for key, text in zip(keys, self._json)]
        rows = map(",".join, zip(*pairs)) if pairs else [""] * len(self)
        xs = [_ENCODE(x) if x is not None else "null" for x in self.x]
        return [f'{{"id":"{i}","case":{n},"row":{{{r}}},"x":{x},"time_s":{t}}}\n'
                for i, n, r, x, t in zip(self.ids, self.index, rows, xs, _json_column(self.time_s))]

    def cells(self, key):
        """The CSV cells of column ``key`` (None if the rows do not have it)."""
        try:
            k = self.keys.index(key)
        except ValueError:
            return None
        self._texts()
        return self._cells[k]


def _unpickled(index, ids, keys, values, x, time_s, cpu_s, cells, floats, data, lengths):
    block = Block.__new__(Block)
    block.index, block.ids, block.keys, block.values = index, ids, keys, values
    block.x, block.time_s, block.cpu_s = x, time_s, cpu_s
    block._json, block._cells, block._floats, block._journal = None, cells, floats, (data, lengths)
    return block


def blocks(index, ids, outs) -> list:
    """The finished cases ``index``/``ids`` with their outputs ``outs`` (run_batch's: row, x,
    time_s) as blocks of rows with the same keys, in order of their first case."""
    groups = {}
    for j, out in enumerate(outs):
        groups.setdefault(tuple(out["row"]), []).append(j)
    made = []
    for keys, js in groups.items():
        rows = [outs[j]["row"] for j in js]
        made.append(Block([index[j] for j in js], [ids[j] for j in js], keys,
                          [[r[k] for r in rows] for k in keys],
                          [outs[j]["x"] for j in js], [outs[j]["time_s"] for j in js]))
    return made


def as_blocks(cases, outs) -> list:
    """An executor's answer for ``cases`` as blocks: the blocks made where the batch ran, or its
    outputs (a list of run_batch's dicts) made blocks here."""
    if outs and type(outs[0]) is Block:
        return outs
    return blocks([c.index for c in cases], [c.id for c in cases], outs)


def as_outputs(cases, outs) -> list:
    """An executor's answer for ``cases`` as run_batch's outputs, one per case in their order
    (the inverse of :func:`as_blocks`)."""
    if not (outs and type(outs[0]) is Block):
        return list(outs)
    where = {}
    for block in outs:
        for j, i in enumerate(block.index):
            where.setdefault(i, []).append((block, j))
    found = [where[c.index].pop(0) for c in cases]
    return [{"row": b.row(j), "x": b.x[j], "time_s": b.time_s[j]} for b, j in found]


def _column_text(values):
    """(JSON texts, CSV cells, whether they are all floats) of one column's values."""
    kinds = set(map(type, values))
    if kinds == {float}:
        text = _float_texts(values)
        joined = "".join(text)
        if "n" in joined:   # nan, inf: JSON's NaN, Infinity (a finite float's repr has no n)
            return [_JSON_SPECIAL.get(t, t) for t in text], text, True
        return text, text, True
    if kinds <= {bool}:
        text = ["true" if v else "false" for v in values]
        return text, text, False
    if len(values) > 8:   # the distinct values' texts made once (a status repeated down the column)
        distinct = set(values) if all(t in (str, int, type(None)) for t in kinds) else None
        if distinct is not None and len(distinct) * 4 <= len(values):
            json_text = {v: _ENCODE(v) for v in distinct}
            csv_text = {v: csv_cell(v) for v in distinct}
            return [json_text[v] for v in values], [csv_text[v] for v in values], False
    return [_ENCODE(v) for v in values], [csv_cell(v) for v in values], False


def _float_texts(values) -> list:
    """``repr`` of each float (the shortest text that reads back as it: ~1-2 us each, most of a
    batch's text), made once per distinct value where a column repeats them (a geometry's
    constraint extremes or a peak's place in a study that varies masses: 1-20 distinct values in
    256); not where 0.0 is among them (0.0 == -0.0, whose texts differ)."""
    distinct = set(values)
    if len(distinct) * 2 > len(values) or 0.0 in distinct:
        return list(map(repr, values))
    texts = {v: repr(v) for v in distinct}
    return [texts[v] for v in values]


def _json_column(values) -> list:
    if set(map(type, values)) == {float} and not any(map(math.isinf, values)) and not any(map(math.isnan, values)):
        return list(map(repr, values))
    return [_ENCODE(v) for v in values]


_QUOTED: dict = {}


def csv_cell(value) -> str:
    """``cell(value)`` as the csv module writes it in a row (quoted where it must be)."""
    text = cell(value)
    if not ("," in text or '"' in text or "\n" in text or "\r" in text):
        return text
    quoted = _QUOTED.get(text)
    if quoted is None:
        buf = io.StringIO()
        csv.writer(buf, lineterminator="\n").writerow([text, ""])
        quoted = buf.getvalue()[:-2]
        if len(_QUOTED) < 4096:
            _QUOTED[text] = quoted
    return quoted
