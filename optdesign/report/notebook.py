"""Rich display in Jupyter (issue 29): ``_repr_html_`` of scenes, analyses, optima, simulations
and studies: the key table and the figure (a PNG inlined as base64), in the units of the rest of
the reports (docs/figures.md).  The result classes live in layers below this one; ``optdesign``
(the package's front doors, which may import any layer) sets their ``_repr_html_`` to these
functions when a front door is first used (:func:`optdesign._rich_display`)."""
from __future__ import annotations

import base64
import html
import io


def _table(rows) -> str:
    return ("<table>" + "".join(f"<tr><th style='text-align:left'>{html.escape(str(k))}</th>"
                                f"<td style='text-align:left'>{html.escape(str(v))}</td></tr>" for k, v in rows)
            + "</table>")


def _png(fig) -> str:
    """A figure (or a PNG's bytes) as an inline image."""
    if isinstance(fig, bytes):
        data = fig
    else:
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=80, bbox_inches="tight")
        data = buf.getvalue()
    return f"<img src='data:image/png;base64,{base64.b64encode(data).decode('ascii')}'>"


def _page(title, rows, fig=None) -> str:
    return f"<div><b>{html.escape(title)}</b>{_table(rows)}{_png(fig) if fig is not None else ''}</div>"


def scene_html(scene) -> str:
    from .units import sweep_scale
    from ..scene import ResolvedScene

    r = ResolvedScene(scene)
    sf, su = sweep_scale(scene)
    rows = [("sweep", f"{scene.sweep.name} from {r.start * sf:.4g} to {r.stop * sf:.4g} {su}".rstrip()),
            ("drive", "-" if scene.drive is None else scene.drive.kind),
            ("design variables", ", ".join(r.design_names) or "none"),
            ("load cases", ", ".join(c.name for c in scene.cases) or "none"),
            ("motors", ", ".join(m.name for m in scene.motors) or "none"),
            ("objective", scene.objective.minimise if scene.objective else "none")]
    return _page(scene.title, rows)


def _stroke_figure(scene, s, curves, ylabel):
    from .output import new_figure
    from .units import sweep_label, sweep_scale

    sf, _ = sweep_scale(scene)
    fig, ax = new_figure(figsize=(6, 3))
    for label, values in curves:
        ax.plot(s * sf, values, label=label)
    ax.set_xlabel(sweep_label(scene))
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def analysis_html(result) -> str:
    from .checks import summary_lines

    import numpy as np

    rows = [(line.split(":")[0], line.split(":", 1)[1].strip()) if ":" in line else ("", line)
            for line in summary_lines(result)[1:]]
    cases = getattr(result, "cases", None)
    unit = "N m" if result.drive_kind == "rotary" else "N"
    curves = [("nominal [drive] state" if cases is not None else "drive", result.columns["drive"])]
    fig = _stroke_figure(result.scene, np.asarray(result.columns["s"]), curves, f"drive [{unit}]")
    if cases is not None:
        ax = fig.axes[0]
        from .units import sweep_scale

        sf, _ = sweep_scale(result.scene)
        for name, c in cases.cases.items():
            ax.plot(np.asarray(c.columns["s"]) * sf, c.columns["drive"], lw=1, label=f"case {name}")
        ax.legend(fontsize=8)
    return _page(result.scene.title, rows, fig)


def optimisation_html(result) -> str:
    from .units import objective_kind_text

    rows = [("minimise", result.scene.objective.minimise), ("status", result.status),
            ("objective", f"{result.objective:.6g} ({objective_kind_text(result)})" if result.success else "-")]
    rows += [(f"design {k}", f"{v:.6g}") for k, v in result.design.items()]
    rows += [(f"active: {name}", c["active"]) for name, c in result.constraints.items() if c.get("active")]
    rows.append(("starts at the best", f"{result.starts_at_best} of {result.starts_total}"))
    fig = None
    if result.success and result.scene.cases:
        from .cases import case_load_figure
        from .design_cases import cases_at_optimum
        from .sized import cylinder_figure, torque_speed_figure

        cases = cases_at_optimum(result)
        train = cases.train or {}
        for name, m in (train.get("motors") or {}).items():
            rows.append((f"motor {name}", f"peak {m['peak']:.4g} of {m['peak_torque']:.4g} N m, RMS "
                                          f"{m.get('rms', float('nan')):.4g} of {m['rated_torque']:.4g} N m: "
                                          f"{'fits' if m['fits'] else 'does not fit'}"))
        if train.get("motors"):
            fig = _drawn(torque_speed_figure, cases)
        elif "bore" in train:
            rows += [("cylinder", f"bore {train['bore'] * 1e3:.4g} mm, rod {train['rod'] * 1e3:.4g} mm, pressure "
                                  f"{train['pressure_push'] * 1e-5:.4g} bar pushing, pump flow "
                                  f"{train['pump_flow'] * 6e4:.4g} l/min")]
            fig = _drawn(cylinder_figure, cases)
        else:
            fig = _drawn(lambda c, path: case_load_figure(c, result.scene, path), cases)
    elif result.success:
        import numpy as np

        from ..model.analysis import analyse

        a = analyse(result.scene.with_parameters(**result.design))
        fig = _stroke_figure(result.scene, np.asarray(a.columns["s"]), [("optimum", a.columns["drive"])],
                             "drive [N m]" if a.drive_kind == "rotary" else "drive [N]")
    return _page(result.scene.title, rows, fig)


def _drawn(draw, cases) -> bytes:
    """The PNG that ``draw(cases, path)`` (report/sized.py, report/cases.py) writes, as bytes."""
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as tmp:
        return Path(draw(cases, Path(tmp) / "figure.png")).read_bytes()


def simulation_html(result) -> str:
    import numpy as np

    unit = "N m" if result.drive_kind == "rotary" else "N"
    rows = [("stopped", f"t = {result.t[-1]:.6g} s: {result.stop}"), ("integrator", result.integrator),
            ("events", len(result.events)), ("peak |drive|", f"{np.max(np.abs(result.drive)):.6g} {unit}")]
    from .output import new_figure

    fig, ax = new_figure(figsize=(6, 3))
    ax.plot(result.t, result.drive)
    ax.set_xlabel("time t [s]")
    ax.set_ylabel(f"drive load [{unit}]")
    ax.grid(alpha=0.3)
    return _page(result.scene.title, rows, fig)


def study_html(result) -> str:
    """A study: its counts and its cases' table (cases.csv's first columns, the first 20 rows)."""
    rows = [("folder", str(result.folder)), ("cases", len(result.rows)),
            ("computed now", result.computed), ("from the journal", result.reused),
            ("complete", result.complete)]
    table = ""
    if result.rows:
        keys = list(result.rows[0])[:8]
        table = ("<table><tr>" + "".join(f"<th>{html.escape(str(k))}</th>" for k in keys) + "</tr>"
                 + "".join("<tr>" + "".join(f"<td>{html.escape(_short(row.get(k)))}</td>" for k in keys) + "</tr>"
                           for row in result.rows[:20]) + "</table>")
    scene = getattr(result.study, "scene", None)
    return _page(scene.title if scene is not None else "study", rows) + table


def _short(v) -> str:
    return f"{v:.6g}" if isinstance(v, float) else str(v)
