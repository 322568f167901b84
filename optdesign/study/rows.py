"""A study's rows held column by column (:class:`Rows`): a million cases in memory as numbers
in typed arrays, not as a million dicts.

A row of cases.csv as a dict costs ~2.8 kB (the dict, its keys' slots, a float object per value);
here a float value costs 8 bytes, a case id 8, a repeated string (a status) a pointer, and the
row the number of its shape (which keys it has, in which order).  ``rows[i]`` builds the row's
dict again, the very same one that was appended (same keys in the same order, same values of
the same types: a float stays a float, an int an int, a missing key missing, None None)."""
from __future__ import annotations

import collections.abc
import math
import operator
import re
from array import array

_HEX16 = re.compile(r"[0-9a-f]{16}\Z")
_HEX16S = re.compile(r"(?:[0-9a-f]{16})*")
_MISSING = object()
_INTERNED = 4096   # distinct strings of a column shared (a status, a note); further ones kept as they are


class _Column:
    """One column's values, one slot per row (rows without the column hold a filler): floats in
    an array of doubles, ints and bools in arrays of integers, case ids (16 hex digits) as 64-bit
    integers, other strings in a list sharing equal ones; a value of another type (None, an int
    in a float column) is kept apart in ``other`` (row -> value)."""

    __slots__ = ("kind", "data", "other", "strings")

    def __init__(self, value, rows):
        self.other, self.strings = {}, {}
        self.kind, self.data = "n", array("b")   # only None so far (kept in other)
        self.pad(rows)
        self._choose(value)

    def _choose(self, value):
        """The column's kind from its first value that is not None."""
        if value is None:
            return
        if isinstance(value, bool):
            kind, typecode = "b", "b"
        elif isinstance(value, int):
            kind, typecode = "q", "q"
        elif isinstance(value, float):
            kind, typecode = "d", "d"
        elif isinstance(value, str) and _HEX16.match(value):
            kind, typecode = "x", "Q"
        else:
            kind, typecode = "O", None
        n = len(self.data)
        self.kind = kind
        self.data = [None] * n if typecode is None else array(typecode, bytes(n * array(typecode).itemsize))

    def pad(self, rows):
        """Filler slots up to ``rows`` (rows without this column)."""
        missing = rows - len(self.data)
        if missing > 0:
            self.data.extend([None] * missing if self.kind == "O" else array(self.data.typecode, bytes(missing * self.data.itemsize)))

    def append(self, value):
        if self.kind == "n":
            self._choose(value)
        kind = self.kind
        fits = (kind == "d" and type(value) is float) or (kind == "b" and type(value) is bool) or \
               (kind == "q" and type(value) is int and -2**63 <= value < 2**63) or \
               (kind == "x" and type(value) is str and _HEX16.match(value) is not None)
        if kind == "O":
            if type(value) is str:
                value = self.strings.setdefault(value, value) if len(self.strings) < _INTERNED else \
                    self.strings.get(value, value)
            self.data.append(value)
        elif fits:
            self.data.append(int(value, 16) if kind == "x" else value)
        else:
            self.other[len(self.data)] = value
            self.data.append(0)

    def extend(self, values: list):
        """:meth:`append` of each value, in one call where they all fit the column's array
        (``values``: a list, or an array of doubles: floats, copied as they are)."""
        if type(values) is array:
            if self.kind == "n" and len(values):
                self._choose(values[0])
            if self.kind == "d":
                self.data.extend(values)
                return
            values = values.tolist()
        if self.kind == "n":
            self._choose(next((v for v in values if v is not None), None))
        kind, types = self.kind, set(map(type, values))
        if (kind == "d" and types == {float}) or (kind == "b" and types == {bool}) or (
                kind == "q" and types == {int} and -2**63 <= min(values) and max(values) < 2**63):
            self.data.extend(values)
        elif kind == "x" and types == {str} and set(map(len, values)) == {16} and \
                _HEX16S.fullmatch("".join(values)):
            self.data.extend([int(v, 16) for v in values])
        elif kind == "O" and types == {str} and len(self.strings) + len(values) <= _INTERNED:
            self.data.extend(map(self.strings.setdefault, values, values))
        else:
            for v in values:
                self.append(v)

    def get(self, i):
        if self.other:
            v = self.other.get(i, _MISSING)
            if v is not _MISSING:
                return v
        v = self.data[i]
        if self.kind == "b":
            return bool(v)
        if self.kind == "x":
            return f"{v:016x}"
        return v


class Rows(collections.abc.Sequence):
    """A study's finished rows in case order (cases.csv's rows with numbers as numbers), a
    read-only sequence of dicts: ``rows[i]`` (a new dict each time: changing it does not change
    the rows), slices, ``len``, iteration, ``==`` with any sequence of dicts; :meth:`column` gives
    one column as a float array without building the dicts, :meth:`has` whether any row has a
    column.  Built by :meth:`append`, one row after the other."""

    def __init__(self, rows=()):
        self._shapes, self._keys = {}, []   # keys of a row (a tuple) <-> its number
        self._shape = array("I")            # each row's shape number
        self._cols: dict = {}
        for row in rows:
            self.append(row)

    def append(self, row: dict):
        keys = tuple(row)
        shape = self._shapes.get(keys)
        if shape is None:
            shape = self._shapes[keys] = len(self._keys)
            self._keys.append(keys)
        n, cols = len(self._shape), self._cols
        for k, v in row.items():
            col = cols.get(k)
            if col is None:
                col = cols[k] = _Column(v, n)
            elif len(col.data) != n:
                col.pad(n)
            if type(v) is float and col.kind == "d":   # most values: at once
                col.data.append(v)
            else:
                col.append(v)
        self._shape.append(shape)

    def extend(self, keys: tuple, columns: list):
        """Append rows given column by column: rows whose keys are ``keys`` (in that order),
        ``columns[k]`` the values of key k, one per row (:meth:`append` of each row, at once)."""
        if not columns:
            return
        keys = tuple(keys)
        shape = self._shapes.get(keys)
        if shape is None:
            shape = self._shapes[keys] = len(self._keys)
            self._keys.append(keys)
        n, cols = len(self._shape), self._cols
        for k, values in zip(keys, columns):
            col = cols.get(k)
            if col is None:
                col = cols[k] = _Column(None, n)
            elif len(col.data) != n:
                col.pad(n)
            col.extend(values)
        self._shape.extend(array("I", [shape]) * len(columns[0]))

    def __len__(self):
        return len(self._shape)

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self._row(j) for j in range(*i.indices(len(self)))]
        try:
            j = operator.index(i)
        except TypeError:
            raise TypeError(f"study rows: indices must be integers or slices, not {type(i).__name__}") from None
        n = len(self)
        j = j + n if j < 0 else j
        if not 0 <= j < n:
            raise IndexError(f"study rows: index {i} out of range ({n} rows)")
        return self._row(j)

    def _row(self, i) -> dict:
        cols = self._cols
        return {k: cols[k].get(i) for k in self._keys[self._shape[i]]}

    def __eq__(self, other):
        if not isinstance(other, collections.abc.Sequence) or isinstance(other, (str, bytes)):
            return NotImplemented
        return len(self) == len(other) and all(a == b for a, b in zip(self, other))

    __hash__ = None

    def __repr__(self):
        return f"Rows({len(self)} rows, {len(self._cols)} columns)"

    def names(self) -> list:
        """The columns, in order of their first appearance."""
        return list(self._cols)

    def has(self, name) -> bool:
        """Whether any row has the column ``name``."""
        return any(name in keys for keys in self._keys)

    def values(self, name, start=0, stop=None) -> list:
        """The values of column ``name`` in rows ``start`` to ``stop`` (None where a row has none)."""
        stop = len(self) if stop is None else stop
        col = self._cols.get(name)
        if col is None:
            return [None] * (stop - start)
        has = [name in keys for keys in self._keys]
        col.pad(stop)
        if all(has) and not col.other:   # the common case, at C speed
            if col.kind in ("d", "q", "O"):
                return list(col.data[start:stop])
            if col.kind == "b":
                return list(map(bool, col.data[start:stop]))
            if col.kind == "x":
                return list(map("{:016x}".format, col.data[start:stop]))
        shape = self._shape
        return [col.get(i) if has[shape[i]] else None for i in range(start, stop)]

    def floats(self, name, start=0, stop=None):
        """The values of column ``name`` in rows ``start`` to ``stop`` as a float array (a copy:
        the same doubles :meth:`values` gives as floats) where every row has the column and each
        value is a float, else None."""
        import numpy as np

        stop = len(self) if stop is None else stop
        col = self._cols.get(name)
        if col is None or col.kind != "d" or col.other or not all(name in keys for keys in self._keys):
            return None
        col.pad(stop)
        return np.frombuffer(col.data, float, stop - start, 8 * start).copy()   # (the view let go: the array grows)

    def column(self, name):
        """The column ``name`` as a float array, one value per row (missing, None and values that
        are not numbers as nan; true and false as 1 and 0)."""
        import numpy as np

        n = len(self)
        col = self._cols.get(name)
        out = np.full(n, math.nan)
        if col is None:
            return out
        col.pad(n)
        if col.kind in ("d", "q", "b"):
            out[:] = np.frombuffer(col.data, dtype={"d": float, "q": np.int64, "b": np.int8}[col.kind])[:n]
            for i, v in col.other.items():
                out[i] = _as_float(v)
        else:   # strings (numbers written as text count, as float() reads them)
            out[:] = [_as_float(col.get(i)) for i in range(n)]
        has = np.array([name in keys for keys in self._keys], dtype=bool)
        if not has.all():
            out[~has[np.frombuffer(self._shape, dtype=np.uint32)]] = math.nan
        return out


def _as_float(v):
    if v is None:
        return math.nan
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


def cell(value) -> str:
    """A CSV cell: floats in their shortest exact form (repr), None as empty."""
    kind = type(value)
    if kind is float:
        return repr(value)   # nan, inf, -inf included
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(float(value))
    return str(value)
