"""``optdesign.optimise(load(scene), 20, 0)`` with the default settings, run once per scene file
for the whole test session: tests/test_optimisation_scenes.py and the library's tests
(tests/library) check the same default run against their own independent references, and a
20-start run of a library scene costs seconds to tens of seconds.  Returns (result, wall time
of the run); the result is shared, so a test must not change it."""
from __future__ import annotations

import functools
import time
from pathlib import Path

import optdesign


@functools.cache
def _run(path: str):
    t0 = time.perf_counter()
    result = optdesign.optimise(optdesign.load(path), 20, 0)
    return result, time.perf_counter() - t0


def default_optimum(path):
    return _run(str(Path(path).resolve()))
