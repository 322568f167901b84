"""Hangs: sizes that cannot fit in memory or end in time (samples, RK4 steps, grid points,
starts) are refused at once, with the estimate in the message, before any work is done."""
from __future__ import annotations

import re
import time

import pytest

import optdesign
from optdesign.errors import ArgumentError
from optdesign.scene import arguments
from optdesign.study import Study, grid, values

from .util import JIB, JIB_DESIGN, SIM, cli

MEMORY = r"would need about [\d.e+]+ [kMGTP]?B of memory \([\d.]+ kB per {}\), more than the [\d.]+ [kMGTP]?B this machine has"


@pytest.fixture(scope="module")
def jib():
    return optdesign.load(JIB)


@pytest.mark.parametrize("args, fragment", [
    (["analyse", JIB, "--samples", "10000000000"], "samples = 10,000,000,000: " + MEMORY.format("sample")),
    (["kinematics", JIB, "--samples", "1000000000000"], "samples = 1,000,000,000,000: " + MEMORY.format("sample")),
    (["optimise", JIB_DESIGN, "--starts", "1000000000000", "--out", "{tmp}/o"],
     "starts = 1,000,000,000,000: " + MEMORY.format("start")),
    (["study", JIB, "--mode", "analyse", "--grid", "mC=1:2:100000000", "--out", "{tmp}/s"],
     r"--grid 'mC=1:2:100000000': N = 100,000,000: " + MEMORY.format("case")),
    (["study", JIB_DESIGN, "--pareto", "cylinder length ratio=1.4:1.9:1000000000", "--out", "{tmp}/s"],
     r"N = 1,000,000,000: " + MEMORY.format("case")),
])
def test_sizes_that_cannot_fit_in_memory_are_refused_at_once(tmp_path, args, fragment):
    t0 = time.perf_counter()
    code, out, err = cli(*[str(a).format(tmp=tmp_path) for a in args])
    assert code == 2 and out == ""
    assert re.search(fragment, err), err
    assert time.perf_counter() - t0 < 15
    assert not any(tmp_path.iterdir())                   # nothing written


def test_rk4_steps_that_cannot_end_in_time_are_refused_with_the_estimate():
    code, out, err = cli("simulate", SIM, "--integrator", "rk4", "--steps", "1000000000")
    assert code == 2
    assert ("steps = 1,000,000,000 per output sample x 200 intervals: 300,000,000,000 RK4 steps would take "
            "about 43.8 days (~12.6 us per RK4 step); at most 142,857,143 RK4 steps (about 30 minutes); use "
            "fewer steps per sample (--steps) or the implicit integrator (bdf)") in err


def test_the_api_refuses_the_same_sizes(jib):
    with pytest.raises(ArgumentError, match="samples = 10,000,000,000: would need about"):
        optdesign.analyse(jib, 10**10)
    with pytest.raises(ArgumentError, match="samples = 10,000,000,000: would need about"):
        optdesign.kinematics(jib, 10**10)
    with pytest.raises(ArgumentError, match=r"axis 'mC': n = 100,000,000: would need about"):
        grid("mC", 1, 2, 10**8)
    with pytest.raises(ArgumentError, match="starts = 1,000,000,000,000: would need about"):
        optdesign.optimise(optdesign.load(JIB_DESIGN), starts=10**12)
    with pytest.raises(ArgumentError, match="samples = 100,000,000,000: would need about"):
        optdesign.simulate(optdesign.load(SIM), samples=10**11)


def test_a_scene_that_asks_for_too_many_samples_is_refused_too(jib):
    import dataclasses

    huge = dataclasses.replace(jib, sweep=dataclasses.replace(jib.sweep, samples=10**11))
    with pytest.raises(ArgumentError, match="samples = 100,000,000,000: would need about"):
        optdesign.analyse(huge)


def test_the_estimates(monkeypatch):
    monkeypatch.setattr(arguments, "available_memory", lambda: 10**9)
    arguments.fits_in_memory("n", 1000, 10**6, "item")          # exactly 1 GB: fits
    with pytest.raises(ArgumentError, match=r"^n = 1,001: would need about 1 GB of memory \(1 MB per item\), "
                                            r"more than the 1 GB this machine has; fewer$"):
        arguments.fits_in_memory("n", 1001, 10**6, "item", "fewer")
    assert arguments.size_text(3.2e15) == "3.2 PB" and arguments.size_text(512) == "512 bytes"


def test_a_case_count_within_memory_is_accepted(jib):
    study = Study(jib, [values("mC", [300.0, 400.0])], mode="analyse")
    assert len(study.cases()) == 2
    assert len(grid("mC", 1, 2, 1000).points) == 1000
