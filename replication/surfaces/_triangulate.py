"""The sweep-hull triangulation pipeline: blocks, two cores, merges.

Steps, for the projected coordinates (u, v) of n points (two columns of a point array):

1. **Blocks** (:mod:`._partition`). Below ``PARALLEL_MIN`` points the cloud is one block;
   larger clouds are cut by a k-d tree into 2^k compact blocks of about ``BLOCK_POINTS``
   points. The blocks depend on the points only, never on the number of threads: the
   triangulation is the same whatever the thread count.
2. **Sort, duplicates, sweep** of each block (:mod:`._blocks`) into shared triangle and
   half-edge arrays; blocks run on the threads of a small pool (:mod:`._threads`; the
   kernels release the GIL). Clouds of at most ``SMALL`` points take a single compiled call.
3. **Merges** (:mod:`._mergehull`) up the k-d tree, sibling merges in parallel; then the
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

from replication import _aot
from replication.surfaces._status import (
    STATUS_COLLINEAR,
    STATUS_OK,
    STATUS_RANGE,
    STATUS_SKIPPED,
    out_of_range,
)
from replication.surfaces._threads import frozen
from replication.surfaces._threads import run as _run

__all__ = ["SMALL", "Triangulation", "triangulate"]

#: Clouds of at most this many points are triangulated in one compiled call.
SMALL = 2048
_INT32_MAX_POINTS = (2**31 - 1) // 6 - 16


@dataclass(frozen=True, eq=False)
class Triangulation:
    """Output of :func:`triangulate` (index arrays of one dtype, int32 unless huge).

    ``triangles`` (m, 3) are counter-clockwise input indices of distinct points;
    ``neighbors[t, k]`` is the triangle across the edge ``triangles[t, k] ->
    triangles[t, (k + 1) % 3]`` (-1 on the hull); ``hull`` lists the hull vertices
    counter-clockwise; ``duplicates`` and ``representatives`` pair every input point that
    repeats an earlier position with the first point at that position (sorted by the
    duplicate's index). ``status`` is a :mod:`._status` code; ``blocks`` their number.
    ``order`` lists the distinct points (input indices) block by block, each block in sweep
    order: a spatially coherent numbering for kernels that visit every triangle.
    """

    triangles: np.ndarray
    neighbors: np.ndarray
    hull: np.ndarray
    duplicates: np.ndarray
    representatives: np.ndarray
    status: int
    blocks: int
    order: np.ndarray | None = None


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
        from replication.surfaces import _mergehull

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

    A cloud whose largest absolute (u, v) coordinate lies outside the exact predicates' range
    is not triangulated: the status is ``STATUS_RANGE`` and the caller scales it
    (:func:`.delaunay.planar_delaunay`).
    """
    points = frozen(points, np.float64)
    n = points.shape[0]
    if blocks is None:  # a small cloud is one block (SMALL < _partition.PARALLEL_MIN, tested)
        levels = 0 if n <= SMALL else _levels(n)
    else:
        levels = int(blocks).bit_length() - 1
    if levels == 0 and 3 <= n <= SMALL:
        single = _aot.kernel("single")  # compiled at install time, or numba's (see replication._aot)
        status, triangles, neighbors, hull, dup, rep = single(points, int(axes[0]), int(axes[1]))
        if dup.shape[0] > 1:
            order = np.argsort(dup)
            dup, rep = dup[order], rep[order]
        return Triangulation(triangles, neighbors, hull, dup, rep, status, 1)
    from replication.surfaces._partition import magnitude

    top = magnitude(points, axes) if n >= 3 else 0.0
    if out_of_range(top):  # the caller scales the cloud
        return _failed(np.int32, STATUS_RANGE, 1)
    result = _triangulate(points, axes, levels)
    if result.status != STATUS_OK and result.blocks > 1:
        result = _triangulate(points, axes, 0)
    return result


def _levels(n: int) -> int:
    from replication.surfaces import _partition

    return _partition.levels(n)


def _failed(dtype, status: int, blocks: int) -> Triangulation:
    empty = np.empty(0, dtype=dtype)
    return Triangulation(empty.reshape(0, 3), empty.reshape(0, 3), empty, empty, empty, status, blocks)


def _triangulate(points: np.ndarray, axes: tuple[int, int], levels: int) -> Triangulation:
    from replication.surfaces import _blocks, _mergehull, _partition  # numba: imported when used

    n = points.shape[0]
    dtype = np.int32 if n <= _INT32_MAX_POINTS else np.int64
    ua, va = int(axes[0]), int(axes[1])
    blocks = 1 << levels
    if n < 3:
        return _failed(dtype, STATUS_COLLINEAR, 1)
    idx = np.empty(n, dtype=dtype)
    xy = np.empty((n, 2))  # the blocks' points, then (block by block) the distinct points in sweep order
    if levels:
        step = max(1, n // (_partition.SAMPLE_PER_BLOCK * blocks))
        cuts = _partition.kd_cuts(points[::step][:, [ua, va]], levels)
        starts = _partition.assign(points, (ua, va), cuts, levels, idx, xy)
        if np.diff(starts).min() < 3:
            return _failed(dtype, STATUS_COLLINEAR, blocks)
    else:
        _partition.columns(points, ua, va, idx, xy)
        starts = np.array([0, n])
    sizes = np.diff(starts)
    t_lo = np.concatenate([[0], np.cumsum(2 * sizes - 5)])
    capacity = int(t_lo[-1]) + _mergehull.SPARE_SLOTS * (blocks - 1)
    inp = np.empty(n, dtype=dtype)
    tri = np.empty(3 * capacity, dtype=dtype)  # untouched pages cost no memory
    he = np.empty(3 * capacity, dtype=dtype)
    hull = np.empty((3, n), dtype=dtype)  # next, previous, half-edge of each hull vertex
    shared = (xy, inp, tri, he, hull)
    parts = _run([_blocks.Part(idx[starts[b] : starts[b + 1]], int(starts[b]), int(t_lo[b]), shared)
                   for b in range(blocks)])  # fmt: skip
    del idx
    status = max(p.status for p in parts)
    if status != STATUS_OK:
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
        return _failed(dtype, STATUS_SKIPPED, blocks)
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
    if all(p.count == p.idx.shape[0] for p in parts):
        order = inp  # no duplicates: every position holds a point
    else:
        order = np.concatenate([inp[p.off : p.off + p.count] for p in parts])
    dup = np.concatenate([p.dup for p in parts]) if levels else parts[0].dup
    rep = np.concatenate([p.rep for p in parts]) if levels else parts[0].rep
    if dup.shape[0] > 1:  # sorted by the duplicate's index (a name of its own: ``order`` is returned)
        by_index = np.argsort(dup)
        dup, rep = dup[by_index], rep[by_index]
    return Triangulation(
        triangles=tri[:end].reshape(n_tri, 3),
        neighbors=he[:end].reshape(n_tri, 3),
        hull=inp[ring],
        duplicates=dup,
        representatives=rep,
        status=STATUS_OK,
        blocks=blocks,
        order=order,
    )
