"""A study's cases as a lazy sequence (:class:`Cases`): a million cases in memory as their ids
(8 bytes each), each :class:`Case` made when asked for from its index.

A case's place follows from its index alone (the axes' points, the last axis fastest; its
chain and its link in the chain), so nothing per case is held but the id: a digest of the
case's content (the scene, the mode, the overrides, the bounds, the run settings and, for a
warm-started case, the previous case's id).  The ids are those of ``json.dumps(content,
sort_keys=True)`` hashed with SHA-256 (its first 16 hex digits), the text assembled from the
axis points' pieces made once (tests/test_study_client.py checks it against json.dumps)."""
from __future__ import annotations

import collections.abc
import dataclasses
import hashlib
import itertools
import json
import operator
from array import array


@dataclasses.dataclass(frozen=True, slots=True)
class Case:
    """One case: its place in the study, its content and its id (a digest of the content and,
    for a warm-started case, of the previous case of its chain)."""

    index: int
    chain: int
    link: int                 # position in its chain (0: cold start)
    overrides: tuple          # ((parameter, value), ...)
    bounds: tuple             # ((constraint, side, value), ...)
    inputs: tuple             # ((column, value), ...) as in the CSV
    id: str


class Ref:
    """A case by its index and id (what an executor hands back with the case's output)."""

    __slots__ = ("index", "id")

    def __init__(self, index, id):
        self.index, self.id = index, id

    def __repr__(self):
        return f"Ref({self.index}, {self.id!r})"


class Cases(collections.abc.Sequence):
    """The cases of ``axes`` in study order (the last axis fastest): ``cases[i]`` a :class:`Case`,
    :meth:`id` its id alone, :meth:`chains` the chains as ranges of indices.  ``chain``: cases
    per chain along the last axis when the cases are chained (warm-started optimisations), else
    None (every case its own chain)."""

    def __init__(self, axes, chain, content_head: dict):
        self.axes = tuple(axes)
        self.sizes = [len(a) for a in self.axes]
        self.n = 1
        for s in self.sizes:
            self.n *= s
        self.chain = chain
        self.last = self.sizes[-1] if self.sizes else 1
        self.per_row = -(-self.last // chain) if chain else 1   # chains per point of the outer axes
        self.strides = [self.n // max(1, _prod(self.sizes[:k + 1])) for k in range(len(self.sizes))]
        self.ids = array("Q", _ids(self.axes, self.sizes, chain, content_head))
        # per axis and point: its overrides and its bounds, as a case holds them
        self._overrides = [[() if a.kind == "pareto" else tuple(p) for p in a.points] for a in self.axes]
        self._bounds = [[((a.constraint, a.side, p[0][1]),) if a.kind == "pareto" else () for p in a.points]
                        for a in self.axes]

    def __len__(self):
        return self.n

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self[j] for j in range(*i.indices(self.n))]
        i = operator.index(i)
        if i < 0:
            i += self.n
        if not 0 <= i < self.n:
            raise IndexError(f"study cases: index {i} out of range ({self.n} cases)")
        chain, link = self.place(i)
        overrides, bounds = [], []
        for axis, k in zip(self.axes, self.position(i)):
            for pair in axis.points[k]:   # the axis's (column, value) pairs, shared by every case (memory)
                if axis.kind == "pareto":
                    bounds.append((axis.constraint, axis.side, pair[1]))
                else:
                    overrides.append(pair)
        overrides = tuple(overrides)
        inputs = overrides if not bounds else tuple(p for axis, k in zip(self.axes, self.position(i))
                                                    for p in axis.points[k])
        return Case(i, chain, link, overrides, tuple(bounds), inputs, self.id(i))

    def batch(self, indices) -> tuple:
        """(refs, overrides, bounds) of the cases ``indices``: a :class:`Ref` (index and id), the
        overrides and the bounds of each (a batch's tasks need no more)."""
        indices = list(indices)
        refs = list(map(Ref, indices, map("{:016x}".format, map(self.ids.__getitem__, indices))))
        # each case's tuples: its axes' points' tuples joined, axis after axis (a column at a time)
        overrides, bounds = [()] * len(indices), [()] * len(indices)
        for k in range(len(self.axes)):
            at = self.column(k, indices)
            overrides = list(map(tuple.__add__, overrides, map(self._overrides[k].__getitem__, at)))
            if any(self._bounds[k]):
                bounds = list(map(tuple.__add__, bounds, map(self._bounds[k].__getitem__, at)))
        return refs, overrides, bounds

    def id(self, i) -> str:
        return f"{self.ids[i]:016x}"

    def position(self, i) -> list:
        """The point of each axis of case ``i``."""
        return [i // stride % size for stride, size in zip(self.strides, self.sizes)]

    def place(self, i) -> tuple:
        """(chain, link) of case ``i``."""
        if not self.chain:
            return i, 0
        outer, pos = divmod(i, self.last)
        return outer * self.per_row + pos // self.chain, pos % self.chain

    @property
    def n_chains(self) -> int:
        return self.n if not self.chain else self.n // self.last * self.per_row

    def chains(self):
        """Each chain as the range of its cases' indices, in order."""
        if not self.chain:
            return (range(i, i + 1) for i in range(self.n))
        return (range(o + s, min(o + s + self.chain, o + self.last))
                for o in range(0, self.n, self.last) for s in range(0, self.last, self.chain))

    def column(self, k, i_list) -> list:
        """The points of axis ``k`` of the cases ``i_list``."""
        stride, size = self.strides[k], self.sizes[k]
        return [i // stride % size for i in i_list]


def _prod(values) -> int:
    out = 1
    for v in values:
        out *= v
    return out


def _dumps(value) -> str:
    return json.dumps(value, sort_keys=True)


def _ids(axes, sizes, chain, head: dict):
    """Each case's id as a 64-bit integer, in study order: the SHA-256 of the JSON text of its
    content (keys sorted, json.dumps's default separators), whose first 8 bytes are the id's
    16 hex digits."""
    pieces = []   # per axis and point: its text in "overrides" and in "bounds"
    for a in axes:
        if a.kind == "pareto":
            pieces.append([("", _dumps([a.constraint, a.side, p[0][1]])) for p in a.points])
        else:
            pieces.append([(", ".join(_dumps(list(pair)) for pair in p), "") for p in a.points])
    start = '{"bounds": ['
    middle = f'], "mode": {_dumps(head["mode"])}, "overrides": ['
    end = f', "run": {_dumps(head["run"])}, "scene": {_dumps(head["scene"])}}}'
    sha, from_bytes = hashlib.sha256, int.from_bytes
    *outer, last = pieces or [[("", "")]]
    for combo in itertools.product(*outer):   # the last axis in the inner loop: its pieces as they are
        head_o = [o for o, _ in combo if o]
        head_b = [b for _, b in combo if b]
        prev = None
        for pos, (o, b) in enumerate(last):
            overrides = ", ".join(head_o + [o]) if o else ", ".join(head_o)
            bounds = ", ".join(head_b + [b]) if b else ", ".join(head_b)
            tail = "null" if not chain or pos % chain == 0 else f'"{prev:016x}"'
            prev = from_bytes(sha(f'{start}{bounds}{middle}{overrides}], "prev": {tail}{end}'.encode()).digest()[:8], "big")
            yield prev
