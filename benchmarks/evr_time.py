"""Error against run time of the time integral on the sample grid (a section of the
error-vs-run-time report; issue 16).

:func:`section` analyses a Scotch yoke (crank angle theta = u + 0.3 sin u of the sweep u, a 30
kg mass lifted on a vertical slot, efficiency 0.8) along three profiles of the sweep -- a
trapezoid, a jerk-limited s-curve and a law V(u) -- and measures, for 11 to 1601 samples, the
error of each case's integral of T_S^2 over time (the RMS over time squared, times the time)
and of its energy int P dt, against a reference computed here on a fine grid: the profile run in
time from its acceleration law (1,600,000 intervals aligned with its phase boundaries, the
acceleration integrated exactly), the drive torque of the yoke written by hand, the midpoint rule.  Beside optdesign's rule (optdesign.model.duty:
g linear in s against the exact time law, the phase boundaries as samples, jerk segments in
time) the naive one a user would write: the trapezoid rule in time on the scene's samples alone.
Time = median wall time of the case analysis (all samples, the integrals included).
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

R, G, ETA, U0, U1 = 0.2, 9.81, 0.8, 0.2, 2.6
SAMPLES = [11, 21, 51, 101, 201, 401, 801, 1601]
PROFILES = {
    "trapezoid": ('{ kind = "trapezoidal", speed = 0.8, acceleration = 0.5, deceleration = 0.3 }', "forward"),
    "s-curve": ('{ kind = "s-curve", speed = 0.9, acceleration = 0.6, deceleration = 0.4, jerk = 2.0 }', "reverse"),
    "law": ('{ kind = "law", speed = "0.6 + 0.3*sin(2*u)" }', "forward"),
}

SCENE = f'''title = "Scotch yoke lifting a mass along three profiles"
[parameters]
r = {R}
m = 30.0
[sweep]
name = "u"
from = {U0}
to = {U1}
samples = SAMPLES
[points]
S = {{ fixed = [0, 0] }}
A = {{ polar = ["S", "r", "u + 0.3*sin(u)"] }}
C = {{ fixed = [0, "r*sin(u + 0.3*sin(u))"] }}
D = {{ fixed = [1, "r*sin(u + 0.3*sin(u))"] }}
[[bodies]]
name = "yoke"
frame = ["C", "D"]
mass = "m"
com = [0, 0]
[gravity]
g = {G}
[drive]
type = "rotary"
crank = ["S", "A"]
speed = 1.0
acceleration = 0.0
efficiency = {ETA}
'''


def _scene(samples):
    from optdesign.scene.file import loads

    cases = "".join(f'\n[[cases]]\nname = "{name}"\ndirection = "{d}"\nprofile = {p}\n' for name, (p, d) in PROFILES.items())
    return loads(SCENE.replace("SAMPLES", str(samples)) + cases, "yoke.toml")


def _torque(u, ud, udd, direction):
    th, g1, g2 = u + 0.3 * np.sin(u), 1 + 0.3 * np.cos(u), -0.3 * np.sin(u)
    thd, thdd = g1 * ud, g1 * udd + g2 * ud**2
    m = 30.0
    ideal = (m * R**2 * np.cos(th) ** 2 * thdd - m * R**2 * np.cos(th) * np.sin(th) * thd**2
             + m * G * R * np.cos(th))
    moving = np.where(np.abs(thd) > 1e-9, np.sign(thd), direction)
    T = np.where(ideal * moving >= 0, 1 / ETA, ETA) * ideal
    return T, T * thd


def _in_time(name, n=1_600_000):
    """Midpoint states (t-step dt, u, u', u'') of a profile on a fine grid aligned with its
    phase boundaries, run in time from its acceleration law (exact for an acceleration linear
    between boundaries), and the direction."""
    L = U1 - U0
    if name == "law":
        edges = np.linspace(U0, U1, n + 1)
        u = 0.5 * (edges[1:] + edges[:-1])
        V = 0.6 + 0.3 * np.sin(2 * u)
        return np.diff(edges) / V, u, V, V * 0.6 * np.cos(2 * u), 1
    if name == "trapezoid":
        v, a, d = 0.8, 0.5, 0.3
        ta, td = v / a, v / d
        T = ta + td + (L - v**2 / (2 * a) - v**2 / (2 * d)) / v
        law = lambda t: np.where(t < ta, a, np.where(t > T - td, -d, 0.0))  # noqa: E731
        breaks = [0.0, ta, T - td, T]
    else:
        v, a, d, j = 0.9, 0.6, 0.4, 2.0

        def phase(rate):
            peak = min(rate, math.sqrt(v * j))
            return peak, peak / j, v / peak - peak / j
        (pa, ja, ca), (pd, jd, cd) = phase(a), phase(d)
        Ta, Td = 2 * ja + ca, 2 * jd + cd
        T = Ta + Td + (L - v * Ta / 2 - v * Td / 2) / v
        ramp = lambda tau, p, tj, tc: np.clip(np.minimum(j * tau, p - j * (tau - tj - tc)), 0.0, p)  # noqa: E731
        law = lambda t: np.where(t < Ta, ramp(t, pa, ja, ca), np.where(t > T - Td, -ramp(T - t, pd, jd, cd), 0.0))  # noqa: E731
        breaks = [0.0, ja, ja + ca, Ta, T - Td, T - Td + jd, T - Td + jd + cd, T]
    edges = np.unique(np.concatenate([np.linspace(b0, b1, max(int(n * (b1 - b0) / T), 2) + 1)
                                      for b0, b1 in zip(breaks[:-1], breaks[1:]) if b1 > b0]))
    dt = np.diff(edges)
    a_lo, a_hi = law(edges[:-1] + 1e-9 * dt), law(edges[1:] - 1e-9 * dt)   # inside each interval
    slope = (a_hi - a_lo) / dt
    vel = np.r_[0.0, np.cumsum(a_lo * dt + slope * dt**2 / 2)]
    x = np.r_[0.0, np.cumsum(vel[:-1] * dt + a_lo * dt**2 / 2 + slope * dt**3 / 6)]
    h = dt / 2
    v_mid = vel[:-1] + a_lo * h + slope * h**2 / 2
    x_mid = x[:-1] + vel[:-1] * h + a_lo * h**2 / 2 + slope * h**3 / 6
    a_mid = a_lo + slope * h
    sign = 1 if PROFILES[name][1] == "forward" else -1
    return dt, (U0 + x_mid) if sign > 0 else (U1 - x_mid), sign * v_mid, sign * a_mid, sign


def references() -> dict:
    """int T_S^2 dt and int P dt of each profile by the midpoint rule on the fine grid."""
    out = {}
    for name in PROFILES:
        dt, u, ud, udd, sign = _in_time(name)
        T, P = _torque(u, ud, udd, sign)
        out[name] = (float(np.dot(T**2, dt)), float(np.dot(P, dt)))
    return out


def measure(refs, repeats=5) -> list:
    """Rows (profile, samples, time, error of int T^2 dt and of the energy: optdesign's rule and
    the naive trapezoid in time on the scene's samples)."""
    from optdesign.kinematics.mechanism import Mechanism
    from optdesign.model.cases import CaseAnalysis

    rows = []
    for n in SAMPLES:
        mech = Mechanism(_scene(n))
        analysis = CaseAnalysis(mech, mech.stroke())
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            res = analysis.run(mech.parameter_values)
            times.append(time.perf_counter() - t0)
        for name in PROFILES:
            c = res.cases[name]
            sq, energy = refs[name]
            on = np.isin(c.columns["s"], mech.stroke())
            tt, T, P = c.columns["t"][on], c.columns["drive"][on], c.columns["power"][on]
            naive_sq = abs(np.trapezoid(T**2, tt))
            naive_e = np.trapezoid(P, tt) * np.sign(tt[-1] - tt[0])
            rows.append({"profile": name, "samples": n, "time_ms": 1e3 * float(np.median(times)) / len(PROFILES),
                         "error_sq": abs(c.integrals["drive_squared"] - sq) / sq,
                         "error_energy": abs(c.integrals["energy"] - energy) / abs(energy),
                         "naive_sq": abs(naive_sq - sq) / sq, "naive_energy": abs(naive_e - energy) / abs(energy)})
    return rows


def section(out_dir: Path) -> str:
    """Markdown of the time-integral part of the report; its figure (PNG) goes into ``out_dir``."""
    from optdesign.report.output import new_figure, save_figure

    t0 = time.perf_counter()
    refs = references()
    t_ref = time.perf_counter() - t0
    rows = measure(refs)
    fig, axes = new_figure(1, 2, figsize=(11, 4.2))
    for ax, key, title in ((axes[0], "sq", "int T_S^2 dt"), (axes[1], "energy", "energy int P dt")):
        for i, name in enumerate(PROFILES):
            mine = [r for r in rows if r["profile"] == name]
            ax.loglog([r["time_ms"] for r in mine], [max(r[f"error_{key}"], 1e-16) for r in mine], "o-", color=f"C{i}",
                      label=f"{name}: optdesign's rule")
            ax.loglog([r["time_ms"] for r in mine], [max(r[f"naive_{key}"], 1e-16) for r in mine], "x--", color=f"C{i}",
                      label=f"{name}: trapezoid in time on the samples")
        ax.set_xlabel("run time of the case analysis per case [ms]")
        ax.set_ylabel("relative error")
        ax.set_title(title)
        ax.grid(alpha=0.3, which="both")
    axes[0].legend(fontsize=7)
    save_figure(fig, out_dir / "time_integral.png")
    lines = [
        "## (e) The integral over time on the sample grid (issue 16)",
        "",
        __doc__.split("\n\n", 1)[1].strip(),
        "",
        f"The fine-grid references took {t_ref:.1f} s (once). Relative errors; the naive rule's columns "
        "for comparison.",
        "",
        "![error of the time integral against run time](error_vs_runtime/time_integral.png)",
        "",
        "| profile | samples | time per case [ms] | int T_S^2 dt: rule | naive | energy: rule | naive |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(f"| {r['profile']} | {r['samples']} | {r['time_ms']:.3g} | {r['error_sq']:.2e} | "
                     f"{r['naive_sq']:.2e} | {r['error_energy']:.2e} | {r['naive_energy']:.2e} |")
    orders = []
    for name in PROFILES:
        mine = [r for r in rows if r["profile"] == name and r["samples"] in (201, 401)]
        if len(mine) == 2 and mine[1]["error_sq"] > 0:
            orders.append(f"{name} {math.log2(mine[0]['error_sq'] / mine[1]['error_sq']):.2f}")
    lines += ["", "Observed order of the rule between 201 and 401 samples (int T_S^2 dt): " + ", ".join(orders) + ".", ""]
    return "\n".join(lines)


if __name__ == "__main__":
    import sys

    out = Path(sys.argv[1] if len(sys.argv) > 1 else "/tmp/evr_time")
    out.mkdir(parents=True, exist_ok=True)
    print(section(out))
