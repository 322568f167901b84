"""Helpers for the tests of processes that must die with their parent: a process's children as
seen by pgrep, and which of them are still there a while after it was killed."""
from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path


def children_of(proc, seconds=60.0) -> list:
    """The process ids of ``proc``'s children, waited for until at least one is seen (or
    ``seconds`` pass: then [])."""
    t0, children = time.monotonic(), []
    while not children and time.monotonic() - t0 < seconds:
        time.sleep(0.1)
        children = subprocess.run(["pgrep", "-P", str(proc.pid)], capture_output=True, text=True).stdout.split()
    return children


def still_there(pids, seconds=10.0) -> list:
    """Those of ``pids`` that are still running after up to ``seconds`` of waiting for them to go."""
    t0 = time.monotonic()
    while any(Path(f"/proc/{p}").exists() for p in pids) and time.monotonic() - t0 < seconds:
        time.sleep(0.05)
    return [p for p in pids if Path(f"/proc/{p}").exists()]


def kill_once_forked(code, settle=0.0, seconds=10.0) -> tuple:
    """Run ``code`` in a new Python process; once it has a child (and ``settle`` seconds more),
    kill it with SIGKILL.  (its children, those of them still there ``seconds`` later)."""
    proc = subprocess.Popen([sys.executable, "-c", code], start_new_session=True)
    try:
        children = children_of(proc)
        if children:
            time.sleep(settle)
    finally:
        proc.kill()
        proc.wait()
    return children, still_there(children, seconds)
