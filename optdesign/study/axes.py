"""The axes of a study: a parameter's grid or listed values, parameters that change together,
or a constraint's bound (a Pareto front by the epsilon-constraint method)."""
from __future__ import annotations

import dataclasses
import math

from ..errors import SceneError
from ..scene.arguments import study_cases


@dataclasses.dataclass(frozen=True)
class Axis:
    """One axis of a study: ``points`` is a tuple of ((column, value), ...) per point.

    ``kind`` is 'parameter' (one parameter), 'together' (several parameters per point) or
    'pareto' (the ``side`` bound, 'min' or 'max', of constraint ``constraint``)."""

    kind: str
    points: tuple
    constraint: str | None = None
    side: str | None = None

    @property
    def columns(self) -> tuple:
        return tuple(k for k, _ in self.points[0]) if self.points else ()

    @property
    def column(self) -> str:
        """The column drawn on a figure's abscissa (the first of a 'together' axis)."""
        return self.columns[0]

    @property
    def label(self) -> str:
        return self.constraint if self.kind == "pareto" else self.column

    def __len__(self):
        return len(self.points)


def values(name: str, items) -> Axis:
    """An axis over parameter ``name`` taking the given values (numbers or expressions)."""
    items = [_number(v) for v in items]
    if not items:
        raise SceneError(f"axis {name!r}: no values")
    return Axis("parameter", tuple(((name, v),) for v in items))


def grid(name: str, start: float, stop: float, n: int) -> Axis:
    """``n`` evenly spaced values of parameter ``name`` from ``start`` to ``stop`` (ends included,
    exactly as written: :func:`evenly_spaced`)."""
    if int(n) < 1:
        raise SceneError(f"axis {name!r}: expected at least one value, found n = {n}")
    study_cases(f"axis {name!r}: n", int(n))
    return values(name, evenly_spaced(start, stop, int(n)))


def evenly_spaced(start: float, stop: float, n: int) -> list:
    """``n`` evenly spaced values from ``start`` to ``stop`` whose ends are exactly ``start``
    and ``stop`` (-0.2 + 0.65*13/13 rounds to 0.45000000000000007; the last value is 0.45)."""
    start, stop = float(start), float(stop)
    if n <= 1:
        return [start][:n]
    out = [start + (stop - start) * i / (n - 1) for i in range(n)]
    out[-1] = stop
    return out


def together(rows) -> Axis:
    """An axis of cases in which several parameters change together: a list of dicts with the
    same keys, e.g. ``[{"L": 5, "mB": 540}, {"L": 6, "mB": 650}]``."""
    rows = [dict(r) for r in rows]
    if not rows or not rows[0]:
        raise SceneError("together(): expected a non-empty list of {parameter: value} dicts")
    keys = list(rows[0])
    for i, r in enumerate(rows):
        if list(r) != keys:
            raise SceneError(f"together(): case {i} sets {sorted(r)}, the first sets {sorted(keys)}; "
                             "every case must set the same parameters")
    return Axis("together", tuple(tuple((k, _number(r[k])) for k in keys) for r in rows))


def pareto(constraint: str, bounds, side: str | None = None) -> Axis:
    """An epsilon-constraint axis: the scene's constraint ``constraint`` gets its ``side``
    bound ('min' or 'max'; may be left out when the constraint has one bound only) set to each
    value of ``bounds`` in turn (numbers, or expressions such as "30 deg")."""
    items = [_constant(b, f"pareto bound of {constraint!r}") for b in bounds]
    if not items:
        raise SceneError(f"pareto axis {constraint!r}: no bound values")
    if side not in (None, "min", "max"):
        raise SceneError(f"pareto axis {constraint!r}: side must be 'min' or 'max', found {side!r}")
    return Axis("pareto", tuple(((f"bound:{constraint}:{side or '?'}", v),) for v in items), constraint, side)


def _number(v):
    """Numbers as floats; strings kept as expressions (validated when the scene is changed)."""
    if isinstance(v, str):
        try:
            return float(v)
        except ValueError:
            return v.strip()
    if isinstance(v, bool) or not isinstance(v, (int, float)) and not hasattr(v, "__float__"):
        raise SceneError(f"expected a number or an expression, found {v!r}")
    return float(v)


def _constant(v, where):
    v = _number(v)
    if isinstance(v, str):
        from ..scene.expressions import constant_value, parse

        v = constant_value(parse(v, where), {}, where)
    return v
