"""`optdesign animate SCENE`: the mechanism moving over its stroke (GIF, and MP4 where ffmpeg is
on PATH) with the drive force or torque traced beside it and the transmission angle."""
from __future__ import annotations

import sys

from .common import add_scene_arguments, output_file, whole_number
from .design_option import add_design_argument, default_file, scene_with_design

HELP = ("animate the mechanism over its stroke with its drive force/torque and transmission angle "
        "(GIF; MP4 too where ffmpeg is on PATH)")


def add_arguments(p):
    add_scene_arguments(p)
    add_design_argument(p)
    p.add_argument("--out", metavar="FILE.gif", help="the GIF (default optdesign-results/<scene>-animation.gif); "
                   "the MP4 goes beside it with the suffix .mp4; - : the GIF alone to standard output, what is "
                   "printed then going to standard error")
    p.add_argument("--frames", type=whole_number(2), default=36, help="frames over the stroke, >= 2 (default 36)")
    p.add_argument("--fps", type=whole_number(1), default=12, help="frames per second (default 12)")
    p.add_argument("--no-mp4", action="store_true", help="write the GIF only, even where ffmpeg is available")
    p.add_argument("--frame", metavar="FRACTION", type=float,
                   help="write one frame alone, at this fraction of the stroke (0 = start, 1 = end), as the PNG "
                        "--out names (e.g. for a document)")


def run(args):
    from pathlib import Path

    from ..errors import OptdesignError
    from ..model.analysis import analyse
    from ..report.animate import animate, ffmpeg_available

    from ..scene.arguments import animation_frames

    still = args.frame is not None
    if not still:
        animation_frames(args.frames)   # before the analysis: a film too long to draw is refused at once
    gif = Path(args.out or default_file(args, "-frame.png" if still else "-animation.gif"))
    suffix = ".png" if still else ".gif"
    if args.out == "-":
        gif = "-"                                   # the GIF (or the frame's PNG) alone
    elif gif.suffix.lower() != suffix:
        raise OptdesignError(f"--out {gif}: expected a file name ending in {suffix}" + (
            " (the MP4 is written beside it)" if not still else " for --frame"))
    if still and not 0 <= args.frame <= 1:
        raise OptdesignError(f"--frame {args.frame}: expected a fraction of the stroke in 0 .. 1")
    paths = [gif] + ([] if args.no_mp4 or still or gif == "-" else [gif.with_suffix(".mp4")])
    for path in paths:
        output_file(path, "--out")
    scene = scene_with_design(args)
    analysis = analyse(scene, args.samples) if scene.drive is not None else None
    written = animate(scene, paths, frames=args.frames, fps=args.fps, analysis=analysis,
                      at=[args.frame] if still else None, label="--out")
    for path in written:
        print(f"wrote {path}", file=sys.stderr)
    if not args.no_mp4 and not still and gif != "-" and not ffmpeg_available():
        print("no MP4: ffmpeg is not on PATH (the GIF holds the same frames)", file=sys.stderr)
    shown = sys.stderr if args.to_stderr else sys.stdout
    if args.json:
        import json

        print(json.dumps({"kind": "animation", "file": scene.path, "files": [str(p) for p in written],
                          "frames": args.frames, "fps": args.fps}), file=shown)
    else:
        what = f"the frame at {args.frame:g} of the stroke" if still else f"{args.frames} frames over the stroke"
        print(f"{scene.title}: {what} -> {', '.join(map(str, written))}", file=shown)
