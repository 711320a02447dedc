"""Exception and warning hierarchy of the package.

Every error the library raises on purpose derives from :class:`ReplicationError`, so
callers (and the command line, which turns them into a one-line message and a non-zero
exit status) can catch one type. Errors about the caller's data or parameters are
:class:`InputError` (also a :class:`ValueError`); problems writing results are
:class:`OutputError` (also an :class:`OSError`); an optional solver that is missing is
:class:`SolverUnavailableError` and a failed simulation :class:`SimulationError`.
"""

from __future__ import annotations

import errno

__all__ = [
    "CheckpointError",
    "CloudFileError",
    "CloudFileWarning",
    "DegenerateInputError",
    "DuplicatePointsWarning",
    "ExecutorError",
    "InputError",
    "JetResolutionWarning",
    "JetUnitsWarning",
    "OutputError",
    "ReplicationError",
    "ReportDataError",
    "SimulationError",
    "SolverUnavailableError",
    "UsageError",
    "escaped",
    "no_room",
    "shortened",
    "shown",
]


def shown(indices, limit: int = 10) -> str:
    """``"3, 7, 12, ..."``: the first ``limit`` indices for an error message."""
    items = [str(int(i)) for i in list(indices)[: limit + 1]]
    return ", ".join(items[:limit]) + (", ..." if len(items) > limit else "")


def escaped(text: str) -> str:
    """A message on one line: a line break or other control character inside it (a file name
    can hold one) is written as Python writes it in a string (``\\n``, ``\\x0b``, ``\\u2028``)."""
    return "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in text)


def shortened(name: object, head: int = 40, tail: int = 20) -> str:
    """A file name for a one-line message: a very long one keeps its first ``head`` and last
    ``tail`` characters (a 300-character name that the system refused filled the terminal)."""
    text = str(name)
    return text if len(text) <= head + tail + 3 else f"{text[:head]}...{text[-tail:]}"


class ReplicationError(Exception):
    """Base class of every error the package raises deliberately."""


class InputError(ReplicationError, ValueError):
    """Bad input data or parameters; the message names the bad value."""


class UsageError(InputError):
    """Options that cannot go together, or one given without the option it needs: a misused
    command line, which the command line answers with exit status 2, as argparse does."""


class CloudFileError(InputError):
    """A point-cloud or surface file that is missing, empty or malformed."""


class DegenerateInputError(InputError):
    """Geometry that admits no surface: too few distinct points, collinear points..."""


class OutputError(ReplicationError, OSError):
    """A result that cannot be written (for example a missing output directory)."""


#: System errors of a write that every later write to the same place would meet too.
_NO_ROOM = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EFBIG})


def no_room(exc: BaseException) -> bool:
    """Whether ``exc`` says results cannot be written at all: an :class:`OutputError`, or a
    system error of a full disk, a quota, a read-only file system or a file-size limit.

    Work that records a failure and carries on (an evaluation of the GA, a simulation of a
    study) must stop on such an error instead: every later result would fail the same way,
    and a failure recorded for it (the GA's worst fitness, a failed simulation in a report)
    would stand for the surface, not for the disk.
    """
    return isinstance(exc, OutputError) or (isinstance(exc, OSError) and exc.errno in _NO_ROOM)


class SolverUnavailableError(ReplicationError):
    """An optional solver is not installed; the message names the command that installs it."""


class SimulationError(ReplicationError):
    """A simulation that failed (blew up, timed out or crashed); the message gives the reason."""


class CheckpointError(InputError):
    """A GA run directory whose configuration or checkpoint is missing, malformed or inconsistent."""


class ReportDataError(InputError):
    """Saved report data (CSV/JSON under ``data/``) that are missing, malformed or incomplete."""


class ExecutorError(ReplicationError):
    """An executor that cannot be used (for example an unreachable dask scheduler)."""


class DuplicatePointsWarning(UserWarning):
    """Points that share a projected position were merged into one vertex."""


class CloudFileWarning(UserWarning):
    """A point-cloud file (or a frame's column names) read, but with a doubt worth telling
    the user about."""


class JetUnitsWarning(UserWarning):
    """A jet that misses a surface a hundred times larger or smaller than itself: most likely
    lengths in another unit than the one taken (millimetres for vertices, metres for the jet)."""


class JetResolutionWarning(UserWarning):
    """A jet whose streamlets are coarser than the surface under it: none strikes it, and its
    force of 0 N says nothing about the jet."""
