"""The numpy evaluation of the reduced model's SX graph gives CasADi's own numbers."""
from pathlib import Path

import numpy as np
import pytest

from optdesign import load
from optdesign.model.analysis import Analysis

# every shipped scene with a reduced model (a [drive])
SCENES = sorted(p for p in (Path(__file__).parents[1] / "problems").glob("*.toml") if load(p).drive is not None)


@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.stem)
def test_vectorised_equals_casadi_map_on_every_shipped_scene(path):
    scene = load(path)
    analysis = Analysis(scene)
    if analysis.vectorised is None:
        assert analysis.mech.sym.__name__ == "MX"  # only loop scenes (MX graphs) keep the map
        return
    p = analysis.mech.parameter_values
    ours = analysis.vectorised(analysis.s_values, p)
    n = len(analysis.s_values)
    reference = analysis.function.map(n)(s=analysis.s_values[None, :], p=p)   # CasADi's own map
    for name, value in reference.items():
        expected = np.broadcast_to(np.asarray(value, float).ravel(), (n,))
        got = np.broadcast_to(np.asarray(ours[name], float), (n,))
        finite = np.isfinite(expected)
        assert np.array_equal(finite, np.isfinite(got)), name
        scale = max(float(np.max(np.abs(expected[finite]), initial=0.0)), 1e-300)
        assert np.max(np.abs(got[finite] - expected[finite]), initial=0.0) <= 1e-13 * scale, name
