"""Which of a study's cases are valid scenes, known without building a scene per case.

A case's scene is valid when the scene's checks (:mod:`optdesign.scene.validate`) pass with the
case's parameter values.  Building and checking a scene costs ~2 ms, minutes for an axis of
100,000 points and hours for every combination of two large axes.  Most checks do not depend on
a parameter's value at all (names, references, shapes); those that do evaluate expressions of
the parameters (:func:`~optdesign.scene.expressions.evaluate`).  One check of the scene, with
those evaluations recorded, shows which expressions each axis's parameter enters:

* none: every value of it passes whatever passes at one value;
* only in expressions affine in the axes' parameters (``mB``, ``mB*L^2/12``, ``m1 + m2``: the
  other names fixed) that a check bounds by constants (a mass or an inertia >= 0, a length > 0,
  0 < efficiency <= 1, gravity >= 0): the values that pass form a convex set (an interval on one
  axis, a half-space's slice on several), so every case passes if the corners of the axes' box
  (each axis's smallest and largest value) do.

The checks are recorded at the first case and at every corner (a check that runs only for some
values, such as the drive's speed against 0 only when its efficiency is below 1, is seen where it
runs).  Recording patches the expressions module's ``evaluate`` while one scene is checked, one
recording at a time (a lock), each recording only its own thread's calls: studies may be made in
several threads at once.

Anything else (a derived parameter, an expression such as ``m^2`` or ``1/m``, a comparison
between two expressions such as a constraint's min and max or the drive's speed against 0,
values that are expressions or not finite) leaves the study to check every axis point with a built scene, as
before, and combinations of several axes one case at a time where they run."""
from __future__ import annotations

import itertools
import math
import threading

# places (table, key) whose checks bound one value by constants (scene/validate.py)
# (a derived parameter that uses an axis's parameter is not among them: its value enters other
# checks under its own name)
CONVEX = {("bodies", "mass"), ("bodies", "inertia"), ("gravity", "g"), ("drive", "efficiency"), ("drive", "inertia")}
_RECORDING = threading.Lock()
CORNERS_MAX = 64   # corners checked at most (6 axes); more axes: every point, as before


def recorded_checks(build) -> list:
    """``build()`` (a scene made and checked) with every expression it evaluates recorded:
    [(expression, where), ...]."""
    from ..scene import expressions

    calls, me = [], threading.get_ident()
    with _RECORDING:   # one recording at a time: each restores the function it replaced
        original = expressions.evaluate

        def traced(expr, values, points=None, where=""):
            if threading.get_ident() == me:   # (another thread's evaluations are not this scene's checks)
                calls.append((expr, where))
            return original(expr, values, points, where)

        expressions.evaluate = traced
        try:
            build()
        finally:
            expressions.evaluate = original
    return calls


def _convex_place(where) -> bool:
    table, key = getattr(where, "table", None), getattr(where, "key", None)
    if table == "points":   # a dyad's or a slider's length: > 0
        return isinstance(key, str) and "length" in key
    return (table, key) in CONVEX


def ranged(axes, calls) -> bool:
    """Whether the parameter axes ``axes`` (single parameters with finite numbers) are valid
    everywhere when their corners are (see the module docstring), from the ``calls`` recorded
    while the scene was checked at one of their points."""
    names = set()
    for a in axes:
        if a.kind != "parameter" or any(type(v) is not float or not math.isfinite(v)
                                        for p in a.points for _, v in p):
            return False
        names.add(a.columns[0])
    for expr, where in calls:
        if expr.names() & names and not (_convex_place(where) and _affine(expr.tree, names)):
            return False
    return True


def _affine(node, names) -> bool:
    """Whether the expression tree ``node`` is an affine function of the parameters ``names``
    (sums, differences and negations of such, products and quotients of one by a term free of
    them), the other names held fixed."""
    from ..scene.expressions import BinOp, Name, Neg, _collect

    if isinstance(node, Name) or not _collect(node, points=False) & names:
        return True
    if isinstance(node, Neg):
        return _affine(node.operand, names)
    if isinstance(node, BinOp):
        free = [not _collect(side, points=False) & names for side in (node.left, node.right)]
        if node.op in ("+", "-"):
            return _affine(node.left, names) and _affine(node.right, names)
        if node.op == "*":
            return (free[0] and _affine(node.right, names)) or (free[1] and _affine(node.left, names))
        if node.op == "/":
            return free[1] and _affine(node.left, names)
    return False


def corners(axes) -> list:
    """The combinations of each axis's smallest and largest value: [{name: value}, ...]."""
    ends = [sorted({min(v for p in a.points for _, v in p), max(v for p in a.points for _, v in p)})
            for a in axes]
    return [dict(zip((a.columns[0] for a in axes), combo)) for combo in itertools.product(*ends)]
