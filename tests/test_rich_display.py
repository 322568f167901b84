"""Rich display in Jupyter without a kernel (the fast sibling of tests/test_notebook.py, which
runs examples/hatch_cover.ipynb in one): a scene, an analysis with load cases, a simulation and
a study each show an HTML table with the numbers the object holds, the results with an inline
PNG figure (report/notebook.py; the optimum's display is in the notebook's test)."""
from __future__ import annotations

import base64
import re
from pathlib import Path

import numpy as np

import optdesign
from optdesign.study import Study, values

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"


def _png_ok(page):
    found = re.findall(r"data:image/png;base64,([A-Za-z0-9+/=]+)", page)
    assert found, "no inline figure"
    assert all(base64.b64decode(f)[:8] == b"\x89PNG\r\n\x1a\n" and len(f) > 2000 for f in found)


def test_scene_and_analysis_with_cases():
    scene = optdesign.load(PROBLEMS / "hatch_cover.toml")
    page = scene._repr_html_()
    assert "<table>" in page and "open, close, open with snow" in page and "theta from 0 to 90 deg" in page
    result = optdesign.analyse(scene, samples=31, certify=False)
    page = result._repr_html_()
    assert "<table>" in page and "the nominal [drive] state" in page
    _png_ok(page)


def test_simulation_shows_its_end_and_peak():
    result = optdesign.simulate(optdesign.load(PROBLEMS / "sim_bar.toml"))
    page = result._repr_html_()
    assert f"t = {result.t[-1]:.6g} s" in page and f"{np.max(np.abs(result.drive)):.6g} N m" in page
    _png_ok(page)


def test_study_shows_its_cases(tmp_path):
    scene = optdesign.load(PROBLEMS / "sim_bar.toml")
    result = Study(scene, [values("m", [2.0, 3.0])], mode="analyse").run(out=tmp_path / "s", workers=1, figures=False)
    page = result._repr_html_()
    assert "<table>" in page and "<th>m</th>" in page
    assert [row["m"] for row in result.rows] == [2.0, 3.0]
    assert page.count("<tr>") >= 2 + len(result.rows)
