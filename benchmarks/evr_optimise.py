"""Error against run time, part (d): the optimiser's tolerance.

``optdesign.design.optimise`` from the scene's own start (one start), with IPOPT's ``tol`` (and
``constr_viol_tol``, which ``SolverSettings.tol`` sets too) from 1e-1 to 1e-12; everything else at
the defaults (the exchange loop stops when the epigraph and the continuous peak agree to
``peak_tol`` = 1e-8).

Reference: the same solve at tol = 1e-12, checked independently by ``Analysis`` over 100,001
samples at its design: the largest |drive| there (the dense peak) must agree with the certified
objective, and every constraint of the scene must hold on the dense samples (the largest
violation is given).  For each tolerance:

- objective error = (J(tol) - J_ref) / J_ref, J the certified objective that ``optimise``
  reports (signed: a value below the reference is possible only by violating a constraint);
- constraint violation = the largest violation of any scene constraint over the 100,001 samples
  at the returned design, relative to its bound (0 when feasible);
- time = median wall time of the solve (``total_s - build_s`` of the result; the build of the
  NLP, once per scene and tolerance, is not counted), over REPEATS runs.
"""
from __future__ import annotations

import math
import statistics
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from optdesign.model.analysis import Analysis  # noqa: E402
from optdesign.design.problem import SolverSettings  # noqa: E402
from optdesign.scene.expressions import constant_value  # noqa: E402
from optdesign.design import optimise  # noqa: E402
from optdesign.report.output import save_figure  # noqa: E402
from optdesign.scene.file import load  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
TOLS = tuple(10.0 ** -k for k in range(1, 13))
REPEATS = 3
DENSE = 100_001
SCENES = {
    "jib design": "problems/seed1_jib_design.toml",
    "crank press": "problems/crank_press_peak.toml",
}


_ANALYSES = {}


def dense_check(scene, design):
    """(dense peak |drive|, largest relative constraint violation) at ``design``, 100,001 samples
    (one compiled Analysis per scene, run at each design's parameter vector)."""
    if scene.path not in _ANALYSES:
        _ANALYSES[scene.path] = Analysis(scene, samples=DENSE)
    analysis = _ANALYSES[scene.path]
    names = list(analysis.mech.parameter_names)
    p = analysis.mech.parameter_values.copy()
    for k, v in design.items():
        p[names.index(k)] = v
    res = analysis.run(p)
    values = scene.parameter_values()
    worst = 0.0
    for c in scene.constraints:
        v = np.atleast_1d(res.constraints[c.name])
        for bound, side in ((c.lower, -1), (c.upper, 1)):
            if bound is None:
                continue
            b = constant_value(bound, values, c.name)
            over = (np.max(v) - b) if side > 0 else (b - np.min(v))
            worst = max(worst, over / max(abs(b), 1e-300))
    return res.peaks["drive"], worst


def solve(scene, tol):
    """Median solve time over REPEATS and the (last) result."""
    times, result = [], None
    for _ in range(REPEATS):
        result = optimise(scene, starts=1, settings=SolverSettings(tol=tol))
        times.append(result.timings["total_s"] - result.timings["build_s"])
    return statistics.median(times), result


def measure(name, path):
    scene = load(ROOT / path)
    t_ref, ref = solve(scene, 1e-12)
    assert ref.success, f"{path}: the reference solve at tol 1e-12 failed: {ref.status}"
    dense_peak, ref_violation = dense_check(scene, ref.design)
    rows = []
    for tol in TOLS:
        t, r = solve(scene, tol)
        if r.success:
            peak, violation = dense_check(scene, r.design)
            err = (r.objective - ref.objective) / ref.objective
            dx = max(abs(r.design[k] - ref.design[k]) / max(abs(ref.design[k]), 1e-300) for k in ref.design)
            rows.append((tol, t, err, violation, dx, r.status, r.starts[0].iterations, r.starts[0].exchanges))
        else:
            rows.append((tol, t, math.nan, math.nan, math.nan, r.status, r.starts[0].iterations, r.starts[0].exchanges))
    return {"name": name, "path": path, "ref": ref, "t_ref": t_ref, "dense_peak": dense_peak,
            "ref_violation": ref_violation, "rows": rows}


def figure(cases, path):
    fig, ax = plt.subplots(figsize=(8, 5.5))
    floor = 1e-17
    for i, case in enumerate(cases):
        tol, t, err, viol, dx, *_ = zip(*case["rows"])
        tol, t, err, viol = map(np.array, (tol, t, err, viol))
        ok = np.isfinite(err)
        color = f"C{i}"
        ax.loglog(t[ok], np.maximum(np.abs(err[ok]), floor), "o-", color=color,
                  label=f"{case['name']}: |objective error|")
        ax.loglog(t[ok], np.maximum(viol[ok], floor), "^:", color=color, alpha=0.6,
                  label=f"{case['name']}: constraint violation (dense)")
        for k in np.flatnonzero(ok):
            ax.annotate(f"{tol[k]:.0e}", (t[k], max(abs(err[k]), floor)), fontsize=6, color=color)
        if np.any(~ok):
            ax.loglog(t[~ok], np.full((~ok).sum(), 1.0), "x", color=color, ms=10,
                      label=f"{case['name']}: no certified optimum (failed)")
    ax.set_xlabel("solve time, one start [s] (median)")
    ax.set_ylabel("relative error")
    ax.set_title("Optimisation: error against run time, IPOPT tol 1e-1 .. 1e-12 (labels)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    save_figure(fig, path)
    plt.close(fig)


def section(out_dir) -> str:
    out_dir = Path(out_dir)
    cases = [measure(name, path) for name, path in SCENES.items()]
    name = "optimise.png"
    figure(cases, out_dir / name)
    parts = ["## (d) Optimisation: IPOPT's tolerance against the objective's error and the time", "",
             __doc__.split("\n\n", 1)[1].strip(), "", f"![optimisation: error against run time]({out_dir.name}/{name})", ""]
    for case in cases:
        ref = case["ref"]
        agree = abs(case["dense_peak"] - ref.objective) / ref.objective
        design = ", ".join(f"{k} = {v:.12g}" for k, v in ref.design.items())
        parts += [f"### {case['name']} (`{case['path']}`)", "",
                  f"Reference (tol 1e-12, {1e3 * case['t_ref']:.3g} ms): J = {ref.objective:.15g} at {design}. "
                  f"Dense check ({DENSE:,} samples): peak |drive| {case['dense_peak']:.15g} ({agree:.1e} relative "
                  f"from J, below it by the sampling), largest constraint violation {case['ref_violation']:.1e}.", "",
                  "| IPOPT tol | solve [ms] | objective error | constraint violation | design error | iterations | exchanges | status |",
                  "|---|---|---|---|---|---|---|---|"]
        for tol, t, err, viol, dx, status, it, ex in case["rows"]:
            cells = ("-", "-", "-") if not math.isfinite(err) else (f"{err:+.1e}", f"{viol:.1e}", f"{dx:.1e}")
            parts.append(f"| {tol:.0e} | {1e3 * t:.3g} | {cells[0]} | {cells[1]} | {cells[2]} | {it} | {ex} | {status} |")
        parts.append("")
    times = [r[1] for c in cases for r in c["rows"]]
    parts += [f"Reading the tables: the solve time changes little with the tolerance (here {1e3 * min(times):.3g} "
              f"to {1e3 * max(times):.3g} ms per start, no trend beyond a few extra iterations): loose "
              "tolerances save little time. "
              + ("Where a loose tolerance left the exchange loop unable to certify the peak to its peak_tol "
                 "within its 12 exchanges, optimise reported a failure, not a result ('-' rows). "
                 if any(not math.isfinite(r[2]) for c in cases for r in c["rows"]) else "")
              + "From about tol = 1e-6 down, the objective's error is of the order of the tolerance. Where the "
              "optimum lies on a constraint (the jib: the cylinder stroke limit), IPOPT's constraint "
              "tolerance (``constr_viol_tol`` = tol on the scaled constraint) lets the returned design exceed "
              "the constraint by about that much, and the objective then lies below the reference by the "
              "same order (a negative error with a positive violation): at the default tol = 1e-10 this is "
              "a few 1e-10, well inside the optimiser's stated ``constraint_tol`` = 1e-7.", ""]
    return "\n".join(parts)


if __name__ == "__main__":
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        print(section(Path(d) / "error_vs_runtime"))
