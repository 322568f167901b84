"""The mechanism figure: one or several designs of a scene drawn side by side at the same
scale, each at the start of its stroke (solid, with the dimensions of its design variables)
over light outlines at a few more positions and the dotted paths of its joints."""
from __future__ import annotations

import textwrap
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .dimensions import dimensions, draw_dimensions
from .drawing import Context, context, draw_ghost, draw_mechanism, draw_paths, frame_view, limits, panel_size
from .geometry import Frames, Geometry
from .joint_arrows import draw_force_elements, draw_pin_forces
from .layout import fixed_layout
from .output import new_figure, save_figures
from .topology import Topology, topology


@dataclass
class View:
    """One design ready to draw: its geometry, topology, frames over the stroke and context."""

    scene: object
    geometry: Geometry
    top: Topology
    frames: Frames
    ctx: Context


def view(scene, samples=61, extent=None) -> View:
    """A :class:`View` of ``scene`` with ``samples`` positions over its stroke."""
    geometry = Geometry(scene)
    top = topology(geometry.scene)
    frames = geometry.frames(geometry.stroke(samples))
    return View(geometry.scene, geometry, top, frames, context(top, frames, extent))


def draw_design(ax, v: View, index=0, ghosts=4, dims=True, labels="joints", title=None, loads=True, joints=True):
    """Draw design ``v`` at sample ``index`` over ``ghosts`` outlines spread over the stroke;
    ``joints``: the forces at its pins too (report/joint_arrows.py)."""
    n = len(v.frames.s)
    draw_paths(ax, v.top, v.ctx)
    for i in np.linspace(0, n - 1, ghosts + 1).round().astype(int)[1:] if ghosts else ():
        if i != index and v.frames.assembled[i]:
            draw_ghost(ax, v.top, v.frames.at(i), v.ctx)
    frame = v.frames.at(index)
    if not v.frames.assembled.all():
        ax.text(0.01, 0.01, assembly_note(v), transform=ax.transAxes, fontsize=7, color="#b00020", va="bottom",
                wrap=True)
    draw_mechanism(ax, v.top, frame, v.ctx, labels=labels, loads=loads, scene=v.scene)
    draw_force_elements(ax, v.scene, frame, v.ctx.w)
    if joints:
        draw_pin_forces(ax, v.scene, v.frames, index, v.ctx)
    if dims:
        xy = np.concatenate([p for p in frame.points.values()])
        centre = np.nanmean(xy[np.all(np.isfinite(xy), axis=1)], axis=0) if np.isfinite(xy).any() else np.zeros(2)
        draw_dimensions(ax, dimensions(v.geometry, frame), v.ctx.w, centre)
    if title:
        ax.set_title(title, fontsize=9)
    ax.set_xlabel("x [m]", fontsize=8)
    ax.set_ylabel("y [m]", fontsize=8)


def assembly_note(v: View) -> str:
    """Where the stroke of ``v`` does not assemble: 'does not assemble for theta = a .. b deg
    ([points] C (dyad))', or '' when it does everywhere."""
    from .units import sweep_scale

    bad = ~v.frames.assembled
    if not bad.any():
        return ""
    factor, unit = sweep_scale(v.scene)
    s = v.frames.s[bad] * factor
    first = v.frames.failed[np.flatnonzero(bad)[0]]
    return (f"does not assemble for {v.scene.sweep.name} = {s.min():.4g} .. {s.max():.4g} {unit} "
            f"({bad.sum()} of {len(bad)} positions; first: [points] {first})").replace(" )", ")")


def design_title(label, scene, names=None) -> str:
    """'label: e = 3 m, b = 4 m' with the design variables in the scene's units."""
    from .units import parameter_unit

    values = scene.parameter_values()
    names = [p.name for p in scene.parameters if p.is_design] if names is None else names
    parts = []
    for name in names:
        factor, unit = parameter_unit(scene.parameter(name), "angle" if "deg" in scene.parameter(name).value.source
                                      else "length", scene)
        parts.append(f"{name} = {values[name] * factor:.4g} {unit}".rstrip())
    return textwrap.fill(f"{label}: " + ", ".join(parts), 70) if parts else label


def mechanism_figure(designs, paths, suptitle=None) -> list:
    """Draw ``designs`` (a list of (label, scene)) side by side at one scale and save the figure
    to every path in ``paths`` (the format from its suffix: .png, .svg); returns the paths."""
    views = [(label, view(scene)) for label, scene in designs]
    extent = max(v.ctx.extent for _, v in views)
    for _, v in views:  # one bar width for all: the same scale side by side
        v.ctx.w = 0.018 * extent
        v.ctx.extent = extent
    box = limits([v.ctx for _, v in views])
    w, h = panel_size(box)
    width = w * len(views)
    fig, axes = new_figure(1, len(views), figsize=(width, h + 0.5), layout=None, squeeze=False)
    titles = []
    for ax, (label, v) in zip(axes[0], views):
        titles.append(design_title(label, v.scene))
        draw_design(ax, v, title=titles[-1])
    box = limits([v.ctx for _, v in views])  # with the arrows drawn
    for ax in axes[0]:
        frame_view(ax, [v.ctx for _, v in views], box=box)
    head = textwrap.fill(suptitle, int(12 * width)) if suptitle else ""
    fixed_layout(fig, list(axes[0]), max(t.count("\n") + 1 for t in titles), head.count("\n") + 1 if head else 0)
    if head:   # its top 4 pt below the figure's
        fig.suptitle(head, fontsize=10, y=1 - 4 / 72 / fig.get_size_inches()[1], va="top")
    return save_figures(fig, paths)
