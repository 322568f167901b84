"""The Dask settings recommended for a study's cluster (optdesign.study.cluster): each is a
setting Dask knows (a misspelt key or environment variable is ignored by Dask without a word),
the environment variables README.md shows are the ones Dask reads back as those settings, and
a cluster started with them runs its workers without the profiler, with the 1 s event-loop
check and the 5 s system monitor (and still computes a study's cases: test_study_parallel)."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

distributed = pytest.importorskip("distributed")
import dask  # noqa: E402

from optdesign.study.cluster import SETTINGS, environ  # noqa: E402

README = Path(__file__).resolve().parents[1] / "README.md"


def test_every_setting_is_one_dask_has():
    missing = object()
    for key in SETTINGS:
        assert dask.config.get(key, default=missing) is not missing, f"Dask has no setting {key}"


def test_the_environment_variables_are_read_back_by_dask_as_the_settings():
    assert set(environ()) == {"DASK_DISTRIBUTED__ADMIN__TICK__INTERVAL", "DASK_DISTRIBUTED__ADMIN__SYSTEM_MONITOR__INTERVAL",
                              "DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED"}
    read = dask.config.collect_env(environ())
    with dask.config.set(read):
        for key, value in SETTINGS.items():
            assert dask.config.get(key) == value, key


def test_readme_shows_the_settings_as_they_are():
    shown = dict(re.findall(r"\b(DASK_[A-Z_]+)=(\S+)", README.read_text()))
    assert shown == environ()


def test_a_cluster_started_with_the_settings_has_them():
    def periodic():
        worker = distributed.get_worker()
        calls = worker.periodic_callbacks
        return "profile" in calls, calls["tick"].callback_time, calls["monitor"].callback_time

    with dask.config.set(SETTINGS):
        with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                      dashboard_address=None) as cl, distributed.Client(cl) as client:
            assert client.submit(periodic, pure=False).result(timeout=60) == (False, 1000, 5000)
            tick = client.run_on_scheduler(lambda dask_scheduler: dask_scheduler.periodic_callbacks["tick"].callback_time)
            assert tick == 1000
