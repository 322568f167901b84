"""The invariants that make a wrong certified figure impossible to report, over the whole
shipped library: a certified peak is never below the largest sampled |v| of the same design,
its certificate's bound is never below it, and a denser sample (4x, its own grid) never
exceeds the certificate's bound.  Every scene in problems/ with a drive, at its default samples."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import optdesign

# every scene with a drive (seed 2's are kinematics alone: no reduced model to certify)
SCENES = [p for p in sorted((Path(__file__).resolve().parents[1] / "problems").glob("*.toml"))
          if "\n[drive]" in p.read_text()]


@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.stem)
def test_certified_peaks_hold_over_the_library(path):
    scene = optdesign.load(path)
    result = optdesign.analyse(scene)
    dense = optdesign.analyse(scene, 4 * scene.sweep.samples - 3)
    assert result.peaks, path.name
    for name, peak in result.peaks.items():
        sampled = np.max(np.abs(np.asarray(result.columns[name], float)))
        assert peak >= sampled * (1 - 1e-12), (path.name, name, peak, sampled)
        assert peak >= result.peaks_sampled[name] * (1 - 1e-12), (path.name, name)
        cert = result.certificates.get(f"peak |{name}|", {})
        bound = cert.get("bound")
        if bound is None:                      # no proof: the tool must say why
            assert cert.get("note"), (path.name, name, cert)
            continue
        assert bound >= peak * (1 - 1e-12), (path.name, name, bound, peak)
        denser = np.max(np.abs(np.asarray(dense.columns[name], float)))
        assert denser <= bound * (1 + 1e-9) + 1e-12, (path.name, name, denser, bound)
