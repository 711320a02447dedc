"""Cutting a cloud into blocks for the parallel triangulator (k-d tree, numba).

Clouds of ``PARALLEL_MIN`` points or more are cut into 2^k blocks of about ``BLOCK_POINTS``
points (k at most 8) by a k-d tree whose cuts alternate between u and v, so blocks stay
compact: each cut is the median of the block's share of a fixed sample of the points, and
``coordinate <= cut`` goes left, so equal positions always share a block. The blocks depend
on the points only, never on the number of threads.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from replication import _numbacache
from replication.surfaces._threads import run

__all__ = [
    "BLOCK_POINTS",
    "PARALLEL_MIN",
    "SAMPLE_PER_BLOCK",
    "assign",
    "columns",
    "kd_cuts",
    "levels",
    "magnitude",
]

#: Clouds with at least this many points are triangulated in blocks, in parallel.
PARALLEL_MIN = 20_000
#: Target block size: small enough for the sweep's working set to stay in cache (measured:
#: 5 % less work per point than blocks of 125 000, 15 % less than one block of 1e6).
BLOCK_POINTS = 50_000
#: Points of the sample per block from which the cuts are chosen.
SAMPLE_PER_BLOCK = 256
_MAX_LEVELS = 8  # at most 256 blocks (leaf numbers fit a byte)
_CHUNKS = 4


def levels(n: int) -> int:
    """k for 2^k blocks of about ``BLOCK_POINTS`` points (0: one block)."""
    if n < PARALLEL_MIN:
        return 0
    return int(min(_MAX_LEVELS, max(1, round(np.log2(n / BLOCK_POINTS)))))


def kd_cuts(sample: np.ndarray, levels: int) -> np.ndarray:
    """Cut values of a complete k-d tree (heap order, node 1 the root; axis = depth % 2)."""
    cuts = np.zeros(2**levels)
    parts = {1: sample}
    for node in range(1, 2**levels):
        points = parts.pop(node)
        axis = (node.bit_length() - 1) % 2
        values = points[:, axis]
        middle = (values.size - 1) // 2
        cut = float(np.partition(values, middle)[middle]) if values.size else 0.0
        cuts[node] = cut
        below = points[:, axis] <= cut
        parts[2 * node] = points[below]
        parts[2 * node + 1] = points[~below]
    return cuts


@njit(cache=True, nogil=True)
def _leaves(pts, ua, va, cuts, levels, lo, hi, leaf, counts):
    """The k-d tree leaf of points lo..hi-1, and how many fall into each leaf."""
    blocks = 1 << levels
    for i in range(lo, hi):
        node = 1
        for depth in range(levels):
            value = pts[i, ua] if depth % 2 == 0 else pts[i, va]
            node = 2 * node + (value > cuts[node])
        leaf[i] = node - blocks
        counts[node - blocks] += 1


@njit(cache=True, nogil=True)
def _scatter(pts, ua, va, lo, hi, leaf, cursor, idx, xy):
    """Points lo..hi-1 to their blocks, in order: indices to ``idx``, (u, v) to ``xy``."""
    for i in range(lo, hi):
        k = cursor[leaf[i]]
        cursor[leaf[i]] = k + 1
        idx[k] = i
        xy[k, 0] = pts[i, ua]
        xy[k, 1] = pts[i, va]


def assign(points, axes, cuts, levels, idx, xy) -> np.ndarray:
    """Sort the points into the k-d tree's leaves, stably: indices into ``idx`` and (u, v)
    into ``xy``, block after block; return the blocks' starts.

    The cloud is read in order, in ``_CHUNKS`` fixed pieces on several threads (the result
    does not depend on the thread count), so the blocks' coordinates end up contiguous
    without random access to the large point array.
    """
    n = points.shape[0]
    blocks = 1 << levels
    ua, va = axes
    edges = [n * c // _CHUNKS for c in range(_CHUNKS + 1)]
    leaf = np.empty(n, dtype=np.uint8)
    counts = np.zeros((_CHUNKS, blocks), dtype=np.int64)
    run([
        (lambda c=c: _leaves(points, ua, va, cuts, levels, edges[c], edges[c + 1], leaf, counts[c]))
        for c in range(_CHUNKS)
    ])  # fmt: skip
    starts = np.zeros(blocks + 1, dtype=np.int64)
    np.cumsum(counts.sum(axis=0), out=starts[1:])
    cursor = starts[:-1] + np.cumsum(counts, axis=0) - counts  # chunk c starts after chunks < c
    run([
        (lambda c=c: _scatter(points, ua, va, edges[c], edges[c + 1], leaf, cursor[c], idx, xy))
        for c in range(_CHUNKS)
    ])  # fmt: skip
    return starts


@njit(cache=True, nogil=True)
def _peak(pts, ua, va, lo, hi, out, k):
    """The largest |u| and |v| of rows lo..hi-1, into ``out[k]``."""
    top = 0.0
    for i in range(lo, hi):
        top = max(top, abs(pts[i, ua]), abs(pts[i, va]))
    out[k] = top


def magnitude(points, axes) -> float:
    """The largest absolute (u, v) coordinate of a large cloud, read in ``_CHUNKS`` pieces on
    several threads (one pass, no temporary)."""
    n = points.shape[0]
    edges = [n * c // _CHUNKS for c in range(_CHUNKS + 1)]
    out = np.zeros(_CHUNKS)
    ua, va = int(axes[0]), int(axes[1])
    run([(lambda c=c: _peak(points, ua, va, edges[c], edges[c + 1], out, c)) for c in range(_CHUNKS)])
    return float(out.max())


@njit(cache=True, nogil=True)
def columns(pts, ua, va, idx, xy):
    """One block: every point in input order."""
    for i in range(pts.shape[0]):
        idx[i] = i
        xy[i, 0] = pts[i, ua]
        xy[i, 1] = pts[i, va]


_numbacache.refresh(globals())  # numba keys its cache on this file only (see replication._numbacache)
