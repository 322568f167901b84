"""A study's worker process (a pool's, or a Dask worker's helper: both run
worker.blocks_made) leaves the objects alive after a model's build out of the collector's full
passes (tasks.settle: gc.freeze once per build), and does not collect and freeze again while
the model it built is the one in use."""
from __future__ import annotations

import gc
import pickle
from pathlib import Path

import optdesign
from optdesign.study import Study, executors, grid, tasks
from optdesign.study.tasks import scene_digest

ROOT = Path(__file__).resolve().parents[1]


def test_a_batch_leaves_its_process_settled():
    study = Study(optdesign.load(ROOT / "problems" / "truck_crane.toml"),
                  [grid("mB", 500, 800, 2), grid("mP", 500, 3000, 4)], mode="analyse")
    refs, overrides, bounds = study.cases().batch(list(range(8)))
    blob, digest = pickle.dumps(study.scene), scene_digest(study.scene)

    def batch():
        return executors.computed(study.tasks(overrides, bounds, None, blob, digest),
                                  [r.index for r in refs], [r.id for r in refs])

    gc.unfreeze()
    cache = tasks._cache()
    cache.frozen = -1   # (as in a fresh worker process: nothing settled yet)
    try:
        made = batch()
        assert sum(len(b) for b in made) == 8
        frozen = gc.get_freeze_count()
        assert frozen > 1000   # the model's graphs and the scene (~40,000 objects on the truck crane)
        assert cache.frozen == cache.builds
        batch()   # the same model: nothing frozen again (frozen objects freed since only leave)
        assert gc.get_freeze_count() <= frozen and cache.frozen == cache.builds
    finally:
        gc.unfreeze()
