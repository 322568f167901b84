"""The preview of ``optdesign draw``: a scene at the start of its stroke and at a few more
positions, every point labelled (helpers in grey), with a bar under them that shows where the
stroke assembles and where it stops.  It draws what it can where a construction does not
assemble, so a scene can be looked at while it is being written."""
from __future__ import annotations

import math
import textwrap
from pathlib import Path

import numpy as np

from .dimensions import dimensions, draw_dimensions
from .drawing import context, draw_mechanism, draw_paths, frame_view, limits
from .geometry import Geometry
from .output import save_figure
from .topology import topology
from .units import sweep_scale


def positions(text, samples) -> np.ndarray:
    """Stroke positions from ``text``: fractions of the stroke '0,0.5,1', or a count '5'
    (evenly spread); returns sample indices of a stroke of ``samples`` samples."""
    from ..errors import OptdesignError

    parts = [p.strip() for p in str(text).split(",") if p.strip()]
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise OptdesignError(f"--positions {text!r}: expected fractions of the stroke such as 0,0.5,1 "
                             "or a count such as 5") from None
    if len(values) == 1 and values[0] >= 2 and values[0].is_integer():
        values = list(np.linspace(0, 1, int(values[0])))
    if not values or any(not 0 <= v <= 1 for v in values):
        raise OptdesignError(f"--positions {text!r}: every fraction must lie in 0 .. 1 (0 the start of the "
                             "stroke, 1 its end)")
    return np.array([round(v * (samples - 1)) for v in values], dtype=int)


def stroke_summary(scene, frames) -> str:
    """'assembles over the whole stroke' or where it does not, in the sweep's units."""
    factor, unit = sweep_scale(scene)
    ok = frames.assembled
    name = scene.sweep.name
    if ok.all():
        return "assembles over the whole stroke"
    if not ok.any():
        return f"does not assemble anywhere on the stroke (first: [points] {frames.failed[0]})"
    parts = []
    idx = np.flatnonzero(np.diff(ok.astype(int)))
    for i in idx:
        s = frames.s[i + (0 if ok[i] else 1)] * factor
        verb = "stops assembling after" if ok[i] else "assembles again from"
        why = f" ([points] {frames.failed[i + 1]})" if ok[i] else ""
        parts.append(f"{verb} {name} = {s:.4g} {unit}{why}".replace("  ", " "))
    if not ok[0]:
        parts.insert(0, f"does not assemble at the start ([points] {frames.failed[0]})")
    return "; ".join(parts)


def preview_figure(scene, paths, fractions="0,0.25,0.5,0.75,1", samples=201, title=None, label="") -> tuple:
    """Draw the preview of ``scene`` and save it to every path in ``paths`` (``label``: the option
    that named them); returns (the paths written, the stroke summary)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    geometry = Geometry(scene)
    top = topology(geometry.scene)
    frames = geometry.frames(geometry.stroke(samples))
    ctx = context(top, frames)
    picks = positions(fractions, len(frames.s))
    factor, unit = sweep_scale(geometry.scene)
    n = len(picks)
    cols = min(n, 3)
    rows = math.ceil(n / cols)
    box = limits([ctx])
    aspect = (box[3] - box[2]) / max(box[1] - box[0], 1e-12)
    panel = 4.3
    fig = Figure(figsize=(panel * cols, rows * float(np.clip(panel * aspect + 0.8, 2.8, 7.0)) + 1.3),
                 layout="constrained")
    FigureCanvasAgg(fig)
    grid = fig.add_gridspec(rows + 1, cols, height_ratios=[1] * rows + [0.06])
    for k, i in enumerate(picks):
        ax = fig.add_subplot(grid[k // cols, k % cols])
        frame = frames.at(i)
        draw_paths(ax, top, ctx)
        draw_mechanism(ax, top, frame, ctx, labels="all", loads=k == 0, scene=geometry.scene, stroke=k == 0)
        if k == 0 and frames.assembled[i]:
            xy = np.concatenate(list(frame.points.values()))
            draw_dimensions(ax, dimensions(geometry, frame), ctx.w, np.nanmean(xy, axis=0))
        s = frames.s[i] * factor
        head = f"{geometry.scene.sweep.name} = {s:.4g} {unit}".rstrip() + (" (start)" if i == 0 else "")
        if not frames.assembled[i]:
            head += f"\ndoes not assemble: [points] {frames.failed[i]}"
        ax.set_title(head, fontsize=8.5, color="black" if frames.assembled[i] else "#b00020")
        frame_view(ax, [ctx], box=limits([ctx]))
    bar = fig.add_subplot(grid[rows, :])
    _stroke_bar(bar, geometry.scene, frames, picks)
    fig.suptitle(textwrap.fill(title or geometry.scene.title, int(11 * panel * cols)), fontsize=10)
    written = [save_figure(fig, path, label) for path in paths]
    return written, stroke_summary(geometry.scene, frames)


def _stroke_bar(ax, scene, frames, picks):
    """Green where the stroke assembles, red where it does not; the drawn positions ticked."""
    factor, unit = sweep_scale(scene)
    s = frames.s * factor
    ok = frames.assembled
    edges = np.concatenate([[s[0]], (s[1:] + s[:-1]) / 2, [s[-1]]])
    for i in range(len(s)):
        ax.axvspan(edges[i], edges[i + 1], color="#5cb85c" if ok[i] else "#d9534f", lw=0)
    for i in picks:
        ax.axvline(s[i], color="black", lw=1.2)
    ax.set_xlim(min(s[0], s[-1]), max(s[0], s[-1]))
    ax.set_yticks([])
    ax.set_xlabel(f"{scene.sweep.name} [{unit}]" if unit else scene.sweep.name, fontsize=8)
    ax.set_title(stroke_summary(scene, frames) + " (green: assembles, red: does not; lines: the drawn positions)",
                 fontsize=8, color="black" if ok.all() else "#b00020")
    ax.tick_params(labelsize=7)
