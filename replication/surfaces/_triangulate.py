"""The sweep-hull triangulation pipeline: blocks, duplicate detection, two cores, merge.

Steps, for the projected coordinates (u, v) of n points (columns of a point array):

1. **Blocks.** Below ``PARALLEL_MIN`` points the cloud is one block. Larger clouds are cut by
   the vertical line ``u = c`` (c: the median of a fixed sample of u) into a left block
   (``u <= c``) and a right block (``u > c``), so equal positions always share a block. The
   cut depends on the points only, never on the number of threads: the triangulation is the
   same whatever the thread count.
2. **Sort and duplicates.** In each block the points are sorted by squared distance from the
   circumcentre of an empty-circle seed triangle (numpy's argsort). Equal positions have
   equal keys, so they are neighbours in that order: only runs of equal keys need a look,
   which finds every duplicate without hashing or sorting rows, and the block's distinct
   points are copied, in sweep order, into one contiguous (n, 2) coordinate array.
3. **Sweep** (:func:`._sweephull.sweep`) of each block, the two blocks at once on two threads
   (the kernels release the GIL), into shared triangle and half-edge arrays.
4. **Merge** (:mod:`._mergehull`) of the two triangulations, compaction, and the mapping of
   vertex positions back to input indices and of half-edges to neighbour triangles.

Indices are int32 (half-edge ids reach 6 n: up to 357 million points; int64 beyond).
When rounding of a sort key defeats the sweep (a point sorted inside the hull) or a block is
collinear, the cloud is triangulated again as one block; when that fails too the caller
falls back to Qhull.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
from numba import njit

from replication.surfaces import _mergehull, _sweephull

__all__ = ["PARALLEL_MIN", "Triangulation", "triangulate"]

#: Clouds with at least this many points are triangulated as two blocks on two threads.
PARALLEL_MIN = 20_000
_SAMPLE = 4096
_INT32_MAX_POINTS = (2**31 - 1) // 6 - 16

_pool: ThreadPoolExecutor | None = None


@dataclass(frozen=True, eq=False)
class Triangulation:
    """Output of :func:`triangulate` (index arrays of one dtype, int32 unless huge).

    ``triangles`` (m, 3) are counter-clockwise input indices of distinct points;
    ``neighbors[t, k]`` is the triangle across the edge ``triangles[t, k] ->
    triangles[t, (k + 1) % 3]`` (-1 on the hull); ``hull`` lists the hull vertices
    counter-clockwise; ``duplicates`` and ``representatives`` pair every input point that
    repeats an earlier position with the first point at that position (sorted by the
    duplicate's index). ``status`` is a :mod:`._sweephull` status; ``blocks`` is 1 or 2.
    """

    triangles: np.ndarray
    neighbors: np.ndarray
    hull: np.ndarray
    duplicates: np.ndarray
    representatives: np.ndarray
    status: int
    blocks: int


def _threads() -> int:
    import numba

    return int(numba.get_num_threads())


def _run(tasks):
    """Run callables, the first in this thread, the rest on a pool (numba's thread count)."""
    global _pool
    if len(tasks) == 1 or _threads() < 2:
        return [task() for task in tasks]
    if _pool is None:
        _pool = ThreadPoolExecutor(max_workers=2, thread_name_prefix="replication-delaunay")
    futures = [_pool.submit(task) for task in tasks[1:]]
    first = tasks[0]()
    return [first, *(f.result() for f in futures)]


@njit(cache=True, nogil=True)
def _split(pts, ua, cut, idx):
    """Indices with ``u <= cut`` to the front of ``idx``, the others after them (both ascending)."""
    n = pts.shape[0]
    lo = 0
    hi = n
    for i in range(n):
        if pts[i, ua] <= cut:
            idx[lo] = i
            lo += 1
        else:
            hi -= 1
            idx[hi] = i
    a = lo
    b = n - 1
    while a < b:  # the right indices were stored from the back: reverse them
        idx[a], idx[b] = idx[b], idx[a]
        a += 1
        b -= 1
    return lo


@njit(cache=True, nogil=True, error_model="numpy")
def _prepare(pts, ua, va, idx, keys):
    """Seed triangle of the block ``idx`` and every point's sort key (squared distance)."""
    i0, i1, i2, cx, cy = _sweephull.seed_triangle(pts, ua, va, idx)
    if i0 >= 0:
        for k in range(idx.shape[0]):
            dx = pts[idx[k], ua] - cx
            dy = pts[idx[k], va] - cy
            keys[k] = dx * dx + dy * dy
    return i0, i1, i2, cx, cy


@njit(cache=True)
def _before(pts, ua, va, i, j):
    """Lexicographic (u, v, index) order of two input points."""
    if pts[i, ua] != pts[j, ua]:
        return pts[i, ua] < pts[j, ua]
    if pts[i, va] != pts[j, va]:
        return pts[i, va] < pts[j, va]
    return i < j


@njit(cache=True, nogil=True)
def _sort_run(pts, ua, va, members):
    """Sort input indices by (u, v, index) in place (Shell sort: runs are short but unbounded)."""
    m = members.shape[0]
    gap = 1
    while gap < m // 3:
        gap = 3 * gap + 1
    while gap >= 1:
        for a in range(gap, m):
            cur = members[a]
            b = a
            while b >= gap and _before(pts, ua, va, cur, members[b - gap]):
                members[b] = members[b - gap]
                b -= gap
            members[b] = cur
        gap //= 3


@njit(cache=True, nogil=True)
def _dedupe(pts, ua, va, order, keys, off, xy, inp, seeds):
    """Merge equal positions within the runs of equal keys (gathered points, in place).

    Returns the number of distinct points and the (duplicate, representative) input-index
    pairs; ``seeds`` (positions) is updated to where the seed points went.
    """
    n = order.shape[0]
    dup = np.empty(16, dtype=inp.dtype)
    rep = np.empty(16, dtype=inp.dtype)
    n_dup = 0
    g0 = inp[seeds[0]]
    g1 = inp[seeds[1]]
    g2 = inp[seeds[2]]
    j = off
    k = 0
    while k < n:
        key = keys[order[k]]
        e = k + 1
        while e < n and keys[order[e]] == key:
            e += 1
        members = inp[off + k : off + e].copy()
        if e - k > 1:
            _sort_run(pts, ua, va, members)
        first = -1
        for a in range(e - k):
            i = members[a]
            if first == -1 or pts[i, ua] != pts[first, ua] or pts[i, va] != pts[first, va]:
                first = i
                xy[j, 0] = pts[i, ua]
                xy[j, 1] = pts[i, va]
                inp[j] = i
                j += 1
            else:
                if n_dup == dup.shape[0]:
                    dup = _mergehull.grown(dup, n_dup)
                    rep = _mergehull.grown(rep, n_dup)
                dup[n_dup] = i
                rep[n_dup] = first
                n_dup += 1
            if i == g0:
                seeds[0] = j - 1
            elif i == g1:
                seeds[1] = j - 1
            elif i == g2:
                seeds[2] = j - 1
        k = e
    return j - off, dup[:n_dup].copy(), rep[:n_dup].copy()


@njit(cache=True, nogil=True, error_model="numpy")
def _block(pts, ua, va, idx, order, keys, seeds, off, centre, xy, inp, tri, he, t_lo, hull):
    """Gather the block's points in sweep order (dropping duplicates) and sweep them.

    ``seeds`` holds the seed triangle's positions in ``idx``; ``hull`` is the
    (next, prev, half-edge) table. Returns (distinct points, triangles, skipped points, a
    hull vertex, duplicates, their representatives).
    """
    n = order.shape[0]
    ties = 0
    previous = -1.0  # keys are >= 0
    s0 = seeds[0]
    s1 = seeds[1]
    s2 = seeds[2]
    for k in range(n):
        local = order[k]
        i = idx[local]
        xy[off + k, 0] = pts[i, ua]
        xy[off + k, 1] = pts[i, va]
        inp[off + k] = i
        key = keys[local]
        ties += key == previous
        previous = key
        if local == s0:
            seeds[0] = off + k
        elif local == s1:
            seeds[1] = off + k
        elif local == s2:
            seeds[2] = off + k
    if ties:
        m, dup, rep = _dedupe(pts, ua, va, order, keys, off, xy, inp, seeds)
    else:
        m = n
        dup = np.empty(0, dtype=inp.dtype)
        rep = np.empty(0, dtype=inp.dtype)
    n_tri, skipped, vertex = _sweephull.sweep(
        xy, off, off + m, seeds[0], seeds[1], seeds[2], centre[0], centre[1], tri, he, t_lo,
        hull[0], hull[1], hull[2],
    )  # fmt: skip
    return m, n_tri, skipped, vertex, dup, rep


class _Part:
    """One block of the cloud: its points, then its sweep (run on a worker thread)."""

    def __init__(self, pts, axes, idx, off, t_lo, shared):
        self.pts, self.axes, self.idx, self.off, self.t_lo, self.shared = pts, axes, idx, off, t_lo, shared
        self.status = _sweephull.STATUS_OK
        self.count = self.n_tri = 0
        self.vertex = -1
        self.dup = self.rep = None

    def __call__(self) -> _Part:
        xy, inp, tri, he, hull = self.shared
        ua, va = self.axes
        keys = np.empty(self.idx.shape[0])
        i0, i1, i2, cx, cy = _prepare(self.pts, ua, va, self.idx, keys)
        if i0 < 0:
            self.status = _sweephull.STATUS_COLLINEAR
            return self
        if not (np.isfinite(cx) and np.isfinite(cy)):  # coordinates beyond float64's range
            self.status = _sweephull.STATUS_SKIPPED
            return self
        order = np.argsort(keys)
        seeds = np.array([i0, i1, i2], dtype=np.int64)
        centre = np.array([cx, cy])
        self.count, self.n_tri, skipped, self.vertex, self.dup, self.rep = _block(
            self.pts,
            ua,
            va,
            self.idx,
            order,
            keys,
            seeds,
            self.off,
            centre,
            xy,
            inp,
            tri,
            he,
            self.t_lo,
            hull,
        )
        if skipped:
            self.status = _sweephull.STATUS_SKIPPED
        return self

    def free_slots(self) -> np.ndarray:
        return np.arange(self.t_lo + self.n_tri, self.t_lo + 2 * self.idx.shape[0] - 5, dtype=np.int64)


def _cut(u: np.ndarray) -> float:
    """The median of a fixed sample of u (depends on the data only)."""
    sample = np.sort(u[:: max(1, u.shape[0] // _SAMPLE)])
    return float(sample[(sample.shape[0] - 1) // 2])


def triangulate(
    points: np.ndarray, axes: tuple[int, int] = (0, 1), *, blocks: int | None = None
) -> Triangulation:
    """Delaunay-triangulate the distinct positions of columns ``axes`` of ``points``.

    Parameters
    ----------
    points : ndarray of float64, shape (n, k), C-contiguous
        Finite coordinates; columns ``axes`` are (u, v).
    blocks : {1, 2}, optional
        One block or two; default: two from ``PARALLEL_MIN`` points on. When a block cannot
        be swept on its own (collinear, or rounding defeated the sweep) the cloud is
        triangulated again as one block.
    """
    if blocks is None:
        blocks = 2 if points.shape[0] >= PARALLEL_MIN else 1
    result = _triangulate(points, axes, blocks)
    if result.status != _sweephull.STATUS_OK and result.blocks == 2:
        result = _triangulate(points, axes, 1)
    return result


def _failed(dtype, status: int, blocks: int) -> Triangulation:
    empty = np.empty(0, dtype=dtype)
    return Triangulation(empty.reshape(0, 3), empty.reshape(0, 3), empty, empty, empty, status, blocks)


def _triangulate(points: np.ndarray, axes: tuple[int, int], blocks: int) -> Triangulation:
    n = points.shape[0]
    dtype = np.int32 if n <= _INT32_MAX_POINTS else np.int64
    if n < 3:
        return _failed(dtype, _sweephull.STATUS_COLLINEAR, 1)
    ua, va = int(axes[0]), int(axes[1])
    if blocks == 2:
        idx = np.empty(n, dtype=dtype)
        n_left = _split(points, ua, _cut(points[:, ua]), idx)
        if n_left < 3 or n - n_left < 3:
            blocks = 1
    if blocks == 1:
        idx = np.arange(n, dtype=dtype)
        n_left = n
    sizes = (n_left, n - n_left)[:blocks]
    capacity = sum(2 * s - 5 for s in sizes) + _mergehull.SPARE_SLOTS * (blocks - 1)
    xy = np.empty((n, 2))
    inp = np.empty(n, dtype=dtype)
    tri = np.empty(3 * capacity, dtype=dtype)  # untouched pages cost no memory
    he = np.empty(3 * capacity, dtype=dtype)
    hull = np.empty((3, n), dtype=dtype)  # next, previous, half-edge of each hull vertex
    shared = (xy, inp, tri, he, hull)
    parts = [_Part(points, (ua, va), idx[:n_left], 0, 0, shared)]
    if blocks == 2:
        parts.append(_Part(points, (ua, va), idx[n_left:], n_left, 2 * n_left - 5, shared))
    parts = _run(parts)
    del idx
    status = max(p.status for p in parts)
    if status != _sweephull.STATUS_OK:
        return _failed(dtype, status, blocks)
    n_tri = sum(p.n_tri for p in parts)
    vertex = parts[0].vertex
    if blocks == 2:
        spare = np.arange(capacity - _mergehull.SPARE_SLOTS, capacity, dtype=np.int64)
        slots = np.concatenate([parts[0].free_slots(), parts[1].free_slots(), spare])
        used, vertex = _mergehull.merge(xy, tri, he, hull, parts[0].vertex, parts[1].vertex, slots)
        n_tri += used
        _mergehull.compact(tri, he, slots[used:], n_tri)
    ring = _mergehull.hull_cycle(vertex, hull[0])
    if n_tri != 2 * sum(p.count for p in parts) - 2 - ring.shape[0]:  # Euler: a point is no vertex
        return _failed(dtype, _sweephull.STATUS_SKIPPED, blocks)
    del xy, hull
    end = 3 * n_tri
    if blocks == 1:
        _mergehull.finish(tri, he, inp, 0, end)
    else:
        half = (end // 6) * 3
        _run(
            [
                lambda: _mergehull.finish(tri, he, inp, 0, half),
                lambda: _mergehull.finish(tri, he, inp, half, end),
            ]
        )
    dup = parts[0].dup if blocks == 1 else np.concatenate([p.dup for p in parts])
    rep = parts[0].rep if blocks == 1 else np.concatenate([p.rep for p in parts])
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
