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


def import_distributed():
    """``import distributed`` for a study's client (``--scheduler ADDRESS``), with Dask's YAML
    configuration (dask.yaml and distributed.yaml, ~400 lines parsed at import, and any of the
    user's Dask configuration files) read by libyaml's parser where PyYAML has it
    (``yaml.CSafeLoader``: the same constructors and resolvers as the pure-Python
    ``yaml.safe_load`` Dask calls, so the same values).  The import is most of a Dask study's
    start-up in the client, ~0.42 s of CPU on the 2-core machine of results/scaling.md; Dask's
    two files take 30-33 ms to parse in pure Python, 2.3-2.6 ms with libyaml.  Dask's own loader is put back when the import ends;
    a process that imported ``distributed`` already is left as it is."""
    import sys

    if "distributed" in sys.modules:
        return sys.modules["distributed"]
    import yaml

    plain = yaml.safe_load
    if getattr(yaml, "CSafeLoader", None) is not None:   # PyYAML built with libyaml
        yaml.safe_load = lambda stream: yaml.load(stream, Loader=yaml.CSafeLoader)
    try:
        import distributed
    finally:
        yaml.safe_load = plain
    return distributed
