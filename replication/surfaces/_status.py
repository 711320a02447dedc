"""Outcomes of the sweep-hull triangulator's kernels.

They live apart from the kernels (:mod:`._sweephull`, which re-exports them) so that code
testing an outcome does not import numba: a command that runs on the ahead-of-time kernels
(:mod:`replication._aot`) never loads it.
"""

from __future__ import annotations

__all__ = [
    "SAFE_MAGNITUDE_HIGH",
    "SAFE_MAGNITUDE_LOW",
    "STATUS_COLLINEAR",
    "STATUS_OK",
    "STATUS_RANGE",
    "STATUS_SKIPPED",
    "out_of_range",
]

#: The block was triangulated.
STATUS_OK = 0
#: Fewer than three distinct points, or all of them on one line.
STATUS_COLLINEAR = 1
#: Rounding of a sort key defeated the sweep (a point sorted inside the hull): try again.
STATUS_SKIPPED = 2
#: The largest absolute coordinate lies outside [SAFE_MAGNITUDE_LOW, SAFE_MAGNITUDE_HIGH]: the
#: exact predicates multiply four coordinates, whose products would overflow (above about
#: 1e77) or underflow (below about 1e-77) there. The caller scales the cloud by a power of
#: two, exactly, and tries again (see :mod:`.delaunay`).
STATUS_RANGE = 3
SAFE_MAGNITUDE_LOW = 2.0**-128
SAFE_MAGNITUDE_HIGH = 2.0**128


def out_of_range(top: float) -> bool:
    """Whether a cloud whose largest absolute coordinate is ``top`` must be scaled first (the
    compiled one-call kernel makes the same test inline)."""
    return top != 0.0 and not SAFE_MAGNITUDE_LOW <= top <= SAFE_MAGNITUDE_HIGH
