"""The NURBS baseline's gridding of a triangulation (paper section 3.1): the callers of :mod:`._raster`.

Large triangulations are cut into fixed pieces that numba's kernels run on the thread pool
(they release the GIL); a small one is one piece, run by :func:`replication._aot.kernel`, so
that ``replication nurbs`` on a typical cloud runs the ahead-of-time kernels and never starts
numba. The pieces never depend on the thread count, so neither do the results.
"""

from __future__ import annotations

import numpy as np

from replication._aot import kernel
from replication.errors import InputError
from replication.surfaces._threads import frozen

__all__ = ["raster", "relabel"]

#: The triangles are cut into this many runs, rasterized on the thread pool into the same grid
#: (a node belongs to the lowest-index triangle containing it, decided by that triangle alone).
_RUNS = 4
#: Triangulations of at least this many triangles are cut into ``_RUNS`` pieces.
_PIECES_MIN = 100_000


def raster(
    xy: np.ndarray, tri: np.ndarray, nbr: np.ndarray, values: np.ndarray, u: np.ndarray, v: np.ndarray
):
    """``(owner, out)``: for each node of the grid ``u x v``, the first triangle containing it
    (-1 outside) and the interpolated value there (undefined outside).

    ``nbr`` is the triangles' adjacency (``Surface.neighbors``): a large triangulation is
    rasterized in pieces at once, and a node on an edge or a vertex is taken by the triangle
    that the adjacency shows to be the lowest-index one containing it. One grid and no
    per-piece copies: at a million nodes the copies were 36 MB of fresh pages and a merge.
    """
    xy, tri, values = frozen(xy, np.float64), frozen(tri, np.int32), frozen(values, np.float64)
    u, v = frozen(u, np.float64), frozen(v, np.float64)
    shape = (u.shape[0], v.shape[0])
    m = tri.shape[0]
    owner, out = np.full(shape, -1, dtype=np.int32), np.empty(shape)
    if m < _PIECES_MIN:
        kernel("raster")(xy, tri, values, u, v, 0, m, owner, out)
        return owner, out
    from replication.surfaces._raster import _raster_shared
    from replication.surfaces._threads import run

    nbr = frozen(nbr, np.int32)
    if nbr.shape != tri.shape:
        raise InputError(f"the adjacency must have the triangles' shape {tri.shape}, got {nbr.shape}")
    edges = [m * r // _RUNS for r in range(_RUNS + 1)]
    run([
        (lambda r=r: _raster_shared(xy, tri, nbr, values, u, v, edges[r], edges[r + 1], owner, out))
        for r in range(_RUNS)
    ])  # fmt: skip
    return owner, out


def relabel(points: np.ndarray, axes: np.ndarray, triangles: np.ndarray, order: np.ndarray):
    """``(xy, values, tri, bounds)``: the (u, v) and depth (columns ``axes``) of vertex
    ``order[k]`` as point k, the triangles relabelled so, and (min u, max u, min v, max v).

    Kernels that visit every triangle then read the vertices of nearby triangles from nearby
    memory (the triangulator's order is block by block, in sweep order), which halves the
    time of a grid of a million nodes. Runs in fixed pieces on the thread pool.
    """
    points, axes = frozen(points, np.float64), frozen(axes, np.int64)
    triangles, order = frozen(triangles, np.int32), np.asarray(order)
    m, count = order.shape[0], triangles.shape[0]
    n = points.shape[0]
    # the kernels index with ``order`` unchecked: it must number every point once (1 ms at 1e6)
    if order.shape != (n,):
        raise InputError(f"the vertex order must be a permutation of 0..{n - 1}, got shape {order.shape}")
    if not np.issubdtype(order.dtype, np.integer):  # a NaN passes both range tests, and casts out of range
        raise InputError(f"the vertex order must be a permutation of 0..{n - 1}, got dtype {order.dtype}")
    if n and (order.min() < 0 or order.max() >= n):
        raise InputError(
            f"the vertex order must be a permutation of 0..{n - 1}, got values {order.min()}..{order.max()}"
        )
    order = frozen(order, np.int32)  # after the range check: a wider integer could wrap into range
    position = np.full(n, -1, dtype=np.int32)
    xy = np.empty((m, 2))
    values = np.empty(m)
    tri = np.empty((count, 3), dtype=np.int32)
    pieces = 1 if count < _PIECES_MIN else _RUNS
    cut = [m * r // pieces for r in range(pieces + 1)]
    bounds = np.empty((pieces, 4))
    if pieces == 1:
        kernel("number")(order, 0, m, position)
    else:
        from replication.surfaces._raster import _number
        from replication.surfaces._threads import run

        run([(lambda r=r: _number(order, cut[r], cut[r + 1], position)) for r in range(pieces)])
    if n and position.min() < 0:  # n entries in range, yet a point was never numbered: one came twice
        raise InputError(f"the vertex order must be a permutation of 0..{n - 1}: it repeats a vertex")
    if pieces == 1:
        kernel("gather")(points, axes, position, 0, n, xy, values, bounds[0])
    else:
        from replication.surfaces._raster import _gather

        run([
            (lambda r=r: _gather(points, axes, position, cut[r], cut[r + 1], xy, values, bounds[r]))
            for r in range(pieces)
        ])  # fmt: skip
    if pieces == 1:
        kernel("renumber")(triangles, position, 0, count, tri)
    else:
        from replication.surfaces._raster import _renumber

        cut = [count * r // pieces for r in range(pieces + 1)]
        run([(lambda r=r: _renumber(triangles, position, cut[r], cut[r + 1], tri)) for r in range(pieces)])
    lo, hi = bounds.min(axis=0), bounds.max(axis=0)
    return xy, values, tri, (float(lo[0]), float(hi[1]), float(lo[2]), float(hi[3]))
