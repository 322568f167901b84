"""Error against run time, part (b): the peak of the drive load over the stroke.

A sampled peak (the largest |drive| at N equally spaced samples) is what a table of the analysis
gives; it misses the continuous peak between samples by O(1/N^2) where the peak is a smooth
interior maximum.  optdesign's certified peak (``optdesign.kinematics.peaks.continuous_maxima``) refines every
sampled local maximum by safeguarded Newton steps on d|drive|/ds = 0 with exact (AD) derivatives.

For each scene and N = 11 .. 10,000 samples we measure

- sampled: the drive over N samples (the SX graph run by ``optdesign.model.vectorised``, as
  ``Analysis.run`` does) and its largest |value|;
- certified: the same samples, then Newton on every sampled local maximum, to s_tol = 1e-14.

Reference: the certified peak from 10,001 samples with Newton to s_tol = 1e-14, cross-checked by
the largest |drive| over 1,000,001 samples (which may only lie below it, by at most the
curvature times the half-spacing squared); both numbers are in the text.
Error = |peak - reference| / reference; time = median wall time of the whole computation.
"""
from __future__ import annotations

import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from optdesign.kinematics.mechanism import Mechanism  # noqa: E402
from optdesign.kinematics.peaks import continuous_maxima  # noqa: E402
from optdesign.model.reduction import ReducedModel  # noqa: E402
from optdesign.report.output import save_figure  # noqa: E402
from optdesign.scene.file import load  # noqa: E402
from optdesign.model.vectorised import VectorisedSX  # noqa: E402
from benchfile import median_time  # noqa: E402  (benchmarks/ is on the path: error_vs_runtime.py)

ROOT = Path(__file__).resolve().parents[1]
SAMPLES = (11, 21, 51, 101, 201, 501, 1001, 2001, 5001, 10000)
REFERENCE_GRID = 10001
DENSE = 1_000_001
S_TOL = 1e-14
REPEATS = 9
SCENES = {
    "slider-crank": ("problems/seed1_slider_crank.toml", "T_S [N m]"),
    "crank press": ("problems/crank_press_peak.toml", "T_S [N m]"),
    "level-luffing crane": ("problems/level_luffing_crane.toml", "F_S [N]"),
}


class Drive:
    """The drive load of a scene over rows of sweep values, and (v, dv/ds, d2v/ds2) at one s."""

    def __init__(self, path):
        scene = load(ROOT / path)
        mech = Mechanism(scene)
        drive = ReducedModel(mech).outputs()["drive"]
        self.p = mech.parameter_values
        self.rows = VectorisedSX(mech.function("drive", {"v": drive}))
        d1 = mech.ds(drive)
        self.derivatives = mech.function("drive_ds", {"v": drive, "d1": d1, "d2": mech.ds(d1)})
        stroke = mech.stroke()
        self.a, self.b = float(stroke[0]), float(stroke[-1])

    def values(self, s):
        return self.rows(s, self.p)["v"]

    def at(self, s):
        out = self.derivatives(s, self.p)
        return float(out[0]), float(out[1]), float(out[2])

    def sampled(self, n):
        s = np.linspace(self.a, self.b, n)
        return float(np.max(np.abs(self.values(s))))

    def certified(self, n):
        s = np.linspace(self.a, self.b, n)
        ext = continuous_maxima(self.at, s, self.values(s), "abs", s_tol=S_TOL)
        return abs(ext[0].value)

    def dense(self, n=DENSE, chunk=200_001):
        """Largest |drive| over n samples, in chunks (memory)."""
        s = np.linspace(self.a, self.b, n)
        return max(float(np.max(np.abs(self.values(s[i:i + chunk])))) for i in range(0, n, chunk))


def measure(name, path):
    drive = Drive(path)
    reference = drive.certified(REFERENCE_GRID)
    t0 = time.perf_counter()
    dense = drive.dense()
    t_dense = time.perf_counter() - t0
    rows = []
    for n in SAMPLES:
        t_s, v_s = median_time(lambda: drive.sampled(n), REPEATS)
        t_c, v_c = median_time(lambda: drive.certified(n), REPEATS)
        rows.append((n, t_s, abs(v_s - reference) / reference, t_c, abs(v_c - reference) / reference))
    return {"name": name, "path": path, "reference": reference, "dense": dense, "t_dense": t_dense, "rows": rows}


def figure(cases, path):
    fig, ax = plt.subplots(figsize=(8, 5.5))
    floor = 1e-17
    for i, case in enumerate(cases):
        n, t_s, e_s, t_c, e_c = map(np.array, zip(*case["rows"]))
        color = f"C{i}"
        ax.loglog(t_s, np.maximum(e_s, floor), "o-", color=color, label=f"{case['name']}: sampled peak")
        ax.loglog(t_c, np.maximum(e_c, floor), "s--", color=color, label=f"{case['name']}: certified (Newton)")
        for k in (0, len(n) - 1):
            ax.annotate(f"N={n[k]}", (t_s[k], max(e_s[k], floor)), fontsize=7, color=color)
    ax.axhline(2.2e-16, color="grey", lw=0.8, ls=":")
    ax.set_xlabel("run time [s] (median): N samples of the drive (+ Newton for certified)")
    ax.set_ylabel("|peak - reference| / reference")
    ax.set_title("Peak |drive| over the stroke: error against run time (N = 11 .. 10,000)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    save_figure(fig, path)
    plt.close(fig)


def section(out_dir) -> str:
    out_dir = Path(out_dir)
    cases = [measure(name, path) for name, (path, _) in SCENES.items()]
    name = "peak.png"
    figure(cases, out_dir / name)
    parts = ["## (b) The peak over the stroke: sampled against certified", "", __doc__.split("\n\n", 1)[1].strip(), "",
             f"![peak: error against run time]({out_dir.name}/{name})", ""]
    for case in cases:
        unit = SCENES[case["name"]][1]
        gap = (case["reference"] - case["dense"]) / case["reference"]
        parts += [f"### {case['name']} (`{case['path']}`)", "",
                  f"Reference (certified, {REFERENCE_GRID} samples + Newton): {case['reference']:.15g} {unit}; "
                  f"largest of {DENSE:,} samples: {case['dense']:.15g} ({gap:.1e} relative below it; "
                  f"{case['t_dense']:.2g} s).", "",
                  "| N | sampled: time [ms] | sampled: error | certified: time [ms] | certified: error |",
                  "|---|---|---|---|---|"]
        for n, t_s, e_s, t_c, e_c in case["rows"]:
            parts.append(f"| {n} | {1e3 * t_s:.3g} | {e_s:.1e} | {1e3 * t_c:.3g} | {e_c:.1e} |")
        parts.append("")
    missed = [(c["name"], r[0]) for c in cases for r in c["rows"] if r[4] > 1e-12]
    parts += ["Reading the figure: the sampled peak's error falls as 1/N^2 where the peak is a smooth "
              "interior maximum (it falls in steps: grids whose points happen to lie equally far from the "
              "peak give the same error) and costs time in proportion to N; the certified peak reaches "
              "round-off from a coarse grid for the price of a few Newton steps (each one CasADi call with the "
              "first and second derivatives, one refinement per sampled local maximum), as long as the grid "
              "brackets the global maximum. A grid too coarse to resolve the load's features could miss the "
              "peak's bracket; then the certified value is only the best local maximum found. "
              + ("In this run that happened for " + ", ".join(f"{n} at N = {k}" for n, k in missed) + "."
                 if missed else "In this run it did not happen for any scene, even at N = 11 (the crank press's "
                 "forming-force bump, 8 mm of ram travel wide, is still bracketed)."), ""]
    return "\n".join(parts)


if __name__ == "__main__":
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        print(section(Path(d) / "error_vs_runtime"))
