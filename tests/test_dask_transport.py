"""How a study's batches and results travel on Dask (optdesign.study.worker, executors._Dask):
a message on a helper's pipe gives back its kind, value and raw bytes exactly (a raw part of
megabytes read whole, in one bytearray, also when the pipe hands it over in pieces; an
end of stream inside a message is an EOFError), and a client of a study's own gathers results
straight from the workers only if it can reach every one of them."""
from __future__ import annotations

import os
import pickle
import socket
import threading

import pytest

from optdesign.study import worker


def _through_pipe(messages):
    """``messages`` (args of worker._send) written into an OS pipe by a thread, read back here."""
    r, w = os.pipe()
    with os.fdopen(r, "rb") as inp, os.fdopen(w, "wb") as out:
        def write():
            for args in messages:
                worker._send(out, *args)
            out.close()

        t = threading.Thread(target=write)
        t.start()
        got = []
        try:
            while True:
                got.append(worker._receive(inp))
        except EOFError:
            pass
        t.join()
    return got


def test_messages_come_back_with_their_kind_value_and_raw_bytes():
    raw = os.urandom(5_000_003)   # larger than a pipe's buffer: written and read in pieces
    value = {"x": [0.1, 1 / 3, float("inf")], "s": "é"}
    got = _through_pipe([("case", value), ("blocks", None, raw), ("end", None), ("blocks", (1, 2), b"x")])
    assert [g[0] for g in got] == ["case", "blocks", "end", "blocks"]
    assert got[0][1] == value and got[0][2] is None
    assert got[1][1] is None and isinstance(got[1][2], bytearray) and bytes(got[1][2]) == raw
    assert got[2][1:] == (None, None)
    assert got[3][1:] == ((1, 2), bytearray(b"x"))


def test_a_stream_that_ends_inside_a_message_is_the_end_of_the_stream():
    data = pickle.dumps(("blocks", None))
    whole = worker._HEADER.pack(len(data), 1000) + data + bytes(1000)
    for cut in (0, 3, worker._HEADER.size, worker._HEADER.size + len(data), len(whole) - 1):
        r, w = os.pipe()
        os.write(w, whole[:cut])
        os.close(w)
        with os.fdopen(r, "rb") as inp, pytest.raises(EOFError):
            worker._receive(inp)
    r, w = os.pipe()
    os.write(w, whole)
    os.close(w)
    with os.fdopen(r, "rb") as inp:
        kind, value, raw = worker._receive(inp)
    assert (kind, value, bytes(raw)) == ("blocks", None, bytes(1000))


def test_results_come_straight_from_the_workers_only_if_every_worker_answers_here():
    pytest.importorskip("distributed")
    from optdesign.study.executors import _Dask

    listening = socket.socket()
    listening.bind(("127.0.0.1", 0))
    listening.listen()
    closed = socket.socket()
    closed.bind(("127.0.0.1", 0))   # bound, not listening: a connection is refused
    try:
        up = f"tcp://127.0.0.1:{listening.getsockname()[1]}"
        down = f"tcp://127.0.0.1:{closed.getsockname()[1]}"
        dask = _Dask.__new__(_Dask)
        dask.reached = {}
        assert dask._reachable([up]) is True
        assert dask._reachable([up, down]) is False
        assert dask.reached == {up: True, down: False}
        assert dask._reachable(["inproc://127.0.0.1/1/2"]) is False   # not tcp: Dask's relay kept
        assert dask._reachable([]) is True
    finally:
        listening.close()
        closed.close()


def test_a_study_client_on_a_loopback_cluster_gathers_from_its_workers():
    distributed = pytest.importorskip("distributed")
    from optdesign.study.executors import _Dask

    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False, host="127.0.0.1",
                                  protocol="tcp://", dashboard_address=":0") as cluster:
        dask = _Dask(cluster.scheduler_address)
        try:
            assert dask.client.direct_to_workers is True
            assert list(dask.reached) == list(cluster.scheduler_info["workers"])
        finally:
            dask.close()
        given = distributed.Client(cluster)
        try:   # a Client handed to the study is the caller's: left as it is
            dask = _Dask(given)
            assert given.direct_to_workers is None and dask.reached == {}
            dask.close()
        finally:
            given.close()


def test_idle_helpers_end_with_their_worker():
    # at exit (atexit), every idle helper gets the end of its input, ends by itself, and its
    # pipes are closed: no process left behind, no "subprocess is still running" warning
    from optdesign.study import worker

    assert worker.prestart(1) >= 1
    helpers = list(worker._IDLE)
    # time to end by itself: a helper reads its input only after its imports, which take
    # longer than _close_idle's 2 s at load ~10 (killed then: returncode -9)
    worker._close_idle(timeout=120)
    assert worker._IDLE == []
    for helper in helpers:
        assert helper.returncode == 0   # it ended at the end of its input, not killed
        assert helper.stdin.closed and helper.stdout.closed
