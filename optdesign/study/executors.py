"""Where a study's cases run: in this process, in a process pool on this machine, or on a Dask
cluster.  Every executor takes batches (consecutive cases of one chain) with
``submit(cases, tasks)`` and yields ``(cases, outputs)`` from ``results()`` as batches finish
(a batch's cases together, or in parts after a process died).

The pool and Dask keep a bounded *window* of batches in flight (a small multiple of their
workers: enough to keep every worker busy while the results of others travel back); the other
batches wait here, in a queue.  What the pool or the cluster holds does not grow with the study.

Process deaths.  A pool process that dies (SIGKILL, the kernel's out-of-memory killer, a crash
in native code) breaks the whole ``ProcessPoolExecutor``: every batch in flight fails with
``BrokenProcessPool``, and which of them ran in the dead process is not known.  The pool is
replaced and the batches in flight go back to the front of the queue; each of them then runs
*alone* (nothing else in flight), so that a batch that kills its process again is known to be
the culprit.  A batch whose process died ``MAX_DEATHS`` times is recorded as failed, with the
reason, and the study goes on.  A pool that cannot be replaced ends the study as a lost Dask
scheduler does (:class:`~.results.ClusterLost`: the cases kept and how to resume).  On Dask the
task retries its batch in a new helper process of its worker (:mod:`.worker`), case by case;
a Dask worker that dies is Dask's to replace, and a batch that killed ``distributed.scheduler.
allowed-failures`` workers (``KilledWorker``) is recorded as failed the same way.
"""
from __future__ import annotations

import collections
import concurrent.futures as cf
import dataclasses
import multiprocessing
import os
import pickle
import sys
import time
from concurrent.futures.process import BrokenProcessPool

from ..errors import OptdesignError, worker_process
from .results import ClusterLost
from .blocks import as_blocks
from .tasks import died_output, run_batch
from .worker import MAX_DEATHS, blocks_made, pickled_blocks_in_helper, prestart, profiler_paused, together


def computed(tasks, index, ids) -> list:
    """:func:`~.tasks.run_batch` where the batch runs (a pool's process), its outputs handed back
    as blocks with their text made there (:func:`.tasks.batch_blocks`): the client's work per
    case done by the workers, in parallel."""
    return blocks_made(tasks, index, ids)


def computed_in_helper(payload: bytes, together: bool):
    """:func:`computed` on a Dask worker of the batch pickled in ``payload`` (``(tasks, index,
    ids)``) by the client, in its helper process (:mod:`.worker`; a batch of analyse cases'
    blocks as the helper pickled them, unpickled by the client).  One bytes object, not the
    batch's lists: Dask walks a task's lists and tuples looking for futures, element by element
    (2 per case: in a 20,000-case analyse study ~0.9 s of the client's CPU at load ~7, by cProfile)."""
    with profiler_paused():
        return pickled_blocks_in_helper(payload, together)


def _where(batch):
    return [c.index for c in batch.cases], [c.id for c in batch.cases]


def record(case, out) -> dict:
    """The journal's record of a finished case."""
    return {"id": case.id, "case": case.index, "row": out["row"], "x": out["x"], "time_s": out["time_s"]}


@dataclasses.dataclass
class _Batch:
    cases: list
    tasks: list
    deaths: int = 0          # times a process died with this batch in flight


class _Inline:
    """In this process, one case after another."""

    def __init__(self):
        self.queue, self.finished = [], 0

    def batch_size(self, remaining):
        return 1

    def submit(self, cases, tasks):
        self.queue.append((cases, tasks))

    def results(self):
        while self.queue:
            cases, tasks = self.queue.pop(0)
            yield cases, run_batch(tasks)

    def room(self):
        return not self.queue

    def ready(self):
        return False

    def stop(self, journal, abandon=False):
        return self.finished

    def close(self):
        pass

    def describe(self):
        return "1 worker, in process"


class _Futures:
    """Shared by the process pool and Dask: a queue of batches, a window of futures in flight."""

    BROKEN = ()          # the exceptions of a future whose process died (the pool's)

    def __init__(self):
        self.pending, self.queue, self.finished = {}, collections.deque(), 0
        self.window, self.stopping = 1, False

    def batch_size(self, remaining):
        return 1

    def submit(self, cases, tasks):
        self.queue.append(_Batch(list(cases), tasks))   # tasks: a list, or a study's TaskList (made lazily)

    def room(self):
        """True while fewer batches than the window are in flight or queued."""
        return len(self.pending) + len(self.queue) < self.window

    def ready(self):
        """True if a result is there to be taken without waiting."""
        return any(f.done() for f in self.pending)

    def _fill(self):
        """Submit queued batches up to the window; a batch that was in flight when a process
        died runs alone (and nothing joins it)."""
        while self.queue and len(self.pending) < self.window and not self.stopping:
            alone = self.queue[0].deaths or any(b.deaths for b in self.pending.values())
            if alone and self.pending:
                return
            batch = self.queue.popleft()
            self.pending[self._submit(batch)] = batch

    def results(self):
        while True:
            self._fill()
            if not self.pending:
                return
            for f in self._wait_first(list(self.pending)):
                if f not in self.pending:   # already dealt with by a replaced pool
                    continue
                batch = self.pending.pop(f)
                try:
                    outs = self._outputs(f, batch)
                except self.BROKEN:
                    if not self.stopping:
                        yield from self._replace(batch)
                    continue
                yield batch.cases, outs

    def _outputs(self, f, batch):
        return f.result()

    def _keep_running(self, f) -> bool:
        """Ctrl-C: False if ``f`` was cancelled before it started."""
        return True

    def stop(self, journal, abandon=False):
        """Ctrl-C: nothing more is submitted; the batches in flight finish and are journalled
        (a second Ctrl-C, or ``abandon``, drops them)."""
        self.queue.clear()
        self.stopping = True
        if not abandon:
            for f in list(self.pending):
                if not self._keep_running(f):
                    self.pending.pop(f)
            try:
                for cases, outs in self.results():
                    journal.add_blocks(as_blocks(cases, outs))
                    journal.sync()
                    self.finished += len(cases)
            except (KeyboardInterrupt, cf.CancelledError, *self.BROKEN):
                pass   # abandoned, cancelled or lost with its worker: nothing to keep
        self._cancel(list(self.pending))
        self.pending.clear()
        return self.finished

    def _cancel(self, futures):
        for f in futures:
            f.cancel()


class _Pool(_Futures):
    """A process pool on this machine; each worker builds the scene's model once."""

    BROKEN = (BrokenProcessPool,)

    def __init__(self, workers):
        super().__init__()
        self.workers, self.window = workers, 2 * workers
        self.deaths, self.retried = 0, 0
        self.pool = self._start()

    def _start(self):
        # fork where there is one: workers start at once with the modules already imported, and
        # a script without an `if __name__ == "__main__":` guard is not run again in each worker
        methods = multiprocessing.get_all_start_methods()
        ctx = multiprocessing.get_context("fork" if "fork" in methods else "spawn")
        # workers leave Ctrl-C to the parent, which stops the study cleanly, and die with it
        return cf.ProcessPoolExecutor(self.workers, mp_context=ctx, initializer=worker_process,
                                      initargs=(os.getpid(),))

    def _submit(self, batch):
        try:
            return self.pool.submit(computed, batch.tasks, *_where(batch))
        except BrokenProcessPool as exc:   # broken since the last look: seen as its future's
            f = cf.Future()
            f.set_exception(exc)
            return f
        except OSError as exc:   # no process could be started (out of memory, process limit)
            raise _not_started(exc) from None

    @staticmethod
    def _wait_first(futures):
        return cf.wait(futures, return_when=cf.FIRST_COMPLETED).done

    def _keep_running(self, f):
        return not f.cancel()

    def _replace(self, batch):
        """A process of the pool died: keep what finished before, replace the pool, put the
        batches in flight back (each to run alone), or record those that died too often."""
        suspects = [batch]
        for f, other in list(self.pending.items()):
            self.pending.pop(f)
            if f.done() and not f.cancelled() and f.exception() is None:
                yield other.cases, f.result()   # finished before the death
            else:
                suspects.append(other)
        self.pool.shutdown(wait=False, cancel_futures=True)
        self.deaths += 1
        try:
            self.pool = self._start()
        except OSError as exc:
            raise _not_started(exc) from None
        again = []
        for b in suspects:
            b.deaths += 1
            if len(b.cases) > 1:   # analyse cases run together: which one died is not known; each alone
                again += [_Batch([c], [t], b.deaths) for c, t in zip(b.cases, b.tasks)]
                continue
            if b.deaths < MAX_DEATHS:
                again.append(b)
                continue
            reason = (f"the worker process computing this case died {b.deaths} times (killed, out of memory or "
                      "crashed); it is not tried again")
            yield b.cases, [died_output(reason) for _ in b.cases]
        self.retried += sum(len(b.cases) for b in again)
        self.queue.extendleft(reversed(again))
        n = sum(len(b.cases) for b in again)
        print(f"\noptdesign study: a worker process died (killed, out of memory or crashed); the pool was "
              f"replaced and the {n} case{'s' if n != 1 else ''} in flight {'are' if n != 1 else 'is'} "
              "run again", file=sys.stderr)

    def close(self):
        self.pool.shutdown(wait=not self.pending, cancel_futures=True)

    def describe(self):
        where = f"{self.workers} worker processes"
        if self.deaths:
            where += (f"; {self.deaths} died and {'were' if self.deaths > 1 else 'was'} replaced, "
                      f"{self.retried} case{'s' if self.retried != 1 else ''} run again")
        return where


def _not_started(exc) -> ClusterLost:
    return ClusterLost(f"the study's worker processes could not be started ({exc.strerror or exc})")


class _Dask(_Futures):
    """A Dask distributed cluster: ``scheduler`` is its address or a ``distributed.Client``.

    Cases go in batches of about ``group_s`` seconds of work each (from the cases finished so far):
    consecutive cases of a chain, or an analyse study's independent cases.  Each
    batch is computed in a helper process of its worker (:mod:`.worker`: the worker's own threads
    slowed the cases down 1.3-1.9 times), which builds the scene's model once.  At most
    ``WINDOW`` batches per worker thread are in flight, consumed as they complete
    (``distributed.as_completed``).  The journal stays here, each case written when its batch
    comes back."""

    # a batch's seconds of work (an analyse batch's: execute._group_size; the pool's: execute.GROUP_S,
    # 0.5 s, and one case per chain batch): a Dask task costs the client, the scheduler and the
    # worker's process milliseconds of CPU each, tens on a loaded machine, on the cores the
    # helpers compute on, and a case's time is wall time: the busier the machine, the fewer cases
    # in a batch of 0.5 s.  Optimise chains of 4 jib cases (bench_study_dask.py's), 96 cases, a
    # cluster with cluster.SETTINGS, 2 interleaved pairs at load ~7: the client's, scheduler's
    # and workers' CPU 3.1 / 2.5 s in batches of 0.5 s (84 tasks), 1.9 / 1.3 s in batches of 2 s
    group_s = 2.0
    # an analyse batch's seconds of work (execute._group_size): 1 s, not group_s.  A batch of
    # 4,096 truck-crane cases (~1 s) once cost its helper more per case than one of 1,024 (its
    # arrays of cases x samples larger than the caches); a batch is now analysed
    # analysed.CHUNK cases at a time, so its size no longer sets its cost per case, and a
    # task's own cost (milliseconds of the client's, scheduler's and worker's CPU) stays small
    analyse_s = 1.0
    FIRST_BATCH = 4      # cases per batch before any case has finished
    WINDOW = 2           # batches in flight per worker thread
    LOOK_S = 5.0         # how often the cluster's worker threads are counted again
    REACH_S = 1.0        # seconds a worker's address is given to answer a connection from here

    def __init__(self, scheduler):
        super().__init__()
        self.work_s, self.work_n, self.lost, self.looked = 0.0, 0, False, 0.0
        self.reached = {}    # worker address -> whether a connection from here got through
        import distributed

        self.distributed = distributed
        if isinstance(scheduler, distributed.Client):
            self.client, self.own = scheduler, False
        else:
            try:
                # connect timeout: dask's config distributed.comm.timeouts.connect (30 s by default)
                _probe(scheduler)
                self.client, self.own = distributed.Client(scheduler), True
            except (OSError, ValueError, TypeError) as exc:
                raise OptdesignError(f"--scheduler {scheduler!r}: cannot reach the Dask scheduler ({exc}); expected "
                                     "an address such as tcp://10.0.0.5:8786") from None
        self.address = self.client.scheduler.address
        self.completed = distributed.as_completed()
        import logging

        # its own log lines ('Failed to reconnect to scheduler ...') would interleave with ours;
        # a lost scheduler is reported once, as ClusterLost
        self._logger = logging.getLogger("distributed.client")
        self._log_level = self._logger.level
        self._logger.setLevel(logging.CRITICAL)
        nthreads = None
        try:   # helper processes started on every worker now, while the study is being prepared
            nthreads = self.client.nthreads()
            # returns at once (they start aside); waited for, so that no batch comes before it
            self.client.run(prestart, max(nthreads.values(), default=1))
        except Exception:   # noqa: BLE001 - only a head start: a batch starts its helper if need be
            pass
        self._look(nthreads)

    def _look(self, nthreads=None):
        """The window from the cluster's worker threads (``nthreads``, or asked now: workers come and go)."""
        self.looked = time.monotonic()
        try:
            nthreads = self.client.nthreads() if nthreads is None else nthreads
            self.window = max(self.WINDOW, self.WINDOW * sum(nthreads.values()))
        except (OSError, TimeoutError, cf.CancelledError):   # the scheduler is gone: results() says so
            return
        import dask

        if self.own and dask.config.get("distributed.client.direct-to-workers", None) is None:
            self.client.direct_to_workers = self._reachable(nthreads)

    def _reachable(self, addresses) -> bool:
        """Whether this client reaches every worker at ``addresses`` itself (``tcp://`` ones, each
        tried once with a connection of at most ``REACH_S`` seconds): then batches' results come
        straight from their worker (the client's ``direct_to_workers``), not relayed by the
        scheduler, Dask's default for a client outside the cluster, where the scheduler receives
        and sends on every result (a truck-crane batch's ~5 MB: 25 such results cost the
        scheduler 0.23 s of CPU relayed, 0.10 s not; a worker process ~0.2 s either way;
        2 interleaved pairs at load ~8, 2026-11-29).  A worker the client cannot reach (a
        cluster behind NAT or a firewall) keeps Dask's relay for all."""
        import socket

        from distributed.comm import parse_address, parse_host_port

        for address in addresses:
            if address not in self.reached:
                try:
                    scheme, where = parse_address(address)
                    if scheme != "tcp":
                        raise OSError(scheme)
                    with socket.create_connection(parse_host_port(where), timeout=self.REACH_S):
                        self.reached[address] = True
                except (OSError, ValueError, TypeError):
                    self.reached[address] = False
        return all(self.reached[a] for a in addresses)

    def batch_size(self, remaining):
        """The chain's ``remaining`` cases cut into batches of about ``group_s`` seconds, evenly."""
        per_batch = (self.FIRST_BATCH if not self.work_n else
                     max(1, int(self.group_s / max(self.work_s / self.work_n, 1e-4))))
        batches = -(-remaining // per_batch)
        return -(-remaining // batches)

    def _submit(self, batch):
        payload = pickle.dumps((batch.tasks, *_where(batch)), protocol=pickle.HIGHEST_PROTOCOL)
        f = self.client.submit(computed_in_helper, payload, together(batch.tasks), pure=False)
        self.completed.add(f)
        return f

    def results(self):
        try:
            for cases, outs in super().results():
                self.work_s += sum(sum(b.time_s) for b in as_blocks(cases, outs))
                self.work_n += len(cases)
                if time.monotonic() - self.looked > self.LOOK_S:
                    self._look()
                yield cases, outs
        except (cf.CancelledError, OSError, TimeoutError) as exc:   # FuturesCancelledError, CommClosedError
            self.lost = True
            raise ClusterLost(f"the Dask scheduler at {self.address} was lost ({type(exc).__name__})") from None

    def _wait_first(self, futures):
        return [next(self.completed)]

    def ready(self):
        return self.completed.has_ready()

    def _outputs(self, f, batch):
        try:
            made = f.result()
            return pickle.loads(made) if isinstance(made, (bytes, bytearray)) else made   # (computed_in_helper's)
        except self.distributed.KilledWorker as exc:   # Dask retried it on other workers: each died
            reason = f"every Dask worker that computed this case died ({exc})"
            return [died_output(reason)] * len(batch.cases)

    def _cancel(self, futures):
        if futures:
            self.client.cancel(futures)

    def close(self):
        self.completed.clear()
        if not self.lost:   # a lost client still logs its reconnection failure after this: keep it quiet
            self._logger.setLevel(self._log_level)
        if self.own:
            try:
                self.client.close()
            except (OSError, TimeoutError, cf.CancelledError):   # the scheduler is gone already
                pass

    def describe(self):
        try:
            n = len(self.client.scheduler_info().get("workers", {}))
        except (OSError, TimeoutError, cf.CancelledError, AttributeError):   # the scheduler is gone
            return f"Dask cluster at {self.address} (lost)"
        return f"Dask cluster at {self.address}, {n} workers"


def _probe(address: str):
    """Check that a Dask scheduler answers at a ``tcp://`` address before a Client is made: Dask
    waits for the handshake's answer without a timeout (a port where an HTTP server listens:
    no answer after 150 s) and reads arbitrary bytes as a message's length (999 PiB asked of
    numpy).  Here the connection and the handshake together get dask's connect timeout
    (``distributed.comm.timeouts.connect``, 30 s by default); anything but a Dask answer is an
    OSError saying so."""
    import asyncio

    import dask
    from dask.utils import parse_timedelta
    from distributed.comm import connect

    if not isinstance(address, str) or not address.startswith("tcp://"):
        return   # other protocols (tls://, inproc://) are Dask's to check
    timeout = parse_timedelta(dask.config.get("distributed.comm.timeouts.connect"), default="seconds")

    async def handshake():
        comm = await connect(address, timeout=timeout)
        await comm.close()

    try:
        asyncio.run(asyncio.wait_for(handshake(), timeout))
    except asyncio.TimeoutError:
        raise OSError(f"no answer from {address} in {timeout:g} s (distributed.comm.timeouts.connect): something "
                      "listens there but it is not a Dask scheduler, or it is busy") from None
    except OSError:
        raise
    except Exception as exc:   # noqa: BLE001 - bytes that are not Dask's (MemoryError, ValueError, TypeError, ...)
        raise OSError(f"what answers at {address} is not a Dask scheduler ({type(exc).__name__})") from None


def _executor(workers, scheduler, n_chains):
    if scheduler is not None:
        return _Dask(scheduler)
    workers = (os.cpu_count() or 1) if workers is None else int(workers)
    if workers < 1:
        raise OptdesignError(f"workers must be at least 1, found {workers}")
    workers = min(workers, max(n_chains, 1))
    return _Inline() if workers == 1 else _Pool(workers)
