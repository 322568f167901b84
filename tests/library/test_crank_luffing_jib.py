"""problems/lib_crank_luffing_jib.toml against its independent numpy reference
(ref_crank_luffing_jib.py).

optdesign's 20-start optimisation (default settings) must reach the global optimum that a grid
over the whole design box plus polished SLSQP solves finds on the numpy model (1e-6 relative,
the design to 1e-4); its certified peak must be the numpy peak at optdesign's design over 20,001
samples with the extreme refined (1e-8 relative) and every constraint must hold there; the crank
torque of optdesign's model (analyse) must be the numpy model's at the start and at both optima
(1e-9 of the peak).  The reference's optimum has the active set the scene's comment predicts
(a vertex: the crank's transmission angle on both its limits, the rod-to-jib angle on its lower
limit, the crank centre at its highest).  How many of the 20 starts reach the global optimum is
printed (issue 14 records it; not asserted yet).
"""
from __future__ import annotations

import functools
import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
import ref_crank_luffing_jib as ref  # noqa: E402
import reflib_checks as checks  # noqa: E402
import reflib_search as rs  # noqa: E402


@functools.cache
def reference():
    return ref.global_optimum("small")


def test_optimum_is_the_global_one():
    result, seconds = checks.optimum(ref.SCENE)
    glob = reference()
    at, others, text = checks.starts_report(result, glob["peak"])
    print(f"\nlib_crank_luffing_jib: {text}; optimise took {seconds:.1f} s")
    assert result.success, (result.status, result.message)
    assert glob["violation"] <= 1e-9
    assert glob["peak"] <= glob["grid_best"][0]  # the polish beats the best grid point (refined)
    assert result.objective == pytest.approx(glob["peak"], rel=1e-6)
    for name in ref.DESIGN:
        lo, hi = ref.data()["box"][name]
        assert result.design[name] == pytest.approx(glob["design"][name], abs=1e-4 * (hi - lo))


def test_certified_peak_is_the_dense_peak():
    result, _ = checks.optimum(ref.SCENE)
    assert result.success, (result.status, result.message)
    assert ref.dense_peak(result.design, 20001) == pytest.approx(result.peak_certified, rel=1e-8)
    _, viol, _, _ = rs.evaluate(ref.problem(), [result.design[n] for n in ref.DESIGN], 20001)
    assert viol <= 1e-7


def test_drive_agrees_with_the_numpy_model():
    result, _ = checks.optimum(ref.SCENE)
    p = ref.data()["params"]
    designs = {"start": {n: p[n] for n in ref.DESIGN}, "numpy optimum": reference()["design"]}
    if result.success:
        designs["optdesign optimum"] = result.design
    for label, design in designs.items():
        mismatch, ours, theirs = checks.drive_mismatch(ref.SCENE, design, ref.drive, samples=9)
        assert mismatch <= 1e-9, (label, ours, theirs)


def test_reference_active_set():
    """At the reference's optimum (20,001 samples, extremes refined): the crank transmission
    angle touches 30 and 150 deg, the rod-to-jib angle 30 deg (to 1e-7 rad), yO sits on its
    upper bound, and the crank never reaches a dead centre (k = dq/dtheta > 0)."""
    glob = reference()
    peak, viol, ext, at = rs.evaluate(ref.problem(), [glob["design"][n] for n in ref.DESIGN], 20001)
    assert viol <= 1e-9
    assert ext[("crank", "min")] == pytest.approx(math.radians(30), abs=1e-7)
    assert ext[("crank", "max")] == pytest.approx(math.radians(150), abs=1e-7)
    assert ext[("rod", "min")] == pytest.approx(math.radians(30), abs=1e-7)
    assert ext[("rod", "max")] < math.radians(150) - 0.1
    assert glob["design"]["yO"] == pytest.approx(ref.data()["box"]["yO"][1], abs=1e-9)
    X = {n: np.array([[v]]) for n, v in glob["design"].items()}
    assert ref.rows(X, np.linspace(*ref.data()["sweep"], 20001))["k"].min() > 0
