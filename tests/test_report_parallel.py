"""A report's figures drawn on several processes: same results, in order, and only where forking is safe."""

import functools
import os
import sys

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
import functools, json, os, sys
from replication.report.parallel import fork_is_safe, run_figure_tasks
from replication.io.vtk import write_vtp
from replication.surfaces import adt, random_cloud

write_vtp(adt(random_cloud(20, rng=1)), sys.argv[1])  # VTK's data and IO modules: no reason not to fork

def pid_and(value):
    return os.getpid(), value

calls = [functools.partial(pid_and, k) for k in range(3)]
safe, forked = fork_is_safe(), run_figure_tasks(calls, workers=2)
import threading
release = threading.Event()
other = threading.Thread(target=release.wait)
other.start()
with_thread, here = fork_is_safe(), run_figure_tasks(calls, workers=2)  # another thread: no fork
release.set()
other.join()
print(json.dumps([safe, os.getpid(), forked, with_thread, here, fork_is_safe()]))
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="figure workers are forked on Linux only")
def test_calls_run_on_forked_workers_when_that_is_safe(tmp_path):
    """In a fresh interpreter (one thread, VTK loaded to write a mesh, no rendering): the calls
    run in other processes, in order; while another thread runs, here (the test process
    itself may run pytest-xdist's threads, so this is checked in a process of its own)."""
    import json
    import subprocess

    command = [sys.executable, "-c", _FORKED, str(tmp_path / "s.vtp")]
    done = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    safe, parent, results, with_thread, here, safe_again = json.loads(done.stdout)
    assert safe and not with_thread and safe_again
    assert [value for _, value in results] == [0, 1, 2] == [value for _, value in here]
    assert parent not in {pid for pid, _ in results}
    assert {pid for pid, _ in here} == {parent}


def test_no_fork_once_vtk_rendering_is_loaded(monkeypatch):
    from replication.report.parallel import _RENDERING, _vtk_forks_safely

    for name in [m for m in sys.modules if m.startswith(_RENDERING)]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.delitem(sys.modules, "vtkmodules.vtkCommonCore", raising=False)
    assert _vtk_forks_safely()  # so that the check below can fail
    monkeypatch.setitem(sys.modules, "vtkmodules.vtkRenderingCore", object())
    assert not _vtk_forks_safely() and not fork_is_safe()
    done = run_figure_tasks([functools.partial(_pid_and, 1)] * 2, workers=2)
    assert {pid for pid, _ in done} == {os.getpid()}


def _vtk_core(backend):
    """A stand-in for ``vtkmodules.vtkCommonCore`` whose parallel loops use ``backend``."""
    smp = type("vtkSMPTools", (), {"GetBackend": staticmethod(lambda: backend)})
    return type("vtkCommonCore", (), {"vtkSMPTools": smp})


def test_no_fork_while_vtk_keeps_threads_of_its_own(monkeypatch):
    """VTK's state alone (the test process may run other threads, which forbid a fork anyway)."""
    from replication.report.parallel import _RENDERING, _vtk_forks_safely

    for name in [m for m in sys.modules if m.startswith(_RENDERING)]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "vtkmodules.vtkCommonCore", _vtk_core("Sequential"))
    assert _vtk_forks_safely()
    monkeypatch.setitem(sys.modules, "vtkmodules.vtkCommonCore", _vtk_core("STDThread"))
    assert not _vtk_forks_safely() and not fork_is_safe()
    monkeypatch.setitem(sys.modules, "vtkmodules.vtkCommonCore", _vtk_core("Sequential"))
    monkeypatch.setitem(sys.modules, "vtkmodules.vtkRenderingCore", object())
    assert not _vtk_forks_safely()


def test_an_error_in_a_call_is_raised_here():
    with pytest.raises(ZeroDivisionError):
        run_figure_tasks([functools.partial(divmod, 1, 0), functools.partial(_pid_and, 0)], workers=2)
