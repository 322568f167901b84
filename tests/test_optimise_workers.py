"""Starts shared among forked worker processes give the serial run's optimum and per-start
outcomes, in start order, and the same result on every run with the same number of workers."""
from __future__ import annotations

import multiprocessing
from pathlib import Path

import pytest

from optdesign.design import optimise
from optdesign.scene.file import load

SCENE = Path(__file__).resolve().parents[1] / "problems" / "seed1_jib_design.toml"


@pytest.mark.skipif("fork" not in multiprocessing.get_all_start_methods(), reason="needs fork")
def test_two_workers_reach_the_serial_optimum():
    scene = load(SCENE)
    serial = optimise(scene, starts=8, seed=3, workers=1)
    seen = []
    parallel = optimise(scene, starts=8, seed=3, workers=2, progress=lambda done, total: seen.append((done, total)))
    again = optimise(scene, starts=8, seed=3, workers=2)
    assert serial.success and parallel.success
    # the same optimum to within the certification tolerance (peak_tol 1e-8)
    assert parallel.objective == pytest.approx(serial.objective, rel=1e-8)
    for name, value in serial.design.items():
        assert parallel.design[name] == pytest.approx(value, rel=1e-6, abs=1e-9)
    assert [r.index for r in parallel.starts] == list(range(8))
    assert [r.start for r in parallel.starts] == [r.start for r in serial.starts]
    assert [r.success for r in parallel.starts] == [r.success for r in serial.starts]
    assert seen == [(k, 8) for k in range(0, 9)]  # (0, 8) once the starts are planned, then one per start
    # deterministic for a given number of workers: not a race between the processes
    assert again.objective == parallel.objective
    assert [r.iterations for r in again.starts] == [r.iterations for r in parallel.starts]
