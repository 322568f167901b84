"""A study's or a multistart's worker process computes with one BLAS thread (what Dask's nanny
gives its workers): CasADi's OpenBLAS, loaded by the first IPOPT solve in the worker or already
in the parent before the fork, reports one thread there; a number the user set is kept."""
from __future__ import annotations

import concurrent.futures as cf
import ctypes
import multiprocessing
import os

import casadi as ca
import pytest

from optdesign.errors import worker_process

LIB = os.path.join(os.path.dirname(ca.__file__), "libcasadi-tp-openblas.so.0")

pytestmark = pytest.mark.skipif((os.cpu_count() or 1) < 2 or not os.path.exists(LIB) or "fork" not in
                                multiprocessing.get_all_start_methods(),
                                reason="OpenBLAS starts one thread anyway on one core; CasADi without its OpenBLAS")


def _solved_threads():
    """OpenBLAS's thread count after an IPOPT solve in this process."""
    x = ca.SX.sym("x", 2)
    solver = ca.nlpsol("s", "ipopt", {"x": x, "f": (x[0] - 1) ** 2 + (x[1] - 2) ** 4},
                       {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes"})
    solver(x0=[0, 0])
    return ctypes.CDLL(LIB, mode=os.RTLD_NOLOAD).openblas_get_num_threads()


def _in_worker(fn, env=None):
    ctx = multiprocessing.get_context("fork")
    old = {k: os.environ.get(k) for k in (env or {})}
    os.environ.update(env or {})
    try:
        with cf.ProcessPoolExecutor(1, mp_context=ctx, initializer=worker_process, initargs=(os.getpid(),)) as pool:
            return pool.submit(fn).result(timeout=120)
    finally:
        for k, v in old.items():
            os.environ.pop(k) if v is None else os.environ.__setitem__(k, v)


def _unset_threads_in_parent():
    """This process's count after a solve, the thread variables unset (Python's default: the machine's cores)."""
    for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.pop(k, None)
    return _solved_threads()


def test_a_worker_has_one_blas_thread_whether_or_not_its_parent_loaded_openblas():
    # in a fresh process (nothing loaded, no thread variables set): the parent's own count is the
    # machine's (so the worker's 1 is the worker's doing), then the worker's.  Spawned, not forked:
    # a fork of this process would inherit an OpenBLAS an earlier test loaded here with one thread
    # (seen under xdist: the parent's count was 1, whatever its variables)
    ctx = multiprocessing.get_context("spawn")
    with cf.ProcessPoolExecutor(1, mp_context=ctx) as outer:   # a plain process: no initializer
        assert outer.submit(_in_worker, _solved_threads, {}).result(timeout=120) == 1
        parent_had = outer.submit(_unset_threads_in_parent).result(timeout=120)
    assert parent_had > 1
    assert _in_worker(_solved_threads) == 1   # this process may have loaded it: told directly


def _user_set_two():
    return _in_worker(_solved_threads, {"OPENBLAS_NUM_THREADS": "2"})


def test_a_thread_count_the_user_set_is_kept():
    # from a fresh process, as the user's variable is there before anything loads OpenBLAS (this
    # process may have loaded it with another count: a fork of it would keep that one)
    with cf.ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as outer:
        assert outer.submit(_user_set_two).result(timeout=120) == 2
