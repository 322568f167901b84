"""`optdesign draw SCENE`: a preview of a scene (every point labelled, at the start and a few
stroke positions, marking where the stroke stops assembling), or its geometry as DXF/SVG."""
from __future__ import annotations

import sys

from .common import add_scene_arguments, output_file
from .design_option import add_design_argument, default_file, scene_with_design

HELP = ("draw a scene at the start and a few stroke positions with every point labelled (PNG or SVG), "
        "or export its geometry at chosen positions as DXF/SVG for CAD")


def add_arguments(p):
    add_scene_arguments(p)
    add_design_argument(p)
    p.add_argument("--out", metavar="FILE", help="the preview (.png or .svg; default "
                   "optdesign-results/<scene>-draw.png; with --dxf or --svg only when given; - : a PNG to "
                   "standard output, what is printed then going to standard error)")
    p.add_argument("--positions", metavar="F1,F2,...|N",
                   help="stroke positions as fractions (0 = start, 1 = end), e.g. 0,0.5,1, or a count N "
                        "(default 0,0.25,0.5,0.75,1 for the preview, 0 for --dxf/--svg)")
    p.add_argument("--dxf", metavar="FILE", help="write the geometry at --positions as DXF (mm, one layer per position)")
    p.add_argument("--svg", metavar="FILE", help="write the geometry at --positions as a plain SVG (mm)")


def run(args):
    from ..report import cad
    from ..report.preview import positions, preview_figure

    for flag in ("--out", "--dxf", "--svg"):
        if getattr(args, flag[2:]):
            output_file(getattr(args, flag[2:]), flag)
    scene = scene_with_design(args)
    samples = args.samples or 201
    if args.dxf or args.svg:
        indices = positions(args.positions or "0", samples)
        if args.dxf:
            print(f"wrote {cad.write_dxf(args.dxf, scene, indices, samples, '--dxf')}", file=sys.stderr)
        if args.svg:
            print(f"wrote {cad.write_svg(args.svg, scene, indices, samples, '--svg')}", file=sys.stderr)
        if not args.out:
            return
    out = args.out or output_file(default_file(args, "-draw.png"), "--out")
    paths, summary = preview_figure(scene, [out], args.positions or "0,0.25,0.5,0.75,1", samples, label="--out")
    for path in paths:
        print(f"wrote {path}", file=sys.stderr)
    shown = sys.stderr if args.to_stderr else sys.stdout
    if args.json:
        import json

        print(json.dumps({"kind": "drawing", "file": scene.path, "files": [str(p) for p in paths],
                          "assembly": summary}), file=shown)
    else:
        print(f"{scene.title}: {summary}", file=shown)
