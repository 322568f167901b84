"""What every library-scene test does with optdesign's answer, through its front doors only
(``optdesign.load``, ``optdesign.optimise``, ``optdesign.analyse``): run the 20-start
optimisation once, count the starts that reach the independent global optimum, and compare
optdesign's drive load with a reference's numpy model at a few stroke samples."""
from __future__ import annotations

import functools

import numpy as np

import optdesign
from default_optimum import default_optimum  # noqa: E402 (tests/ is on sys.path under pytest)

AT_GLOBAL = 1e-6  # a start "reaches the global optimum" within this relative distance


@functools.cache
def optimum(path):
    """``optdesign.optimise(optdesign.load(path), 20, 0)`` (default settings) and its wall time,
    run once per scene for the whole session (tests/default_optimum.py)."""
    return default_optimum(path)


def starts_report(result, global_value):
    """(starts within AT_GLOBAL of the global optimum, {status: count} of the others, text)."""
    at, others = 0, {}
    for s in result.starts:
        if s.success and s.objective is not None and abs(s.objective - global_value) <= AT_GLOBAL * abs(global_value):
            at += 1
        else:
            key = s.status if s.success is False or s.objective is None else f"{s.status}, objective {s.objective:.10g}"
            others[key] = others.get(key, 0) + 1
    text = f"{at}/{len(result.starts)} starts at the global optimum {global_value:.10g}"
    if others:
        text += "; others: " + "; ".join(f"{n} x {k}" for k, n in sorted(others.items()))
    return at, others, text


def drive_mismatch(path, design, numpy_drive, samples=9):
    """Largest |optdesign's drive - numpy's drive| over ``samples`` evenly spaced stroke samples
    (``optdesign.analyse`` of the scene with ``design`` set), relative to the largest |drive|
    there; and the optdesign values (for messages)."""
    scene = optdesign.load(path).with_parameters(**design)
    res = optdesign.analyse(scene, samples)
    s = np.asarray(res.columns["s"], float)
    ours = np.asarray(res.columns["drive"], float)
    ref = np.asarray(numpy_drive(design, s), float)
    scale = np.max(np.abs(ref))
    return float(np.max(np.abs(ours - ref)) / scale), ours, ref

