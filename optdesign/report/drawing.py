"""Drawing a mechanism at a few positions of its stroke (matplotlib)."""
from __future__ import annotations

import numpy as np

from ..scene import Attach, Dyad, Loop, Polar, Slider


def links(scene):
    """Pairs of point names to draw as lines: what each construction ties together, body
    frames, and the drive (drawn thicker)."""
    pairs = []
    for c in scene.points:
        if isinstance(c, Polar):
            pairs.append((c.centre, c.name))
        elif isinstance(c, Dyad):
            pairs += [(c.p, c.name), (c.q, c.name)]
        elif isinstance(c, Slider):
            pairs.append((c.p, c.name))
        elif isinstance(c, Attach):
            pairs.append((c.origin, c.name))
        elif isinstance(c, Loop):
            chain = [c.base, *c.joints]
            pairs += list(zip(chain[:-1], chain[1:]))
    for b in scene.bodies:
        pairs.append(tuple(b.frame))
    return list(dict.fromkeys(pairs))


def draw_positions(ax, scene, kinematics_result, positions=5, colour_map="viridis"):
    """Draw the mechanism at ``positions`` sweep values spread over the stroke."""
    import matplotlib

    pts = kinematics_result.points
    n = len(kinematics_result.s)
    idx = np.linspace(0, n - 1, positions).round().astype(int)
    cmap = matplotlib.colormaps[colour_map]
    pairs = links(scene)
    drive = tuple(scene.drive.pins) if scene.drive is not None else None
    for j, i in enumerate(idx):
        colour = cmap(j / max(len(idx) - 1, 1))
        for a, b in pairs:
            ax.plot([pts[a]["x"][i], pts[b]["x"][i]], [pts[a]["y"][i], pts[b]["y"][i]], "-", color=colour, lw=1.2)
        if drive is not None:
            a, b = drive
            ax.plot([pts[a]["x"][i], pts[b]["x"][i]], [pts[a]["y"][i], pts[b]["y"][i]], "-", color=colour, lw=3.5, alpha=0.6)
        xs = [pts[p]["x"][i] for p in pts]
        ys = [pts[p]["y"][i] for p in pts]
        ax.plot(xs, ys, "o", color=colour, ms=3)
    last = idx[-1]
    for p in pts:
        ax.annotate(p, (pts[p]["x"][last], pts[p]["y"][last]), fontsize=7, xytext=(3, 3), textcoords="offset points")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(alpha=0.3)
