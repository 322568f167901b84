"""cases.parquet: a study's rows as a Parquet table (Apache Arrow's columnar file, the field's
standard for large tables: read by pandas, polars, DuckDB, Spark), written beside cases.csv while
the study runs.

The same rows as cases.csv, in the same order and the same columns: a row group is written each
time ``GROUP`` rows are in (the rows come in case order from :class:`~optdesign.study.table.
CsvWriter`), so memory holds one group, not the table.  Each column takes the Arrow type of its
values: float64, int64, bool, or string; a column whose values are of different kinds (an int
beside a float, a number beside a text) is a string column of cases.csv's cells, so nothing is
converted to something it was not.  Read back, every cell of cases.csv is there: a missing value
or None as null (cases.csv's empty cell), a float as the same double.  When a later group brings
a new column, or a column changes type (its first values were all missing), the groups written
so far are copied once into a new file with the wider schema, group by group.

Without pyarrow (an optional dependency: ``pip install 'optdesign[parquet]'``) nothing is
written and :attr:`ParquetWriter.note` says so; the study is not affected."""
from __future__ import annotations

import os
from pathlib import Path

PARQUET = "cases.parquet"
PARTIAL = f".{PARQUET}.partial.tmp"   # cases.parquet while the study runs
REWRITE = f".{PARQUET}.rewrite.tmp"
GROUP = 10_000                         # rows per row group (~2 MB of a 25-column row)
MISSING_NOTE = "cases.parquet not written: pyarrow is not installed (pip install 'optdesign[parquet]' or pip install pyarrow)"


_KINDS = {type(None): "null", bool: "bool", int: "int", float: "float", str: "string"}


def _kind(values) -> str:
    """The kind of a column's values (one pass over their types, not a call per value)."""
    kinds = {_KINDS.get(t, "string") for t in set(map(type, values))}
    kind = "null"
    for k in kinds:
        kind = _merge(kind, k)
    if kind == "int" and any(not -2**63 <= v < 2**63 for v in values if v is not None):
        return "string"   # an int beyond int64 as its text
    return kind


def _merge(a: str, b: str) -> str:
    return b if a == "null" or a == b else a if b == "null" else "string"


class ParquetWriter:
    """cases.parquet written in ``folder`` (under ``PARTIAL``) as rows come in, read from ``rows``
    (the study's :class:`~optdesign.study.rows.Rows`, column by column: no row is held twice):
    :meth:`add` after each row appended there, with the table's current columns, :meth:`finish`
    at the end; ``note`` says why no file was
    written (pyarrow missing, or an Arrow error: the study goes on without it), ``error`` holds a
    failed write (a full disk: raised at the end, as cases.csv's)."""

    def __init__(self, folder, rows):
        self.path, self.rows, self.written = Path(folder) / PARTIAL, rows, 0
        self.note = self.error = None
        self.kinds, self.cols, self.cols_now, self.writer, self.done = {}, [], [], None, False
        try:
            import pyarrow  # noqa: F401
            import pyarrow.parquet  # noqa: F401
        except ImportError:
            self.note = MISSING_NOTE

    @property
    def active(self) -> bool:
        return self.note is None and self.error is None

    def add(self, cols: list):
        if self.active:
            self.cols_now = cols
            if len(self.rows) - self.written >= GROUP:
                self._guard(self._flush)

    def finish(self, cols: list):
        """The last group written and the file closed (a table of no rows gets the columns)."""
        if self.done:
            return
        self.done = True
        if self.active:
            self.cols_now = cols
            self._guard(self._flush)
        self.close()

    def close(self):
        if self.writer is not None:
            writer, self.writer = self.writer, None
            self._guard(writer.close)

    def _guard(self, action):
        import pyarrow as pa

        try:
            action()
        except pa.ArrowException as exc:
            if isinstance(exc, OSError):
                self.error = exc
            else:
                self.note = f"cases.parquet not written: {exc}"
        except OSError as exc:
            self.error = exc
        if not self.active and self.writer is not None:
            writer, self.writer = self.writer, None
            try:
                writer.close()
            except (OSError, ValueError):
                pass

    def _flush(self):
        import pyarrow as pa

        start, stop = self.written, len(self.rows)
        cols = list(self.cols_now)
        arrays, kinds = [], {}
        for k in cols:   # one column's values at a time, made an Arrow array at once
            floats = self.rows.floats(k, start, stop)   # (a column of floats: its doubles as they are)
            if floats is not None and _merge(self.kinds.get(k, "null"), "float") == "float":
                kinds[k] = "float"
                arrays.append(pa.array(floats, type=pa.float64()))
                continue
            values = self.rows.values(k, start, stop)
            kinds[k] = _merge(self.kinds.get(k, "null"), _kind(values))
            arrays.append(_array(values, kinds[k]))
        first = self.writer is None
        if first or cols != self.cols or kinds != self.kinds:
            self._widen(cols, kinds)
        if stop > start or first:
            self.writer.write_table(pa.Table.from_arrays(arrays, schema=self.schema))
        self.written = stop

    def _widen(self, cols, kinds):
        """A writer with the schema of ``cols`` and ``kinds``, the groups written so far copied
        into its file (with the new columns as nulls, and columns that changed type converted)."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        self.schema = pa.schema([(k, _arrow_type(kinds[k])) for k in cols])
        old, self.cols, self.kinds = self.writer, cols, kinds
        if old is None:   # the first group: a killed run's files go (the folder is locked by now)
            self.path.with_name(REWRITE).unlink(missing_ok=True)
            self.writer = pq.ParquetWriter(self.path, self.schema)
            return
        old.close()
        tmp = self.path.with_name(REWRITE)
        self.writer = pq.ParquetWriter(tmp, self.schema)
        for group in pq.ParquetFile(self.path).iter_batches(batch_size=GROUP):
            n = group.num_rows
            names = group.schema.names
            arrays = []
            for k in cols:
                if k not in names:
                    arrays.append(pa.nulls(n, self.schema.field(k).type))
                else:
                    col = group.column(names.index(k))
                    arrays.append(col if col.type == self.schema.field(k).type else _array(col.to_pylist(), kinds[k]))
            self.writer.write_table(pa.Table.from_arrays(arrays, schema=self.schema))
        os.replace(tmp, self.path)   # the open writer keeps writing the same file under its new name


def _array(values, kind):
    import pyarrow as pa

    from .rows import cell

    if kind == "string":
        values = [None if v is None else v if isinstance(v, str) else cell(v) for v in values]
    return pa.array(values, type=_arrow_type(kind))


def _arrow_type(kind):
    import pyarrow as pa

    return {"null": pa.null, "bool": pa.bool_, "int": pa.int64, "float": pa.float64, "string": pa.string}[kind]()
