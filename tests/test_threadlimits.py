"""Thread limits: executor workers run with one BLAS thread and one kernel thread; numba's own
thread settings are untouched."""

import os
import socket
import sys

import pytest

from replication.casestudy.evaluate import executor
from replication.surfaces._threads import threads
from replication.threadlimits import BLAS_ENV, blas_threads, single_blas_thread


def _worker_state():
    """What an executor's worker runs with, after loading scipy's own BLAS (as ADT does)."""
    import numba
    import scipy.linalg  # noqa: F401 - a BLAS library loaded after the worker started

    from replication.surfaces._threads import threads

    return {
        "pid": os.getpid(),
        "blas": blas_threads(),
        "kernel threads": threads(),
        "numba": (numba.config.NUMBA_NUM_THREADS, numba.get_num_threads()),
        "env": {name: os.environ.get(name) for name in (*BLAS_ENV, "OMP_NUM_THREADS", "NUMBA_NUM_THREADS")},
    }


def _check_workers(states, parent_numba):
    for state in states:
        assert state["blas"], "no BLAS library found in the worker"
        assert set(state["blas"].values()) == {1}, state["blas"]
        assert state["kernel threads"] == 1  # a jet force is not split across threads there
        assert state["numba"] == parent_numba  # numba's own threading is left alone
        assert state["env"]["NUMBA_NUM_THREADS"] == os.environ.get("NUMBA_NUM_THREADS")


def _parent_numba():
    import numba

    return numba.config.NUMBA_NUM_THREADS, numba.get_num_threads()


def test_single_blas_thread_limits_and_restores():
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=2, user_api="blas"):
        before = blas_threads()
        with single_blas_thread():
            assert set(blas_threads().values()) == {1}
        assert blas_threads() == before  # restored, whatever the machine allowed


def test_port_fixture_really_occupies_8787(port_8787_taken):
    with socket.socket() as sock, pytest.raises(OSError):
        sock.bind(("127.0.0.1", port_8787_taken))


@pytest.mark.slow
def test_process_pool_workers_run_with_one_blas_thread():
    before = blas_threads()
    with executor("process", workers=2) as pool:
        states = [f.result() for f in [pool.submit(_worker_state) for _ in range(4)]]
    _check_workers(states, _parent_numba())
    assert threads() == _parent_numba()[1]  # the calling process keeps its kernel threads
    for state in states:  # later libraries and child processes start with one thread too
        assert all(state["env"][name] == "1" for name in BLAS_ENV)
        assert state["env"]["OMP_NUM_THREADS"] == os.environ.get("OMP_NUM_THREADS")
    assert blas_threads() == before  # the calling process keeps its pool


@pytest.fixture
def dask_without_default_env(port_8787_taken):
    """dask, with its nanny's default OPENBLAS_NUM_THREADS=1 for workers switched off."""
    pytest.importorskip("dask.distributed")
    import cloudpickle
    import dask

    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # workers cannot import tests/
    with dask.config.set({"distributed.nanny.pre-spawn-environ": {}}):
        yield
    cloudpickle.unregister_pickle_by_value(sys.modules[__name__])


@pytest.mark.slow
def test_dask_workers_run_with_one_blas_thread(dask_without_default_env):
    before = blas_threads()
    with executor("dask", workers=2) as pool:
        states = [f.result() for f in [pool.submit(_worker_state) for _ in range(4)]]
    _check_workers(states, _parent_numba())
    assert blas_threads() == before
