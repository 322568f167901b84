"""A study's batches on a Dask worker pause the worker's statistical profiler while they wait on
their helper processes (optdesign.study.worker.profiler_paused): paused from the first batch
that starts to the last that ends, overlapping batches included, and running again after; the
profiler of a worker started with it disabled is left alone; outside a Dask worker nothing
happens."""
from __future__ import annotations

import asyncio

import pytest

distributed = pytest.importorskip("distributed")

from optdesign.study.worker import profiler_paused  # noqa: E402


def _profiling(worker) -> bool:
    """Whether the worker's profiler runs, once the callbacks queued on its event loop have run."""
    distributed.utils.sync(worker.loop, asyncio.sleep, 0)   # FIFO: what was queued before has run
    return worker.periodic_callbacks["profile"].is_running()


def _first(seen):
    """A batch that waits until a second one has come and gone."""
    worker = distributed.get_worker()
    seen.append(("before", _profiling(worker)))
    with profiler_paused():
        seen.append(("first in", _profiling(worker)))
        distributed.Event("first in").set()
        distributed.Event("second out").wait(timeout=60)
        seen.append(("second out", _profiling(worker)))
    seen.append(("first out", _profiling(worker)))
    return seen


def _second():
    worker = distributed.get_worker()
    distributed.Event("first in").wait(timeout=60)
    with profiler_paused():
        inside = _profiling(worker)
    distributed.Event("second out").set()
    return inside


def test_overlapping_batches_pause_the_profiler_until_the_last_ends():
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None) as cl, \
            distributed.Client(cl) as client:
        first = client.submit(_first, [], pure=False)
        second = client.submit(_second, pure=False)
        assert second.result(timeout=60) is False
        assert first.result(timeout=60) == [("before", True), ("first in", False), ("second out", False),
                                            ("first out", True)]


def test_a_profiler_disabled_by_the_clusters_config_stays_off_and_nothing_happens_outside_dask():
    def inside():
        worker = distributed.get_worker()
        with profiler_paused():
            pass
        distributed.utils.sync(worker.loop, asyncio.sleep, 0)
        return "profile" in worker.periodic_callbacks

    import dask

    with dask.config.set({"distributed.worker.profile.enabled": False}):
        with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                      dashboard_address=None) as cl, distributed.Client(cl) as client:
            assert client.submit(inside, pure=False).result(timeout=60) is False
    with profiler_paused():   # not a Dask worker's task
        pass
