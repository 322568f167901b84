"""The geometry of a design at chosen stroke positions for a CAD user: DXF (ezdxf) and a plain
SVG with the same entities.

Each position is one layer (``POS1``, ``POS2``, ...; its sweep value is written in a text on
it).  On it: the links' centre lines (LINE), every pin as a circle and the ground pivots with a
cross (CIRCLE, LINE), the slider guides (LINE), the drive's axis (LINE; a linear drive with its
barrel as a second, offset pair of lines), centres of mass (POINT and CIRCLE) and every point's
name (TEXT).  Lengths are in millimetres (DXF header $INSUNITS = 4, mm)."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .drawing import context
from .geometry import Geometry
from .topology import topology
from .units import sweep_scale

MM = 1000.0


@dataclass
class Entity:
    """One CAD entity in mm: ``kind`` 'line' (points a, b), 'circle' (centre a, radius r),
    'point' (a) or 'text' (at a, ``text``, height r); ``layer`` and ``colour`` (ACI)."""

    kind: str
    layer: str
    a: tuple
    b: tuple = (0.0, 0.0)
    r: float = 0.0
    text: str = ""
    colour: int = 7


def entities(scene, indices, samples=201) -> tuple:
    """The entities of ``scene`` at the stroke samples ``indices`` (of ``samples``); returns
    (entities, layer descriptions).  Positions where the mechanism does not assemble are left
    out of the links, with a note on their layer."""
    geometry = Geometry(scene)
    top = topology(geometry.scene)
    frames = geometry.frames(geometry.stroke(samples))
    ctx = context(top, frames)
    factor, unit = sweep_scale(geometry.scene)
    w = ctx.w * MM
    out, layers = [], {}

    def xy(frame, name):
        p = frame.feet[name[5:]][0] if name.startswith("foot:") else frame.points[name][0]
        return tuple(float(v) * MM for v in p)

    def ok(*pts):
        return all(np.all(np.isfinite(p)) for p in pts)

    for k, i in enumerate(indices):
        layer = f"POS{k + 1}"
        frame = frames.at(i)
        value = f"{geometry.scene.sweep.name} = {frames.s[i] * factor:.6g} {unit}".rstrip()
        layers[layer] = value
        note = value if frames.assembled[i] else f"{value}: does not assemble ([points] {frames.failed[i]})"
        corner = np.nanmin(np.concatenate([v for v in ctx.paths.values() if len(v)] or [np.zeros((1, 2))]), axis=0)
        out.append(Entity("text", layer, tuple(corner * MM - [0, (k + 2) * 2.2 * w]), r=1.5 * w, text=note))
        for a, b in top.bars:
            p, q = xy(frame, a), xy(frame, b)
            if ok(p, q) and np.hypot(p[0] - q[0], p[1] - q[1]) > 1e-9:
                out.append(Entity("line", layer, p, q, colour=5))
        for name in top.ground + top.joints:
            p = xy(frame, name)
            if ok(p):
                out.append(Entity("circle", layer, p, r=0.42 * w, colour=7))
        for name in top.ground:
            p = np.array(xy(frame, name))
            if ok(p):
                for d in ((1, 0), (0, 1)):
                    e = np.array(d) * 1.2 * w
                    out.append(Entity("line", layer, tuple(p - e), tuple(p + e), colour=8))
        for point, key, _ in top.sliders:
            origin, angle = frames.guides[key]
            if key in ctx.spans and ok(xy(frame, origin)):
                u = np.array([np.cos(angle[i]), np.sin(angle[i])])
                o = np.array(xy(frame, origin))
                a, b = (o + t * MM * u for t in ctx.spans[key])
                out.append(Entity("line", layer, tuple(a), tuple(b), colour=8))
        if top.drive is not None:
            p, q = (np.array(xy(frame, n)) for n in top.drive[1])
            if ok(p, q):
                out.append(Entity("line", layer, tuple(p), tuple(q), colour=1))
                if top.drive[0] == "linear" and ctx.lengths:
                    u = (q - p) / max(np.hypot(*(q - p)), 1e-12)
                    n = np.array([-u[1], u[0]]) * 0.78 * w
                    end = p + u * 0.86 * ctx.lengths[0] * MM
                    for sgn in (1, -1):
                        out.append(Entity("line", layer, tuple(p + sgn * n), tuple(end + sgn * n), colour=1))
        for name, c in frame.coms.items():
            p = tuple(float(v) * MM for v in c[0])
            if ok(p):
                out.append(Entity("point", layer, p, colour=3))
                out.append(Entity("circle", layer, p, r=0.55 * w, colour=3))
        for name in frame.points:
            p = xy(frame, name)
            if ok(p) and name not in top.helpers:
                out.append(Entity("text", layer, (p[0] + 0.6 * w, p[1] + 0.6 * w), r=1.2 * w, text=name))
    return out, layers


def write_dxf(path, scene, indices, samples=201, label="") -> Path:
    """The entities as a DXF file (R2010, mm), written by report/files.py (``label``: the option
    that named it); returns the path."""
    import io

    import ezdxf

    from .files import write_file

    items, layers = entities(scene, indices, samples)
    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 4  # millimetres
    for name, description in layers.items():
        doc.layers.add(name).description = description
    msp = doc.modelspace()
    for e in items:
        attrs = {"layer": e.layer, "color": e.colour}
        if e.kind == "line":
            msp.add_line(e.a, e.b, dxfattribs=attrs)
        elif e.kind == "circle":
            msp.add_circle(e.a, e.r, dxfattribs=attrs)
        elif e.kind == "point":
            msp.add_point(e.a, dxfattribs=attrs)
        else:
            msp.add_text(e.text, height=e.r, dxfattribs=attrs).set_placement(e.a)
    buf = io.StringIO()
    doc.write(buf)
    return write_file(path, buf.getvalue(), label)


SVG_COLOURS = {1: "#d62728", 3: "#2ca02c", 5: "#1f3b5a", 7: "#000000", 8: "#555555"}


def write_svg(path, scene, indices, samples=201, label="") -> Path:
    """The same entities as a plain SVG (one group per position, y up, 1 unit = 1 mm)."""
    from xml.sax.saxutils import escape

    from .files import write_file

    items, layers = entities(scene, indices, samples)
    pts = np.array([e.a for e in items] + [e.b for e in items if e.kind == "line"], float)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pad = 0.05 * max(np.max(hi - lo), 1.0)
    x0, y0 = lo - pad
    width, height = hi - lo + 2 * pad
    stroke = max(width, height) / 600
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width:.6g}mm" height="{height:.6g}mm" '
           f'viewBox="{x0:.6g} {-(y0 + height):.6g} {width:.6g} {height:.6g}">']
    for layer, description in layers.items():
        out.append(f'<g id="{layer}"><title>{escape(description)}</title>')
        for e in (e for e in items if e.layer == layer):
            colour = SVG_COLOURS.get(e.colour, "#000000")
            if e.kind == "line":
                out.append(f'<line x1="{e.a[0]:.6g}" y1="{-e.a[1]:.6g}" x2="{e.b[0]:.6g}" y2="{-e.b[1]:.6g}" '
                           f'stroke="{colour}" stroke-width="{stroke:.4g}"/>')
            elif e.kind in ("circle", "point"):
                r = e.r if e.kind == "circle" else stroke
                out.append(f'<circle cx="{e.a[0]:.6g}" cy="{-e.a[1]:.6g}" r="{r:.6g}" fill="none" '
                           f'stroke="{colour}" stroke-width="{stroke:.4g}"/>')
            else:
                out.append(f'<text x="{e.a[0]:.6g}" y="{-e.a[1]:.6g}" font-size="{e.r:.4g}" '
                           f'font-family="sans-serif" fill="{colour}">{escape(e.text)}</text>')
        out.append("</g>")
    out.append("</svg>")
    return write_file(path, "\n".join(out) + "\n", label)
