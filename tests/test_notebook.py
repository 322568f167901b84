"""The example notebook (examples/hatch_cover.ipynb) runs in a Jupyter kernel (nbclient, a test
extra) and every result it shows has a rich display: an HTML table and an inline PNG figure
(report/notebook.py), with the numbers the result objects hold."""
from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_example_notebook_runs_and_shows_tables_and_figures():
    nbformat = pytest.importorskip("nbformat", reason="nbformat is in the test extra: pip install -e '.[test]'")
    nbclient = pytest.importorskip("nbclient", reason="nbclient is in the test extra: pip install -e '.[test]'")
    pytest.importorskip("ipykernel", reason="ipykernel is in the test extra: pip install -e '.[test]'")
    nb = nbformat.read(ROOT / "examples" / "hatch_cover.ipynb", as_version=4)
    nbclient.NotebookClient(nb, timeout=900, kernel_name="python3", resources={"metadata": {"path": str(ROOT)}}).execute()
    html = {}
    for cell in nb.cells:
        if cell.cell_type != "code":
            continue
        for out in cell.outputs:
            assert out.output_type != "error", out
            if "text/html" in out.get("data", {}):
                html[cell.source.splitlines()[-1]] = out["data"]["text/html"]
    assert set(html) == {"scene", "analysis", "optimum"}
    assert "<table>" in html["scene"] and "hatch" in html["scene"].lower()
    for name in ("analysis", "optimum"):
        assert "<table>" in html[name] and "data:image/png;base64," in html[name], name
    assert "certified over the continuous stroke" in html["optimum"]
    printed = "".join(o.get("text", "") for o in nb.cells[-1].outputs)
    assert printed.startswith("bore 100 mm, pressure pushing ")
