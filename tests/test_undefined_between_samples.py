"""A quantity undefined on part of the stroke, between two samples, is never called certified
there (issue 27's leftover: an interval on which the function is undefined could close).

The scene: seed1_slider_crank with a constraint -sqrt((alpha - 1.005) (alpha - 1.010)), NaN
for alpha in (1.005, 1.010), which lies between the samples 1.00356 and 1.01229 (721 over a
turn), so that every sample is finite.  The old code enclosed the hole by [NaN, -0] (the
negation of sqrt's [0, NaN]) and certified the constraint's minimum (-5.2757, note ''); no
extreme of an expression undefined inside the stroke may be certified."""
from __future__ import annotations

from pathlib import Path

import numpy as np

import optdesign

ROOT = Path(__file__).resolve().parents[1]


def test_no_extreme_of_a_quantity_undefined_between_samples_is_certified():
    text = (ROOT / "problems" / "seed1_slider_crank.toml").read_text() + '''
[[constraints]]
name = "hole"
expr = "-sqrt((alpha - 1.005)*(alpha - 1.010))"
max = 1
'''
    result = optdesign.analyse(optdesign.loads(text, "hole.toml"))
    s = np.asarray(result.columns["s"])
    assert not np.any((s > 1.005) & (s < 1.010)) and np.all(np.isfinite(result.constraints["hole"]))
    for sense in ("min", "max"):
        certificate = result.certificates[f"hole {sense}"]
        assert certificate["note"].startswith("not certified"), (sense, certificate)
