"""The sweep-hull triangulation pipeline: blocks, duplicate detection, two cores, merges.

Steps, for the projected coordinates (u, v) of n points (two columns of a point array):

1. **Blocks.** Below ``PARALLEL_MIN`` points the cloud is one block. Larger clouds are cut
   into 2^k blocks of about ``BLOCK_POINTS`` points (k at most 8) by a k-d tree whose cuts alternate
   between u and v (so blocks stay compact): each cut is the median of the block's share of
   a fixed sample of the points, and ``coordinate <= cut`` goes left, so equal positions
   always share a block. The blocks depend on the points only, never on the number of
   threads: the triangulation is the same whatever the thread count.
2. **Sort and duplicates.** Each block's points are copied to a small contiguous array and
   sorted by squared distance from the circumcentre of an empty-circle seed triangle
   (numpy's argsort). Equal positions have equal keys, so only runs of equal keys need a
   look: that finds every duplicate without hashing or sorting rows. The distinct points are
   copied, in sweep order, into one shared (n, 2) coordinate array.
3. **Sweep** (:func:`._sweephull.sweep`) of each block into shared triangle and half-edge
   arrays; blocks run on the threads of a small pool (the kernels release the GIL).
4. **Merges** (:mod:`._mergehull`) up the k-d tree, sibling merges in parallel; then the
   compaction, and the mapping of vertex positions back to input indices and of half-edges
   to neighbour triangles.

Indices are int32 (half-edge ids reach 6 n: up to 357 million points; int64 beyond). When
rounding of a sort key defeats the sweep (a point sorted inside the hull) or a block is
collinear, the cloud is triangulated again as one block; when that fails too the caller
falls back to Qhull.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from replication.surfaces import _mergehull, _sweephull
from replication.surfaces._threads import run as _run

__all__ = ["BLOCK_POINTS", "PARALLEL_MIN", "Triangulation", "triangulate"]

#: Clouds with at least this many points are triangulated in blocks, in parallel.
PARALLEL_MIN = 20_000
#: Target block size: small enough for the sweep's working set to stay in cache (measured:
#: 5 % less work per point than blocks of 125 000, 15 % less than one block of 1e6).
BLOCK_POINTS = 50_000
_MAX_LEVELS = 8  # at most 256 blocks
_SAMPLE_PER_BLOCK = 256
_CHUNKS = 4
_INT32_MAX_POINTS = (2**31 - 1) // 6 - 16


@dataclass(frozen=True, eq=False)
class Triangulation:
    """Output of :func:`triangulate` (index arrays of one dtype, int32 unless huge).

    ``triangles`` (m, 3) are counter-clockwise input indices of distinct points;
    ``neighbors[t, k]`` is the triangle across the edge ``triangles[t, k] ->
    triangles[t, (k + 1) % 3]`` (-1 on the hull); ``hull`` lists the hull vertices
    counter-clockwise; ``duplicates`` and ``representatives`` pair every input point that
    repeats an earlier position with the first point at that position (sorted by the
    duplicate's index). ``status`` is a :mod:`._sweephull` status; ``blocks`` their number.
    """

    triangles: np.ndarray
    neighbors: np.ndarray
    hull: np.ndarray
    duplicates: np.ndarray
    representatives: np.ndarray
    status: int
    blocks: int


def _levels(n: int) -> int:
    if n < PARALLEL_MIN:
        return 0
    return int(min(_MAX_LEVELS, max(1, round(np.log2(n / BLOCK_POINTS)))))


def _kd_cuts(sample: np.ndarray, levels: int) -> np.ndarray:
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


def _assign(points, axes, cuts, levels, idx, xy) -> np.ndarray:
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
    _run([
        (lambda c=c: _leaves(points, ua, va, cuts, levels, edges[c], edges[c + 1], leaf, counts[c]))
        for c in range(_CHUNKS)
    ])  # fmt: skip
    starts = np.zeros(blocks + 1, dtype=np.int64)
    np.cumsum(counts.sum(axis=0), out=starts[1:])
    cursor = starts[:-1] + np.cumsum(counts, axis=0) - counts  # chunk c starts after chunks < c
    _run([
        (lambda c=c: _scatter(points, ua, va, edges[c], edges[c + 1], leaf, cursor[c], idx, xy))
        for c in range(_CHUNKS)
    ])  # fmt: skip
    return starts


@njit(cache=True, nogil=True)
def _columns(pts, ua, va, idx, xy):
    """One block: every point in input order."""
    for i in range(pts.shape[0]):
        idx[i] = i
        xy[i, 0] = pts[i, ua]
        xy[i, 1] = pts[i, va]


@njit(cache=True, nogil=True, error_model="numpy")
def _prepare(block, local, keys):
    """Copy the block's points to ``local``; its seed triangle and every point's sort key."""
    for k in range(block.shape[0]):
        local[k, 0] = block[k, 0]
        local[k, 1] = block[k, 1]
    i0, i1, i2, cx, cy = _sweephull.seed_triangle(local)
    if i0 >= 0:
        for k in range(block.shape[0]):
            dx = local[k, 0] - cx
            dy = local[k, 1] - cy
            keys[k] = dx * dx + dy * dy
    return i0, i1, i2, cx, cy


@njit(cache=True)
def _before(local, idx, i, j):
    """Lexicographic (u, v, input index) order of two points of the block."""
    if local[i, 0] != local[j, 0]:
        return local[i, 0] < local[j, 0]
    if local[i, 1] != local[j, 1]:
        return local[i, 1] < local[j, 1]
    return idx[i] < idx[j]


@njit(cache=True, nogil=True)
def _sort_run(local, idx, members):
    """Sort block positions by (u, v, input index) in place (Shell sort: runs are short)."""
    m = members.shape[0]
    gap = 1
    while gap < m // 3:
        gap = 3 * gap + 1
    while gap >= 1:
        for a in range(gap, m):
            cur = members[a]
            b = a
            while b >= gap and _before(local, idx, cur, members[b - gap]):
                members[b] = members[b - gap]
                b -= gap
            members[b] = cur
        gap //= 3


@njit(cache=True, nogil=True)
def _dedupe(local, idx, order, keys, off, xy, inp, seeds):
    """Gather the block in sweep order merging equal positions (found in runs of equal keys).

    Returns the number of distinct points and the (duplicate, representative) input-index
    pairs; ``seeds`` (block positions) becomes the seed points' places in ``xy``.
    """
    n = order.shape[0]
    dup = np.empty(16, dtype=inp.dtype)
    rep = np.empty(16, dtype=inp.dtype)
    n_dup = 0
    s0, s1, s2 = seeds[0], seeds[1], seeds[2]
    j = off
    k = 0
    while k < n:
        key = keys[order[k]]
        e = k + 1
        while e < n and keys[order[e]] == key:
            e += 1
        members = order[k:e].copy()
        if e - k > 1:
            _sort_run(local, idx, members)
        first = -1
        for a in range(e - k):
            m = members[a]
            if first == -1 or local[m, 0] != local[first, 0] or local[m, 1] != local[first, 1]:
                first = m
                xy[j, 0] = local[m, 0]
                xy[j, 1] = local[m, 1]
                inp[j] = idx[m]
                j += 1
            else:
                if n_dup == dup.shape[0]:
                    dup = _mergehull.grown(dup, n_dup)
                    rep = _mergehull.grown(rep, n_dup)
                dup[n_dup] = idx[m]
                rep[n_dup] = idx[first]
                n_dup += 1
            if m == s0:
                seeds[0] = j - 1
            elif m == s1:
                seeds[1] = j - 1
            elif m == s2:
                seeds[2] = j - 1
        k = e
    return j - off, dup[:n_dup].copy(), rep[:n_dup].copy()


@njit(cache=True, nogil=True, error_model="numpy")
def _block(local, idx, order, keys, seeds, off, centre, xy, inp, tri, he, t_lo, hull):
    """Gather the block's points in sweep order (dropping duplicates) and sweep them.

    ``seeds`` holds the seed triangle's block positions; ``hull`` is the (next, previous,
    half-edge) table. Returns (distinct points, triangles, skipped points, a hull vertex,
    duplicates, their representatives).
    """
    n = order.shape[0]
    ties = 0
    for k in range(1, n):
        ties += keys[order[k]] == keys[order[k - 1]]
    if ties:
        m, dup, rep = _dedupe(local, idx, order, keys, off, xy, inp, seeds)
    else:
        m = n
        s0, s1, s2 = seeds[0], seeds[1], seeds[2]
        for k in range(n):
            b = order[k]
            xy[off + k, 0] = local[b, 0]
            xy[off + k, 1] = local[b, 1]
            inp[off + k] = idx[b]
            if b == s0:
                seeds[0] = off + k
            elif b == s1:
                seeds[1] = off + k
            elif b == s2:
                seeds[2] = off + k
        dup = np.empty(0, dtype=inp.dtype)
        rep = np.empty(0, dtype=inp.dtype)
    n_tri, skipped, vertex = _sweephull.sweep(
        xy, off, off + m, seeds[0], seeds[1], seeds[2], centre[0], centre[1], tri, he, t_lo,
        hull[0], hull[1], hull[2],
    )  # fmt: skip
    return m, n_tri, skipped, vertex, dup, rep


class _Part:
    """One block of the cloud: its points, then its sweep (run on a worker thread)."""

    def __init__(self, idx, off, t_lo, shared):
        self.idx, self.off, self.t_lo, self.shared = idx, off, t_lo, shared
        self.status = _sweephull.STATUS_OK
        self.count = self.n_tri = 0
        self.vertex = -1
        self.dup = self.rep = None

    def __call__(self) -> _Part:
        xy, inp, tri, he, hull = self.shared
        n = self.idx.shape[0]
        local = np.empty((n, 2))
        keys = np.empty(n)
        i0, i1, i2, cx, cy = _prepare(xy[self.off : self.off + n], local, keys)
        if i0 < 0:
            self.status = _sweephull.STATUS_COLLINEAR
            return self
        if not (np.isfinite(cx) and np.isfinite(cy)):  # coordinates beyond float64's range
            self.status = _sweephull.STATUS_SKIPPED
            return self
        order = np.argsort(keys)
        seeds = np.array([i0, i1, i2], dtype=np.int64)
        centre = np.array([cx, cy])
        args = (local, self.idx, order, keys, seeds, self.off, centre, xy, inp, tri, he, self.t_lo, hull)
        self.count, self.n_tri, skipped, self.vertex, self.dup, self.rep = _block(*args)
        if skipped:
            self.status = _sweephull.STATUS_SKIPPED
        return self

    def free_slots(self) -> np.ndarray:
        return np.arange(self.t_lo + self.n_tri, self.t_lo + 2 * self.idx.shape[0] - 5, dtype=np.int64)


class _Join:
    """One merge of two sibling blocks (run on a worker thread)."""

    def __init__(self, shared, left, right, slots, horizontal):
        self.shared, self.left, self.right, self.slots, self.horizontal = (
            shared,
            left,
            right,
            slots,
            horizontal,
        )
        self.used = self.vertex = -1

    def __call__(self) -> _Join:
        xy, _, tri, he, hull = self.shared
        self.used, self.vertex = _mergehull.merge(
            xy, tri, he, hull, self.left, self.right, self.slots, self.horizontal
        )
        return self


def triangulate(
    points: np.ndarray, axes: tuple[int, int] = (0, 1), *, blocks: int | None = None
) -> Triangulation:
    """Delaunay-triangulate the distinct positions of columns ``axes`` of ``points``.

    Parameters
    ----------
    points : ndarray of float64, shape (n, k), C-contiguous
        Finite coordinates; columns ``axes`` are (u, v).
    blocks : int, optional
        A power of two: the number of blocks (default: from the number of points, see the
        module notes). When a block cannot be swept on its own (collinear, or rounding
        defeated the sweep) the cloud is triangulated again as one block.
    """
    levels = _levels(points.shape[0]) if blocks is None else int(blocks).bit_length() - 1
    result = _triangulate(points, axes, levels)
    if result.status != _sweephull.STATUS_OK and result.blocks > 1:
        result = _triangulate(points, axes, 0)
    return result


def _failed(dtype, status: int, blocks: int) -> Triangulation:
    empty = np.empty(0, dtype=dtype)
    return Triangulation(empty.reshape(0, 3), empty.reshape(0, 3), empty, empty, empty, status, blocks)


def _triangulate(points: np.ndarray, axes: tuple[int, int], levels: int) -> Triangulation:
    n = points.shape[0]
    dtype = np.int32 if n <= _INT32_MAX_POINTS else np.int64
    ua, va = int(axes[0]), int(axes[1])
    blocks = 1 << levels
    if n < 3:
        return _failed(dtype, _sweephull.STATUS_COLLINEAR, 1)
    idx = np.empty(n, dtype=dtype)
    xy = np.empty((n, 2))  # the blocks' points, then (block by block) the distinct points in sweep order
    if levels:
        step = max(1, n // (_SAMPLE_PER_BLOCK * blocks))
        cuts = _kd_cuts(points[::step][:, [ua, va]], levels)
        starts = _assign(points, (ua, va), cuts, levels, idx, xy)
        if np.diff(starts).min() < 3:
            return _failed(dtype, _sweephull.STATUS_COLLINEAR, blocks)
    else:
        _columns(points, ua, va, idx, xy)
        starts = np.array([0, n])
    sizes = np.diff(starts)
    t_lo = np.concatenate([[0], np.cumsum(2 * sizes - 5)])
    capacity = int(t_lo[-1]) + _mergehull.SPARE_SLOTS * (blocks - 1)
    inp = np.empty(n, dtype=dtype)
    tri = np.empty(3 * capacity, dtype=dtype)  # untouched pages cost no memory
    he = np.empty(3 * capacity, dtype=dtype)
    hull = np.empty((3, n), dtype=dtype)  # next, previous, half-edge of each hull vertex
    shared = (xy, inp, tri, he, hull)
    parts = _run(
        [_Part(idx[starts[b] : starts[b + 1]], int(starts[b]), int(t_lo[b]), shared) for b in range(blocks)]
    )  # fmt: skip
    del idx
    status = max(p.status for p in parts)
    if status != _sweephull.STATUS_OK:
        return _failed(dtype, status, blocks)
    n_tri = sum(p.n_tri for p in parts)
    # merges up the k-d tree: node j (heap order) joins its children 2j and 2j + 1
    vertex = {blocks + b: p.vertex for b, p in enumerate(parts)}
    free = {blocks + b: p.free_slots() for b, p in enumerate(parts)}
    base = int(t_lo[-1])
    for depth in range(levels - 1, -1, -1):
        joins = []
        for j in range(2**depth, 2 ** (depth + 1)):
            spare = np.arange(base + _mergehull.SPARE_SLOTS * (j - 1), base + _mergehull.SPARE_SLOTS * j)
            slots = np.concatenate([free.pop(2 * j), free.pop(2 * j + 1), spare])
            joins.append(_Join(shared, vertex[2 * j], vertex[2 * j + 1], slots, depth % 2 == 1))
        for j, join in zip(range(2**depth, 2 ** (depth + 1)), _run(joins)):
            n_tri += join.used
            vertex[j] = join.vertex
            free[j] = join.slots[join.used :]
    root = 1 if levels else blocks
    if levels:
        _mergehull.compact(tri, he, free[1], n_tri)
    ring = _mergehull.hull_cycle(vertex[root], hull[0])
    if n_tri != 2 * sum(p.count for p in parts) - 2 - ring.shape[0]:  # Euler: a point is no vertex
        return _failed(dtype, _sweephull.STATUS_SKIPPED, blocks)
    del xy, hull
    end = 3 * n_tri
    cut = (end // 6) * 3
    if levels:
        _run(
            [
                lambda: _mergehull.finish(tri, he, inp, 0, cut),
                lambda: _mergehull.finish(tri, he, inp, cut, end),
            ]
        )
    else:
        _mergehull.finish(tri, he, inp, 0, end)
    dup = np.concatenate([p.dup for p in parts]) if levels else parts[0].dup
    rep = np.concatenate([p.rep for p in parts]) if levels else parts[0].rep
    if dup.shape[0] > 1:
        order = np.argsort(dup)
        dup, rep = dup[order], rep[order]
    return Triangulation(
        triangles=tri[:end].reshape(n_tri, 3),
        neighbors=he[:end].reshape(n_tri, 3),
        hull=inp[ring],
        duplicates=dup,
        representatives=rep,
        status=_sweephull.STATUS_OK,
        blocks=blocks,
    )
