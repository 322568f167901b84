"""Dask settings for a cluster that runs studies (``optdesign study --scheduler``).

A study's batches are computed in helper processes of the Dask workers (:mod:`.worker`); the
cluster's own processes (the scheduler, each worker and its nanny) only pass batches and results
on.  With Dask's defaults they also wake up every 20 ms (``distributed.admin.tick.interval``: an
event-loop health check that only logs a warning when the loop was blocked for seconds), poll
the process's CPU and memory every 500 ms (``distributed.admin.system-monitor.interval``, for
the dashboard's plots) and, on a worker, sample the running tasks' stacks every 10 ms
(``distributed.worker.profile``, the dashboard's profile page: a study's task only waits on its
helper's pipe).  Measured on the 2-core machine of results/scaling.md (a scheduler and 2 workers
with nannies on loopback, /proc CPU over 20 s, each worker running a task that sleeps): 16 % of
a core in all with Dask's defaults (workers 9.4 %, nannies 4.2 %, scheduler 2.4 %), 1.5 % with
the settings below (0.8 / 0.1 / 0.6 %); that CPU comes from the cores the helpers compute on.

None of them changes what a task computes or how the cluster schedules, retries or restarts:
they set only how often Dask checks and samples itself for its dashboard and logs.  A study
does not change a cluster it is given (its tasks only pause a worker's profiler while they wait:
:func:`.worker.profiler_paused`); the settings are for whoever starts the cluster, as
environment variables of ``dask scheduler`` and ``dask worker`` (:func:`environ`, shown in
README.md) or with ``dask.config.set(SETTINGS)`` around a ``distributed.LocalCluster``.
"""
from __future__ import annotations

SETTINGS = {
    "distributed.admin.tick.interval": "1s",              # Dask's default 20ms
    "distributed.admin.system-monitor.interval": "5s",    # 500ms
    "distributed.worker.profile.enabled": False,          # True (every 10ms)
}


def environ(settings: dict = SETTINGS) -> dict:
    """``settings`` as the environment variables Dask reads at start (``DASK_`` and the key, its
    dots ``__``, its dashes ``_``, upper case; the value as Python would write it)."""
    return {"DASK_" + key.replace(".", "__").replace("-", "_").upper(): str(value)
            for key, value in settings.items()}
