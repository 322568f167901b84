"""Engineering drawings of a mechanism (matplotlib, any backend: PNG, SVG).

A drawing is made of the symbols of a kinematic diagram, all sized in data units from the
mechanism's size so that they scale with it: ground hatching under fixed pivots, revolute
joints as circles, sliders as blocks on their guides, links as bars, a linear drive as a
cylinder barrel and rod with its stroke marked, a rotary drive as a motor at the crank,
centres of mass with their masses, weights and applied forces as arrows.  What to draw comes
from :mod:`.topology`, where from :mod:`.geometry`, the dimensions from :mod:`.dimensions`.

:func:`draw_mechanism` draws one position; :func:`draw_ghost` a light outline of another.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .units import quantity

LINK_FACE, LINK_EDGE = "#a9c4e0", "#1f3b5a"
GROUND = "#303030"
WEIGHT, FORCE = "#2b6e3f", "#c0392b"
BARREL_FACE, ROD_FACE = "#8d99a6", "#dfe4ea"


@dataclass
class Context:
    """What one drawing needs from the whole stroke of one design: the mechanism's size
    ``extent`` and the bar width ``w`` derived from it, each guide's span along its line,
    the drive's shortest and longest length, the largest load (for arrow lengths), and the
    path of every point."""

    extent: float
    w: float
    spans: dict = field(default_factory=dict)
    lengths: tuple | None = None
    load_max: float = 0.0
    paths: dict = field(default_factory=dict)
    extra: list = field(default_factory=list)   # points drawn outside the paths (arrow tips)


def context(top, frames, extent=None) -> Context:
    """The :class:`Context` of one design from its ``frames`` over the stroke."""
    extent = frames.extent() if extent is None else extent
    ok = frames.assembled
    ctx = Context(extent=extent, w=0.018 * extent,
                  paths={k: v[ok] for k, v in frames.points.items() if k not in top.helpers})
    for point, key, _ in top.sliders:
        origin, angle = frames.guides[key]
        o, p = frames.points[origin][ok], frames.points[point][ok]
        if not len(p):
            continue
        u = np.stack([np.cos(angle[ok]), np.sin(angle[ok])], axis=1)
        t = np.einsum("ij,ij->i", p - o, u)
        pad = 0.06 * extent
        ctx.spans[key] = (float(np.nanmin(t)) - pad, float(np.nanmax(t)) + pad)
    if top.drive is not None and top.drive[0] == "linear":
        a, b = top.drive[1]
        length = np.hypot(*(frames.points[b][ok] - frames.points[a][ok]).T)
        if length.size and np.isfinite(length).any():
            ctx.lengths = (float(np.nanmin(length)), float(np.nanmax(length)))
    loads = [abs(m * frames.g) for m in frames.masses.values()]
    loads += [float(np.nanmax(np.hypot(*f[ok].T), initial=0.0)) for f in frames.forces.values()]
    ctx.load_max = max(loads, default=0.0)
    return ctx


# --- primitives ----------------------------------------------------------------------------
def _unit(angle):
    return np.array([np.cos(angle), np.sin(angle)])


def _stadium(p, q, half):
    """The outline of a bar of half-width ``half`` from p to q with round ends."""
    d = q - p
    a = np.arctan2(d[1], d[0])
    arc = np.linspace(-np.pi / 2, np.pi / 2, 12)
    end = np.stack([np.cos(a + arc), np.sin(a + arc)], axis=1) * half + q
    start = np.stack([np.cos(a + np.pi + arc), np.sin(a + np.pi + arc)], axis=1) * half + p
    return np.vstack([end, start])


def bar(ax, p, q, w, face=LINK_FACE, edge=LINK_EDGE, z=2, alpha=1.0):
    from matplotlib.patches import Polygon

    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(q))) or np.hypot(*(q - p)) < 1e-9 * max(w, 1e-12):
        return
    ax.add_patch(Polygon(_stadium(np.asarray(p), np.asarray(q), w / 2), closed=True, facecolor=face,
                         edgecolor=edge, lw=0.9, zorder=z, alpha=alpha))


def joint(ax, p, w, z=6, face="white"):
    from matplotlib.patches import Circle

    if np.all(np.isfinite(p)):
        ax.add_patch(Circle(p, 0.42 * w, facecolor=face, edgecolor="black", lw=0.9, zorder=z))


def ground(ax, p, w, z=1):
    """A fixed pivot: a triangle under the joint on a hatched base."""
    from matplotlib.patches import Polygon

    if not np.all(np.isfinite(p)):
        return
    x, y = p
    h, b = 1.6 * w, 1.1 * w
    ax.add_patch(Polygon([[x, y], [x - b, y - h], [x + b, y - h]], closed=True, facecolor="#e8e8e8",
                         edgecolor=GROUND, lw=0.9, zorder=z))
    hatch(ax, np.array([x - 1.7 * b, y - h]), np.array([x + 1.7 * b, y - h]), w, z=z)


def hatch(ax, a, b, w, z=1, side=-1):
    """A ground line from a to b with short strokes on its ``side`` (-1: right of a -> b)."""
    ax.plot([a[0], b[0]], [a[1], b[1]], color=GROUND, lw=1.2, zorder=z, solid_capstyle="butt")
    d = b - a
    n = np.hypot(*d)
    if n == 0:
        return
    u = d / n
    normal = side * np.array([-u[1], u[0]])
    count = max(2, int(n / (0.55 * w)))
    for t in np.linspace(0, n, count + 1)[:-1]:
        s = a + u * t
        e = s + 0.7 * w * (normal - 0.8 * u)
        ax.plot([s[0], e[0]], [s[1], e[1]], color=GROUND, lw=0.7, zorder=z)


def guide(ax, origin, angle, span, w, grounded, z=1):
    """A slider's guide: its line over ``span`` (along the line from ``origin``), hatched when
    it is part of the ground."""
    u = _unit(angle)
    a, b = origin + span[0] * u, origin + span[1] * u
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        return
    off = np.array([-u[1], u[0]]) * 0.75 * w
    for sign in (1, -1):
        ax.plot([a[0] + sign * off[0], b[0] + sign * off[0]], [a[1] + sign * off[1], b[1] + sign * off[1]],
                color=GROUND, lw=1.0, zorder=z)
    if grounded:
        hatch(ax, a - off, b - off, w, z=z, side=-1)


def slider_block(ax, p, angle, w, z=4):
    from matplotlib.patches import Polygon

    if not np.all(np.isfinite(p)):
        return
    u, n = _unit(angle), _unit(angle + np.pi / 2)
    half_l, half_h = 1.4 * w, 0.72 * w
    corners = [p + su * half_l * u + sn * half_h * n for su, sn in ((1, 1), (-1, 1), (-1, -1), (1, -1))]
    ax.add_patch(Polygon(corners, closed=True, facecolor="#f4d58d", edgecolor="black", lw=0.9, zorder=z))


def cylinder(ax, p, q, lengths, w, z=3, stroke=True, alpha=1.0, ctx=None):
    """A linear drive from its base pin ``p`` (barrel) to its rod eye ``q`` (rod); ``lengths``
    (shortest, longest over the stroke) size the barrel and mark the stroke."""
    from matplotlib.patches import Polygon

    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(q))):
        return
    d = q - p
    length = float(np.hypot(*d))
    if length == 0:
        return
    u = d / length
    n = np.array([-u[1], u[0]])
    lmin, lmax = lengths if lengths else (length, length)
    barrel = 0.86 * lmin
    rod_start = p + u * max(0.0, length - (lmax - barrel + 0.1 * lmin))

    def rect(a, b, half):
        return [a + half * n, b + half * n, b - half * n, a - half * n]

    ax.add_patch(Polygon(rect(rod_start, q, 0.28 * w), closed=True, facecolor=ROD_FACE, edgecolor="black",
                         lw=0.8, zorder=z, alpha=alpha))
    ax.add_patch(Polygon(rect(p, p + u * barrel, 0.78 * w), closed=True, facecolor=BARREL_FACE,
                         edgecolor="black", lw=0.9, zorder=z + 0.1, alpha=alpha))
    if stroke and lengths and lmax > lmin * (1 + 1e-6):
        off = -n * 1.9 * w
        a, b = p + u * lmin + off, p + u * lmax + off
        if ctx is not None:   # the stroke's mark and its text stay inside the view
            ctx.extra += [a - n * 2.5 * w, b - n * 2.5 * w]
        ax.annotate("", a, b, arrowprops=dict(arrowstyle="<->", color="#7a4f01", lw=0.8, shrinkA=0, shrinkB=0),
                    zorder=z + 0.2)
        for e in (a, b):
            ax.plot(*np.stack([e - off * 0.75, e + n * 0.4 * w]).T, color="#7a4f01", lw=0.6, zorder=z + 0.2)
        mid = (a + b) / 2 - n * 1.1 * w
        ang = np.degrees(np.arctan2(u[1], u[0]))
        ang = ang - 180 if ang > 90 else ang + 180 if ang < -90 else ang
        ax.text(*mid, f"stroke {quantity(lmax - lmin, 'm', 3)}", fontsize=6.5, color="#7a4f01", rotation=ang,
                rotation_mode="anchor", ha="center", va="center", zorder=z + 0.3)


def motor(ax, p, w, positive=True, z=5):
    """A rotary drive at the crank's pivot: a circle with an arrow in the drive's sense."""
    from matplotlib.patches import Arc, Circle

    if not np.all(np.isfinite(p)):
        return
    r = 1.5 * w
    ax.add_patch(Circle(p, r, facecolor="#fbe3c4", edgecolor="#9a5b00", lw=0.9, zorder=z - 0.5))
    ax.add_patch(Arc(p, 3.6 * w, 3.6 * w, theta1=20, theta2=160, color="#9a5b00", lw=1.0, zorder=z))
    end = 160 if positive else 20
    tip = p + 1.8 * w * _unit(np.radians(end))
    tangent = _unit(np.radians(end + (90 if positive else -90)))
    ax.annotate("", tip + 0.6 * w * tangent, tip, arrowprops=dict(arrowstyle="-|>", color="#9a5b00", lw=1.0),
                zorder=z)


def centre_of_mass(ax, p, w, z=7):
    """The usual symbol: a circle with two opposite quarters black."""
    from matplotlib.patches import Circle, Wedge

    if not np.all(np.isfinite(p)):
        return
    r = 0.55 * w
    ax.add_patch(Circle(p, r, facecolor="white", edgecolor="black", lw=0.8, zorder=z))
    for t in (0, 180):
        ax.add_patch(Wedge(p, r, t, t + 90, facecolor="black", edgecolor="none", zorder=z + 0.1))


def arrow(ax, p, vec, colour, text, w, z=8, ctx=None):
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(vec))) or np.hypot(*vec) == 0:
        return
    if ctx is not None:
        ctx.extra.append(p + vec)
    ax.annotate("", p + vec, p, arrowprops=dict(arrowstyle="-|>", color=colour, lw=1.3, mutation_scale=9,
                                                 shrinkA=0, shrinkB=0), zorder=z)
    tip = p + vec
    ax.text(tip[0] + 0.5 * w, tip[1], text, fontsize=6.5, color=colour, ha="left", va="center", zorder=z)


# --- the mechanism -------------------------------------------------------------------------
def _xy(frame, name):
    if name.startswith("foot:"):
        return frame.feet[name[5:]][0]
    return frame.points[name][0]


def draw_mechanism(ax, top, frame, ctx: Context, labels="joints", loads=True, masses=True, face=LINK_FACE,
                   edge=LINK_EDGE, stroke=True, scene=None, parts="all"):
    """Draw the mechanism at one position (``frame``: :meth:`Frames.at` of one sample).

    ``labels``: 'joints' names the pins and tips, 'all' every point (helpers too), None none;
    ``loads``: weights and applied forces as arrows; ``masses``: centres of mass with their
    masses (``scene`` gives the bodies' names).  ``parts``: 'all'; 'static' only what never
    moves and lies under the rest (ground symbols, fixed guide marks, guides on the ground);
    'moving' everything else (an animation draws the static parts once, the moving ones per
    frame: together they are the drawing 'all' makes)."""
    w = ctx.w
    static, moving = parts in ("all", "static"), parts in ("all", "moving")
    for key, (origin, angle) in frame.guides.items():
        if key in ctx.spans:
            grounded = next((g for _, k, g in top.sliders if k == key), False)
            if (static and grounded) or (moving and not grounded):
                guide(ax, frame.points[origin][0], angle[0], ctx.spans[key], w, grounded)
    for name in top.guides if static else ():
        p = frame.points[name][0]
        if np.all(np.isfinite(p)):
            ax.plot(*p, marker="+", color=GROUND, ms=5, zorder=2)
    if static and not moving:
        for name in top.ground:
            ground(ax, frame.points[name][0], w)
        return
    for a, b in top.bars:
        bar(ax, _xy(frame, a), _xy(frame, b), w, face=face, edge=edge)
    if top.drive is not None:
        kind, (a, b) = top.drive
        if kind == "linear":
            cylinder(ax, frame.points[a][0], frame.points[b][0], ctx.lengths, w, stroke=stroke, ctx=ctx)
    for point, key, _ in top.sliders:
        slider_block(ax, frame.points[point][0], frame.guides[key][1][0], w)
    for name in top.ground if static else ():
        ground(ax, frame.points[name][0], w)
    if top.drive is not None and top.drive[0] == "rotary":
        motor(ax, frame.points[top.drive[1][0]][0], w)
    for name in top.ground + top.joints:
        joint(ax, frame.points[name][0], w)
    for name in top.tips:
        p = frame.points[name][0]
        if np.all(np.isfinite(p)):
            ax.plot(*p, "o", color=LINK_EDGE, ms=2.5, zorder=6)
    if masses:
        _masses(ax, frame, w, scene)
    if loads:
        _loads(ax, frame, ctx)
    if labels:
        names = list(frame.points) if labels == "all" else top.ground + top.joints + top.tips + top.guides
        label_points(ax, frame, names, w, helpers=top.helpers)


def _masses(ax, frame, w, scene):
    bodies = {b.name: b for b in scene.bodies} if scene is not None else {}
    placed = []
    for name, p in frame.coms.items():
        p = p[0]
        mass = frame.masses.get(name)
        if mass is None or not np.all(np.isfinite(p)):
            continue
        centre_of_mass(ax, p, w)
        shift = sum(1 for q in placed if np.hypot(*(q - p)) < 2 * w)
        placed.append(p)
        text = f"{name if name in bodies else ''}: {quantity(mass, 'kg', 4)}".lstrip(": ")
        ax.text(p[0] + 1.0 * w, p[1] - 0.8 * w - shift * 1.9 * w, text, fontsize=6.5, color="black", zorder=9,
                ha="left", va="top", bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.75))


def _loads(ax, frame, ctx):
    if ctx.load_max <= 0:
        return
    scale = 0.16 * ctx.extent / ctx.load_max
    for name, mass in frame.masses.items():
        p = frame.coms.get(name)
        if p is None or frame.g == 0 or mass == 0:
            continue
        weight = mass * frame.g
        arrow(ax, p[0], np.array([0.0, -weight * scale]), WEIGHT, f"{quantity(weight, 'N', 3)}", ctx.w, ctx=ctx)
    for name, f in frame.forces.items():
        p = frame.coms.get(name)
        if p is not None:
            arrow(ax, p[0], f[0] * scale, FORCE, f"F {quantity(float(np.hypot(*f[0])), 'N', 3)}", ctx.w, ctx=ctx)


def label_points(ax, frame, names, w, helpers=()):
    for name in names:
        p = frame.points[name][0]
        if not np.all(np.isfinite(p)):
            continue
        style = dict(color="#777777", style="italic") if name in helpers else dict(color="black")
        ax.annotate(name, p, xytext=(4, 4), textcoords="offset points", fontsize=7.5, zorder=10,
                    bbox=dict(boxstyle="round,pad=0.1", fc="white", ec="none", alpha=0.7), **style)


def draw_ghost(ax, top, frame, ctx: Context, colour="#9aa5b1", alpha=0.55):
    """A light outline of the mechanism at another position (bars and the drive as lines)."""
    pairs = [(_xy(frame, a), _xy(frame, b)) for a, b in top.bars]
    if top.drive is not None:
        pairs.append(tuple(frame.points[n][0] for n in top.drive[1]))
    for p, q in pairs:
        if np.all(np.isfinite(p)) and np.all(np.isfinite(q)):
            ax.plot([p[0], q[0]], [p[1], q[1]], "-", color=colour, lw=1.0, alpha=alpha, zorder=0.5)


def draw_paths(ax, top, ctx, colour="#b0b8c0"):
    """The path of every moving joint and tip over the stroke (dotted)."""
    for name in top.joints + top.tips:
        xy = ctx.paths.get(name)
        if xy is not None and len(xy) > 1 and np.ptp(xy, axis=0).max() > 1e-6 * ctx.extent:
            ax.plot(xy[:, 0], xy[:, 1], ":", color=colour, lw=0.9, zorder=0.4)


def limits(ctxs, margin=0.12):
    """(x0, x1, y0, y1) around every path and arrow of the contexts ``ctxs``, with a margin."""
    xy = np.concatenate([v for c in ctxs for v in c.paths.values() if len(v)]
                        + [np.reshape(c.extra, (-1, 2)) for c in ctxs] + [np.zeros((0, 2))])
    xy = xy[np.all(np.isfinite(xy), axis=1)]
    if not len(xy):
        return (-1.0, 1.0, -1.0, 1.0)
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    pad = margin * max(np.max(hi - lo), 1e-9)
    return (lo[0] - pad, hi[0] + pad, lo[1] - pad, hi[1] + pad)


def frame_view(ax, ctx_or_boxes, margin=0.12, box=None):
    """Equal axes around every path of the stroke (one or several contexts), with a margin."""
    ctxs = ctx_or_boxes if isinstance(ctx_or_boxes, (list, tuple)) else [ctx_or_boxes]
    x0, x1, y0, y1 = box or limits(ctxs, margin)
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal", adjustable="box")
    ax.tick_params(labelsize=7)
    ax.grid(alpha=0.15)


def panel_size(box, width=5.6, low=3.2, high=8.0) -> tuple:
    """(width, height) in inches of a panel that shows ``box`` at equal scale."""
    x0, x1, y0, y1 = box
    aspect = (y1 - y0) / max(x1 - x0, 1e-12)
    return width, float(np.clip(width * aspect + 0.9, low, high))
