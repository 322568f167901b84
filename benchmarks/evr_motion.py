"""Error against run time of `optdesign simulate` (a section of the error-vs-run-time report).

:func:`section` integrates the slider-crank of problems/sim_slider_crank.toml on its motor curve
with each integrator over a range of tolerances (CVODES BDF and Adams) or step counts (RK4):

- non-stiff: a rotor as heavy as the piston's peak reduced inertia and a soft motor curve
  (T0 = 50 N m, omega0 = 150 rad/s);
- stiff: the scene as shipped (rotor 1e-6 of the peak, T0 = 2000 N m, omega0 = 105 rad/s),

against an independent reference: scipy's DOP853 (non-stiff, rtol 1e-13) or Radau (stiff, rtol
1e-11, with its Jacobian) on the equation of motion (M(a) + J) a'' = T(a') - 1/2 M'(a) a'^2 written
here by hand from the slider-crank's geometry.  The error is the largest crank-speed error at the
output samples relative to the peak speed; the run time is the integration's wall time (build
excluded).  Then the free motion (no motor torque) of the same crank and of the linear jib
(problems/sim_jib.toml with g = 0, F = 0): the kinetic-energy drift (energies from hand-written
positions) against run time.  Then the runs through events (reversals, power-flow switches, a
stall, stroke ends) against the references of tests/test_motion_events.py, and what a stall
costs: benchmarks/evr_events.py.
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
R, L, M_C = 0.1, 0.35, 12.0
I_PEAK = 0.12985293049447894
END = 4.5 * math.pi
CASES = {
    "non-stiff": {"J_rotor": "I_peak", "T0": 50.0, "omega0": 150.0},
    "stiff": {},
}
TOLERANCES = [1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11]
RK4_STEPS = [2, 4, 8, 16, 32, 64, 128, 256]


def _geometry(a):
    sa, ca = np.sin(a), np.cos(a)
    w = np.sqrt(L**2 - R**2 * sa**2)
    dy = R * sa - R**2 * sa * ca / w
    d2y = R * ca - R**2 * (np.cos(2 * a) / w + R**2 * sa**2 * ca**2 / w**3)
    return dy, d2y


def reference(J, T0, omega0, stiff):
    """The crank's motion from alpha = 0.5, omega = 100 rad/s to alpha = 9 pi/2, by scipy."""
    from scipy.integrate import solve_ivp

    def f(t, x):
        a, om = x
        dy, d2y = _geometry(a)
        return [om, (T0 * (1 - om / omega0) - M_C * dy * d2y * om**2) / (M_C * dy**2 + J)]

    def jac(t, x):
        a, om = x
        e = 1e-7
        da = (np.array(f(t, [a + e, om])) - np.array(f(t, [a - e, om]))) / (2 * e)
        dw = (np.array(f(t, [a, om + e * om])) - np.array(f(t, [a, om - e * om]))) / (2 * e * om)
        return np.column_stack([da, dw])

    end = lambda t, x: x[0] - END
    end.terminal = True
    opts = dict(method="Radau", rtol=1e-11, atol=1e-11, jac=jac) if stiff else dict(method="DOP853", rtol=1e-13, atol=1e-13)
    t0 = time.perf_counter()
    sol = solve_ivp(f, (0, 1.0), [0.5, 100.0], events=end, dense_output=True, **opts)
    name = "scipy Radau, rtol 1e-11" if stiff else "scipy DOP853, rtol 1e-13"
    return sol, name, time.perf_counter() - t0


def _runs(simulator, sol):
    """(integrator, setting, wall time, error or None when it failed) for every run."""
    from optdesign.errors import SolverError

    rows = []
    settings = [("bdf", t) for t in TOLERANCES] + [("adams", t) for t in TOLERANCES] + [("rk4", n) for n in RK4_STEPS]
    peak = None
    for method, setting in settings:
        kw = {"tolerance": setting} if method != "rk4" else {"steps": setting, "error_check": False}
        try:
            res = simulator.run(integrator=method, **kw)
        except SolverError:
            rows.append((method, setting, None, None, None))
            continue
        ref = sol.sol(np.minimum(res.t, sol.t_events[0][0]))
        peak = peak or float(np.max(np.abs(ref[1])))
        err = float(np.max(np.abs(res.sd - ref[1]))) / peak
        if not np.isfinite(err):
            err = None
        rows.append((method, setting, res.timings["integrate_s"], err, res.stats["steps"]))
    return rows


def _free_energy(out_dir):
    """Energy drift of the free motion against run time: slider-crank (rotary) and jib (linear)."""
    import optdesign
    from optdesign.dynamics.simulator import Simulator

    crank = Simulator(optdesign.load(ROOT / "problems/sim_slider_crank.toml", {"T0": 0.0, "J_rotor": "1e-2*I_peak"}))
    jib = Simulator(optdesign.load(ROOT / "problems/sim_jib.toml", {"g": 0.0, "F": 0.0}))
    J = 1e-2 * I_PEAK

    def crank_energy(res):
        dy, _ = _geometry(res.s)
        return 0.5 * M_C * (dy * res.sd) ** 2 + 0.5 * J * res.sd**2

    def jib_energy(res):
        b, e, psi, l = 2.4, 1.6, math.radians(-60), 4.0
        x = np.sqrt(b**2 + e**2 - 2 * b * e * np.cos(res.s - psi))
        dx = b * e * np.sin(res.s - psi) / x
        return 0.5 * 500.0 * (l * res.sd) ** 2 + 0.5 * 60.0 * (dx * res.sd) ** 2

    rows = []
    for label, sim, energy, t_end in (("slider-crank (rotary)", crank, crank_energy, 1.0),
                                      ("jib (linear)", jib, jib_energy, 10.0)):
        for method in ("bdf", "adams"):
            for tol in TOLERANCES:
                res = sim.run(integrator=method, tolerance=tol, t_end=t_end)
                E = energy(res)
                rows.append((label, method, tol, res.timings["integrate_s"], float(np.max(np.abs(E - E[0])) / E[0])))
        for n in RK4_STEPS:
            res = sim.run(integrator="rk4", steps=n, t_end=t_end, error_check=False)
            E = energy(res)
            drift = float(np.max(np.abs(E - E[0])) / E[0])
            rows.append((label, "rk4", n, res.timings["integrate_s"], drift if np.isfinite(drift) else None))
    return rows


def section(out_dir: Path) -> str:
    """Markdown of the motion-in-time part of the report; figures (PNG) go into ``out_dir``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    import optdesign
    from optdesign.report.output import save_figure
    from optdesign.dynamics.simulator import Simulator

    out_dir = Path(out_dir)
    lines = ["## (c) Motion in time (`optdesign simulate`): work-precision", "",
             "Slider-crank of `problems/sim_slider_crank.toml` on a motor curve T = T0 (1 - omega/omega0), from "
             "alpha = 0.5 rad at 100 rad/s to the stroke end alpha = 9 pi/2 (through four dead centres). "
             "Error: largest crank-speed error at the output samples relative to the peak speed, against a "
             "reference from scipy on a hand-written equation of motion. Run time: integration wall time "
             "(build excluded), one run each. bdf = CVODES BDF/Newton, adams = CVODES Adams/functional "
             "iteration, both over tolerances 1e-4 .. 1e-11; rk4 = fixed-step RK4 over 2 .. 256 steps per "
             "output sample (200 samples), its own error check off.", ""]
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for ax, (case, params) in zip(axes, CASES.items()):
        scene = optdesign.load(ROOT / "problems/sim_slider_crank.toml", params)
        values = scene.parameter_values()
        sol, ref_name, ref_time = reference(values["J_rotor"], values["T0"], values["omega0"], case == "stiff")
        rows = _runs(Simulator(scene), sol)
        lines += [f"### {case}: rotor J = {values['J_rotor']:.3g} kg m^2 ({values['J_rotor'] / I_PEAK:.0e} of the "
                  f"piston's peak reduced inertia), T0 = {values['T0']:g} N m, omega0 = {values['omega0']:g} rad/s", "",
                  f"Reference: {ref_name} ({ref_time:.1f} s), stop at t = {sol.t_events[0][0]:.12g} s.", "",
                  "| integrator | tolerance / steps per sample | steps | run time [ms] | speed error |",
                  "|---|---|---|---|---|"]
        for method, setting, wall, err, steps in rows:
            tag = f"{setting:g}" if method != "rk4" else f"{setting} steps"
            if wall is None or err is None:
                lines.append(f"| {method} | {tag} | - | {'-' if wall is None else f'{wall * 1e3:.1f}'} | failed (clear SolverError) |")
            else:
                lines.append(f"| {method} | {tag} | {steps} | {wall * 1e3:.1f} | {err:.2e} |")
        for method, style in (("bdf", "o-"), ("adams", "s-"), ("rk4", "^-")):
            pts = [(w, e) for m, _, w, e, _ in rows if m == method and w is not None and e is not None]
            if pts:
                ax.loglog(*zip(*pts), style, label=method)
            failed = [m for m, _, w, e, _ in rows if m == method and (w is None or e is None)]
            if failed:
                ax.plot([], [], " ", label=f"{method}: {len(failed)} runs failed")
        ax.set_xlabel("integration wall time [s]")
        ax.set_ylabel("max speed error / peak speed")
        ax.set_title(f"{case} slider-crank (ref. {ref_name})", fontsize=9)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
        lines.append("")
    save_figure(fig, out_dir / "motion_work_precision.png")
    plt.close(fig)
    lines += [f"![work-precision]({out_dir.name}/motion_work_precision.png)", ""]

    rows = _free_energy(out_dir)
    fig, ax = plt.subplots(figsize=(7, 4.2))
    lines += ["### Energy drift of the free motion (no loads, eta = 1, no drive torque)", "",
              "max |KE(t) - KE(0)| / KE(0) over the run, KE from hand-written positions: slider-crank with a rotor "
              "of 1e-2 of the piston's peak reduced inertia over two turns (t_end 1 s, stops at 9 pi/2), jib "
              "(`problems/sim_jib.toml`, g = 0, F = 0) coasting for 10 s.", "",
              "| scene | integrator | tolerance / steps | run time [ms] | energy drift |", "|---|---|---|---|---|"]
    for label, method, setting, wall, drift in rows:
        tag = f"{setting:g}" if method != "rk4" else f"{setting} steps"
        lines.append(f"| {label} | {method} | {tag} | {wall * 1e3:.1f} | {'diverged' if drift is None else f'{drift:.2e}'} |")
    for label, marker in (("slider-crank (rotary)", "-"), ("jib (linear)", "--")):
        for method, style in (("bdf", "o"), ("adams", "s"), ("rk4", "^")):
            pts = [(w, d) for lab, m, _, w, d in rows if lab == label and m == method and d is not None and d > 0]
            if pts:
                ax.loglog(*zip(*pts), style + marker, label=f"{label}, {method}")
    ax.set_xlabel("integration wall time [s]")
    ax.set_ylabel("relative kinetic-energy drift")
    ax.set_title("free motion: energy drift against run time", fontsize=9)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)
    save_figure(fig, out_dir / "motion_energy_drift.png")
    plt.close(fig)
    lines += ["", f"![energy drift]({out_dir.name}/motion_energy_drift.png)", ""]
    import evr_events  # the events part: its own module (benchmarks/ is on the path)

    lines += [evr_events.section(out_dir)]
    return "\n".join(lines)


if __name__ == "__main__":  # pragma: no cover
    import sys

    folder = Path(sys.argv[1] if len(sys.argv) > 1 else "results/evr_motion")
    t0 = time.perf_counter()
    text = section(folder)
    print(text)
    print(f"\n(section took {time.perf_counter() - t0:.1f} s)")
