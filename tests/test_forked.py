"""Jobs shared by this process and a forked one (report/forked.run_jobs, `analyse --plot`'s
figures): the results are those of the jobs run one after another, in their order, whoever ran
them; what the forked process does not report (it died, a job failed there) is done here, an
error is raised here, and no process is left, also after Ctrl-C."""
from __future__ import annotations

import multiprocessing
import os
import signal
import time
from pathlib import Path

import pytest

from optdesign.report import forked
from processes import kill_once_forked  # tests/ is on sys.path under pytest

PARENT = os.getpid()


def _job(folder, k, seconds=0.05):
    def run():
        time.sleep(seconds)
        path = Path(folder) / f"{k}.txt"
        path.write_text(f"{k} by {os.getpid()}")
        return [path] if k % 3 else []   # some jobs write a file and report none, as a figure not drawn
    return run


def _left():
    return [p for p in multiprocessing.active_children() if p.is_alive()]


def test_the_results_are_the_serial_ones_in_order_and_both_processes_work(tmp_path):
    jobs = [_job(tmp_path, k, 0.1) for k in range(16)]
    shared = forked.run_jobs(jobs, workers=2)
    assert shared == [tmp_path / f"{k}.txt" for k in range(16) if k % 3]
    assert all(isinstance(p, Path) for p in shared)
    by = {(tmp_path / f"{k}.txt").read_text().split(" by ")[1] for k in range(16)}
    assert len(by) == 2 and str(PARENT) in by   # this process and another one drew
    assert forked.run_jobs(jobs, workers=1) == shared
    assert not _left()


def test_a_job_that_kills_the_forked_process_is_done_here(tmp_path):
    def deadly():
        if os.getpid() != PARENT:
            os.kill(os.getpid(), signal.SIGKILL)
        (tmp_path / "deadly.txt").write_text("here")
        return [tmp_path / "deadly.txt"]

    jobs = [_job(tmp_path, 1, 0.5), deadly] + [_job(tmp_path, k) for k in range(2, 6)]
    assert forked.run_jobs(jobs, workers=2) == [tmp_path / "1.txt", tmp_path / "deadly.txt", tmp_path / "2.txt",
                                                 tmp_path / "4.txt", tmp_path / "5.txt"]
    assert (tmp_path / "deadly.txt").read_text() == "here"
    assert not _left()


def test_an_error_in_a_job_is_raised_here_wherever_it_was_taken(tmp_path):
    def broken():
        raise OSError(28, "No space left on device (a stand-in)")

    for first in (0.0, 0.5):   # the job taken by the forked process, or by this one
        with pytest.raises(OSError, match="No space left"):
            forked.run_jobs([_job(tmp_path, 1, first), broken, _job(tmp_path, 2, 0.3)], workers=2)
        assert not _left()


def test_ctrl_c_here_ends_the_forked_process(tmp_path):
    def interrupted():
        if os.getpid() == PARENT:
            raise KeyboardInterrupt
        time.sleep(60)   # the forked process, busy: it must not outlive the call
        return []

    started = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        forked.run_jobs([interrupted, interrupted, interrupted], workers=2)
    assert time.monotonic() - started < 30
    assert not _left()


def test_the_forked_process_dies_with_a_parent_killed_by_sigkill(tmp_path):
    code = ("import time\nfrom optdesign.report import forked\n"
            "forked.run_jobs([lambda: time.sleep(120) or [], lambda: time.sleep(120) or []], workers=2)\n")
    children, left = kill_once_forked(code)
    assert children, "no forked process seen"
    assert left == [], "the forked process outlived its parent"


def test_a_forked_process_that_hangs_is_ended_and_its_jobs_done_here(tmp_path, monkeypatch):
    """The forked process reports nothing for forked.WAIT seconds (here 1 s; a job sleeps a
    minute there): it is killed and its job is done here, the results the serial ones.  Each job
    hangs in the forked process and, here, waits until the forked process has begun one."""
    monkeypatch.setattr(forked, "WAIT", 1.0)
    begun = tmp_path / "begun"

    def job(name):
        def run():
            if os.getpid() != PARENT:
                begun.touch()
                time.sleep(60)
            t0 = time.perf_counter()
            while not begun.exists() and time.perf_counter() - t0 < 30:
                time.sleep(0.01)
            return [tmp_path / name]
        return run
    t0 = time.perf_counter()
    assert forked.run_jobs([job("a"), job("b")], workers=2) == [tmp_path / "a", tmp_path / "b"]
    assert begun.exists() and time.perf_counter() - t0 < 40
    assert _left() == []
