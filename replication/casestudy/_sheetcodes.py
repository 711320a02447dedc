"""Codes shared by the water-jet model's compiled kernels (:mod:`._sheet`) and their callers.

Kept apart from the kernels so that reading a result (:mod:`.jet`) does not import numba: a
single force runs the kernels compiled ahead of time (:mod:`replication._aot`).
"""

from __future__ import annotations

__all__ = [
    "BOUNDARY",
    "ROW_FORCE",
    "ROW_OUT",
    "ROW_SIZE",
    "ROW_TALLY",
    "SYMMETRY",
    "TALLY_MASS_HIT",
    "TALLY_MASS_OUT",
    "TALLY_MASS_TRAPPED",
    "TALLY_PARCELS",
    "TALLY_SIZE",
    "TALLY_STREAMLETS_HIT",
]

#: Neighbour codes: the edge of the surface, and an edge on the half jet's symmetry plane.
BOUNDARY = -1
SYMMETRY = -2

#: Layout of a row of the tally array that :func:`._sheet.trace` fills (one row per streamlet).
TALLY_MASS_HIT, TALLY_MASS_OUT, TALLY_MASS_TRAPPED, TALLY_PARCELS, TALLY_STREAMLETS_HIT = range(5)
TALLY_SIZE = 5

#: Columns of a streamlet's row in the array :func:`._sheet.trace` fills: its force (3), the
#: momentum flux it carries away (3) and its tally.
ROW_FORCE, ROW_OUT, ROW_TALLY = 0, 3, 6
ROW_SIZE = ROW_TALLY + TALLY_SIZE
