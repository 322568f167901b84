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
    return _with_design(scene, design, data, path, args)


def _with_design(scene, design, data, path, args):
    """The scene with the result's design set, by explicit rules: the result must be of this scene
    and give every design variable (or --set gives the ones it lacks); --set wins over the
    design's value of a variable, and an unsuccessful or interrupted result is used as it is;
    both are said on standard error."""
    import sys

    from .common import overrides

    variables = [q.name for q in scene.parameters if q.is_design]
    scene = with_chosen_motor(scene, data.get("chosen_motor"))   # a catalogue's result: its motor
    made = f" (made from {data['file']})" if isinstance(data.get("file"), str) else ""
    give = f"give the result.json of an optimisation of {args.scene}"
    if any(name not in variables for name in design):
        try:
            scene.with_parameters(**design)
        except OptdesignError as exc:
            if all(name in variables for name in design):
                raise
            raise OptdesignError(f"--design {path}: {exc}; its design ({', '.join(design)}) is not this scene's "
                                 f"({', '.join(variables) or 'none'}): is the result of another scene{made}? "
                                 f"{give[0].upper()}{give[1:]}") from None
    if (isinstance(data.get("file"), str) and isinstance(data.get("title"), str) and scene.path
            and Path(data["file"]).name != Path(scene.path).name and data["title"] != scene.title):
        raise OptdesignError(f"--design {path}: made from {data['file']} ({data['title']!r}), not from "
                             f"{args.scene} ({scene.title!r}): {give}")
    given = overrides(getattr(args, "set", None))
    missing = [name for name in variables if name not in design and name not in given]
    if missing:
        raise OptdesignError(
            f"--design {path}: gives no value for the design variable{'s' if len(missing) > 1 else ''} "
            f"{', '.join(missing)} of {args.scene} (it holds {', '.join(design) or 'none'}): it is the result of an "
            f"older version of the scene or of another one; optimise again, or give "
            f"{' '.join(f'--set {name}=VALUE' for name in missing)}")
    for name in (n for n in design if n in given):
        print(f"note: --set {name}={given[name]} is used, not the design's {name} = {design[name]:.10g} from {path}",
              file=sys.stderr)
    if data.get("success") is False or data.get("interrupted") is True:
        why = "was interrupted (the best of its finished starts)" if data.get("interrupted") else (
            f"did not succeed ({data.get('status') or 'success: false'})")
        print(f"note: --design {path}: the optimisation {why}: its design is used as it is, not as a proven optimum",
              file=sys.stderr)
    return scene.with_parameters(**{name: value for name, value in design.items() if name not in given})


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
