"""Dimensions of the design variables on a drawing, found from the geometry itself.

For each design variable v the first construction that uses it (directly or through derived
parameters) places a point P(v).  CasADi's derivatives dP/dv and d2P/dv2 say what v is there:

* P moves along a straight line as v grows (d2P/dv2 = 0): a length.  The dimension runs from
  P - v dP/dv (where P would be at v = 0) to P: a fixed point's coordinate from the axis, a
  polar length from its centre, an attach offset along or across its frame.
* P turns about a centre c = P + J dP/dv (J: a quarter turn) with d2P/dv2 = c - P: an angle.
  The dimension is the arc at c from the direction at v = 0 to P.
* otherwise (a dyad's length, say) the dimension runs along the construction's link when v is
  its length, else v is written next to P.

Values are shown in the units the scene wrote: m for lengths, deg for a variable written in
deg, rad otherwise."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scene import Dyad, Loop, Polar, Slider
from ..scene.expressions import Name
from .units import parameter_unit

DIMENSION = "#1a4f8b"


@dataclass
class Dimension:
    """One dimension: ``kind`` 'linear' (from ``a`` to ``b``), 'angular' (arc at ``a``, radius
    ``radius``, from ``angles[0]`` to ``angles[1]`` rad) or 'note' (text at ``a``)."""

    name: str
    kind: str
    text: str
    a: np.ndarray
    b: np.ndarray | None = None
    radius: float = 0.0
    angles: tuple = (0.0, 0.0)


def _uses(resolved, c, name):
    exprs = []
    for attr in ("x", "y", "length", "angle", "length_p", "length_q", "a", "b"):
        if hasattr(c, attr):
            exprs.append(getattr(c, attr))
    if isinstance(c, Loop):
        exprs += list(c.lengths) + list(c.angles)
    return any(resolved.depends_on(e, (name,)) for e in exprs)


def _text(parameter, value, kind, scene=None):
    factor, unit = parameter_unit(parameter, kind, scene)
    return f"{parameter.name} = {value * factor:.4g} {unit}".rstrip()


def dimensions(geometry, frame, p_values=None) -> list:
    """The dimensions of ``geometry``'s design variables at the position of ``frame`` (one
    sample of :meth:`Geometry.frames`)."""
    resolved = geometry.resolved
    names = [n for n in resolved.design_names if n in resolved.leaf_names]
    if not names:
        return []
    s = float(frame.s[0])
    values = dict(zip(resolved.leaf_names, resolved.leaf_values if p_values is None else p_values))
    derivs = geometry.point_derivatives(s, names, p_values)
    out = []
    for name in names:
        parameter = resolved.scene.parameter(name)
        v = float(values[name])
        c = next((c for c in resolved.scene.points if _uses(resolved, c, name)), None)
        if c is None:
            continue
        point = c.name if not isinstance(c, Loop) else next(
            (j for j in c.joints if np.hypot(*derivs[name][j][0]) > 1e-12), c.joints[-1])
        P = frame.points[point][0]
        if not np.all(np.isfinite(P)):
            continue
        d1, d2 = derivs[name][point]
        n1 = float(np.hypot(*d1))
        scale = max(float(np.hypot(*P)), n1 * abs(v), 1e-12)
        if n1 > 1e-12 and np.hypot(*d2) <= 1e-7 * max(n1, 1.0) * max(1.0, scale):
            out.append(Dimension(name, "linear", _text(parameter, v, "length", resolved.scene), P - v * d1, P))
            continue
        centre = P + np.array([-d1[1], d1[0]])
        if n1 > 1e-12 and np.hypot(*(d2 - (centre - P))) <= 1e-6 * max(n1, 1e-12):
            r = P - centre
            end = float(np.arctan2(r[1], r[0]))
            out.append(Dimension(name, "angular", _text(parameter, v, "angle", resolved.scene), centre, radius=float(np.hypot(*r)),
                                 angles=(end - v, end)))
            continue
        ends = _link_of(c, name, frame)
        if ends is not None:
            out.append(Dimension(name, "linear", _text(parameter, v, "length", resolved.scene), *ends))
        else:
            out.append(Dimension(name, "note", _text(parameter, v, "length", resolved.scene), P))
    return out


def _link_of(c, name, frame):
    """The ends of the link whose length is exactly the parameter ``name``, if any."""
    pairs = []
    if isinstance(c, Dyad):
        pairs = [(c.length_p, c.p, c.name), (c.length_q, c.q, c.name)]
    elif isinstance(c, (Slider, Polar)):
        pairs = [(c.length, c.p if isinstance(c, Slider) else c.centre, c.name)]
    elif isinstance(c, Loop):
        chain = [c.base, *c.joints]
        pairs = [(ln, a, b) for ln, a, b in zip(c.lengths, chain[:-1], chain[1:])]
    for expr, a, b in pairs:
        if isinstance(expr.tree, Name) and expr.tree.name == name:
            return frame.points[a][0], frame.points[b][0]
    return None


def draw_dimensions(ax, dims, w, centre, colour=DIMENSION, z=9):
    """Draw ``dims`` with extension lines, arrows and their text; linear ones are set off to the
    side away from ``centre`` (the middle of the mechanism)."""
    from matplotlib.patches import Arc

    for d in dims:
        if d.kind == "linear":
            a, b = np.asarray(d.a, float), np.asarray(d.b, float)
            length = float(np.hypot(*(b - a)))
            if length < 1e-9 * max(w, 1e-12):
                continue
            u = (b - a) / length
            n = np.array([-u[1], u[0]])
            if np.dot((a + b) / 2 - centre, n) < 0:
                n = -n
            off = n * 2.6 * w
            a2, b2 = a + off, b + off
            for e, e2 in ((a, a2), (b, b2)):
                ax.plot(*np.stack([e + n * 0.4 * w, e2 + n * 0.6 * w]).T, color=colour, lw=0.5, zorder=z)
            ax.annotate("", a2, b2, arrowprops=dict(arrowstyle="<|-|>", color=colour, lw=0.7, mutation_scale=6,
                                                     shrinkA=0, shrinkB=0), zorder=z)
            angle = np.degrees(np.arctan2(u[1], u[0]))
            angle = angle - 180 if angle > 90 else angle + 180 if angle < -90 else angle
            mid = (a2 + b2) / 2 + n * 0.9 * w
            ax.text(*mid, d.text, fontsize=6.5, color=colour, rotation=angle, rotation_mode="anchor",
                    ha="center", va="center", zorder=z,
                    bbox=dict(boxstyle="round,pad=0.1", fc="white", ec="none", alpha=0.8))
        elif d.kind == "angular":
            r = max(d.radius * 0.45, 3 * w)
            t0, t1 = np.degrees(sorted(d.angles))
            ax.add_patch(Arc(d.a, 2 * r, 2 * r, theta1=t0, theta2=t1, color=colour, lw=0.7, zorder=z))
            for t in d.angles:
                e = d.a + r * 1.15 * np.array([np.cos(t), np.sin(t)])
                ax.plot([d.a[0], e[0]], [d.a[1], e[1]], color=colour, lw=0.5, ls="--", zorder=z)
            mid = np.radians((t0 + t1) / 2)
            ax.text(*(d.a + 1.2 * r * np.array([np.cos(mid), np.sin(mid)])), d.text, fontsize=6.5, color=colour,
                    ha="center", va="center", zorder=z,
                    bbox=dict(boxstyle="round,pad=0.1", fc="white", ec="none", alpha=0.8))
        else:
            ax.annotate(d.text, d.a, xytext=(6, -10), textcoords="offset points", fontsize=6.5, color=colour,
                        zorder=z, bbox=dict(boxstyle="round,pad=0.1", fc="white", ec="none", alpha=0.8))
