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


_FORKED = """
import functools, json, os
from replication.report.parallel import fork_is_safe, run_figure_tasks

def pid_and(value):
    return os.getpid(), value

calls = [functools.partial(pid_and, k) for k in range(3)]
print(json.dumps([fork_is_safe(), os.getpid(), run_figure_tasks(calls, workers=2)]))
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="figure workers are forked on Linux only")
def test_calls_run_on_forked_workers_when_that_is_safe():
    """In a fresh interpreter (one thread, no VTK): the calls run in other processes, in order."""
    import json
    import subprocess

    done = subprocess.run([sys.executable, "-c", _FORKED], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    safe, parent, results = json.loads(done.stdout)
    assert safe
    assert [value for _, value in results] == [0, 1, 2]
    assert parent not in {pid for pid, _ in results}


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
