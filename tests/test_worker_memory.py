"""A study's worker process keeps the memory a batch frees for the next batch (errors.KEEP_MEMORY,
glibc's malloc): the same large allocation made again is not faulted in again page by page, as it
is in a process started with glibc's defaults; a setting the user made is kept."""
from __future__ import annotations

import concurrent.futures as cf
import multiprocessing
import os
import platform
import resource

import pytest

from optdesign.errors import KEEP_MEMORY, worker_process


def _huge_pages_always() -> bool:
    """Transparent huge pages for all memory: a fresh allocation then faults in 2 MB at a time
    (a handful of faults whatever malloc does), and the counts below say nothing."""
    try:
        with open("/sys/kernel/mm/transparent_hugepage/enabled") as fh:
            return "[always]" in fh.read()
    except OSError:
        return False


counted = pytest.mark.skipif(platform.libc_ver()[0] != "glibc" or _huge_pages_always(),
                             reason="glibc's malloc settings, counted in 4 kB page faults")

SIZE = 24 << 20   # a batch's array: above glibc's default mmap threshold, below KEEP_MEMORY's


def _second_allocation_faults() -> int:
    """Page faults of an allocation of SIZE bytes (zeroed: every page touched) made again after
    the first was freed, as a worker's next batch does."""
    first = bytearray(SIZE)
    del first
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    again = bytearray(SIZE)
    faults = resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before
    del again
    return faults


def _in_fresh_process(initializer=None, env=None):
    # spawned: a fresh process whose malloc has only its defaults (a fork of this process would
    # inherit what its own allocations made of glibc's adaptive thresholds)
    old = {k: os.environ.get(k) for k in (env or {})}
    os.environ.update(env or {})
    try:
        with cf.ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn"), initializer=initializer,
                                    initargs=(os.getpid(),) if initializer else ()) as pool:
            return pool.submit(_second_allocation_faults).result(timeout=120)
    finally:
        for k, v in old.items():
            os.environ.pop(k) if v is None else os.environ.__setitem__(k, v)


@counted
def test_a_worker_keeps_freed_memory_where_a_plain_process_faults_it_in_again(monkeypatch):
    # none of glibc's variables inherited: a Dask LocalCluster started earlier in this process
    # leaves its nannies' MALLOC_TRIM_THRESHOLD_=65536 in os.environ (distributed/nanny.py), which
    # the worker then keeps as the user's
    for name in KEEP_MEMORY:
        monkeypatch.delenv(name, raising=False)
    pages = SIZE // resource.getpagesize()
    assert _in_fresh_process() > pages // 2              # glibc's defaults: given back, faulted in again
    assert _in_fresh_process(worker_process) < pages // 20   # a worker: kept


@counted
def test_a_malloc_setting_the_user_made_is_kept():
    # the user's variable, read by glibc when the process starts: a trim threshold of 0 gives
    # freed memory back at once, and the worker does not override it
    name = "MALLOC_TRIM_THRESHOLD_"
    assert name in KEEP_MEMORY
    pages = SIZE // resource.getpagesize()
    assert _in_fresh_process(worker_process, {name: "0", "MALLOC_MMAP_THRESHOLD_": str(64 << 20)}) > pages // 2


def test_a_dask_workers_helper_starts_with_the_settings_in_place_of_dasks_trim(monkeypatch):
    # Dask's nanny gives its workers MALLOC_TRIM_THRESHOLD_=65536; the helper (a process started
    # afresh: glibc reads the variables) gets KEEP_MEMORY's values instead, unless the user set one
    from optdesign.study import worker

    seen = []
    monkeypatch.setattr(worker.subprocess, "Popen", lambda *args, env, **kw: seen.append(env))
    for name in KEEP_MEMORY:
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("MALLOC_TRIM_THRESHOLD_", "65536")
    worker._start()
    assert {k: seen[-1].get(k) for k in KEEP_MEMORY} == {k: str(v) for k, v in KEEP_MEMORY.items()}
    monkeypatch.setenv("MALLOC_TOP_PAD_", "0")   # the user's
    worker._start()
    assert seen[-1]["MALLOC_TOP_PAD_"] == "0" and "MALLOC_TRIM_THRESHOLD_" not in seen[-1]
