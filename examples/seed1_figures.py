"""Seed 1's figures (Cink & Kosucki 2016, Figs. 6-9 and 13-16) redrawn for the shipped scenes.

    python examples/seed1_figures.py [--out results/seed1]

Slider-crank (problems/seed1_slider_crank.toml, section 2.5), over the crank angle alpha:
  Fig. 6  effective radius R_z and dR_z/dalpha        Fig. 7  I_zS and dI_zS/dalpha
  Fig. 8  piston accelerations a_C0, delta_a_C, a_C   Fig. 9  torque T_S = T_Su + I_zS*eps_S - dT_S
Jib (problems/seed1_jib.toml, section 3.5), over the cylinder length x = |DB|:
  Fig. 13 ratio i_v and di_v/dx                       Fig. 14 m_zS and dm_zS/dx
  Fig. 15 tip accelerations a_C0, delta_a_C, a_C      Fig. 16 force F_S = F_Su + m_zS*a_S - dF_S

Every figure is a PNG and a CSV holding exactly the plotted numbers (header "name [unit]").
All numbers come from the public API (optdesign.load, optdesign.analyse and, for the sign of
the piston's motion, optdesign.kinematics); every file is written atomically, and only after
every figure has been computed and checked, so a failed run leaves no partial set behind.

Sign of the slider-crank's ratio: optdesign reports R_z = |v_C|/omega_S (seed eq. 1, never
negative).  The paper's Fig. 6 and eq. (18) use the signed ratio, the piston's velocity along its
axis per unit crank speed.  Here it is taken from the kinematics, R_z = (v_C . e)/omega_S with e
the piston's axis (its body frame's x axis, pointing up, away from the crank), and its derivative
from the seed's eq. (3) read backwards, dR_z/dalpha = (a_C - R_z*eps_S)/omega_S^2 with a_C = a_C . e
(exact: the piston moves on a straight line, so its acceleration along e is d/dt(R_z*omega_S)).
The script checks that |R_z| equals the tool's R_z, and that the tool's dR_z/dalpha and a_C are
these times sign(v_C) wherever the piston moves, and refuses to write anything otherwise.
"""
from __future__ import annotations

import argparse
import csv
import io
import math
import textwrap
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import optdesign
from optdesign.scene.expressions import constant_value
from optdesign.report.files import write_file
from optdesign.report.output import save_figure

ROOT = Path(__file__).resolve().parents[1]
SLIDER_CRANK = ROOT / "problems" / "seed1_slider_crank.toml"
JIB = ROOT / "problems" / "seed1_jib.toml"
PAPER = "Cink & Kosucki 2016"


# --- what a figure holds -----------------------------------------------------------------------
@dataclass(frozen=True)
class Series:
    """One plotted quantity: CSV column ``name [unit]``, legend ``label`` (mathtext)."""

    name: str
    unit: str
    label: str
    values: np.ndarray
    style: dict = field(default_factory=dict)

    @property
    def header(self) -> str:
        return f"{self.name} [{self.unit}]"


@dataclass(frozen=True)
class Panel:
    """One set of axes; every series in it shares ``ylabel``'s unit."""

    ylabel: str
    series: tuple
    note: str = ""


@dataclass(frozen=True)
class SeedFigure:
    """A redrawn figure of the seed: ``number`` (the seed's), file ``stem``, the abscissa and
    the panels; ``caption`` carries the scene's data and what the curves mean."""

    number: int
    stem: str
    title: str
    x: Series
    panels: tuple
    caption: str

    def columns(self) -> list:
        """The x series and every plotted series once, in order of appearance."""
        out, seen = [self.x], {self.x.name}
        for panel in self.panels:
            for s in panel.series:
                if s.name not in seen:
                    out.append(s)
                    seen.add(s.name)
        return out


# --- scene data --------------------------------------------------------------------------------
def number(scene, expr, where):
    """The number of a scene expression that must be constant (drive speed, g, ...)."""
    return constant_value(expr, scene.parameter_values(), where)


def drive_motion(scene):
    """(speed, acceleration) of the drive: omega_S, eps_S or v_S, a_S."""
    d = scene.drive
    return number(scene, d.speed, "[drive] speed"), number(scene, d.acceleration, "[drive] acceleration")


def efficiency_text(scene):
    d = scene.drive
    return "eta = 1" if d.efficiency is None else f"eta = {number(scene, d.efficiency, '[drive] efficiency'):g}"


def only_body(result, what):
    """The one massive body of a seed-1 example and its ratios."""
    if len(result.bodies) != 1:
        raise RuntimeError(f"{what}: expected one massive body, found {sorted(result.bodies)}")
    (name, ratios), = result.bodies.items()
    return name, ratios


def require_close(what, got, want, rel):
    """Raise unless |got - want| <= rel * max|want| everywhere (a consistency check of the run)."""
    got, want = np.asarray(got, float), np.asarray(want, float)
    scale = max(float(np.max(np.abs(want))), 1e-300)
    err = float(np.max(np.abs(got - want))) if got.size else 0.0
    if not err <= rel * scale:
        raise RuntimeError(f"{what}: disagree by {err:.3g} (> {rel:g} x {scale:.3g}); not writing figures")


# --- slider-crank: Figs. 6-9 -------------------------------------------------------------------
def signed_piston_ratio(scene, result, body):
    """The paper's signed R_z, dR_z/dalpha and piston acceleration along its axis, from the
    kinematics (see the module docstring), checked against the tool's unsigned values."""
    kin = optdesign.kinematics(scene)
    if not np.array_equal(kin.s, result.columns["s"]):
        raise RuntimeError("kinematics and analysis sampled different strokes")
    omega, eps = drive_motion(scene)
    frame = next(b.frame for b in scene.bodies if b.name == body)
    origin, toward = (kin.points[n] for n in frame)
    axis = np.array([toward["x"] - origin["x"], toward["y"] - origin["y"]])
    axis /= np.hypot(*axis)
    v_along = origin["vx"] * axis[0] + origin["vy"] * axis[1]
    a_along = origin["ax"] * axis[0] + origin["ay"] * axis[1]
    R_z = v_along / omega
    dR_z = (a_along - R_z * eps) / omega**2
    return R_z, dR_z, a_along


def check_signed_against_tool(R_z, dR_z, a_C, ratios):
    """|R_z| is the tool's R_z; where the piston moves, the tool's (unsigned) derivative and
    tangential acceleration are the signed ones times sign(v_C)."""
    require_close("|signed R_z| vs the tool's R_z = |v_C|/omega_S", np.abs(R_z), ratios["R_z"], 1e-12)
    moving = np.abs(R_z) > 1e-6 * np.max(np.abs(R_z))
    sign = np.sign(R_z[moving])
    require_close("sign(v_C) * tool dR_z/dalpha vs signed dR_z/dalpha", sign * ratios["dR_z_dq"][moving], dR_z[moving], 1e-9)
    require_close("sign(v_C) * tool a_C vs the piston's acceleration along its axis", sign * ratios["a_C"][moving], a_C[moving], 1e-9)


def slider_crank_caption(scene, samples):
    p = scene.parameter_values()
    omega, eps = drive_motion(scene)
    return (f"Scene {Path(scene.path).name} (data ours: the paper prints none): r = {p['r']:g} m, "
            f"l = {p['l']:g} m, m_C = {p['mC']:g} kg (piston only), F_C = {p['FC']:g} N (gas force, down), "
            f"omega_S = {omega:g} rad/s, eps_S = {eps:g} rad/s^2, {efficiency_text(scene)}, {samples} samples.\n"
            "Piston on the vertical through S; alpha from the dead centre where the crank points away "
            "from the piston (alpha = 0, 360 deg: bottom, 180 deg: top dead centre).")


def slider_crank_figures(path=SLIDER_CRANK):
    """Figs. 6-9 of the seed for the shipped slider-crank."""
    scene = optdesign.load(path)
    result = optdesign.analyse(scene)
    cols = result.columns
    require_close("dq/dalpha (derivatives by q are by alpha)", cols["k"], np.ones_like(cols["k"]), 1e-12)
    body, ratios = only_body(result, scene.path)
    omega, eps = drive_motion(scene)
    R_z, dR_z, a_C = signed_piston_ratio(scene, result, body)
    check_signed_against_tool(R_z, dR_z, a_C, ratios)
    data = slider_crank_caption(scene, len(cols["s"]))
    x = Series("alpha", "deg", r"crank angle $\alpha$", np.degrees(cols["s"]))
    thin = {"lw": 1.0, "ls": "--", "color": "0.45"}
    sign_note = ("R_z signed as in the paper's Fig. 6: the piston's velocity along its axis (up +) per unit "
                 "crank speed, from the kinematics; grey dashed: optdesign's R_z = |v_C|/omega_S (eq. 1) and "
                 "its derivative, which has no value where v_C = 0 (NaN at 180 deg).")
    fig6 = SeedFigure(6, "fig06_R_z", r"effective radius $R_z$ and its derivative $\mathrm{d}R_z/\mathrm{d}\alpha$ (slider-crank)", x, (
        Panel(r"$R_z$ [m]", (Series("R_z", "m", r"$R_z = v_C/\omega_S$ (signed)", R_z),
                             Series("|R_z|", "m", r"$|v_C|/\omega_S$ (optdesign R_z)", ratios["R_z"], thin))),
        Panel(r"$\mathrm{d}R_z/\mathrm{d}\alpha$ [m/rad]", (
            Series("dR_z/dalpha", "m/rad", r"$\mathrm{d}R_z/\mathrm{d}\alpha$ (signed)", dR_z),
            Series("d|R_z|/dalpha", "m/rad", r"$\mathrm{d}|R_z|/\mathrm{d}\alpha$ (optdesign)", ratios["dR_z_dq"], thin))),
    ), data + "\n" + sign_note)
    fig7 = SeedFigure(7, "fig07_I_zS", r"reduced moment of inertia $I_{zS}$ and $\mathrm{d}I_{zS}/\mathrm{d}\alpha$ (slider-crank)", x, (
        Panel(r"$I_{zS}$ [kg m$^2$]", (Series("I_zS", "kg m^2", r"$I_{zS} = m_C R_z^2/\eta_m$", cols["reduced_inertia"]),)),
        Panel(r"$\mathrm{d}I_{zS}/\mathrm{d}\alpha$ [kg m$^2$/rad]", (
            Series("dI_zS/dalpha", "kg m^2/rad", r"$\mathrm{d}I_{zS}/\mathrm{d}\alpha$", cols["reduced_inertia_dq"], {"color": "C1"}),)),
    ), data + "\nI_zS vanishes at the dead centres (alpha = 0, 180, 360 deg), where the piston stands still.")
    a_C0, delta_a_C = R_z * eps, dR_z * omega**2
    fig8 = SeedFigure(8, "fig08_piston_acceleration", r"piston accelerations $a_{C0}$, $\Delta a_C$ and $a_C$ (slider-crank)", x, (
        Panel(r"acceleration [m/s$^2$]", (
            Series("a_C0", "m/s^2", r"$a_{C0} = R_z\,\varepsilon_S$", a_C0),
            Series("delta_a_C", "m/s^2", r"$\Delta a_C = \omega_S^2\,\mathrm{d}R_z/\mathrm{d}\alpha$", delta_a_C),
            Series("a_C", "m/s^2", r"$a_C = a_{C0} + \Delta a_C$", a_C, {"lw": 1.8, "color": "k", "ls": "--"}))),
        Panel(r"$a_{C0}$ [m/s$^2$]", (Series("a_C0", "m/s^2", r"$a_{C0}$ (zoom)", a_C0),), "zoom"),
    ), data + "\nAlong the piston's axis (up +), seed eq. (3) with the signed R_z of Fig. 6; "
             "optdesign's a_C is the tangential d|v_C|/dt, i.e. these values times sign(v_C).")
    fig9 = SeedFigure(9, "fig09_torque_T_S", r"drive torque $T_S$ and its components (slider-crank)", x, (
        Panel(r"torque [N m]", (
            Series("T_Su", "N m", r"$T_{Su}$ (static)", cols["static_load"]),
            Series("I_zS*eps_S", "N m", r"$I_{zS}\,\varepsilon_S$", cols["inertia_term"]),
            Series("dT_S", "N m", r"$\Delta T_S = -\frac{1}{2}\omega_S^2\,\mathrm{d}I_{zS}/\mathrm{d}\alpha$", cols["velocity_term"]),
            Series("T_S", "N m", r"$T_S = T_{Su} + I_{zS}\varepsilon_S - \Delta T_S$", cols["drive"], {"lw": 2.2, "color": "k"}))),
        Panel(r"$I_{zS}\,\varepsilon_S$ [N m]", (Series("I_zS*eps_S", "N m", r"$I_{zS}\,\varepsilon_S$ (zoom)", cols["inertia_term"], {"color": "C1"}),), "zoom"),
    ), data + "\nT_S at constant omega_S and eps_S (seed eq. 16); dT_S is the seed's Delta T_S, eq. (15).")
    return [fig6, fig7, fig8, fig9]


# --- jib: Figs. 13-16 --------------------------------------------------------------------------
def jib_caption(scene, samples):
    p = scene.parameter_values()
    v_S, a_S = drive_motion(scene)
    g = number(scene, scene.gravity.g, "[gravity] g")
    return (f"Scene {Path(scene.path).name} (data ours: the paper prints none): l = {p['l']:g} m, e = |AD| = {p['e']:g} m, "
            f"b = |AB| = {p['b']:g} m, psi = {math.degrees(p['psi']):g} deg, m_C = {p['mC']:g} kg at the jib tip "
            f"(point mass, I_C = 0),\ng = {g:g} m/s^2, v_S = {v_S:g} m/s, a_S = {a_S:g} m/s^2, "
            f"{efficiency_text(scene)}; x = |DB| from 2.2 to 3.2 m, {samples} samples uniform in the jib angle.")


def jib_figures(path=JIB):
    """Figs. 13-16 of the seed for the shipped jib."""
    scene = optdesign.load(path)
    result = optdesign.analyse(scene)
    cols = result.columns
    body, ratios = only_body(result, scene.path)
    data = jib_caption(scene, len(cols["s"]))
    x = Series("x", "m", r"cylinder length $x = |DB|$", cols["q"])
    fig13 = SeedFigure(13, "fig13_i_v", r"ratio $i_v$ and its derivative $\mathrm{d}i_v/\mathrm{d}x$ (jib)", x, (
        Panel(r"$i_v$ [-]", (Series("i_v", "-", r"$i_v = v_S/v_C$", ratios["i_v"]),)),
        Panel(r"$\mathrm{d}i_v/\mathrm{d}x$ [1/m]", (Series("di_v/dx", "1/m", r"$\mathrm{d}i_v/\mathrm{d}x$", ratios["di_v_dq"], {"color": "C1"}),)),
    ), data)
    fig14 = SeedFigure(14, "fig14_m_zS", r"reduced mass $m_{zS}$ and its derivative $\mathrm{d}m_{zS}/\mathrm{d}x$ (jib)", x, (
        Panel(r"$m_{zS}$ [kg]", (Series("m_zS", "kg", r"$m_{zS} = m_C/(i_v^2\eta_m)$", cols["reduced_inertia"]),)),
        Panel(r"$\mathrm{d}m_{zS}/\mathrm{d}x$ [kg/m]", (Series("dm_zS/dx", "kg/m", r"$\mathrm{d}m_{zS}/\mathrm{d}x$", cols["reduced_inertia_dq"], {"color": "C1"}),)),
    ), data + "\nm_zS grows with x as the ratio i_v falls (the cylinder moves less per unit of tip motion).")
    fig15 = SeedFigure(15, "fig15_tip_acceleration", r"tangential accelerations $a_{C0}$, $\Delta a_C$, $a_C$ of the jib tip (jib)", x, (
        Panel(r"acceleration [m/s$^2$]", (
            Series("a_C0", "m/s^2", r"$a_{C0} = a_S/i_v$", ratios["a_C0"]),
            Series("delta_a_C", "m/s^2", r"$\Delta a_C = -v_S^2\,(\mathrm{d}i_v/\mathrm{d}x)/i_v^2$", ratios["delta_a_C"]),
            Series("a_C", "m/s^2", r"$a_C = a_{C0} + \Delta a_C$", ratios["a_C"], {"lw": 2.2, "color": "k", "ls": "--"}))),
        Panel(r"$\Delta a_C$ [m/s$^2$]", (Series("delta_a_C", "m/s^2", r"$\Delta a_C$ (zoom)", ratios["delta_a_C"], {"color": "C1"}),), "zoom"),
    ), data + "\nSeed eq. (24), with di_v/dx where the print has di_v/dt.")
    fig16 = SeedFigure(16, "fig16_force_F_S", r"drive force $F_S$ and its components (jib)", x, (
        Panel(r"force [N]", (
            Series("F_Su", "N", r"$F_{Su}$ (static, weight)", cols["static_load"]),
            Series("m_zS*a_S", "N", r"$m_{zS}\,a_S$", cols["inertia_term"]),
            Series("dF_S", "N", r"$\Delta F_S = -\frac{1}{2}v_S^2\,\mathrm{d}m_{zS}/\mathrm{d}x$", cols["velocity_term"]),
            Series("F_S", "N", r"$F_S = F_{Su} + m_{zS}a_S - \Delta F_S$", cols["drive"], {"lw": 2.2, "color": "k"}))),
        Panel(r"$\Delta F_S$ [N]", (Series("dF_S", "N", r"$\Delta F_S$ (zoom)", cols["velocity_term"], {"color": "C2"}),), "zoom"),
    ), data + "\nF_S at constant v_S and a_S (seed eq. 37); dF_S is the seed's Delta F_S, eq. (36).")
    return [fig13, fig14, fig15, fig16]


# --- output --------------------------------------------------------------------------------------
def csv_text(figure: SeedFigure) -> str:
    """The plotted numbers, full precision (17 significant digits round-trip a double)."""
    columns = figure.columns()
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow([c.header for c in columns])
    for row in zip(*(c.values for c in columns)):
        writer.writerow([f"{v:.17g}" for v in row])
    return buf.getvalue()


def draw(figure: SeedFigure):
    """The matplotlib figure (Agg backend; the caller saves and closes it)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    heights = [1.0 if p.note else 2.0 for p in figure.panels]
    fig, axes = plt.subplots(len(figure.panels), 1, figsize=(8, 1.1 + 2.2 * sum(heights)), sharex=True,
                             gridspec_kw={"height_ratios": heights}, squeeze=False)
    for ax, panel in zip(axes[:, 0], figure.panels):
        for s in panel.series:
            ax.plot(figure.x.values, s.values, label=s.label, **({"lw": 1.5} | s.style))
        ax.set_ylabel(panel.ylabel)
        ax.grid(alpha=0.3)
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.legend(fontsize=8, loc="best")
    bottom = axes[-1, 0]
    bottom.set_xlabel(f"{figure.x.label} [{figure.x.unit}]")
    if figure.x.unit == "deg":
        bottom.set_xticks(np.arange(0, 361, 45))
    bottom.set_xlim(figure.x.values[0], figure.x.values[-1])
    fig.suptitle(f"Seed 1 ({PAPER}), Fig. {figure.number}: {figure.title}", fontsize=10.5)
    fig.tight_layout()
    caption = "\n".join(textwrap.fill(par, 150) for par in figure.caption.split("\n"))
    fig.text(0.01, 0.0, caption, fontsize=6.8, va="top", ha="left")
    return fig


def write_figures(figures, folder) -> list:
    """Write each figure's PNG and CSV atomically; returns the paths written."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    folder = Path(folder)
    written = []
    for figure in figures:
        csv_path = folder / f"{figure.stem}.csv"
        write_file(csv_path, csv_text(figure))
        fig = draw(figure)
        png_path = folder / f"{figure.stem}.png"
        save_figure(fig, png_path)
        plt.close(fig)
        written += [png_path, csv_path]
    return written


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default=str(ROOT / "results" / "seed1"), help="output folder (default: results/seed1)")
    args = parser.parse_args(argv)
    figures = slider_crank_figures() + jib_figures()  # compute and check everything before writing
    for path in write_figures(figures, args.out):
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
