"""matplotlib imported without its docstrings' property tables (report/mpl_import.py): in a
fresh process, the figures drawn after that import are the bytes drawn after matplotlib's own
import, and ``kwdoc`` is matplotlib's own again afterwards."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

SCRIPT = r"""
import hashlib, json, sys
from pathlib import Path
if sys.argv[1] == "cheap":
    from optdesign.report.mpl_import import import_for_drawing
    import_for_drawing()
else:
    import matplotlib.backends.backend_agg, matplotlib.backends.backend_svg, matplotlib.figure
import matplotlib.artist as artist
from matplotlib.lines import Line2D
import optdesign
from optdesign.model.analysis import analyse
from optdesign.report import stroke_plots
from optdesign.report.mechanism import mechanism_figure
folder = Path(sys.argv[2])
scene = optdesign.load(sys.argv[3])
stroke_plots.stroke_figure([("", analyse(scene))], folder / "drive.png", title="drive")
mechanism_figure([("start", scene)], [folder / "mechanism.png"], suptitle="mechanism")
print(json.dumps({"kwdoc": artist.kwdoc.__module__ + "." + artist.kwdoc.__name__,
                  "doc": "Properties:" in (Line2D.set.__doc__ or ""),
                  "files": {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir())}}))
"""


def _run(kind, folder):
    folder.mkdir()
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": str(ROOT)}
    out = subprocess.run([sys.executable, "-c", SCRIPT, kind, str(folder), str(ROOT / "problems" / "seed1_jib.toml")],
                         env=env, capture_output=True, text=True, check=True, timeout=300)
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_the_cheap_import_draws_the_same_bytes(tmp_path):
    plain = _run("plain", tmp_path / "plain")
    cheap = _run("cheap", tmp_path / "cheap")
    assert set(plain["files"]) == {"drive.png", "mechanism.png"}
    assert cheap["files"] == plain["files"]
    # kwdoc is matplotlib's own again; the docstrings made during the import are the only loss
    assert cheap["kwdoc"] == plain["kwdoc"] == "matplotlib.artist.kwdoc"
    assert plain["doc"] and not cheap["doc"]
