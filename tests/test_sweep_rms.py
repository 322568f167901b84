"""The RMS over the sweep that a study's analyse rows report (`rms:drive`, `rms:power`) is an
integral over the continuous sweep (issue 27): it was the trapezoid rule on the samples.  The
reference: the servo press's nominal state (crank at 4 rad/s, no acceleration, the drawing force
on, efficiency 0.95 switched by the power flow) from the independent numpy model of
tests/ref_press_servo.py, integrated by scipy's quad over the crank angle, split where the power
flow turns."""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

from optdesign.model.analysis import Analysis
from optdesign.scene.file import load
from optdesign.study.tasks import _analyse_rows

sys.path.insert(0, str(Path(__file__).resolve().parent))
from ref_press_servo import STROKE, Press  # noqa: E402

SCENE = Path(__file__).resolve().parents[1] / "problems" / "press_servo_cycle.toml"


def reference(l=0.30, e=0.0, i=20.0, speed=4.0):
    """(RMS of the drive torque, RMS of the power) over phi in [-120 deg, 0] by quad."""
    press = Press(l, e, i, 400e3)

    def drive(phi):
        return float(press.torque(phi, speed, 0.0)[0])
    grid = np.linspace(-STROKE, 0.0, 2001)
    values = [drive(x) for x in grid]
    cuts = [brentq(drive, grid[k], grid[k + 1], xtol=1e-15) for k in range(len(grid) - 1)
            if values[k] * values[k + 1] < 0]
    edges = [-STROKE] + cuts + [0.0]
    total = sum(quad(lambda x: drive(x) ** 2, a, b, epsabs=0, epsrel=1e-13, limit=400)[0]
                for a, b in zip(edges[:-1], edges[1:]))
    rms = math.sqrt(total / STROKE)
    return rms, rms * speed


def test_the_study_rows_rms_is_the_continuous_one():
    """rms:drive and rms:power of an analyse row within 1e-9 of quad's; the error estimate is
    stated and below 1e-9.  On the old code (the trapezoid rule on the 161 samples) the row was off
    by more than that."""
    analysis = Analysis(load(SCENE))
    row = _analyse_rows(analysis, [analysis.mech.parameter_values])[0]
    drive, power = reference()
    assert row["rms:drive"] == pytest.approx(drive, rel=1e-9)
    assert row["rms:power"] == pytest.approx(power, rel=1e-9)
    found = analysis.sweep_rms(analysis.mech.parameter_values)
    assert 0 <= found["drive"][1] <= 1e-9 * found["drive"][0]


def test_at_three_samples_the_quadrature_still_resolves_the_sweep():
    """The quadrature's first intervals are the samples, refined where needed: 3 samples give the
    same RMS (within 1e-9) where their trapezoid rule is far off."""
    analysis = Analysis(load(SCENE), samples=3)
    drive, _ = reference()
    value, error = analysis.sweep_rms(analysis.mech.parameter_values)["drive"]
    assert value == pytest.approx(drive, rel=1e-9)
    assert error <= 1e-9 * value


def test_the_recheck_refuses_a_wrong_certified_sweep_rms():
    """An rms(...) objective's certified value (Gauss-Legendre) is rechecked before a start may
    count (design/certify.ContinuousCheck._recheck_rms: the trapezoid rule 16 and 8 times denser,
    Richardson): crank_press_rms's passes, one 1e-6 off is refused with the reason.  A guard: it
    skipped rms objectives before, and no shipped scene's start fails it."""
    from optdesign.design.certify import ContinuousCheck
    from optdesign.design.problem import DesignProblem

    pb = DesignProblem(load(SCENE.parent / "crank_press_rms.toml"))
    fixed = pb.mech.parameter_values[pb.fixed_index]
    key = next((b.name, "rms") for b in pb.blocks if b.kind == "rms")
    value = pb.rms(pb.start, fixed, 2 * pb.rms_panels)
    check = ContinuousCheck(pb)
    assert check._recheck_rms(pb.start, fixed, {key: value}) is None
    reason = check._recheck_rms(pb.start, fixed, {key: value * (1 + 1e-6)})
    assert reason is not None and "trapezoid rule" in reason
