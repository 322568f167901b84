"""analyse --csv with load cases (issue 29): beside the nominal state's CSV, one CSV per case
and one of the duty cycle's time series, every header 'name [unit]', the sweep in the unit the
scene wrote (deg).  The cycle's series integrates (trapezoid rule in time, written here) to the
RMS over the cycle's time that analyse reports (its own rule: the integral on each case's
sample grid, exact in time), within the trapezoid's error."""
from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np

from optdesign.cli import main as cli

HATCH = Path(__file__).resolve().parents[1] / "problems" / "hatch_cover.toml"


def _read(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


def test_cases_and_cycle_csv(tmp_path, capsys):
    out = tmp_path / "hatch.csv"
    assert cli.main(["analyse", str(HATCH), "--csv", str(out), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    for name, case in doc["cases"].items():
        slug = name.replace(" ", "_")
        head, rows = _read(tmp_path / f"hatch_case-{slug}.csv")
        assert head[0] == "theta [deg]" and "drive [N]" in head and "rod_buckling [-]" in head
        assert len(rows) == len(case["samples"])
        theta = np.array([float(r[0]) for r in rows])
        assert np.allclose(np.sort(theta), np.sort([math.degrees(s["s"]) for s in case["samples"]]), atol=1e-9)
    head, rows = _read(tmp_path / "hatch_cycle.csv")
    assert head[:4] == ["t [s]", "step", "theta [deg]", "drive [N]"]
    t = np.array([float(r[0]) for r in rows])
    drive = np.array([float(r[3]) for r in rows])
    assert np.all(np.diff(t) >= 0) and t[-1] == doc["duty"]["cycle_time"]
    square = np.sum(np.diff(t) * (drive[1:] ** 2 + drive[:-1] ** 2) / 2)
    rms = math.sqrt(square / t[-1])
    assert abs(rms - doc["duty"]["rms_time"]["drive"]) < 2e-3 * doc["duty"]["rms_time"]["drive"]
