"""Figures drawn by two processes at once: :func:`run_jobs` runs a list of drawing jobs, this
process and one forked from it each taking the next job not yet taken, so that a folder of
figures (``optdesign analyse --plot``: up to seven of 0.3-0.9 s of CPU each) is drawn in about
half the time on two cores.  The forked process starts from this one, with matplotlib and the
drawing modules imported, and draws the very bytes this one would.

Whatever the forked process did not report as done (it died, a job failed there, it was not
started) is drawn here, so the files never depend on it and an error while drawing is raised
here as it would be without it.  The process ends with the call: on Ctrl-C or any error here it
is killed, and it dies with this process; one that reports nothing for ``WAIT`` seconds (it hangs:
a lock held by another thread at the fork, say) is killed and its jobs are done here."""
from __future__ import annotations

import multiprocessing
import os
from pathlib import Path


WAIT = 300.0   # seconds without a report from the forked process (a figure takes 0.3-2 s) before it is ended


def run_jobs(jobs, workers=None) -> list:
    """The results of ``jobs`` (callables without arguments, each returning a list of paths),
    joined in the jobs' order; with ``workers`` (default: this process's cores) > 1 and fork
    available, two processes share them."""
    jobs = list(jobs)
    workers = _cores() if workers is None else workers
    if workers < 2 or len(jobs) < 2 or "fork" not in multiprocessing.get_all_start_methods():
        return [p for job in jobs for p in job()]
    context = multiprocessing.get_context("fork")
    taken = context.Value("i", 0)           # the next job not taken (its lock shared by both)
    mine, theirs = context.Pipe(duplex=False)
    child = context.Process(target=_child, args=(jobs, taken, mine, theirs, os.getpid()))
    child.start()
    theirs.close()
    done, ended = {}, False
    try:
        while (k := _take(taken, len(jobs))) is not None:
            done[k] = list(jobs[k]())
        while True:                           # what the forked process drew, as it reports it
            try:
                if not mine.poll(WAIT):       # nothing for WAIT seconds: it hangs; ended, its jobs done here
                    break
                k, paths = mine.recv()
            except (EOFError, OSError):       # it has ended (os._exit closes its end)
                ended = True
                break
            done[k] = [Path(p) for p in paths]
    finally:
        mine.close()
        if not ended:                         # an error or Ctrl-C here: it stops too
            child.kill()
        child.join()
    for k in range(len(jobs)):                # its failures and what it did not finish: here
        if k not in done:
            done[k] = jobs[k]()
    return [p for k in range(len(jobs)) for p in done[k]]


def prepare():
    """Import what every drawing uses (matplotlib's figure and Agg canvas, Pillow's writers, the
    default font file) before forking, so that the forked processes do not each import it
    (matplotlib without its docstrings' property tables: report/mpl_import.py)."""
    from .mpl_import import import_for_drawing

    import_for_drawing()
    from matplotlib.font_manager import FontProperties, findfont, get_font
    from PIL import Image

    Image.preinit()                          # Pillow's PNG and GIF writers
    get_font(findfont(FontProperties()))     # the font file, read once


def _take(taken, n):
    with taken.get_lock():
        k = taken.value
        if k >= n:
            return None
        taken.value = k + 1
        return k


def _child(jobs, taken, mine, theirs, parent):
    """The forked process: the next job not taken, until none is left; each one drawn reported
    (k, paths); a job that fails is left for the parent (which then meets its error).  As the
    optimiser's workers (errors.worker_process): Ctrl-C is the parent's (which kills it), and it
    dies with a parent killed by SIGKILL."""
    mine.close()
    try:
        from ..errors import worker_process

        worker_process(parent)
        while (k := _take(taken, len(jobs))) is not None:
            try:
                paths = jobs[k]()
            except Exception:   # noqa: BLE001 - drawn again by the parent, which raises it
                continue
            theirs.send((k, [str(p) for p in paths]))
    except BaseException:   # Ctrl-C, the parent gone: the parent draws what is missing, or stops
        pass
    finally:
        os._exit(0)


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1
