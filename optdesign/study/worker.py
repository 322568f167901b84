"""A study's cases on a Dask worker, computed in a helper process of that worker.

A Dask worker runs its tasks in a thread of a process whose event loop, heartbeats, memory
monitor and statistical profiler (every 10 ms) wake other threads all the time; each wake-up
takes the GIL from the thread that computes.  CasADi holds the GIL through its calls, so the
computing thread is stopped and handed the GIL back again and again, and on a busy machine each
hand-over waits for a core: the cases of a study ran 1.3-1.9 times slower inside Dask workers
than in the local process pool (median time per case, measured on the 2-core machine of
results/bench.md, whatever the batch size).  So the task only forwards its batch to a helper
process started by the worker (one per batch running at the same time, kept for the worker's
life: it builds the scene's model once, as a pool worker does; :func:`prestart` starts them
before the first batch) and waits on the pipe, which releases the GIL.

The helper is a plain subprocess (Dask workers are daemonic processes, which multiprocessing
does not let have children) speaking length-prefixed pickles over its stdin and a duplicate of
its stdout; whatever the computation prints goes to stderr.  It exits when the worker goes
(end of its input).  A case's numbers do not depend on where it runs (:mod:`.tasks`).

What the worker's own process spends stays small: a batch of analyse cases comes back from the
helper pickled, and the worker passes those bytes on to the client as they are (not unpickled
and pickled again: :func:`pickled_blocks_in_helper`); and while its batches wait on their
helpers, the worker's statistical profiler is paused (:func:`profiler_paused`).
"""
from __future__ import annotations

import atexit
import contextlib
import gc
import os
import pickle
import signal
import struct
import subprocess
import sys
import threading
import traceback
from pathlib import Path

_IDLE = []                   # this worker's helpers not computing now
_GUARD = threading.Lock()
_HEADER = struct.Struct("<QQ")   # a message's lengths: its pickle, its raw bytes (_send)
_PAUSED = {"tasks": 0, "stopped": False}   # this worker's batches waiting on helpers; profiler stopped by us


def blocks_in_helper(tasks, index: list, ids: list) -> list:
    """The blocks of a batch (:func:`.executors.computed`'s) made in a helper process of this
    worker: a batch of analyse cases is analysed together and its blocks, their journal text
    made, come back in one message (the worker's own process only passes them on); other
    batches case by case (:func:`run_batch_in_helper`).  A helper that dies on a batch of
    analyse cases is replaced and the cases are run one per call, as there."""
    payload = pickle.dumps((tasks, index, ids), protocol=pickle.HIGHEST_PROTOCOL)
    made = pickled_blocks_in_helper(payload, together(tasks))
    return pickle.loads(made) if isinstance(made, (bytes, bytearray)) else made


def together(tasks) -> bool:
    """Whether a batch's cases are analysed together in one message (analyse cases; a batch's
    tasks share their mode)."""
    return len(tasks) > 1 and tasks[0].mode == "analyse"


def pickled_blocks_in_helper(payload: bytes, together: bool):
    """:func:`blocks_in_helper` of the batch pickled in ``payload`` (``(tasks, index, ids)``, as
    the client pickled it: one bytes object, which Dask neither walks nor pickles again), a
    batch of analyse cases (``together``) handed to the helper as those bytes and its blocks
    left as the helper pickled them (a bytearray, read from the helper's pipe straight into it:
    the client unpickles them; the worker's process neither unpickles nor pickles the batch or
    its blocks, and Dask sends a bytearray on without a copy), other batches' blocks as a list."""
    from .blocks import blocks

    if together:
        helper = _take()
        try:
            _send(helper.stdin, "blocks", raw=payload)
            kind, value, made = _receive(helper.stdout)
        except (OSError, EOFError, pickle.UnpicklingError):
            helper.kill()
            helper.wait()   # which case died is not known yet: each alone
            tasks, index, ids = pickle.loads(payload)
            return lines_made(blocks(index, ids, run_batch_in_helper(tasks, alone=True)))
        _give(helper)
        if kind == "error":
            raise RuntimeError(f"a case failed in the study's helper process:\n{value}")
        return made
    tasks, index, ids = pickle.loads(payload)
    return lines_made(blocks(index, ids, run_batch_in_helper(tasks)))


@contextlib.contextmanager
def profiler_paused():
    """The Dask worker's statistical profiler paused while batches of a study wait here on their
    helpers.  Every 10 ms (``distributed.worker.profile.interval``) it wakes the worker's event
    loop and walks the stack of each running task's thread; a study's task only waits on its
    helper's pipe, so it learns nothing, and it cost each worker process ~2.5 % of a core, taken
    from the helpers' cores (4.8 % with it, 2.2 % without, a worker waiting on a task that
    sleeps; measured on the 2-core machine of results/scaling.md).  It is resumed as soon as no
    batch of a study runs on the worker; outside a Dask worker this does nothing."""
    try:
        from distributed import get_worker

        worker = get_worker()
        profile = worker.periodic_callbacks.get("profile")
    except (ImportError, ValueError, AttributeError):   # not in a Dask worker's task
        profile = None
    if profile is None:
        yield
        return
    with _GUARD:
        _PAUSED["tasks"] += 1
        if _PAUSED["tasks"] == 1:
            _on_loop(worker, _pause, profile)
    try:
        yield
    finally:
        with _GUARD:
            _PAUSED["tasks"] -= 1
            if not _PAUSED["tasks"]:
                _on_loop(worker, _resume, profile)


def _on_loop(worker, step, profile):
    """``step(profile)`` on the worker's event loop (periodic callbacks belong to its thread)."""
    try:
        worker.loop.add_callback(step, profile)
    except RuntimeError:   # the loop is closed: the worker is going, and its profiler with it
        pass


def _pause(profile):
    if profile.is_running():
        profile.stop()
        _PAUSED["stopped"] = True


def _resume(profile):
    if _PAUSED["stopped"] and not _PAUSED["tasks"]:
        _PAUSED["stopped"] = False
        profile.start()


def lines_made(made: list) -> list:
    for block in made:
        block.journal()
    return made


def blocks_made(tasks, index: list, ids: list) -> list:
    """The batch's blocks with their text made (:func:`.tasks.batch_blocks`) where it runs (a
    pool's process, a Dask worker's helper), which then settles (:func:`.tasks.settle`)."""
    from .tasks import batch_blocks, settle

    with collector_paused() if together(tasks) else contextlib.nullcontext():
        made = lines_made(batch_blocks(tasks, index, ids))
    settle()
    return made


@contextlib.contextmanager
def collector_paused():
    """Python's cyclic garbage collector off while a batch of analyse cases computes (where the
    batch runs: a pool's process, a Dask worker's helper), as it was after.  Such a batch makes
    ~20 container objects per case (rows, dicts, lists) that reference counting frees; each 700
    of them set off a collection (the older generations' now and then), 2-3 % of the
    batch's processor time (py-spy, truck crane, 1,536 cases).  What a batch leaves in cycles
    (an exception's traceback) is collected after it, as before."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def run_batch_in_helper(tasks: list, alone: bool = False) -> list:
    """:func:`.tasks.run_batch` in a helper process of this worker (one per batch running at the
    same time; each kept for the worker's life).  The helper sends each case's output as it
    finishes; a helper that dies (killed, out of memory, crashed) is replaced and the batch
    goes on from the case it was computing, warm-started as before; a case whose helper died
    ``MAX_DEATHS`` times is recorded as failed with the reason."""
    from .tasks import died_output, warm_from

    outs, deaths = [], 0
    while len(outs) < len(tasks):
        # after a death that no case's output preceded (a batch of analyse cases run together
        # gives them all at its end), the rest one case per call: the case that dies is known
        rest = list(tasks[len(outs):len(outs) + 1 if alone else len(tasks)])
        if outs:
            rest[0] = warm_from(rest[0], outs[-1])
        helper, done = _take(), len(outs)
        try:
            _send(helper.stdin, "batch", rest)
            kind, value, _ = _receive(helper.stdout)
            while kind == "case":
                outs.append(value)
                kind, value, _ = _receive(helper.stdout)
        except (OSError, EOFError, pickle.UnpicklingError):
            helper.kill()
            code = helper.wait()
            if len(rest) > 1 and len(outs) == done and not alone and all(t.mode == "analyse" for t in rest):
                alone = True   # which case died is not known yet
                continue
            deaths = 1 if len(outs) > done else deaths + 1   # of the case it was computing
            if deaths >= MAX_DEATHS:
                outs.append(died_output(f"the study's helper process computing this case on a Dask worker died "
                                        f"{deaths} times ({_how(code)}); it is not tried again"))
                deaths = 0
            continue
        _give(helper)
        if kind == "error":
            raise RuntimeError(f"a case failed in the study's helper process:\n{value}")
    return outs


MAX_DEATHS = 3   # a case whose process died this many times is recorded as failed (also the pool's)


def _how(code) -> str:
    if code is not None and code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit status {code}"


def prestart(count: int) -> int:
    """Have ``count`` helpers ready on this worker before its first batch (they start Python and
    import CasADi and optdesign while the client prepares the study).  Returns how many run."""
    with _GUARD:
        _IDLE[:] = [h for h in _IDLE if h.poll() is None]
        while len(_IDLE) < count:
            _IDLE.append(_start())
        return len(_IDLE)


def _take():
    with _GUARD:
        while _IDLE:
            helper = _IDLE.pop()
            if helper.poll() is None:
                return helper
    return _start()


def _give(helper):
    with _GUARD:
        _IDLE.append(helper)


@atexit.register
def _close_idle(timeout: float = 2.0):
    """At the worker's exit: each idle helper's pipes closed (it ends at the end of its input)
    and the helper waited for, killed if it has not ended within ``timeout`` s; none left
    running behind the worker, nor its pipes left to the garbage collector."""
    with _GUARD:
        helpers, _IDLE[:] = list(_IDLE), []
    for helper in helpers:
        for stream in (helper.stdin, helper.stdout):
            with contextlib.suppress(OSError):
                stream.close()
        try:
            helper.wait(timeout)
        except subprocess.TimeoutExpired:
            helper.kill()
            helper.wait()


def _start():
    from ..errors import KEEP_MEMORY

    env = dict(os.environ)
    root = str(Path(__file__).resolve().parents[2])   # this optdesign, installed or not
    env["PYTHONPATH"] = root + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    # Dask starts its workers with MALLOC_TRIM_THRESHOLD_=65536 (memory back to the system at
    # once): CasADi's and numpy's many small allocations then cost a case 20-25 % more; the
    # helper keeps what a batch frees for the next one, as a pool's process (errors.KEEP_MEMORY)
    env.pop("MALLOC_TRIM_THRESHOLD_", None)
    if not any(name in env for name in KEEP_MEMORY):
        env.update({name: str(value) for name, value in KEEP_MEMORY.items()})
    return subprocess.Popen([sys.executable, "-m", "optdesign.study.worker"], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, env=env)


def _send(stream, kind: str, value=None, raw=b""):
    """A message on a helper's pipe: the lengths of its two parts, ``(kind, value)`` pickled, and
    ``raw`` bytes as they are (a batch pickled by the client, a batch's blocks pickled by the
    helper: ~5 MB for a truck-crane batch of 1 s, written from where they lie, not pickled again
    into the message nor joined to its header)."""
    data = pickle.dumps((kind, value), protocol=pickle.HIGHEST_PROTOCOL)
    stream.write(_HEADER.pack(len(data), len(raw)) + data)
    if raw:
        stream.write(raw)
    stream.flush()


def _receive(stream):
    """``(kind, value, raw)`` of a message of :func:`_send`; ``raw`` read into one bytearray
    (what Dask sends on as it is), None if there was none."""
    header = stream.read(_HEADER.size)
    if len(header) < _HEADER.size:
        raise EOFError("end of stream")
    size, raw_size = _HEADER.unpack(header)
    data = stream.read(size)
    if len(data) < size:
        raise EOFError("end of stream")
    raw = None
    if raw_size:
        raw = bytearray(raw_size)
        if stream.readinto(raw) < raw_size:
            raise EOFError("end of stream")
    return (*pickle.loads(data), raw)


def serve():
    """The helper: batches in, outputs out, until its input ends."""
    from .tasks import run_batch

    signal.signal(signal.SIGINT, signal.SIG_IGN)   # Ctrl-C is the client's to handle (as in the pool)
    from ..design import multistart, problem, repair   # noqa: F401  (what the first case needs,
    from ..model import analysis   # noqa: F401          imported before it comes)
    out = os.fdopen(os.dup(1), "wb")   # the answers' channel; prints of the computation go to stderr
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    inp = sys.stdin.buffer
    while True:
        try:
            kind, tasks, payload = _receive(inp)
        except EOFError:
            return
        try:
            if kind == "blocks":   # the batch's blocks in one message, pickled for the client
                made = blocks_made(*pickle.loads(payload))   # (executors.computed's)
                answer = ("blocks", None, pickle.dumps(made, protocol=pickle.HIGHEST_PROTOCOL))
            else:   # each case's output as it finishes, then the end of the batch
                run_batch(tasks, each=lambda output: _send(out, "case", output))
                answer = ("end", None, b"")
        except BaseException:   # noqa: BLE001 - a bug: its traceback goes back to the worker
            answer = ("error", traceback.format_exc(), b"")
        _send(out, *answer)


if __name__ == "__main__":
    serve()
