"""A study's Dask connection and its Ctrl-C: ``--scheduler`` at a port where something that is
not Dask listens (an HTTP server, a listener that never answers, one that answers arbitrary
bytes) is an error within dask's connect timeout, never a hang or a traceback; the first
Ctrl-C of a Dask study lets the batches in flight finish and journals them, as its message
says.  Every server here is a thread on loopback."""
from __future__ import annotations

import contextlib
import http.server
import json
import os
import signal
import socket
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from .util import JIB, ROOT

distributed = pytest.importorskip("distributed")


@contextlib.contextmanager
def listener(answer):
    """A TCP server thread on 127.0.0.1 that accepts and, for each connection, reads what comes
    and sends ``answer`` (bytes) once, or nothing if None, keeping the connection open; yields
    its tcp:// address."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    open_ = []

    def serve():
        while True:
            try:
                conn, _ = server.accept()
            except OSError:   # closed: the test is over
                return
            open_.append(conn)
            conn.settimeout(0.5)
            try:
                conn.recv(65536)
            except OSError:
                pass
            if answer is not None:
                with contextlib.suppress(OSError):
                    conn.sendall(answer)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{server.getsockname()[1]}"
    finally:
        server.close()
        for conn in open_:
            conn.close()
        thread.join(5)


@contextlib.contextmanager
def http_server():
    """An HTTP server (as Dask's dashboard port has) in a thread on 127.0.0.1."""
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), http.server.SimpleHTTPRequestHandler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{server.server_address[1]}"
    finally:
        server.shutdown()
        server.server_close()
        thread.join(5)


def study_at(address, tmp_path):
    """``optdesign study ... --scheduler ADDRESS`` with a 3 s connect timeout (dask's config
    from the environment); a hang fails the test at 90 s."""
    env = {**os.environ, "MPLBACKEND": "Agg", "DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT": "3s"}
    done = subprocess.run([sys.executable, "-m", "optdesign", "study", str(JIB), "--mode", "analyse", "--values",
                           "mC=100,200", "--scheduler", address, "--out", str(tmp_path / "s")], capture_output=True,
                          text=True, cwd=ROOT, env=env, timeout=90)
    return done.returncode, done.stderr


@pytest.mark.parametrize("kind, server, why", [
    ("silent listener", lambda: listener(None), "no answer from {address} in 3 s (distributed.comm.timeouts.connect)"),
    ("arbitrary bytes", lambda: listener(b"\xff" * 4096), "what answers at {address} is not a Dask scheduler"),
    ("HTTP reply", lambda: listener(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n"),
     "what answers at {address} is not a Dask scheduler"),
    ("HTTP server", http_server, None),
])
def test_a_scheduler_address_where_dask_does_not_answer_is_an_error_within_the_timeout(tmp_path, kind, server, why):
    with server() as address:
        code, err = study_at(address, tmp_path)
    assert code == 2, err
    assert "Traceback" not in err and err.count("\n") == 1, err
    assert err.startswith(f"optdesign study: error: --scheduler '{address}': cannot reach the Dask scheduler ("), err
    if why is not None:
        assert why.format(address=address) in err, err
    else:   # a real HTTP server: one of the two, depending on when it answers
        assert (f"no answer from {address} in 3 s" in err or f"what answers at {address} is not a Dask scheduler"
                in err), err
    assert not (tmp_path / "s" / "cases.csv").exists()


# --- Ctrl-C -------------------------------------------------------------------------------------------------
def test_the_first_ctrl_c_of_a_dask_study_lets_the_batches_in_flight_finish_and_journals_them(tmp_path):
    """The message says the cases in flight finish and are kept: the batches in flight at the
    Ctrl-C (the window: 2 per worker thread) are all journalled; none is cancelled."""
    import optdesign
    from optdesign.study import Study, values
    from optdesign.study.executors import _Dask
    from optdesign.study.results import StudyInterrupted

    n = 40
    study = Study(optdesign.load(JIB), [values("mC", [100.0 + 10 * i for i in range(n)])], mode="analyse")
    seen, submitted, real = [], [], _Dask.submit

    def submit(self, cases, tasks):
        submitted.extend(c.id for c in cases)
        return real(self, cases, tasks)

    def progress(done, total):
        seen.append(done)
        if done and len([d for d in seen if d]) == 1:
            os.kill(os.getpid(), signal.SIGINT)   # Ctrl-C, once the first cases are journalled

    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        with pytest.raises(StudyInterrupted) as caught:
            _Dask.submit = submit
            try:
                study.run(out=tmp_path, scheduler=cluster.scheduler_address, progress=progress, figures=False)
            finally:
                _Dask.submit = real
    ids = [json.loads(line)["id"] for line in (tmp_path / "journal.jsonl").read_text().splitlines()]
    journalled = len(ids)
    # every batch submitted (those that finished before the Ctrl-C was seen, and every one in flight then:
    # at most the window, 2 per worker thread) is journalled, none cancelled; nothing submitted after it
    assert sorted(ids) == sorted(submitted), (journalled, seen)
    assert f"{journalled} of {n} cases are finished and kept" in str(caught.value)
    assert len((tmp_path / "cases.csv").read_text().splitlines()) == 1 + journalled
