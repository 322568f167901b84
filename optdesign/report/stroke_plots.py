"""Plots over the stroke in the units the scene wrote: the sweep in deg where [sweep] was written
in deg, loads in kN (kN m) where large, angle constraints in deg where their bounds were; every
constraint's bounds as dashed lines with the feasible side shaded and the parts of a curve that
leave it drawn red; the peak and its governing position marked.  One figure may overlay several
analyses of a scene (an optimisation's start and optimum)."""
from __future__ import annotations

import textwrap

import numpy as np

from .checks import _bounds, column_display, violations
from .output import new_figure, save_figure
from .plots import bound_lines, headroom, mark_peak
from .units import constraint_scale, number, scaled, sweep_scale

SEED = {"rotary": {"static_load": "T_Su", "inertia_term": "I_zS eps_S", "velocity_term": "dT_S", "drive": "T_S"},
        "linear": {"static_load": "F_Su", "inertia_term": "m_zS a_S", "velocity_term": "dF_S", "drive": "F_S"}}
NAMES = {"rotary": "drive torque", "linear": "drive force"}


def _peak(result, key="drive"):
    """(s, signed value) of the peak |key|: the certified position where the analysis has it."""
    at = (getattr(result, "peak_at", {}) or {}).get(key)
    if at is not None:
        return at["s"], at["value"]
    i = int(np.argmax(np.abs(result.columns[key])))
    return float(result.columns["s"][i]), float(result.columns[key][i])


def per_sample(result) -> list:
    return [k for k, v in result.constraints.items() if np.ndim(v)]


def stroke_figure(runs, path, title=None, components=False, drive=True, constraints=True):
    """The drive load (with its ``components``) and every per-sample constraint over the sweep for
    the analyses ``runs`` (a list of (label, AnalysisResult) of one scene) in one figure at
    ``path``; ``drive``/``constraints`` False leave that part out."""
    first = runs[0][1]
    scene = first.scene
    names = per_sample(first) if constraints else []
    sf, su = sweep_scale(scene)
    xlabel = f"{scene.sweep.name} [{su}]" if su else scene.sweep.name
    top = 1 if drive else 0
    fig, axes = new_figure(top + len(names), 1, figsize=(7.5, 3.3 * top + 2.6 * len(names) + 0.6 * (1 - top)),
                           squeeze=False, sharex=True)
    axes = axes[:, 0]
    kind = first.drive_kind
    k, unit = scaled(np.concatenate([r.columns["drive"] for _, r in runs]), SEED_UNIT[kind])
    ax = axes[0]
    for j, (label, res) in enumerate(runs if drive else ()):
        x = res.columns["s"] * sf
        colour = f"C{j}"
        if components:
            for key, style in (("static_load", ":"), ("inertia_term", "-."), ("velocity_term", "--")):
                if key in res.columns:
                    ax.plot(x, res.columns[key] * k, style, color=colour, lw=1.0, alpha=0.8,
                            label=f"{SEED[kind][key]} ({key.replace('_', ' ')})")
        at, value = _peak(res)
        ax.plot(x, res.columns["drive"] * k, color=colour, lw=2.0,
                label=f"{label + ': ' if label else ''}{SEED[kind]['drive']}, peak {number(abs(value) * k, 5)} {unit}")
        mark_peak(ax, at * sf, value * k, f"{number(abs(value) * k, 4)} {unit} at {number(at * sf, 4)}")
    if drive:
        headroom(ax)
        ax.set_ylabel(f"{NAMES[kind]} [{unit}]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7.5, loc="best")
    bounds = _bounds(first)
    for ax, name in zip(axes[top:], names):
        c, lo, hi = bounds[name]
        f, cu = constraint_scale(c)
        for j, (label, res) in enumerate(runs):
            x, v = res.columns["s"] * sf, np.asarray(res.constraints[name]) * f
            ax.plot(x, v, color=f"C{j}", lw=1.6, label=label or None)
            bad = np.zeros(len(v), bool)
            if lo is not None:
                bad |= v < lo * f - 1e-6 * max(1, abs(lo * f))
            if hi is not None:
                bad |= v > hi * f + 1e-6 * max(1, abs(hi * f))
            if bad.any():
                ax.plot(x, np.where(bad, v, np.nan), color="#d62728", lw=3.0, alpha=0.75, zorder=4)
            for item in violations(res):
                if item["name"] == name and item["at"] is not None:
                    mark_peak(ax, item["at"] * sf, item["worst"] * f,
                              f"{label + ': ' if label else ''}{item['bound']} violated by "
                              f"{number(item['by'] * f, 3)} {cu}".rstrip())
        bound_lines(ax, None if lo is None else lo * f, None if hi is None else hi * f)
        ax.set_ylabel(textwrap.fill(f"{name} [{cu}]" if cu else name, 28), fontsize=9)
        ax.grid(alpha=0.3)
        if len(runs) > 1:
            ax.legend(fontsize=7.5, loc="best")
    axes[-1].set_xlabel(xlabel)
    head = "\n".join(textwrap.fill(line, 85) for line in (title or scene.title).split("\n"))
    axes[0].set_title(head, fontsize=9.5)
    save_figure(fig, path)
    return path


SEED_UNIT = {"rotary": "N m", "linear": "N"}


def _broken(x, y, at):
    """x, y with a NaN inserted after each index of ``at`` (a line drawn with a gap there)."""
    return np.insert(np.asarray(x, float), at + 1, np.nan), np.insert(np.asarray(y, float), at + 1, np.nan)


def inertia_figure(result, path, note=""):
    """The reduced inertia (mass) and its derivative over the sweep (``note`` after the title).
    With an efficiency both are c times the ideal ones (seed 1, eqs. 12, 33: c = 1/eta while the
    drive delivers power, eta while it takes power back): they jump where the power changes sign,
    which the figure draws as gaps at dotted lines, with the ideal inertia (smooth) beside them."""
    scene = result.scene
    sf, su = sweep_scale(scene)
    fig, ax = new_figure(figsize=(7.5, 4.4))
    x = result.columns["s"] * sf
    f, unit = column_display(result, "reduced_inertia")
    name = "I_zS" if result.drive_kind == "rotary" else "m_zS"
    inertia, d_inertia = result.columns["reduced_inertia"], result.columns["reduced_inertia_dq"]
    c = result.columns.get("efficiency_factor")
    switches = np.flatnonzero(np.diff(c) != 0) if c is not None else np.array([], int)
    ax.plot(*_broken(x, inertia * f, switches), label=f"{name} [{unit}]")
    ax2 = ax.twinx()
    dunit = "kg m^2/rad" if result.drive_kind == "rotary" else "kg/m"
    ax2.plot(*_broken(x, d_inertia, switches), "C1--", label=f"d{name}/dq [{dunit}]")
    why = ""
    if len(switches):
        ideal = "M_q"   # (reduction.py's name, the drive coordinate q's mass or inertia)
        ax.plot(x, inertia / c * f, color="0.45", lw=0.9, ls=":", label=f"{ideal} = {name} / c [{unit}] (no efficiency)")
        for k in switches:
            ax.axvline(0.5 * (x[k] + x[k + 1]), color="0.6", lw=0.8, ls=":")
        ratio = float(np.max(c) / np.min(c))
        why = (f"\n{name} = c {ideal} jumps by {number(ratio, 4)}x where the power changes sign (dotted lines): "
               "c = 1/eta while the drive delivers power, eta while it takes it back (seed eqs. 12, 33)")
    ax.set_xlabel(f"{scene.sweep.name} [{su}]" if su else scene.sweep.name)
    ax.set_ylabel(f"{name} [{unit}]")
    ax2.set_ylabel(f"d{name}/dq [{dunit}]")
    title = "reduced inertia and its derivative" + ("\n" + note.strip() if note else "")
    ax.set_title("\n".join(textwrap.fill(line, 95) for line in (title + why).split("\n")), fontsize=9, loc="left")
    fig.legend(loc="outside lower center", ncols=3 if len(switches) else 2, fontsize=7.5)
    ax.grid(alpha=0.3)
    save_figure(fig, path)
    return path


def quantities_figure(result, path, note=""):
    """Each of the scene's [quantities] over the sweep (in the scene's sweep unit), one panel
    each, labelled with its unit (``note`` after the title)."""
    scene = result.scene
    units = {q.name: q.unit for q in scene.quantities}
    factor, unit = sweep_scale(scene)
    names = list(result.quantities)
    fig, axes = new_figure(len(names), 1, figsize=(7, 1.0 + 2.0 * len(names)), sharex=True, squeeze=False)
    s = np.asarray(result.columns["s"]) * factor
    for ax, name in zip(axes[:, 0], names):
        ax.plot(s, result.quantities[name])
        ax.set_ylabel(f"{name} [{units.get(name) or '-'}]")
        ax.grid(True, alpha=0.3)
    axes[-1, 0].set_xlabel(f"{scene.sweep.name}" + (f" [{unit}]" if unit else ""))
    axes[0, 0].set_title(textwrap.shorten(f"{scene.title}: quantities", 90 - len(note)) + note)
    save_figure(fig, path)
    return path


def joints_figure(result, path, note=""):
    """The force at each pin (``pin_force(P)``, the first party's) and each slider's normal force
    over the sweep (analyse --joints), on one axis in the scene's force unit, each peak over the
    continuous stroke marked where it lies (``note`` after the title)."""
    scene = result.scene
    sf, su = sweep_scale(scene)
    names = [k for k in result.columns if k.startswith(("pin_force(", "slider_normal(")) and ", " not in k]
    top = max(float(np.max(np.abs(result.columns[k]))) for k in names)
    k, unit = scaled(np.array([top]), "N")
    fig, ax = new_figure(figsize=(7.5, 4))
    x = result.columns["s"] * sf
    for name in names:
        (line,) = ax.plot(x, result.columns[name] * k, label=name)
        at = result.peak_at.get(name)
        if at is not None:
            ax.plot([at["s"] * sf], [at["value"] * k], "v", color=line.get_color(), ms=6)
    ax.set_xlabel(f"{scene.sweep.name} [{su}]" if su else scene.sweep.name)
    ax.set_ylabel(f"force [{unit}]")
    ax.set_title(textwrap.shorten(f"joint forces (peaks marked): {scene.title}", 90 - len(note)) + note, fontsize=10)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    save_figure(fig, path)
    return path
