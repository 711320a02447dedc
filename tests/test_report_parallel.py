"""A report's figures drawn on several processes: same results, in order, and only where forking is safe."""

import functools
import os
import sys
import threading

import pytest

from replication.report.parallel import fork_is_safe, run_figure_tasks


def _pid_and(value):
    return os.getpid(), value


def test_one_worker_runs_every_call_here_in_order():
    calls = [functools.partial(_pid_and, k) for k in range(4)]
    assert run_figure_tasks(calls, workers=1) == [(os.getpid(), k) for k in range(4)]
    assert run_figure_tasks([], workers=3) == []


@pytest.mark.parametrize("workers", [0, -2])
def test_bad_worker_counts_are_refused(workers):
    with pytest.raises(ValueError, match=f"got {workers}"):
        run_figure_tasks([], workers=workers)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="figure workers are forked on Linux only")
def test_calls_run_on_forked_workers_when_that_is_safe(monkeypatch):
    from replication.kernels import release_threads

    release_threads()  # the kernels' idle thread pool, started by earlier tests
    for name in [m for m in sys.modules if m == "vtkmodules" or m.startswith("vtkmodules.")]:
        monkeypatch.delitem(sys.modules, name)  # as in a command that has not rendered yet
    if threading.active_count() > 1:
        pytest.skip("another thread runs in this test process")
    assert fork_is_safe()
    done = run_figure_tasks([functools.partial(_pid_and, k) for k in range(3)], workers=2)
    assert [value for _, value in done] == [0, 1, 2]
    assert os.getpid() not in {pid for pid, _ in done}


def test_no_fork_once_vtk_is_loaded_or_another_thread_runs(monkeypatch):
    monkeypatch.setitem(sys.modules, "vtkmodules.vtkRenderingCore", object())
    assert not fork_is_safe()
    done = run_figure_tasks([functools.partial(_pid_and, 1)] * 2, workers=2)
    assert {pid for pid, _ in done} == {os.getpid()}
    monkeypatch.delitem(sys.modules, "vtkmodules.vtkRenderingCore")
    release = threading.Event()
    other = threading.Thread(target=release.wait)
    other.start()
    try:
        assert not fork_is_safe()
    finally:
        release.set()
        other.join()


def test_an_error_in_a_call_is_raised_here():
    with pytest.raises(ZeroDivisionError):
        run_figure_tasks([functools.partial(divmod, 1, 0), functools.partial(_pid_and, 0)], workers=2)
