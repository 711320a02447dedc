"""Output files of the surface commands: checked before any work, written all or none.

A command that writes a surface (``-o``) and the generated cloud (``--save-cloud``) checks
first that every output's directory exists and is writable, and that no output is the same
file as an input or as another output (:func:`replication.io.paths.check_distinct`); it
writes only after the work succeeded, and moves the outputs into place only when every one
is written: a failed or interrupted write leaves every output as it was before the command.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

from replication.errors import InputError

__all__ = ["check_outputs", "save_generated_cloud", "suffix_warning", "write_all_or_none"]


def check_outputs(args: argparse.Namespace) -> None:
    """Before any work: every output's directory exists and is writable, and no output is an
    input or another output.

    The outputs are ``-o/--output`` and ``--save-cloud``; the input is INPUT. A file is
    created and removed in each output's directory (:func:`~replication.io.paths.check_writable_dir`:
    permission bits say nothing for root or a read-only file system). Names are compared by
    resolved path and, for existing files, by device and inode (links too).
    """
    from replication.io import CLOUD_SUFFIXES
    from replication.io.atomic import check_output_path
    from replication.io.paths import check_distinct, check_writable_dir

    outputs = [("-o", getattr(args, "output", None)), ("--save-cloud", getattr(args, "save_cloud", None))]
    for _, path in outputs:
        if path:  # was found unwritable only when written, after all the work
            final = check_output_path(path)
            check_writable_dir(final.parent, f"cannot write {path}: the directory")
    cloud_file = getattr(args, "save_cloud", None)
    if cloud_file and Path(cloud_file).suffix.lower() not in CLOUD_SUFFIXES:
        raise InputError(
            f"--save-cloud {cloud_file}: unsupported point-cloud file type "
            f"{Path(cloud_file).suffix or '(none)'!r}; use one of {', '.join(CLOUD_SUFFIXES)}"
        )
    check_distinct(outputs, [("INPUT", getattr(args, "input", None))])


def check_format_suffix(path: str | None, fmt: str | None, names: dict[str, str]) -> None:
    """Refuse ``--format`` that contradicts the suffix of another of its formats: a ``.vtk``
    name for VTP, which ``force`` and every reader that goes by the suffix then misread."""
    suffix = Path(path).suffix.lower().lstrip(".") if path else ""
    if fmt and suffix in names and suffix != fmt:
        from replication.errors import UsageError

        raise UsageError(
            f"-o {path} names a .{suffix} file ({names[suffix]}), but --format {fmt} writes {names[fmt]}: "
            f"name it .{fmt}, or drop --format"
        )


def suffix_warning(path: str | None, fmt: str | None, names: dict[str, str]) -> None:
    """Warn when ``--format`` writes a file under a suffix of none of its formats (``.csv``, or none)."""
    if not path or not fmt:
        return
    suffix = Path(path).suffix.lower().lstrip(".")
    if suffix != fmt:
        where = f"under a .{suffix} name" if suffix else "under a name without a suffix"
        print(
            f"warning: {path} gets --format {fmt} ({names[fmt]}) {where}; "
            "programs that go by the suffix will misread it",
            file=sys.stderr,
        )


def save_generated_cloud(cloud: np.ndarray, args: argparse.Namespace, meta: dict[str, Any]) -> None:
    """Write the --save-cloud file (after the command's work succeeded) and note it in ``meta``."""
    if getattr(args, "save_cloud", None):
        from replication.io import save_cloud

        meta["cloud_file"] = args.save_cloud
        meta["cloud_bytes"] = save_cloud(cloud, args.save_cloud)


def write_all_or_none(*writers: tuple[str | None, Any]) -> list[Any]:
    """Run ``(path, write)`` pairs (``write`` writes ``path`` atomically); return their results.

    The files are moved into place only when every write succeeded
    (:func:`replication.io.atomic.all_or_none`): a failed or interrupted command leaves no new
    file, and every file that existed before it as it was. A pair whose path is None is
    skipped (its result is None).
    """
    from replication.io.atomic import all_or_none

    with all_or_none():
        return [None if path is None else write() for path, write in writers]
