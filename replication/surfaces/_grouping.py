"""Hash grouping of exactly equal (u, v) bit patterns in O(n) (numba), for :mod:`.duplicates`."""

from __future__ import annotations

import numpy as np
from numba import njit

from replication import _numbacache

__all__ = []

_M1 = np.uint64(0x9E3779B97F4A7C15)
_M2 = np.uint64(0xC2B2AE3D27D4EB4F)
_SHIFT = np.uint64(31)


@njit(cache=True)
def _group_bits(ubits, vbits):
    n = ubits.shape[0]
    size = 1
    while size < 2 * n:
        size *= 2
    mask = np.uint64(size - 1)
    table = np.full(size, -1, dtype=np.int64)  # slot -> group id
    group = np.empty(n, dtype=np.int64)
    first = np.empty(n, dtype=np.int64)
    n_groups = 0
    for i in range(n):
        h = ubits[i] * _M1 ^ vbits[i] * _M2
        h ^= h >> _SHIFT
        slot = h & mask
        while True:
            g = table[slot]
            if g == -1:
                table[slot] = n_groups
                group[i] = n_groups
                first[n_groups] = i
                n_groups += 1
                break
            j = first[g]
            if ubits[j] == ubits[i] and vbits[j] == vbits[i]:
                group[i] = g
                break
            slot = (slot + np.uint64(1)) & mask
    return group, first[:n_groups].copy()


_numbacache.refresh(globals())  # numba keys its cache on this file only (see replication._numbacache)
