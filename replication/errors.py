"""Exception and warning hierarchy of the package.

Every error the library raises on purpose derives from :class:`ReplicationError`, so
callers (and the command line, which turns them into a one-line message and a non-zero
exit status) can catch one type. Errors about the caller's data or parameters are
:class:`InputError` (also a :class:`ValueError`); problems writing results are
:class:`OutputError` (also an :class:`OSError`).
"""

from __future__ import annotations

__all__ = [
    "ReplicationError",
    "InputError",
    "CloudFileError",
    "DegenerateInputError",
    "OutputError",
    "DuplicatePointsWarning",
]


class ReplicationError(Exception):
    """Base class of every error the package raises deliberately."""


class InputError(ReplicationError, ValueError):
    """Bad input data or parameters; the message names the bad value."""


class CloudFileError(InputError):
    """A point-cloud or surface file that is missing, empty or malformed."""


class DegenerateInputError(InputError):
    """Geometry that admits no surface: too few distinct points, collinear points..."""


class OutputError(ReplicationError, OSError):
    """A result that cannot be written (for example a missing output directory)."""


class DuplicatePointsWarning(UserWarning):
    """Points that share a projected position were merged into one vertex."""
