"""Scratch directories in the system's temporary directory that a killed command does not leave.

A command killed outright (SIGKILL, a lost machine, the OOM killer) cannot remove its scratch
directory. Each is named with its writer's tag (:func:`replication.io.atomic.writer_tag`), so
the next command that makes one of the same kind removes those whose process has ended, on
this machine; another machine's (a shared temporary directory) and a running process's stay.
"""

from __future__ import annotations

import contextlib
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

from replication.io.atomic import writer_gone, writer_tag

__all__ = ["scratch_directory"]


@contextlib.contextmanager
def scratch_directory(prefix: str) -> Iterator[Path]:
    """A new directory ``<tmp>/<prefix><writer tag>...``, removed with its contents at the end;
    first, the directories of ``prefix`` abandoned by ended processes are removed."""
    base = Path(tempfile.gettempdir())
    for path in base.glob(f"{prefix}*"):
        if path.is_dir() and not path.is_symlink() and writer_gone(path.name[len(prefix) :]):
            shutil.rmtree(path, ignore_errors=True)
    path = Path(tempfile.mkdtemp(prefix=f"{prefix}{writer_tag()}", dir=base))
    try:
        yield path
    finally:
        shutil.rmtree(path, ignore_errors=True)
