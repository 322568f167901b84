"""One certified case (Analysis.run) certifies its assembly margins and its peaks and extremes
in one call of the one certification (optdesign/kinematics/joint.py, model/runs._together):
every figure, certificate and error text is the one the two calls give apart, bit for bit, which
a batch of cases (run_many: the two calls, each over the batch) gives each of its cases.  Each
shipped scene here with an assembly margin that varies takes the one call (a spy counts it),
and its case 0 of a batch of two is the same text; a family of four-bars, some of which do not assemble or lock up, likewise.  The
figures' soundness against independent models is tested where they are (test_enclosure_*,
test_analysis_many's four-bars against virtual work), through the same Analysis.run."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import optdesign
from optdesign.kinematics import joint
from optdesign.model import runs
from optdesign.model.analysis import Analysis

ROOT = Path(__file__).resolve().parents[1]
SCENES = ["problems/seed1_slider_crank.toml", "problems/crank_press_peak.toml", "problems/lib_excavator_boom.toml",
          "problems/lib_toggle_press.toml", "tests/data/issue27/knuckle_press.toml"]
NO_MARGINS = "problems/lib_excavator_boom.toml"   # (no margin varies along its stroke: nothing to join)


def _text(r):
    """A run's figures (a CaseRun's or an AnalysisResult's) as text, floats to their last digit."""
    stroke = {k: v for k, v in (r.stroke if hasattr(r, "stroke") else r.constraints).items() if not np.ndim(v)}
    sampled = r.stroke_sampled if hasattr(r, "stroke_sampled") else r.constraints_sampled
    return json.dumps([r.peaks, r.peak_at, r.peaks_sampled, r.constraint_extremes, stroke, sampled, r.certificates],
                      sort_keys=True)


@pytest.fixture
def together(monkeypatch):
    """The number of calls of maxima_together (the one call) since the test began."""
    calls = []
    real = runs.maxima_together

    def spy(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(runs, "maxima_together", spy)
    return calls


@pytest.mark.parametrize("path", SCENES)
def test_a_case_alone_in_one_call_is_case_0_of_a_batch_of_two_bit_for_bit(path, together):
    a = Analysis(optdesign.load(ROOT / path))
    p = np.asarray(a.mech.parameter_values, float)
    alone = _text(a.run(p))
    assert bool(together) == (path != NO_MARGINS), "the case alone did not take the one call"
    before = len(together)
    batch = a.run_many(np.stack([p, p]))
    assert len(together) == before   # (a batch: the two calls, as before)
    assert [r.error for r in batch] == [None, None]
    assert _text(batch[0]) == alone
    assert _text(batch[1]) == alone


def test_four_bars_that_assemble_fail_or_lock_up_alone_are_their_batchs_own(together):
    """Crank-rocker and other four-bars over a range of link lengths (some do not assemble over
    the sweep, some lock up between samples): each alone (the one call where it assembles at its
    samples) gives its batch's figures or error text."""
    base = """title = "four-bar family"
[parameters]
a = 0.3
b = 1.0
c = 0.8
d = 1.0
[sweep]
name = "phi"
from = "0 deg"
to = "360 deg"
samples = 61
[points]
A = { fixed = [0, 0] }
D = { fixed = ["d", 0] }
B = { polar = ["A", "a", "phi"] }
C = { dyad = ["B", "b", "D", "c"], side = "left" }
[[bodies]]
name = "coupler"
frame = ["B", "C"]
mass = 2.0
com = [0.5, 0]
[drive]
type = "rotary"
crank = ["A", "B"]
speed = 2.0
acceleration = 0.0
"""
    a = Analysis(optdesign.loads(base, "fourbar_family.toml"))
    names = a.mech.parameter_names
    rng = np.random.default_rng(31)
    P = np.tile(np.asarray(a.mech.parameter_values, float), (24, 1))
    P[:, names.index("a")] = rng.uniform(0.1, 0.6, 24)
    P[:, names.index("b")] = rng.uniform(0.5, 1.3, 24)
    P[:, names.index("c")] = rng.uniform(0.4, 1.2, 24)
    batch = a.run_many(P)
    texts, errors = [], 0
    for p, r in zip(P, batch):
        try:
            texts.append(_text(a.run(p)))
        except optdesign.OptdesignError as exc:
            texts.append(f"error: {exc}")
            errors += 1
    assert texts == [f"error: {r.error}" if r.error is not None else _text(r) for r in batch]
    assert 0 < errors < len(P)   # (both kinds in the family)
    assert together


def test_distinct_evaluates_each_interval_once_with_its_own_numbers():
    """joint.Distinct: intervals repeated (the parts' common blocks) are evaluated once, and
    every interval's bounds are those of the enclosure called on it alone."""
    a = Analysis(optdesign.load(ROOT / SCENES[0]))
    enclosure = a.certified.enclosures.at(np.asarray(a.mech.parameter_values, float)[None, :])
    lo = np.linspace(0.0, 6.0, 13)
    los, his = np.concatenate((lo[:-1], lo[:-1], [1.0])), np.concatenate((lo[1:], lo[1:], [1.2]))
    centre = np.full(len(los), np.nan)
    centre[-1] = 1.1
    rows = np.arange(a.certified.n_rows)
    got = joint.Distinct(enclosure).bounds(los, his, rows, np.zeros(len(los), int), centre)
    for i in range(len(los)):
        one = enclosure.bounds(los[i:i + 1], his[i:i + 1], rows, np.zeros(1, int), centre[i:i + 1])
        for x, y in zip(got, one):
            assert x[:, i].tobytes() == y[:, 0].tobytes()
