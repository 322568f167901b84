"""examples/study_truck_crane.py (the README's scripted study) runs as written, in a fresh
folder, and makes the figure it shows; its numbers obey what the physics says without any
computation: the optimal peak cylinder force grows with the payload and with the boom length
(more load moment about the boom pivot, and the placement that served the lighter or shorter
case is still available to the heavier or longer one)."""
from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path


from optdesign.study import read_csv

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "examples" / "study_truck_crane.py"


def test_example_runs_and_writes_its_figure_and_csv(tmp_path):
    (tmp_path / "problems").mkdir()
    shutil.copy(ROOT / "problems" / "truck_crane.toml", tmp_path / "problems")
    done = subprocess.run([sys.executable, str(SCRIPT)], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    out = tmp_path / "results" / "study_truck_crane"
    assert (out / "force_and_pivots.png").stat().st_size > 20_000
    assert (out / "study.png").exists()
    rows = read_csv(out / "cases.csv")
    assert len(rows) == 18 and all(r["success"] == "true" for r in rows)
    force = {(float(r["L"]), float(r["mP"])): float(r["objective"]) for r in rows}
    lengths, payloads = sorted({k[0] for k in force}), sorted({k[1] for k in force})
    for L in lengths:
        assert all(force[L, a] < force[L, b] for a, b in zip(payloads, payloads[1:]))
    for m in payloads:
        assert all(force[a, m] < force[b, m] for a, b in zip(lengths, lengths[1:]))
    # run again: every case comes from the journal, the CSV is unchanged
    before = (out / "cases.csv").read_bytes()
    again = subprocess.run([sys.executable, str(SCRIPT)], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert "18 cases, 0 computed now" in again.stdout
    assert (out / "cases.csv").read_bytes() == before


def test_readme_shows_the_example_as_it_is():
    readme = (ROOT / "README.md").read_text()
    assert "examples/study_truck_crane.py" in readme, "README has lost its scripted-study section"
    blocks = re.findall(r"```python\n(.*?)```", readme, flags=re.S)
    code = SCRIPT.read_text()
    body = code[code.index("import matplotlib"):]
    assert any(block.strip() == body.strip() for block in blocks), "README's study example differs from the script"
