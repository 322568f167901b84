"""Progress of a long command on standard error: a bar with the rate and the time left on a
terminal, and, for a study whose output goes to a log file or a batch job's output (not a
terminal), a line with the same figures every ``EVERY_S`` seconds or ``EVERY_FRACTION`` of the
total, and at the end."""
from __future__ import annotations

import sys
import time

EVERY_S = 10.0
EVERY_FRACTION = 0.05


def duration(seconds: float) -> str:
    """``seconds`` as a person reads a time left: 42 s, 3 min 12 s, 2 h 03 min."""
    s = int(round(seconds))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {s % 3600 // 60:02d} min"


def progress_bar(what, log: bool = False, stream=None, clock=time.monotonic):
    """``show(done, total)`` for a run's progress: a bar on ``stream`` (standard error) when it is
    a terminal; otherwise log lines when ``log`` (a study), else None (nothing shown).  The rate
    is this run's: the items done since the first call over the time since then (items found
    done before, e.g. a resumed study's, do not count), and the time left is the items to do at
    that rate."""
    stream = stream if stream is not None else sys.stderr
    tty = stream.isatty()
    if not tty and not log:
        return None
    first, last = [], []   # (time, done) of the first call and of the last line written

    def figures(done, total, now):
        t0, d0 = first[0]
        pace = ""
        if done > d0 and now > t0:
            rate = (done - d0) / (now - t0)
            pace = f", {rate:.3g}/s" + (f", {duration((total - done) / rate)} left" if done < total else
                                        f", {duration(now - t0)} in all")
        return pace

    def show(done, total):
        now = clock()
        if not first:
            first.append((now, done))
        if tty:
            bar = "#" * round(30 * done / total) if total else ""
            end = "\n" if done == total else ""
            stream.write(f"\r{what} {done:>4}/{total} [{bar:<30}]{figures(done, total, now)}\x1b[K{end}")
        else:
            if last and done < total and now - last[0][0] < EVERY_S and done - last[0][1] < EVERY_FRACTION * total:
                return
            if last and done == last[0][1]:
                return   # nothing new since the last line (the end reported twice)
            last[:] = [(now, done)]
            share = f" ({100 * done / total:.1f} %)" if total else ""
            stream.write(f"{what} {done}/{total}{share}{figures(done, total, now)}\n")
        stream.flush()

    return show
