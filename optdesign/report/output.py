"""How results reach files: JSON with inf/nan as null, plain tables, figures without pyplot; each
file written by report/files.py (atomic for a regular file, never replacing a link, FIFO or device)."""
from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from .files import write_file

SCHEMA = "optdesign/1"


def new_figure(nrows=1, ncols=1, figsize=(7, 4), layout="constrained", **subplot_kw):
    """A matplotlib figure and its axes (as ``plt.subplots``) without pyplot: no GUI backend,
    no global figure registry, nothing to close, and ~0.3 s less import time; laid out by
    matplotlib's constrained layout when it is drawn (``layout=None``: the caller places the
    axes, and :func:`save_figures` saves it)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, layout=layout)
    FigureCanvasAgg(fig)
    return fig, fig.subplots(nrows, ncols, **subplot_kw)


def save_figure(fig, path, label=""):
    """Save a matplotlib figure (report/files.py; ``label``: the option that named the path).  A figure from :func:`new_figure` is laid out in
    the one draw that saving makes; any other is cropped to its contents (a second draw)."""
    import io

    buf = io.BytesIO()
    tight = None if fig.get_layout_engine() is not None else "tight"
    fig.savefig(buf, format=Path(path).suffix.lstrip(".") or "png", dpi=120, bbox_inches=tight)
    return write_file(path, buf.getvalue(), label)


def save_figures(fig, paths, label="") -> list:
    """Save a figure whose axes the caller placed (no layout engine: each save is one draw) to
    each of ``paths`` (PNG, SVG, ...) atomically, as it is (not cropped); returns the paths."""
    import io

    written = []
    for path in paths:
        buf = io.BytesIO()
        fig.savefig(buf, format=Path(path).suffix.lstrip(".") or "png", dpi=120)
        written.append(write_file(path, buf.getvalue(), label))
    return written


def _clean(value):
    """Numbers for JSON: floats, with inf/nan as null."""
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    if isinstance(value, (np.floating, float)):
        v = float(value)
        return v if math.isfinite(v) else None
    if isinstance(value, np.integer):
        return int(value)
    return value


class Rows(Sequence):
    """A lazy list of ``n`` rows, ``row(i)`` each: the per-sample part of a large report, made
    one row at a time while it is written (:func:`json_chunks`), never held whole."""

    def __init__(self, n: int, row):
        self.n, self.row = int(n), row

    def __len__(self):
        return self.n

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self.row(j) for j in range(*i.indices(self.n))]
        if i < 0:
            i += self.n
        if not 0 <= i < self.n:
            raise IndexError(i)
        return self.row(i)

    def __iter__(self):
        return (self.row(i) for i in range(self.n))


def to_json(data: dict) -> str:
    """The JSON text of ``data`` (indent 1, inf/nan as null); :class:`Rows` values included."""
    return "".join(json_chunks(data))


def json_chunks(data: dict, batch: int = 500):
    """The text of :func:`to_json` in pieces: a :class:`Rows` value row by row (``batch`` rows
    per piece), so that a report of millions of samples is never one string."""
    if not data:
        yield "{}"
        return
    yield "{"
    for k, (key, value) in enumerate(data.items()):
        yield ("," if k else "") + "\n " + json.dumps(key) + ": "
        if isinstance(value, Rows):
            if not len(value):
                yield "[]"
                continue
            yield "["
            buf = []
            for i, row in enumerate(value):
                buf.append(("," if i else "") + "\n  " + _dumps(row).replace("\n", "\n  "))
                if len(buf) >= batch:
                    yield "".join(buf)
                    buf.clear()
            yield "".join(buf) + "\n ]"
        else:
            yield _dumps(value).replace("\n", "\n ")
    yield "\n}"


def _dumps(value) -> str:
    return json.dumps(_clean(value), indent=1, allow_nan=False)


def table(columns: dict, names=None) -> str:
    """A plain fixed-width table of equal-length arrays."""
    return "".join(table_chunks(columns, names))


def table_chunks(columns: dict, names=None, batch: int = 2000):
    """The text of :func:`table` in pieces of ``batch`` rows (no newline after the last row)."""
    names = list(names or columns)
    width = max(12, *(len(n) + 2 for n in names))
    yield "".join(f"{n:>{width}}" for n in names)
    n = len(columns[names[0]])
    cols = [columns[c] for c in names]
    for start in range(0, n, batch):
        yield "".join("\n" + "".join(f"{col[i]:>{width}.6g}" for col in cols)
                      for i in range(start, min(n, start + batch)))
