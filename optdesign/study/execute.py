"""Running a study: which case runs next, where (this process, a process pool, Dask), the
journal, Ctrl-C, and the files written at the end.

Scheduling: every chain has at most one case in flight; when it finishes it is journalled
and the chain's next case is submitted with its optimum as the warm start.  A resumed chain
takes the warm start from the journal (JSON keeps floats exact), so a resumed study computes
exactly what an uninterrupted one would have."""
from __future__ import annotations

import collections
import dataclasses
import gc
import json
import math
import pickle
import signal
import sys
import threading
import time
from pathlib import Path

from ..errors import OptdesignError
from ..report import study as study_figures
from . import journal as study_journal
from . import table as study_table
from .results import ClusterLost, StudyInterrupted, StudyResult
from .rows import Rows
from ..report.folder import NoHardLinks, inspect, replace_folder
from ..report.files import write_file
from .blocks import as_blocks
from .executors import _executor, _Inline, record  # noqa: F401  (_Inline: the tests' stand-in executors)
from .tasks import scene_digest


# the files a study derives from its journal (replaced at the end; a restart drops them)
DERIVED = (study_table.CSV, study_table.PARQUET, "pareto.csv", "study.png", "pareto.png", "study.json", "summary.txt")


def execute(study, folder: Path, workers, scheduler, progress, restart, figures):
    t0 = time.perf_counter()
    cases = study.cases()
    inspect(folder, {study_journal.JOURNAL, *DERIVED}, "study folder")   # a folder we may write, before any work
    journal = None

    def finished(case):   # a finished case the table has not been handed: its record read back
        if journal is None or case.id not in journal.records:   # (None: the journal being read)
            return None
        return merged_row(case, journal.records[case.id]["row"])

    # cases.csv takes each journal record as it is read (parsed once), in case order
    table = study_table.CsvWriter(folder, study.input_columns, cases, finished)
    with study_journal.Journal(folder, restart=restart, produces=DERIVED, consume=table.offer) as journal:
        try:
            table.flush_offered()   # the cases finished before (a resumed study)
            table.advance()
            records, ids = journal.records.spans, cases.ids
            todo = sum(1 for v in ids if f"{v:016x}" not in records)
            reused = len(cases) - todo
            executor = _executor(workers, scheduler, todo if not cases.chain else cases.n_chains)
            computed, interrupted, lost = 0, False, None
            # the objects alive now (the scene, the case list: ~39,000) left out of the collector's
            # full passes while the cases run (they took 0.004 of the client's 0.040 ms per case),
            # and out of those of the pool's forked processes
            frozen = not gc.get_freeze_count()
            if frozen:
                gc.freeze()
            with _CtrlC() as ctrl_c:
                try:
                    computed = _schedule(study, cases, todo, journal, executor, progress, reused, ctrl_c,
                                         table.add_blocks)
                except KeyboardInterrupt:
                    interrupted = True
                    computed = executor.stop(journal, abandon=ctrl_c.abandoned)
                except ClusterLost as exc:   # the Dask scheduler is gone: keep what came back
                    lost, computed = exc, executor.finished
                finally:
                    if frozen:
                        gc.unfreeze()
                    journal.sync()
                    where = executor.describe()
                    executor.close()
            rows = table.finish()
            # the cases let go once cases.csv is complete (the folder needs only their count and chains)
            total, chains = len(cases), cases.n_chains
            cases = table.cases = None
            try:
                result = write_folder(study, (total, chains), folder, rows, table, figures, computed, reused, t0, where,
                                      [f"journal: {note}" for note in journal.notes])
            except OptdesignError as exc:
                raise OptdesignError(f"{exc}; the {len(rows)} finished cases are kept in {journal.path}: run the "
                                     "same study again with the same folder to write them") from None
        finally:
            table.discard()   # its files moved into the folder, or not to be left there
    if lost is not None:
        raise ClusterLost(
            f"{lost}: {len(rows)} of {total} cases are finished and kept in {folder / study_journal.JOURNAL}; "
            "run the same study again with the same folder to resume (finished cases are not redone)",
            len(rows), total, folder / study_journal.JOURNAL, result)
    if interrupted:
        raise StudyInterrupted(
            f"study interrupted: {len(rows)} of {total} cases are finished and kept in "
            f"{folder / study_journal.JOURNAL} ({folder / study_table.CSV} holds them); run the same study "
            "again with the same folder to resume (finished cases are not redone)", result)
    return result


def write_folder(study, counts, folder, rows, table, figures, computed, reused, t0, where, notes) -> StudyResult:
    """The derived files (study.json, cases.csv, figures, summary.txt) swapped in as a whole,
    with the journal held (its lock too) and carried into the new folder as the same file by a
    hard link: a kill at any instant leaves the old whole folder or the new whole one, and the
    journal at its place.  Where the filesystem has no hard links, written in place one by one."""
    complete = len(rows) == counts[0]   # counts: (cases, chains)
    made = []

    def write(tmp) -> list:
        paths = [write_file(tmp / "study.json", json.dumps(definition(study, *counts), indent=1) + "\n"),
                 *study_table.write_tables(tmp, table)]
        pareto = bool(study.axes) and study.axes[-1].kind == "pareto"
        if complete and figures:
            paths += study_figures.figures(study, rows, tmp, study_table.front(study, rows) if pareto else None)
        if complete and pareto:   # a table, not a figure: --no-figures keeps it
            paths.append(study_table.pareto_csv(study, rows, tmp))
        result = StudyResult(study, tmp, rows, complete, computed, reused, time.perf_counter() - t0, paths,
                             (*notes, *([table.parquet.note] if table.parquet.note else [])))
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


def merged_row(case, row) -> dict:
    """A finished case's row as in cases.csv: identification, inputs, results."""
    return {"case": case.index, "id": case.id, "chain": case.chain, "link": case.link, **dict(case.inputs), **row}


def definition(study, cases: int, chains: int) -> dict:
    """study.json: what the study is (not how long it took)."""
    return {"schema": "optdesign/study/1", "title": study.scene.title, "file": study.scene.path,
            "scene_digest": scene_digest(study.scene), "mode": study.mode, "cases": cases,
            "chains": chains,
            "axes": [{"kind": a.kind, "columns": list(a.columns), "constraint": a.constraint, "side": a.side,
                      "points": [[v for _, v in p] for p in a.points]} for a in study.axes],
            "starts": study.starts, "seed": study.seed, "warm": study.warm, "warm_starts": study.warm_starts,
            "chain": study.chain, "settings": dataclasses.asdict(study.settings)}


def write_summary(result, where) -> Path:
    rows = result.rows
    success = rows.column("success") == 1
    ok = int(success.sum())
    lines = [f"{result.study.scene.title}",
             f"{result.study.mode} study of {math.prod(len(a) for a in result.study.axes)} cases: {len(rows)} finished "
             f"({ok} successful, {len(rows) - ok} failed), {'complete' if result.complete else 'INCOMPLETE: run again to resume'}",
             f"this run: {result.computed} computed, {result.reused} taken from the journal, "
             f"{result.wall_s:.2f} s wall ({where})"]
    if result.computed:
        lines.append(f"cases per second (this run): {result.computed / result.wall_s:.3g}")
    for i in (~success).nonzero()[0][:20]:
        r = rows[i]
        lines.append(f"  case {r['case']} failed: {r.get('status')}")
    if result.study.mode == "analyse" and result.study.scene.cases:
        lines.append("columns: peak:*, rms:* and constraint:* are the nominal state's (at the [drive] speed and "
                     "acceleration); the load cases' are case_peak:* (with the governing case), cycle_rms:*, cycle:*, "
                     "motor_fits:*, smallest_motor and cylinder:*")
    lines += list(result.notes)
    lines += case_table(result.study, rows)
    lines.append(f"files: {', '.join(p.name for p in result.paths)}")
    path = result.folder / "summary.txt"
    write_file(path, "\n".join(lines) + "\n")
    return path


def case_table(study, rows, shown=30) -> list:
    """A compact table of the cases (cases.csv's axes, and the objective or the peak drive load
    with the design for an optimisation), the first ``shown`` of them."""
    if not rows:
        return []
    rows = rows if isinstance(rows, Rows) else Rows(rows)
    keys = [c for a in study.axes for c in a.columns] + (
        ["objective"] + [k for k in rows[0] if k.startswith("design:")] if study.mode == "optimise"
        else [k for k in ("peak:drive", "case_peak:drive", "cycle_rms:drive") if k in rows[0]])
    keys = list(dict.fromkeys(k for k in keys if rows.has(k)))

    def cell(v):
        return "-" if v is None else f"{v:.6g}" if isinstance(v, float) else str(v)

    table = [["case"] + keys] + [[str(r.get("case"))] + [cell(r.get(k)) for k in keys] for r in rows[:shown]]
    widths = [max(len(row[j]) for row in table) for j in range(len(table[0]))]
    out = ["cases:"] + ["  " + "  ".join(c.rjust(w) for c, w in zip(row, widths)) for row in table]
    if len(rows) > shown:
        out.append(f"  ... {len(rows) - shown} more in cases.csv")
    return out


GROUP_FIRST = 32   # analyse cases in a batch before a case's time is known
GROUP_S = 0.5      # then about this many seconds of work per batch (tasks.run_batch analyses them together)
GROUP_SEEN = 8     # the batches whose time per case sets the next one's size (the median of the last ones)
BATCH_MAX = 4096    # cases per batch at most (1: each case's analysis alone, tasks.run_task)


def _group_size(executor, work, remaining) -> int:
    """Cases per batch of an analyse study: the executor's ``analyse_s`` seconds of work (GROUP_S
    unless it says otherwise) at the time per case of the last batches (``work``: their seconds
    per case (:func:`_work`), the median taken: a worker's first batch, which builds the model,
    does not keep the next ones small), or fewer (down to a quarter of GROUP_S) so that every
    batch the executor keeps in flight (its window) has some while few are left."""
    per_case = sorted(work)[len(work) // 2] if work else None
    if per_case is None:
        per = min(GROUP_FIRST, BATCH_MAX)
        floor = per // 4
    else:
        each = max(per_case, 1e-6)
        per = max(1, min(BATCH_MAX, int(getattr(executor, "analyse_s", GROUP_S) / each)))
        # near the end, smaller batches keep every worker busy; not below a quarter of GROUP_S
        # (a batch's round trip costs milliseconds, tens on Dask)
        floor = max(1, min(BATCH_MAX, int(GROUP_S / each))) // 4
    return max(1, min(per, max(floor, -(-remaining // getattr(executor, "window", 1)))))


def _work(made, n) -> float:
    """Seconds per case of a batch that came back (its blocks ``made``, ``n`` cases): the
    processor time of the process that computed it where that was measured (a batch's own cost,
    not what other processes on a busy machine took meanwhile: on 2 shared cores at load ~8 a
    truck-crane case took ~5 times its processor time, and batches of 0.5 s of wall time held
    ~80 cases, each batch paying its fixed cost), else its wall time (time_s)."""
    if made and all(b.cpu_s is not None for b in made):
        return sum(b.cpu_s * len(b) for b in made) / max(n, 1)
    return sum(sum(b.time_s) for b in made) / max(n, 1)


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
            print("\nstopping once the case(s) in flight finish (they are kept); Ctrl-C again to abandon them",
                  file=sys.stderr)
            return
        self.abandoned = True
        raise KeyboardInterrupt


def _schedule(study, cases, todo, journal, executor, progress, done, ctrl_c, came_back) -> int:
    """Feed the executor the chains' cases while it has room (a bounded window: the cases wait
    here, as indices, not in the pool or on the cluster), journal each batch as it comes back
    and report its cases once they are durable (group commit: one fsync for the batches that
    came back together, in a thread of the journal's), and continue each chain from its last finished
    case.  An analyse study's cases are independent (chains of one case, nothing to
    warm-start): they go in batches of several cases.  ``came_back(blocks)`` after each batch is
    journalled (cases.csv's rows).  ``todo``: the cases not finished yet."""
    blob, digest = pickle.dumps(study.scene), scene_digest(study.scene)
    records, total = journal.records, len(cases)
    grouped = study.mode == "analyse" and not cases.chain
    # the chains (ranges of case indices) with a case to compute, in order, taken as needed
    spans, ids = records.spans, cases.ids
    waiting = ((range(i, i + 1) for i in range(total) if f"{ids[i]:016x}" not in spans) if grouped else
               (ch for ch in cases.chains() if any(cases.id(i) not in records for i in ch)))
    left = todo   # grouped: cases not submitted yet
    # case id -> per batch holding it (a study may list one case twice, a batch hold both):
    # [cases of its batch still to come, its chain, position of the batch's last case]
    open_ = {}
    computed = reported = 0
    work = collections.deque(maxlen=GROUP_SEEN)   # seconds per case of the last batches (their sizes)
    if progress is not None:
        progress(done, total)

    def submit(chain, pos):
        """Submit the chain's first unfinished case at or after ``pos``, with the unfinished cases
        right after it when the executor takes batches (each warm-started on the worker from the
        one before it: tasks.run_batch)."""
        while pos < len(chain) and cases.id(chain[pos]) in records:
            pos += 1
        if pos == len(chain):
            return
        batch = [cases[i] for i in chain[pos:pos + executor.batch_size(len(chain) - pos)]]
        batch = batch[:next((i for i, c in enumerate(batch) if c.id in records), len(batch))]
        prev = records.get(cases.id(chain[pos - 1])) if pos > 0 else None
        x_warm = prev.get("x") if prev is not None else None
        tasks = [study.task(case, x_warm if i == 0 else None, blob, digest) for i, case in enumerate(batch)]
        entry = [len(batch), chain, pos + len(batch) - 1]
        for case in batch:
            open_.setdefault(case.id, []).append(entry)
        executor.submit(batch, tasks)

    def feed():
        nonlocal left
        while left and executor.room():
            if grouped:
                size = _group_size(executor, work, left)
                picked = []
                for _ in range(min(size, left)):
                    chain = next(waiting, None)   # None: the rest finished meanwhile (a case listed twice)
                    if chain is None:
                        left = 0
                        break
                    picked.append(chain.start)
                left = max(left - len(picked), 0)
                if not picked:
                    return
                refs, overrides, bounds = cases.batch(picked)
                executor.submit(refs, study.tasks(overrides, bounds, None, blob, digest))
            else:
                chain = next(waiting, None)
                if chain is None:
                    left = 0
                    return
                submit(chain, 0)

    def commit(wait=False):
        """Group commit: the journal made durable up to the cases computed so far, in its own
        thread (or at once with ``wait``); the cases made durable so far reported."""
        nonlocal reported
        if wait:
            journal.sync()
            durable = computed
        else:
            journal.commit(computed)
            durable = journal.committed() or 0
        if progress is not None and reported < durable:
            progress(done + durable, total)
        reported = max(reported, durable)

    feed()
    for batch, outs in executor.results():
        if ctrl_c.abandoned:   # computed while the second Ctrl-C was raised: maybe not a result
            raise KeyboardInterrupt
        made = as_blocks(batch, outs)
        work.append(_work(made, len(batch)))
        journal.add_blocks(made)
        came_back(made)
        computed += len(batch)
        executor.finished += len(batch)
        commit()   # durable in the background: reported once it is (at a later batch, or at the end)
        follow = []
        if not grouped:
            for case in batch:
                entry = open_[case.id].pop(0)
                if not open_[case.id]:
                    del open_[case.id]
                entry[0] -= 1
                if not entry[0]:
                    follow.append(entry)
            if not follow:
                continue   # more of its batch to come
        if ctrl_c.presses:
            commit(wait=True)
            raise KeyboardInterrupt
        for entry in follow:
            submit(entry[1], entry[2] + 1)
        feed()
    commit(wait=True)
    return computed


__all__ = ["execute", "merged_row"]
