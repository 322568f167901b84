"""report.html of an optimisation: one self-contained page (no script, no network: the figures
are inlined, the SVG drawing as markup, the PNG figures and the GIF animation as base64 data)
with the problem, the design table with its bounds, the constraints with the active ones
marked, the certified peak, the local optima the starts found, the sensitivities, the figures,
the animation and every start."""
from __future__ import annotations

import base64
import html
import re
from pathlib import Path

import numpy as np

from .units import constraint_scale, objective_kind_text, number, parameter_unit, peak_quantity, quantity, scaled, sweep_scale

STYLE = """
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; margin: 0; color: #1d2733;
       background: #f6f7f9; line-height: 1.4; }
main { max-width: 1150px; margin: 0 auto; padding: 1.2em 1.5em 3em; background: white; }
h1 { font-size: 1.45em; margin: 0.2em 0 0.1em; } h2 { font-size: 1.15em; margin-top: 1.6em;
     border-bottom: 1px solid #d8dde3; padding-bottom: 0.2em; }
.meta { color: #5b6775; font-size: 0.9em; }
.verdict { padding: 0.7em 1em; border-radius: 6px; margin: 1em 0; font-size: 1.05em; }
.ok { background: #e8f5e9; border: 1px solid #a5d6a7; } .warn { background: #fff8e1; border: 1px solid #ffd54f; }
.bad { background: #fdecea; border: 1px solid #ef9a9a; }
table { border-collapse: collapse; margin: 0.5em 0; font-size: 0.92em; }
th, td { border: 1px solid #d8dde3; padding: 0.25em 0.6em; text-align: right; }
th { background: #eef1f4; } td:first-child, th:first-child { text-align: left; }
tr.active td { background: #fff3e0; font-weight: 600; }
figure { margin: 1em 0; } figure img, figure svg { max-width: 100%; height: auto; border: 1px solid #e3e7eb; }
figcaption { color: #5b6775; font-size: 0.88em; }
details summary { cursor: pointer; color: #1a4f8b; }
"""


def _e(text) -> str:
    return html.escape(str(text), quote=True)


def _table(table_id, head, rows, active=None) -> str:
    out = [f'<table id="{table_id}"><thead><tr>' + "".join(f"<th>{_e(h)}</th>" for h in head) + "</tr></thead><tbody>"]
    for i, row in enumerate(rows):
        cls = ' class="active"' if active and active[i] else ""
        out.append(f"<tr{cls}>" + "".join(f"<td>{_e(c)}</td>" for c in row) + "</tr>")
    out.append("</tbody></table>")
    return "".join(out)


def _image(path, alt) -> str:
    data = base64.b64encode(Path(path).read_bytes()).decode("ascii")
    kind = {"png": "image/png", "gif": "image/gif", "jpg": "image/jpeg"}[Path(path).suffix.lstrip(".").lower()]
    return f'<img src="data:{kind};base64,{data}" alt="{_e(alt)}">'


def _svg(path) -> str:
    """The SVG's markup without its XML prolog and metadata, to sit inside the page."""
    text = Path(path).read_text()
    start = text.find("<svg")
    svg = re.sub(r"<metadata>.*?</metadata>\s*", "", text[start:], count=1, flags=re.S)
    return re.sub(r"<svg([^>]*?)\swidth=\"[^\"]*\"\sheight=\"[^\"]*\"", r'<svg\1 role="img"', svg, count=1)


def objective_unit(result) -> str:
    """The objective's unit where it is one quantity's peak or RMS (N m, N, W, ...), else ''."""
    from .cases import UNITS

    text = result.scene.objective.minimise.replace(" ", "")
    m = re.fullmatch(r"(?:peak|rms|rms_sweep|rms_time)\((\w+)(?:,[^()]*)?\)", text)
    if m is None or result.scene.drive is None:
        return ""
    unit = UNITS[result.scene.drive.kind].get(m.group(1), "")
    return "" if unit == "1" else unit


def verdict(result) -> tuple:
    """(css class, sentence): what the result is, worded for a person."""
    optima = getattr(result, "optima", ()) or ()
    if not result.success:
        return "bad", f"No optimum: {result.status}. {result.message}"
    unit = objective_unit(result)
    value = quantity(result.objective, unit, 6) if unit else number(result.objective, 6)
    n, total = result.starts_at_best, result.starts_total
    if total == 1:
        return "warn", (f"Local optimum {value} from a single start: run more starts (--starts 20) to see whether a "
                        "better one exists.")
    text = f"Best optimum {value} ({objective_kind_text(result)}), reached by {n} of {total} starts"
    if len(optima) > 1:
        text += f"; the starts found {len(optima)} distinct local optima"
    if 4 * n < total or n < 2:
        return "warn", text + ": few starts agree, run more starts to be confident it is the best."
    return "ok", text + "."


def _design_rows(result, analyses):
    scene = result.scene
    values = scene.parameter_values()
    rows, active = [], []
    for p in scene.parameters:
        if not p.is_design:
            continue
        kind = "angle" if "deg" in p.value.source else "length"
        f, unit = parameter_unit(p, kind, scene)
        bound = result.constraints.get(f"bounds of {p.name}", {})
        at = bound.get("active")
        rows.append([p.name, number(values[p.name] * f), number(result.design[p.name] * f, 6),
                     "-" if p.lower is None else number(p.lower * f), "-" if p.upper is None else number(p.upper * f),
                     unit, {"lower": "at its min", "upper": "at its max"}.get(at, "")])
        active.append(bool(at))
    return rows, active


def _constraint_rows(result):
    scene = result.scene
    by_name = {c.name: c for c in scene.constraints}
    rows, active = [], []
    for name, c in result.constraints.items():
        if c.get("kind") == "bound":
            continue
        f, unit = constraint_scale(by_name[name]) if name in by_name else (1.0, "")
        size = max([abs(c[k]) for k in ("min", "max", "value", "lower", "upper") if c.get(k) is not None], default=0.0)
        show = lambda v: "-" if v is None else number(v * f, scale=size * f)  # noqa: E731  (round-off as 0)
        if c.get("min") is not None and c.get("max") is not None and c.get("kind") != "stroke constraint":
            value = f"{show(c['min'])} .. {show(c['max'])}"
        else:
            value = show(c.get("value"))
        per = f" per {unit}" if unit else ""   # d objective / d bound in the unit the bound is shown in
        rows.append([name, c.get("kind", ""), value, show(c.get("lower")), show(c.get("upper")), unit,
                     c.get("active") or "", number((c.get("multiplier") or 0.0) / f, 4) + per])
        active.append(bool(c.get("active")))
    return rows, active


def _problem(result) -> str:
    scene = result.scene
    sf, su = sweep_scale(scene)
    from ..scene import ResolvedScene

    resolved = ResolvedScene(scene)
    sweep = f"{scene.sweep.name} from {number(resolved.start * sf)} to {number(resolved.stop * sf)} {su}".rstrip()
    drive = "-" if scene.drive is None else f"{scene.drive.kind}, between {' and '.join(scene.drive.pins)}"
    items = [("minimise", scene.objective.minimise), ("stroke", f"{sweep} ({scene.sweep.samples} samples)"),
             ("drive", drive), ("design variables", ", ".join(resolved.design_names)),
             ("constraints", ", ".join(c.name for c in scene.constraints) or "none")]
    if scene.source:
        items.append(("source", scene.source))
    return "<table id=\"problem\"><tbody>" + "".join(
        f"<tr><th>{_e(k)}</th><td style=\"text-align:left\">{_e(v)}</td></tr>" for k, v in items) + "</tbody></table>"


def _peak(result, analyses) -> str:
    unit = objective_unit(result)
    parts = []
    if result.objective is not None:
        shown = (lambda v: quantity(v, unit, 7)) if unit else (lambda v: number(v, 7))
        if result.objective_kind in ("peak", None):
            parts.append(f"<p id=\"certified\">Objective <b>{_e(shown(result.objective))}</b>, certified over the "
                         f"continuous stroke ({_e(shown(result.objective_sampled))} on the scene's samples alone).</p>")
        else:
            parts.append(f"<p id=\"certified\">Objective <b>{_e(shown(result.objective))}</b>: "
                         f"{_e(objective_kind_text(result))}.</p>")
    what = peak_quantity(result)
    if result.peak_certified is not None and what != "drive":   # peak(NAME) of another quantity
        parts.append(f"<p>Peak |{_e(what)}| {_e(number(result.peak_certified, 7))} certified "
                     f"({_e(number(result.peak_sampled, 7))} sampled).</p>")
    elif result.peak_certified is not None and analyses:
        optimum = analyses[-1][1]
        drive = "N m" if result.scene.drive.kind == "rotary" else "N"
        at = (getattr(optimum, "peak_at", {}) or {}).get("drive")
        s = at["s"] if at else float(optimum.columns["s"][int(np.argmax(np.abs(optimum.columns["drive"])))])
        sf, su = sweep_scale(result.scene)
        parts.append(f"<p>Peak |drive| {_e(quantity(result.peak_certified, drive, 7))} certified "
                     f"({_e(quantity(result.peak_sampled, drive, 7))} sampled), at {_e(result.scene.sweep.name)} = "
                     f"{_e(number(s * sf))} {_e(su)}.</p>")
    return "".join(parts)


def _optima(result) -> str:
    optima = getattr(result, "optima", ()) or ()
    if not optima:
        return "<p id=\"optima\">This result holds no list of the distinct local optima its starts found.</p>"
    found = [o.as_dict() if hasattr(o, "as_dict") else dict(o) for o in optima]
    unit = objective_unit(result)
    k, shown = scaled([d["value"] for d in found], unit) if unit else (1.0, "")
    names = list(result.design)
    head = ["#", f"objective [{shown}]" if shown else "objective", "starts"] + names
    rows = [[j + 1, number(d["value"] * k, 7), len(d["starts"])] + [number(d["design"][n], 5) for n in names]
            for j, d in enumerate(found)]
    return _table("optima", head, rows)


def _drive_train(result, folder) -> str:
    """The drive-train section (report/drive_train.py) from the folder's result.json: the
    numbers the JSON holds."""
    import json

    from .drive_train import train_html

    path = Path(folder) / "result.json"
    if not result.scene.cases or not path.exists():
        return ""
    sf, su = sweep_scale(result.scene)
    return train_html(json.loads(path.read_text()), (sf, su, result.scene.sweep.name), _table, _e)


def write_html(result, folder, analyses=(), files=()) -> Path:
    """Write ``folder``/report.html (atomically) from ``result`` and the figure ``files`` that
    exist in ``folder``; ``analyses``: (label, AnalysisResult) of the start and the optimum."""
    from importlib import metadata

    from .files import write_file

    folder = Path(folder)
    scene = result.scene
    cls, sentence = verdict(result)
    design_rows, design_active = _design_rows(result, analyses)
    constraint_rows, constraint_active = _constraint_rows(result)
    try:
        version = metadata.version("optdesign")
    except metadata.PackageNotFoundError:  # pragma: no cover - run from a plain checkout
        version = "?"
    body = [f"<header><h1>{_e(scene.title)}</h1><p class=\"meta\">{_e(scene.path)} &middot; optdesign {_e(version)} "
            f"&middot; IPOPT status {_e(result.status)}</p></header>",
            f'<div id="verdict" class="verdict {cls}">{_e(sentence)}</div>',
            "<h2>Problem</h2>", _problem(result),
            "<h2>Design</h2>", _table("design", ["variable", "start", "optimum", "min", "max", "unit", ""],
                                      design_rows, design_active),
            "<h2>Constraints</h2>",
            "<p class=\"meta\">Per-sample constraints show their range over the stroke at the optimum; the "
            "multiplier is d objective / d bound per unit of the bound as shown (per deg where it is in deg; 0 "
            "where the bound is not active). Active rows are marked.</p>",
            _table("constraints", ["constraint", "kind", "value", "min", "max", "unit", "active", "multiplier"],
                   constraint_rows, constraint_active),
            "<h2>Objective</h2>", _peak(result, analyses), _drive_train(result, folder),
            "<h2>Local optima</h2>", _optima(result)]
    if result.sensitivities:
        body += ["<h2>Sensitivities</h2>", "<p class=\"meta\">d objective / d parameter, SI units.</p>",
                 _table("sensitivities", ["parameter", "d objective / d parameter"],
                        [[k, number(v, 6)] for k, v in result.sensitivities.items()])]
    body.append("<h2>Figures</h2>")
    captions = {"mechanism.svg": "The start and the optimum, side by side at one scale, at the start of the stroke.",
                "drive_and_constraints.png": "Drive load and constraints over the stroke, start and optimum: bounds "
                                             "dashed, feasible side shaded, peaks marked"
                                             + (" (the nominal [drive] state; the load cases below)."
                                                if scene.cases else "."),
                "cases.png": "Each load case at the optimum over the stroke, the governing case of each peak marked.",
                "torque_speed.png": "The motor's torque-speed plane at the optimum: peak and rated envelopes, the speed "
                                    "limit, each case's operating points and RMS point, the duty cycle's RMS point.",
                "cylinder.png": "The cylinder's pressure and pump flow through the duty cycle at the optimum.",
                "animation.gif": "The optimum moving over its stroke, with its drive load"
                                 + (" (the governing case's)" if scene.cases else "") + " and transmission angle."}
    for name in ("mechanism.svg", "drive_and_constraints.png", "cases.png", "torque_speed.png", "cylinder.png",
                 "animation.gif"):
        path = folder / name
        if name in files or path.exists():
            if name == "animation.gif":
                body.append("<h2>Animation</h2>")
            content = _svg(path) if name.endswith(".svg") else _image(path, captions[name])
            body.append(f'<figure id="{name.split(".")[0]}">{content}<figcaption>{_e(captions[name])}'
                        f"</figcaption></figure>")
    starts = [[s.index, s.status, "-" if s.objective is None else number(s.objective, 9), s.iterations,
               "yes" if s.repaired else "", f"{s.time_s * 1e3:.0f}"] for s in result.starts]
    body.append("<h2>Starts</h2><details><summary>every start (" + str(len(starts)) + ")</summary>"
                + _table("starts", ["start", "status", "objective", "iterations", "repaired", "time [ms]"], starts)
                + "</details>")
    page = ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">"
            f"<title>{_e(scene.title)}</title><style>{STYLE}</style></head><body><main>"
            + "\n".join(body) + "</main></body></html>\n")
    return write_file(folder / "report.html", page)
