"""What the commands that take a design share: ``--design result.json`` (draw, animate, analyse or
simulate an optimised design) and, for the drawing commands, the
default output folder, ``optdesign-results/`` under the current directory (never the
project's tracked ``results/`` unless asked with ``--out``).  Imports cheaply."""
from __future__ import annotations

from pathlib import Path

from ..errors import OptdesignError
from .common import load_scene

DEFAULT_ROOT = Path("optdesign-results")


def add_design_argument(p, verb="draw", example=""):
    p.add_argument("--design", metavar="RESULT_JSON",
                   help=f"{verb} the design of an optimisation: its result.json (the scene's design variables set "
                        f"to the optimum's values{example})")


def scene_with_design(args):
    """The scene with --set applied and, with --design, the design of the result file."""
    import json

    scene = load_scene(args)
    if not getattr(args, "design", None):
        return scene
    path = Path(args.design)
    if path.is_dir():
        inside = f" (--design {path / 'result.json'})" if (path / "result.json").is_file() else ""
        raise OptdesignError(f"--design {path}: a folder, not a file; give the result.json that `optdesign optimise` "
                             f"wrote in it{inside}")
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError:
        raise OptdesignError(f"--design {path}: no such file (expected the result.json of `optdesign optimise`)") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise OptdesignError(f"--design {path}: not a result file, it does not read as JSON ({exc}); give the "
                             "result.json that `optdesign optimise` wrote") from None
    design = data.get("design") if isinstance(data, dict) else None
    if not isinstance(design, dict) or not all(isinstance(v, (int, float)) for v in design.values()):
        raise OptdesignError(f"--design {path}: no 'design' table of numbers in it (expected the result.json of "
                             "`optdesign optimise`)")
    variables = [q.name for q in scene.parameters if q.is_design]
    scene = with_chosen_motor(scene, data.get("chosen_motor"))
    try:
        return scene.with_parameters(**design)
    except OptdesignError as exc:
        if all(name in variables for name in design):
            raise
        made = f" (made from {data['file']})" if isinstance(data.get("file"), str) else ""
        raise OptdesignError(
            f"--design {path}: {exc}; its design ({', '.join(design)}) is not this scene's "
            f"({', '.join(variables) or 'none'}): is the result of another scene{made}? Give the "
            f"result.json of an optimisation of {args.scene}") from None

def default_file(args, suffix) -> Path:
    """optdesign-results/<scene name><suffix>, e.g. optdesign-results/truck_crane-draw.png."""
    stem = Path(args.scene).stem + ("-optimum" if getattr(args, "design", None) else "")
    return DEFAULT_ROOT / f"{stem}{suffix}"


def with_chosen_motor(scene, chosen):
    """With a motor catalogue's result (``chosen``: its chosen_motor), the scene's duty cycle in
    time ([simulation] motor) runs the motor the result chose, not the one the file names."""
    import dataclasses

    sim = scene.simulation
    if not isinstance(chosen, str) or sim is None or sim.motor in (None, chosen):
        return scene
    if chosen not in {m.name for m in scene.motors}:
        raise OptdesignError(f"--design: its chosen motor {chosen!r} is not in this scene's [[motors]] "
                             f"({', '.join(m.name for m in scene.motors)}): give the result of an optimisation of "
                             "this scene")
    return dataclasses.replace(scene, simulation=dataclasses.replace(sim, motor=chosen))
