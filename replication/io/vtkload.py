"""Imports of VTK and pyvista, with Ctrl-C and SIGTERM held until the modules are loaded.

VTK's compiled modules run Python code while they initialise (``vtkCommonCore`` imports
``vtkmodules.numpy_interface``), and Python runs its signal handlers there. A Ctrl-C, or a
SIGTERM taken as one (:mod:`replication.sigterm`), raised at that moment left the module half
built, and the interpreter crashed with a segmentation fault instead of reporting the
interrupt: no message, no clean-up, no "resume with" line. A timer's SIGINT 16-24 ms into
``from vtkmodules.util.numpy_support import numpy_to_vtk`` crashed 7 times in 9 on this
project's machine, and a SIGTERM 1.3 s into ``replication reproduce --quick`` (its first
``.vtp`` file) crashed 1 run in 40. So every import of VTK or pyvista in this package is
written inside :func:`vtk_imports`, which holds the interrupt until the block ends and then
raises it (:func:`replication.io.atomic.interrupt_deferred`); a test checks that none is
written outside one. Importing pyvista takes about a second, the longest an interrupt waits.

Notes
-----
Infrastructure for the ADT files of the paper's section 5 (item 5) and the figures of
sections 4 and 6; the paper itself says nothing about signals.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

from replication.io.atomic import interrupt_deferred

__all__ = ["vtk_imports"]


@contextlib.contextmanager
def vtk_imports() -> Iterator[None]:
    """Around imports of ``vtkmodules`` or ``pyvista``: a Ctrl-C or SIGTERM that arrives while
    they load is raised when the block ends (see the module notes)."""
    with interrupt_deferred():
        yield
