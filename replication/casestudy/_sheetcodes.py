"""Codes shared by the water-jet model's compiled kernels (:mod:`._sheet`) and their callers.

Kept apart from the kernels so that reading a result (:mod:`.jet`) does not import numba: a
single force runs the kernels compiled ahead of time (:mod:`replication._aot`).
"""

from __future__ import annotations

__all__ = [
    "BOUNDARY",
    "SYMMETRY",
    "TALLY_MASS_HIT",
    "TALLY_MASS_OUT",
    "TALLY_MASS_TRAPPED",
    "TALLY_PARCELS",
    "TALLY_STREAMLETS_HIT",
]

#: Neighbour codes: the edge of the surface, and an edge on the half jet's symmetry plane.
BOUNDARY = -1
SYMMETRY = -2

#: Layout of the tally array returned by :func:`._sheet.trace`.
TALLY_MASS_HIT, TALLY_MASS_OUT, TALLY_MASS_TRAPPED, TALLY_PARCELS, TALLY_STREAMLETS_HIT = range(5)
