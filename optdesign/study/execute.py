"""Running a study: which case runs next, where (this process, a process pool, Dask), the
journal, Ctrl-C, and the files written at the end.

Scheduling: every chain has at most one case in flight; when it finishes it is journalled
and the chain's next case is submitted with its optimum as the warm start.  A resumed chain
takes the warm start from the journal (JSON keeps floats exact), so a resumed study computes
exactly what an uninterrupted one would have."""
from __future__ import annotations

import concurrent.futures as cf
import dataclasses
import json
import multiprocessing
import os
import pickle
import signal
import sys
import threading
import time
from pathlib import Path

from ..errors import OptdesignError, worker_process
from ..report import study as study_figures
from . import journal as study_journal
from . import table as study_table
from .results import ClusterLost, StudyInterrupted, StudyResult
from ..report.folder import NoHardLinks, inspect, replace_folder
from ..report.files import write_file
from .tasks import run_batch, scene_digest
from .worker import prestart, run_batch_in_helper


# the files a study derives from its journal (replaced at the end; a restart drops them)
DERIVED = (study_table.CSV, "pareto.csv", "study.png", "pareto.png", "study.json", "summary.txt")


def execute(study, folder: Path, workers, scheduler, progress, restart, figures):
    t0 = time.perf_counter()
    cases = study.cases()
    inspect(folder, {study_journal.JOURNAL, *DERIVED}, "study folder")   # a folder we may write, before any work
    with study_journal.Journal(folder, restart=restart, produces=DERIVED) as journal:
        reused = sum(1 for c in cases if c.id in journal.records)
        chains = {}
        for c in cases:
            chains.setdefault(c.chain, []).append(c)
        todo = [ch for ch in chains.values() if any(c.id not in journal.records for c in ch)]
        executor = _executor(workers, scheduler, len(todo))
        computed, interrupted, lost = 0, False, None
        with _CtrlC() as ctrl_c:
            try:
                computed = _schedule(study, todo, journal, executor, progress, reused, len(cases), ctrl_c)
            except KeyboardInterrupt:
                interrupted = True
                computed = executor.stop(journal)
            except ClusterLost as exc:   # the Dask scheduler is gone: keep what came back
                lost, computed = exc, executor.finished
            finally:
                where = executor.describe()
                executor.close()
        rows = merged_rows(cases, journal.records)
        try:
            result = write_folder(study, cases, folder, rows, figures, computed, reused, t0, where, journal.notes)
        except OptdesignError as exc:
            raise OptdesignError(f"{exc}; the {len(rows)} finished cases are kept in {journal.path}: run the same "
                                 "study again with the same folder to write them") from None
    if lost is not None:
        raise ClusterLost(
            f"{lost}: {len(rows)} of {len(cases)} cases are finished and kept in {folder / study_journal.JOURNAL}; "
            "run the same study again with the same folder to resume (finished cases are not redone)",
            len(rows), len(cases), folder / study_journal.JOURNAL, result)
    if interrupted:
        raise StudyInterrupted(
            f"study interrupted: {len(rows)} of {len(cases)} cases are finished and kept in "
            f"{folder / study_journal.JOURNAL} ({folder / study_table.CSV} holds them); run the same study "
            "again with the same folder to resume (finished cases are not redone)", result)
    return result


def write_folder(study, cases, folder, rows, figures, computed, reused, t0, where, notes) -> StudyResult:
    """The derived files (study.json, cases.csv, figures, summary.txt) swapped in as a whole,
    with the journal held (its lock too) and carried into the new folder as the same file by a
    hard link: a kill at any instant leaves the old whole folder or the new whole one, and the
    journal at its place.  Where the filesystem has no hard links, written in place one by one."""
    complete = len(rows) == len(cases)
    made = []

    def write(tmp) -> list:
        paths = [write_file(tmp / "study.json", json.dumps(definition(study, cases), indent=1) + "\n"),
                 study_table.write_csv(tmp, rows, study.input_columns)]
        pareto = bool(study.axes) and study.axes[-1].kind == "pareto"
        if complete and figures:
            paths += study_figures.figures(study, rows, tmp, study_table.front(study, rows) if pareto else None)
        if complete and pareto:   # a table, not a figure: --no-figures keeps it
            paths.append(study_table.pareto_csv(study, rows, tmp))
        result = StudyResult(study, tmp, rows, complete, computed, reused, time.perf_counter() - t0, paths,
                             tuple(notes))
        paths.append(write_summary(result, where))
        made.append(result)
        return paths

    try:
        paths = replace_folder(folder, write, DERIVED, linked={study_journal.JOURNAL}, label="study folder")
    except NoHardLinks:
        notes = [*notes, f"{folder}: no hard links on this filesystem: the files were replaced one by one"]
        made.clear()
        paths = write(folder)
    return dataclasses.replace(made[-1], folder=folder, paths=paths)


def merged_rows(cases, records) -> list:
    """One dict per finished case, in case order: identification, inputs, results."""
    rows = []
    for c in cases:
        rec = records.get(c.id)
        if rec is not None:
            rows.append({"case": c.index, "id": c.id, "chain": c.chain, "link": c.link,
                         **dict(c.inputs), **rec["row"]})
    return rows


def definition(study, cases) -> dict:
    """study.json: what the study is (not how long it took)."""
    return {"schema": "optdesign/study/1", "title": study.scene.title, "file": study.scene.path,
            "scene_digest": scene_digest(study.scene), "mode": study.mode, "cases": len(cases),
            "chains": len({c.chain for c in cases}),
            "axes": [{"kind": a.kind, "columns": list(a.columns), "constraint": a.constraint, "side": a.side,
                      "points": [[v for _, v in p] for p in a.points]} for a in study.axes],
            "starts": study.starts, "seed": study.seed, "warm": study.warm, "warm_starts": study.warm_starts,
            "chain": study.chain, "settings": dataclasses.asdict(study.settings)}


def write_summary(result, where) -> Path:
    rows = result.rows
    ok = sum(1 for r in rows if r.get("success"))
    lines = [f"{result.study.scene.title}",
             f"{result.study.mode} study of {len(result.study.cases())} cases: {len(rows)} finished "
             f"({ok} successful, {len(rows) - ok} failed), {'complete' if result.complete else 'INCOMPLETE: run again to resume'}",
             f"this run: {result.computed} computed, {result.reused} taken from the journal, "
             f"{result.wall_s:.2f} s wall ({where})"]
    if result.computed:
        lines.append(f"cases per second (this run): {result.computed / result.wall_s:.3g}")
    bad = [r for r in rows if not r.get("success")]
    for r in bad[:20]:
        lines.append(f"  case {r['case']} failed: {r.get('status')}")
    if result.study.mode == "analyse" and result.study.scene.cases:
        lines.append("columns: peak:*, rms:* and constraint:* are the nominal state's (at the [drive] speed and "
                     "acceleration); the load cases' are case_peak:* (with the governing case), cycle_rms:*, cycle:*, "
                     "motor_fits:*, smallest_motor and cylinder:*")
    lines += [f"journal: {note}" for note in result.notes]
    lines.append(f"files: {', '.join(p.name for p in result.paths)}")
    path = result.folder / "summary.txt"
    write_file(path, "\n".join(lines) + "\n")
    return path


# --- the scheduling loop -------------------------------------------------------------------
class _CtrlC:
    """Ctrl-C during a study.  The first press asks to stop once the running case(s) finish
    (they are kept); only a second press interrupts at once.  The first press must not raise:
    CasADi catches an exception raised inside IPOPT and returns a failed solve (status
    NonIpopt_Exception_Thrown), which would be journalled as the case's result.  A case that
    was running in this process when the second press came is therefore never journalled."""

    def __init__(self):
        self.presses, self.abandoned, self._old = 0, False, None

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            self._old = signal.signal(signal.SIGINT, self._handler)
        return self

    def __exit__(self, *exc):
        if self._old is not None:
            signal.signal(signal.SIGINT, self._old)

    def _handler(self, signum, frame):
        self.presses += 1
        if self.presses == 1:
            print("\nstopping once the running case(s) finish (they are kept); Ctrl-C again to abandon them",
                  file=sys.stderr)
            return
        self.abandoned = True
        raise KeyboardInterrupt


def _schedule(study, chains, journal, executor, progress, done, total, ctrl_c) -> int:
    blob, digest = pickle.dumps(study.scene), scene_digest(study.scene)
    state = {}   # chain number -> position of its case in flight
    computed = 0
    if progress is not None:
        progress(done, total)

    def submit(chain, pos):
        """Submit the chain's first unfinished case at or after ``pos``, with the unfinished cases
        right after it when the executor takes batches (each warm-started on the worker from the
        one before it: tasks.run_batch); False if none."""
        while pos < len(chain) and chain[pos].id in journal.records:
            pos += 1
        if pos == len(chain):
            return False
        batch = chain[pos:pos + executor.batch_size(len(chain) - pos)]
        batch = batch[:next((i for i, c in enumerate(batch) if c.id in journal.records), len(batch))]
        prev = journal.records.get(chain[pos - 1].id) if pos > 0 else None
        x_warm = prev.get("x") if prev is not None else None
        executor.submit(batch, [study.task(case, x_warm if i == 0 else None, blob, digest)
                                for i, case in enumerate(batch)])
        state[batch[0].chain] = (chain, pos + len(batch) - 1)   # the batch's last case
        return True

    for chain in chains:
        submit(chain, 0)
    for case, out in executor.results():
        if ctrl_c.abandoned:   # computed while the second Ctrl-C was raised: maybe not a result
            raise KeyboardInterrupt
        journal.add({"id": case.id, "case": case.index, "row": out["row"], "x": out["x"], "time_s": out["time_s"]})
        computed += 1
        executor.finished += 1
        if progress is not None:
            progress(done + computed, total)
        chain, pos = state[case.chain]
        if chain[pos].id != case.id:
            continue   # more of its batch to come
        if ctrl_c.presses:
            raise KeyboardInterrupt
        state.pop(case.chain)
        submit(chain, pos + 1)
    return computed


# --- executors: submit(cases, tasks) (consecutive cases of one chain, batch_size(...) of them),
# results() yields (case, output) as cases finish ----------------------------------------------
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
            yield from zip(cases, run_batch(tasks))

    def stop(self, journal):
        return self.finished

    def close(self):
        pass

    def describe(self):
        return "1 worker, in process"


class _Futures:
    """Shared by the process pool and Dask: futures mapped to their cases."""

    def __init__(self):
        self.pending, self.finished = {}, 0

    def batch_size(self, remaining):
        return 1

    def results(self):
        while self.pending:
            done = self._wait_first(list(self.pending))
            for f in done:
                cases = self.pending.pop(f)
                yield from zip(cases, f.result())

    def stop(self, journal):
        """Ctrl-C: cancel what has not started, keep what finishes."""
        for f in list(self.pending):
            if f.cancel():
                self.pending.pop(f)
        try:
            for case, out in self.results():
                journal.add({"id": case.id, "case": case.index, "row": out["row"], "x": out["x"],
                             "time_s": out["time_s"]})
                self.finished += 1
        except (KeyboardInterrupt, cf.CancelledError, cf.process.BrokenProcessPool):
            pass   # abandoned, cancelled or lost with its worker: nothing to keep
        return self.finished


class _Pool(_Futures):
    """A process pool on this machine; each worker builds the scene's model once."""

    def __init__(self, workers):
        super().__init__()
        # fork where there is one: workers start at once with the modules already imported, and
        # a script without an `if __name__ == "__main__":` guard is not run again in each worker
        methods = multiprocessing.get_all_start_methods()
        ctx = multiprocessing.get_context("fork" if "fork" in methods else "spawn")
        self.workers = workers
        # workers leave Ctrl-C to the parent, which stops the study cleanly, and die with it
        self.pool = cf.ProcessPoolExecutor(workers, mp_context=ctx, initializer=worker_process,
                                           initargs=(os.getpid(),))

    def submit(self, cases, tasks):
        self.pending[self.pool.submit(run_batch, tasks)] = cases

    @staticmethod
    def _wait_first(futures):
        return cf.wait(futures, return_when=cf.FIRST_COMPLETED).done

    def close(self):
        self.pool.shutdown(wait=not self.pending, cancel_futures=True)

    def describe(self):
        return f"{self.workers} worker processes"


class _Dask(_Futures):
    """A Dask distributed cluster: ``scheduler`` is its address or a ``distributed.Client``.

    Cases go in batches of consecutive cases of a chain, about ``BATCH_S`` seconds of work each
    (from the cases finished so far): a task's round trip through the scheduler costs
    milliseconds to tens of milliseconds, a case of an optimisation study a few tens.  Each
    batch is computed in a helper process of its worker (:mod:`.worker`: the worker's own threads
    slowed the cases down 1.3-1.9 times), which builds the scene's model once.  The journal
    stays here, each case written when its batch comes back."""

    BATCH_S = 0.5
    FIRST_BATCH = 4      # cases per batch before any case has finished

    def __init__(self, scheduler):
        super().__init__()
        self.work_s, self.work_n, self.lost = 0.0, 0, False
        import distributed

        self.distributed = distributed
        if isinstance(scheduler, distributed.Client):
            self.client, self.own = scheduler, False
        else:
            try:
                # connect timeout: dask's config distributed.comm.timeouts.connect (30 s by default)
                self.client, self.own = distributed.Client(scheduler), True
            except (OSError, ValueError, TypeError) as exc:
                raise OptdesignError(f"--scheduler {scheduler!r}: cannot reach the Dask scheduler ({exc}); expected "
                                     "an address such as tcp://10.0.0.5:8786") from None
        self.address = self.client.scheduler.address
        import logging

        # its own log lines ('Failed to reconnect to scheduler ...') would interleave with ours;
        # a lost scheduler is reported once, as ClusterLost
        self._logger = logging.getLogger("distributed.client")
        self._log_level = self._logger.level
        self._logger.setLevel(logging.CRITICAL)
        try:   # helper processes started on every worker now, while the study is being prepared
            threads = max(self.client.nthreads().values(), default=1)
            self.client.run(prestart, threads)   # returns at once: they start aside
        except Exception:   # noqa: BLE001 - only a head start: a batch starts its helper if need be
            pass

    def batch_size(self, remaining):
        """The chain's ``remaining`` cases cut into batches of about BATCH_S seconds, evenly."""
        per_batch = (self.FIRST_BATCH if not self.work_n else
                     max(1, int(self.BATCH_S / max(self.work_s / self.work_n, 1e-4))))
        batches = -(-remaining // per_batch)
        return -(-remaining // batches)

    def submit(self, cases, tasks):
        self.pending[self.client.submit(run_batch_in_helper, tasks, pure=False)] = cases

    def results(self):
        try:
            for case, out in super().results():
                self.work_s += out["time_s"]
                self.work_n += 1
                yield case, out
        except (cf.CancelledError, OSError, TimeoutError) as exc:   # FuturesCancelledError, CommClosedError
            self.lost = True
            raise ClusterLost(f"the Dask scheduler at {self.address} was lost ({type(exc).__name__})") from None

    def _wait_first(self, futures):
        return self.distributed.wait(futures, return_when="FIRST_COMPLETED").done

    def stop(self, journal):
        """Ctrl-C: cancel every case on the cluster (finished ones are already journalled)."""
        self.client.cancel(list(self.pending))
        self.pending.clear()
        return self.finished

    def close(self):
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


def _executor(workers, scheduler, n_chains):
    if scheduler is not None:
        return _Dask(scheduler)
    workers = (os.cpu_count() or 1) if workers is None else int(workers)
    if workers < 1:
        from ..errors import OptdesignError

        raise OptdesignError(f"workers must be at least 1, found {workers}")
    workers = min(workers, max(n_chains, 1))
    return _Inline() if workers == 1 else _Pool(workers)


__all__ = ["execute", "merged_rows"]
