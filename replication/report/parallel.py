"""A report's independent figures drawn on several processes at once.

Drawing the case study's figures (two matplotlib figures, each written as PNG and SVG, and
one off-screen VTK render per GA run) takes about 2 s of one core: on a command given two
workers, that was a tenth of its time spent on one of them. :func:`run_figure_tasks` runs
such calls on a short-lived process pool of forked workers (they start in milliseconds and
inherit the loaded modules), or in this process, one after another, when:

* one worker is asked for, or there is at most one call;
* forking is not safe here: not Linux, or other threads run (see
  :func:`replication.casestudy.interrupts.quiet_worker_context`; a spawned worker would
  spend a second importing what a fork inherits);
* this process has loaded VTK's rendering (a forked child must not inherit the graphics
  state of a render window, EGL or Mesa, made by its parent), or VTK runs its parallel loops
  on threads of its own (an SMP backend other than ``Sequential``, which the PyPI wheel uses
  by default): writing or reading a mesh, which loads VTK's data and IO modules only, does
  not prevent a fork.

The figures are the same either way: each call writes its own files, atomically, and
returns what the report needs to know of it.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence
from typing import TypeVar

__all__ = ["fork_is_safe", "run_figure_tasks"]

T = TypeVar("T")


def fork_is_safe() -> bool:
    """Whether figure tasks may run in processes forked from this one (see the module notes)."""
    from replication.casestudy.interrupts import quiet_worker_context

    return _vtk_forks_safely() and quiet_worker_context().get_start_method() == "fork"


def _vtk_forks_safely() -> bool:
    """No render window can exist here, and VTK keeps no threads (see the module notes)."""
    if any(name.startswith(_RENDERING) for name in sys.modules):
        return False
    core = sys.modules.get("vtkmodules.vtkCommonCore")
    return core is None or core.vtkSMPTools.GetBackend() == "Sequential"


#: Modules whose presence means a render window may have been made in this process.
_RENDERING = ("vtkmodules.vtkRendering", "vtkmodules.vtkInteraction", "pyvista.plotting")


def run_figure_tasks(calls: Sequence[Callable[[], T]], *, workers: int = 1) -> list[T]:
    """Run independent figure-drawing calls; their results, in order.

    Parameters
    ----------
    calls : sequence of callables
        Picklable calls (module-level functions, or :func:`functools.partial` of them), each
        writing its own files. Put the longest first: the pool hands them out in order.
    workers : int
        Processes at most (the command's ``--workers``); 1 runs every call here.

    Notes
    -----
    Ctrl-C stops the pool as the GA's executors do (:func:`.casestudy.evaluate.executor`):
    the calls under way finish, the others are cancelled. An exception in a call is raised
    here.
    """
    if workers < 1:
        raise ValueError(f"workers must be a positive integer, got {workers!r}")
    if workers == 1 or len(calls) <= 1:
        return [call() for call in calls]
    from replication.kernels import release_threads

    release_threads()  # the idle threads of the kernels' pool would make a fork unsafe
    if not fork_is_safe():
        return [call() for call in calls]
    from replication.casestudy.evaluate import executor

    with executor("process", workers=min(workers, len(calls))) as pool:
        futures = [pool.submit(call) for call in calls]
        return [future.result() for future in futures]
