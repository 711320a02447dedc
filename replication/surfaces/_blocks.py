"""One block of the sweep-hull triangulator: sort, duplicates, sweep (numba).

Each block's points are copied to a small contiguous array and sorted by squared distance
from the circumcentre of an empty-circle seed triangle. Equal positions have equal keys, so
only runs of equal keys need a look: that finds every duplicate without hashing or sorting
rows (the run is put in (u, v, input index) order, so the result does not depend on how the
sort orders equal keys). The distinct points are copied, in sweep order, into the shared
coordinate array and swept (:func:`._sweephull.sweep`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from replication import _numbacache
from replication.surfaces import _mergehull, _sweephull
from replication.surfaces._status import SAFE_MAGNITUDE_HIGH, SAFE_MAGNITUDE_LOW, STATUS_RANGE

__all__ = ["Part", "block", "single"]


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
    n_dup = np.int64(0)
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
def block(local, idx, order, keys, seeds, off, centre, xy, inp, tri, he, t_lo, hull):
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


class Part:
    """One block of the cloud: its points, then its sweep (run on a worker thread)."""

    def __init__(self, idx, off, t_lo, shared):
        self.idx, self.off, self.t_lo, self.shared = idx, off, t_lo, shared
        self.status = _sweephull.STATUS_OK
        self.count = self.n_tri = 0
        self.vertex = -1
        self.dup = self.rep = None

    def __call__(self) -> Part:
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
        self.count, self.n_tri, skipped, self.vertex, self.dup, self.rep = block(*args)
        if skipped:
            self.status = _sweephull.STATUS_SKIPPED
        return self

    def free_slots(self) -> np.ndarray:
        return np.arange(self.t_lo + self.n_tri, self.t_lo + 2 * self.idx.shape[0] - 5, dtype=np.int64)


@njit(cache=True, nogil=True)
def _argsort(keys):
    """Indices that sort ``keys`` (Shell sort; for small blocks, where it beats a dispatch)."""
    n = keys.shape[0]
    order = np.arange(n)
    gap = 1
    while gap < n // 3:
        gap = 3 * gap + 1
    while gap >= 1:
        for a in range(gap, n):
            cur = order[a]
            key = keys[cur]
            b = a
            while b >= gap and keys[order[b - gap]] > key:
                order[b] = order[b - gap]
                b -= gap
            order[b] = cur
        gap //= 3
    return order


@njit(cache=True, nogil=True, error_model="numpy")
def single(points, ua, va):
    """A small cloud in one call: ``(status, triangles, neighbours, hull, duplicates, their
    representatives)`` (int32, input indices; see :class:`._triangulate.Triangulation`)."""
    n = points.shape[0]
    zero = np.int64(0)  # not a literal: the kernels keep one compiled signature
    empty = np.empty(0, dtype=np.int32)
    idx = np.empty(n, dtype=np.int32)
    xy = np.empty((n, 2))
    top = 0.0
    for i in range(n):
        idx[i] = i
        xy[i, 0] = points[i, ua]
        xy[i, 1] = points[i, va]
        top = max(top, abs(xy[i, 0]), abs(xy[i, 1]))
    if top != 0.0 and not SAFE_MAGNITUDE_LOW <= top <= SAFE_MAGNITUDE_HIGH:  # the caller scales the cloud
        return STATUS_RANGE, empty.reshape(0, 3), empty.reshape(0, 3), empty, empty, empty
    local = np.empty((n, 2))
    keys = np.empty(n)
    i0, i1, i2, cx, cy = _prepare(xy, local, keys)
    if i0 < 0:
        return _sweephull.STATUS_COLLINEAR, empty.reshape(0, 3), empty.reshape(0, 3), empty, empty, empty
    if not (np.isfinite(cx) and np.isfinite(cy)):  # coordinates beyond float64's range
        return _sweephull.STATUS_SKIPPED, empty.reshape(0, 3), empty.reshape(0, 3), empty, empty, empty
    order = _argsort(keys)
    seeds = np.empty(3, dtype=np.int64)
    seeds[0], seeds[1], seeds[2] = i0, i1, i2
    centre = np.empty(2)
    centre[0], centre[1] = cx, cy
    inp = np.empty(n, dtype=np.int32)
    tri = np.empty(3 * (2 * n - 5), dtype=np.int32)
    he = np.empty(3 * (2 * n - 5), dtype=np.int32)
    hull = np.empty((3, n), dtype=np.int32)
    m, n_tri, skipped, vertex, dup, rep = block(
        local, idx, order, keys, seeds, zero, centre, xy, inp, tri, he, zero, hull
    )
    ring = _mergehull.hull_cycle(vertex, hull[0])
    if skipped or n_tri != 2 * m - 2 - ring.shape[0]:  # Euler: a point is no vertex
        return _sweephull.STATUS_SKIPPED, empty.reshape(0, 3), empty.reshape(0, 3), empty, empty, empty
    _mergehull.finish(tri, he, inp, zero, 3 * n_tri)
    out = np.empty(ring.shape[0], dtype=np.int32)
    for k in range(ring.shape[0]):
        out[k] = inp[ring[k]]
    return (
        _sweephull.STATUS_OK,
        tri[: 3 * n_tri].reshape(n_tri, 3),
        he[: 3 * n_tri].reshape(n_tri, 3),
        out,
        dup,
        rep,
    )


_numbacache.refresh(globals())  # numba keys its cache on this file only (see replication._numbacache)
