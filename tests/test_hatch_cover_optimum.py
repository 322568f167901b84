"""problems/hatch_cover.toml against its independent numpy model (tests/ref_hatch_cover.py:
geometry, virtual work, the trapezoid and the constraints written there, nothing of optdesign).

Fast (default suite): the numpy cylinder force equals optdesign's analyse in every case at the
shipped optimum (results/hatch_cover/result.json) and at the scene's start, and the shipped
objective is the numpy model's continuous peak there, with the constraints as reported.
Slow: the numpy model's global optimum (a grid on the stroke equality plus polished SLSQP
solves) is the shipped optimum, and `optdesign optimise` with the default settings (20 starts,
seed 0) reaches it, counting how many starts do."""
from __future__ import annotations

import functools
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

import optdesign

sys.path.insert(0, str(Path(__file__).resolve().parent))
import ref_hatch_cover as ref  # noqa: E402
from default_optimum import default_optimum  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = ROOT / "results" / "hatch_cover" / "result.json"
AT_GLOBAL = 1e-6   # a start "reaches the global optimum" within this relative distance


def shipped():
    return json.loads(SHIPPED.read_text())


def test_reference_reads_the_scene_it_models():
    """The constants of the numpy model are the scene's (an edit of the scene must show here)."""
    n = ref.scene_numbers()
    assert (n["Lc"], n["mc"], n["h"], n["eta"], n["g"]) == (ref.LC, ref.MC, ref.H, ref.ETA, ref.G)
    assert n["box"] == ref.BOX
    assert [(c, 1 if d == "forward" else -1, float(m)) for c, d, m in n["cases"]] == list(ref.CASES)
    assert n["cylinder"] == (ref.ROD, ref.MODULUS, ref.SAFETY)


@pytest.mark.parametrize("which", ["shipped optimum", "scene start"])
def test_numpy_force_is_analyses_in_every_case(which):
    design = shipped()["design"] if which == "shipped optimum" else {"xD": 0.3, "yD": -0.6, "b": 0.5}
    res = optdesign.analyse(optdesign.load(ref.SCENE).with_parameters(**design))
    x3 = [design[n] for n in ref.BOX]
    x1 = ref.V ** 2 / (2 * ref.ACC)
    for name, d, m in ref.CASES:
        case = res.cases.cases[name]
        s = np.asarray(case.columns["s"], float)
        x = s if d > 0 else ref.L - s
        inside = (np.abs(x - x1) > 1e-6) & (np.abs(x - (ref.L - x1)) > 1e-6)   # off the phase boundaries
        a = np.where(x < x1, ref.ACC, np.where(x > ref.L - x1, -ref.ACC, 0.0))
        theirs = ref.force(*x3, x[inside], a[inside], d, m)
        ours = np.asarray(case.columns["drive"], float)[inside]
        assert np.max(np.abs(ours - theirs)) <= 1e-9 * np.max(np.abs(theirs)), name
        # the case's peak over its continuous stroke (at a phase boundary, from the right side)
        peak = max(float(np.max(np.abs(ref.force(*x3, xs, a_, d, m))))
                   for xs, a_ in ((np.linspace(0, x1, 4001), ref.ACC), (np.linspace(x1, ref.L - x1, 4001), 0.0),
                                  (np.linspace(ref.L - x1, ref.L, 4001), -ref.ACC)))
        assert case.peaks["drive"] == pytest.approx(peak, rel=1e-8), name


def test_shipped_objective_is_the_numpy_peak_and_its_constraints_hold():
    data = shipped()
    x3 = [data["design"][n] for n in ref.BOX]
    value, case, (x, _) = ref.refined_peak(x3)
    assert data["objective"] == pytest.approx(value, rel=1e-8)
    assert case == "open with snow" and math.degrees(x) == pytest.approx(3.75, abs=1e-6)
    assert ref.stroke(*x3) == pytest.approx(ref.STROKE, abs=1e-9)
    angle, at = ref.min_angle(x3)
    assert angle >= ref.MIN_ANGLE - 1e-9 and angle == pytest.approx(ref.MIN_ANGLE, abs=1e-8)   # active
    assert ref.buckling(x3) < 1 and ref.dk_min(x3) > 0
    assert data["constraints"]["cylinder to cover angle"]["min"] == pytest.approx(angle, abs=1e-9)
    shown = data["constraints"]
    assert shown["rod buckling in case 'open with snow'"]["value"] == pytest.approx(ref.buckling(x3), rel=1e-7)


@functools.cache
def reference():
    return ref.global_optimum()


@pytest.mark.slow
def test_shipped_optimum_is_the_global_one():
    glob, data = reference(), shipped()
    assert glob["peak"] <= glob["grid_best"]            # the polish improves on the grid
    assert abs(glob["stroke"] - ref.STROKE) <= 1e-10 and glob["angle"] >= ref.MIN_ANGLE - 1e-9
    assert ref.buckling(list(glob["design"].values())) < 1 and ref.dk_min(list(glob["design"].values())) > 0
    assert data["objective"] == pytest.approx(glob["peak"], rel=AT_GLOBAL)
    for n, (lo, hi) in ref.BOX.items():
        assert data["design"][n] == pytest.approx(glob["design"][n], abs=1e-4 * (hi - lo))


@pytest.mark.slow
def test_optimise_with_default_settings_reaches_the_global_optimum():
    """``optdesign.optimise(load(scene), 20, 0)``, what `optdesign optimise` runs by default."""
    result, seconds = default_optimum(ref.SCENE)
    glob = reference()
    at = sum(1 for s in result.starts if s.success and s.objective is not None
             and abs(s.objective - glob["peak"]) <= AT_GLOBAL * glob["peak"])
    print(f"\nhatch_cover: {at}/{len(result.starts)} starts at the global optimum {glob['peak']:.10g}; "
          f"optimise took {seconds:.1f} s")
    assert result.success, (result.status, result.message)
    assert result.objective == pytest.approx(glob["peak"], rel=AT_GLOBAL)
    for n, (lo, hi) in ref.BOX.items():
        assert result.design[n] == pytest.approx(glob["design"][n], abs=1e-4 * (hi - lo))
    assert at >= 18, f"only {at} of 20 starts reach the global optimum"
