"""Process deaths: a study's pool process or Dask helper process that dies (SIGKILL, the
out-of-memory killer, a crash) is replaced and its cases run again, each finished case
journalled once; a case that kills its process every time is recorded as failed with the
reason after MAX_DEATHS deaths and the study goes on; a pool that cannot be replaced ends the
study with exit 2, the cases kept and the command that resumes.  ``optimise --workers`` losing a
process is one message, no traceback, no hang.  Every wait is on a condition, never a sleep.

A case that kills its process is made with a task whose pickled scene, when loaded where the
case runs, sends SIGKILL to that process: no hook in optdesign's code."""
from __future__ import annotations

import dataclasses
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import optdesign
from optdesign.study import Study, values
from optdesign.study.blocks import as_outputs
from optdesign.study.executors import _Pool, computed
from optdesign.study.worker import MAX_DEATHS, blocks_in_helper, run_batch_in_helper

from .util import JIB, JIB_DESIGN, ROOT

pytestmark = pytest.mark.skipif(not Path("/proc/self/maps").exists() or not hasattr(signal, "SIGKILL"),
                                reason="needs /proc and SIGKILL")


class _Killer:
    """Unpickled where a case runs: the process kills itself (as the OOM killer would)."""

    def __reduce__(self):
        return signal.raise_signal, (signal.SIGKILL,)


def _tasks(n=5):
    """``n`` analyse cases of the jib (mC = 100, 200, ...) as a study hands them to a worker."""
    study = Study(optdesign.load(JIB), [values("mC", [100.0 * (i + 1) for i in range(n)])], mode="analyse")
    return study, study.cases(), [study.task(c) for c in study.cases()]


def _poisoned(task):
    """``task`` whose scene kills the process that loads it (a digest of its own: never cached)."""
    import pickle

    return dataclasses.replace(task, scene_blob=pickle.dumps(_Killer()), scene_digest="killer" + task.scene_digest)


def _reference(tasks):
    from optdesign.study.tasks import run_task

    return [run_task(t)["row"] for t in tasks]


# --- the local pool --------------------------------------------------------------------------------------
def test_a_case_that_kills_its_pool_process_is_failed_after_max_deaths_and_the_others_are_computed_once():
    study, cases, tasks = _tasks(5)
    bad = 2
    pool = _Pool(2)
    try:
        for i, (case, task) in enumerate(zip(cases, tasks)):
            pool.submit([case], [_poisoned(task) if i == bad else task])
        got = [(c, o) for part, outs in pool.results() for c, o in zip(part, as_outputs(part, outs))]
    finally:
        pool.close()
    ids = [case.id for case, _ in got]
    assert sorted(ids) == sorted(c.id for c in cases)      # every case once, none twice
    out = {case.index: o for case, o in got}
    assert out[bad]["row"]["success"] is False
    assert out[bad]["row"]["status"].startswith(f"error: the worker process computing this case died {MAX_DEATHS} times")
    expected = _reference([t for i, t in enumerate(tasks) if i != bad])
    assert [out[i]["row"] for i in range(5) if i != bad] == expected   # the others: their own numbers
    assert pool.deaths == MAX_DEATHS
    assert f"{MAX_DEATHS} died and were replaced" in pool.describe()


def test_a_study_whose_pool_process_is_killed_mid_study_finishes_with_every_case_once(tmp_path):
    """SIGKILL one process of the pool while the study runs: it finishes, exit 0, every case
    journalled exactly once and cases.csv whole."""
    out = tmp_path / "s"
    n = 16
    args = [sys.executable, "-m", "optdesign", "study", str(JIB_DESIGN), "--grid", f"mC=300:750:{n}", "--starts", "2",
            "--chain", "2", "--workers", "2", "--no-figures", "--out", str(out)]
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT,
                            start_new_session=True, env={**os.environ, "MPLBACKEND": "Agg"})
    journal = out / "journal.jsonl"
    t0 = time.monotonic()
    victim = None
    while victim is None:   # a case journalled: the pool's processes are at work
        assert proc.poll() is None, "the study ended before a worker could be killed: " + proc.communicate()[1]
        assert time.monotonic() - t0 < 120, "no case journalled in 120 s"
        if journal.exists() and journal.read_bytes().count(b"\n") >= 2:
            children = subprocess.run(["pgrep", "-P", str(proc.pid)], capture_output=True, text=True).stdout.split()
            victim = int(children[0]) if children else None
        time.sleep(0.02)
    os.kill(victim, signal.SIGKILL)
    stdout, stderr = proc.communicate(timeout=300)
    assert proc.returncode == 0, stderr
    assert "Traceback" not in stderr
    assert "a worker process died (killed, out of memory or crashed); the pool was replaced" in stderr
    ids = [json.loads(line)["id"] for line in journal.read_text().splitlines()]
    assert len(ids) == n and len(set(ids)) == n           # every case journalled once
    rows = (out / "cases.csv").read_text().splitlines()
    assert len(rows) == 1 + n
    summary = (out / "summary.txt").read_text()
    assert f"{n} finished ({n} successful, 0 failed), complete" in summary
    assert "1 died and was replaced" in summary


def test_a_pool_that_cannot_be_replaced_ends_with_exit_2_the_cases_kept_and_the_resume_command(
        tmp_path, capsys, monkeypatch):
    from optdesign.cli.main import main
    from optdesign.study import executors

    started = []

    def start(self, real=executors._Pool._start):
        started.append(1)
        if len(started) > 1:
            raise OSError(12, "Cannot allocate memory")
        return real(self)

    def submit(self, batch, real=executors._Pool._submit):   # the third case kills its process
        batch.tasks = [_poisoned(t) if t.overrides == (("mC", 300.0),) else t for t in batch.tasks]
        return real(self, batch)

    monkeypatch.setattr(executors._Pool, "_start", start)
    monkeypatch.setattr(executors._Pool, "_submit", submit)
    out = tmp_path / "s"
    argv = ["study", str(JIB), "--mode", "analyse", "--values", "mC=100,200,300,400", "--workers", "2",
            "--no-figures", "--out", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    last = err.strip().splitlines()[-1]
    kept = len((out / "journal.jsonl").read_text().splitlines())
    assert last.startswith("optdesign study: error: the study's worker processes could not be started "
                           f"(Cannot allocate memory): {kept} of 4 cases are finished and kept in "), last
    assert last.endswith(f"; resume with: optdesign study {JIB} --mode analyse --values mC=100,200,300,400 "
                         f"--workers 2 --no-figures --out {out}"), last


def test_a_case_that_kills_its_pool_process_in_an_analyse_batch_is_failed_and_the_batchs_others_computed():
    """A batch of analyse cases (one Analysis.run_many: study/tasks.run_batch) gives its outputs
    together at its end: when its process dies, which case killed it is not known, so each case of the batch is
    run again alone; the one that kills is failed after MAX_DEATHS, the others keep their numbers
    (the batch's cases were all recorded as failed before)."""
    study, cases, tasks = _tasks(5)
    bad = 3
    pool = _Pool(2)
    try:
        pool.submit(cases, [_poisoned(t) if i == bad else t for i, t in enumerate(tasks)])
        got = [(c, o) for part, outs in pool.results() for c, o in zip(part, as_outputs(part, outs))]
    finally:
        pool.close()
    assert sorted(case.id for case, _ in got) == sorted(c.id for c in cases)
    out = {case.index: o for case, o in got}
    assert out[bad]["row"]["status"].startswith(f"error: the worker process computing this case died {MAX_DEATHS} times")
    assert [out[i]["row"] for i in range(5) if i != bad] == _reference([t for i, t in enumerate(tasks) if i != bad])


# --- the helper process of a Dask worker -----------------------------------------------------------------
def test_a_dask_helper_that_dies_is_replaced_and_its_batch_goes_on_from_the_case_it_was_computing():
    study, cases, tasks = _tasks(4)
    batch = [tasks[0], _poisoned(tasks[1]), tasks[2], tasks[3]]
    outs = run_batch_in_helper(batch)
    assert len(outs) == 4
    assert outs[1]["row"] == {"status": f"error: the study's helper process computing this case on a Dask worker "
                                        f"died {MAX_DEATHS} times (killed by SIGKILL); it is not tried again",
                              "success": False}
    assert [outs[i]["row"] for i in (0, 2, 3)] == _reference([tasks[0], tasks[2], tasks[3]])


def test_a_dask_helper_gives_a_batch_of_analyse_cases_as_the_pool_does_and_each_case_alone_after_it_died():
    """A batch of analyse cases comes back from the helper as its blocks in one message (the
    journal's lines byte-identical to those a pool process makes); when the helper dies on it,
    which case killed it is not known, so each case runs alone: the one that kills is failed after
    MAX_DEATHS, the others keep their numbers."""
    study, cases, tasks = _tasks(4)
    index, ids = [c.index for c in cases], [c.id for c in cases]
    made, pools = blocks_in_helper(tasks, index, ids), computed(tasks, index, ids)
    timeless = re.compile(r'"time_s":[^}]*}')   # (time_s: the run's own)

    def content(b):
        return (b.index, b.ids, b.keys, [list(v) for v in b.values], [b.cells(k) for k in b.keys],
                [timeless.sub("", line) for line in b.lines()])

    assert [content(b) for b in made] == [content(b) for b in pools]
    outs = as_outputs(cases, blocks_in_helper([tasks[0], _poisoned(tasks[1]), tasks[2], tasks[3]], index, ids))
    assert outs[1]["row"] == {"status": f"error: the study's helper process computing this case on a Dask worker "
                                        f"died {MAX_DEATHS} times (killed by SIGKILL); it is not tried again",
                              "success": False}
    assert [outs[i]["row"] for i in (0, 2, 3)] == _reference([tasks[0], tasks[2], tasks[3]])


# --- optimise --workers ----------------------------------------------------------------------------------
KILL_START_3 = """
import signal, sys
from optdesign.cli.main import main
from optdesign.design import multistart
real = multistart.solve_start
def solve_start(solver, repair, index, *args, **kw):   # in the forked worker: start 3 kills its process
    if index == 3:
        signal.raise_signal(signal.SIGKILL)
    return real(solver, repair, index, *args, **kw)
multistart.solve_start = solve_start
sys.exit(main(sys.argv[1:]))
"""


def test_optimise_whose_worker_dies_is_one_message_and_exit_2(tmp_path):
    """(A multiprocessing.Pool replaced the dead worker and waited for its start for ever.)"""
    out = tmp_path / "o"
    done = subprocess.run([sys.executable, "-c", KILL_START_3, "optimise", str(JIB_DESIGN), "--starts", "8",
                           "--workers", "2", "--out", str(out)], capture_output=True, text=True, timeout=120,
                          cwd=ROOT, env={**os.environ, "MPLBACKEND": "Agg"})
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr
    assert done.stderr.strip().splitlines()[-1].startswith(
        "optdesign optimise: error: a worker process of --workers 2 died while solving the starts (killed, out of "
        "memory or crashed) after "), done.stderr
    assert not out.exists()


def test_optimise_from_python_whose_worker_dies_raises_a_solver_error(monkeypatch):
    from optdesign.design import multistart
    from optdesign.errors import SolverError

    real = multistart.solve_start
    monkeypatch.setattr(multistart, "solve_start", lambda s, r, index, *a, **k: (
        signal.raise_signal(signal.SIGKILL) if index == 0 else real(s, r, index, *a, **k)))
    with pytest.raises(SolverError, match=r"a worker process of --workers 2 died while solving the starts"):
        optdesign.optimise(optdesign.load(JIB_DESIGN), starts=4, workers=2)
