"""Outcomes of the sweep-hull triangulator's kernels.

They live apart from the kernels (:mod:`._sweephull`, which re-exports them) so that code
testing an outcome does not import numba: a command that runs on the ahead-of-time kernels
(:mod:`replication._aot`) never loads it.
"""

from __future__ import annotations

__all__ = ["STATUS_COLLINEAR", "STATUS_OK", "STATUS_SKIPPED"]

#: The block was triangulated.
STATUS_OK = 0
#: Fewer than three distinct points, or all of them on one line.
STATUS_COLLINEAR = 1
#: Rounding of a sort key defeated the sweep (a point sorted inside the hull): try again.
STATUS_SKIPPED = 2
