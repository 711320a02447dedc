"""Point location, barycentric interpolation and nearest vertices on a planar triangulation.

Used for the depth of an ADT surface at arbitrary (u, v) positions (paper section 4: the
surfaces are compared "for the same x-axis and y-axis coordinates"), for the linear gridding
of the NURBS baseline (section 3.1) and by the water-jet model to find where a streamlet
strikes a height-field surface.

Locating a point walks from triangle to triangle across the edge the point lies beyond
(a visibility walk, which terminates on Delaunay triangulations), deciding sides with the
exact orientation predicate; points on an edge or on the hull boundary are inside. A
brute-force search backs up the walk for triangulations on which it cycles. Barycentric
weights are ratios of orientation determinants, so a query at a vertex gets exactly that
vertex's value. The walk needs each triangle's neighbours: an ADT surface carries them (its
triangulator's half-edges); for other meshes :func:`triangle_neighbors` computes them.

The nearest vertex of a query (outside the hull, for the NURBS grid) is found by a greedy
walk on the Delaunay graph, which reaches the nearest vertex from any start (a vertex that is
not the nearest always has a Delaunay neighbour closer to the query); among vertices at
exactly the same distance the first in the lexicographic order of their positions is taken
(smaller u, then smaller v), so the answer depends on the point set alone, not on the
vertices' numbering (a cloud file's row order).
"""

from __future__ import annotations

import numpy as np

from replication._aot import kernel
from replication.errors import InputError
from replication.surfaces._threads import frozen

__all__ = [
    "triangle_neighbors",
    "locate",
    "locate_valid",
    "interpolate_linear",
    "nearest_vertices",
    "fill_nearest",
]


def triangle_neighbors(triangles: np.ndarray) -> np.ndarray:
    """Neighbour of each triangle across each edge, -1 on the boundary (int32).

    ``neighbors[t, k]`` is the triangle across the edge from ``triangles[t, k]`` to
    ``triangles[t, (k + 1) % 3]``. Sorts every edge: use the triangulator's own adjacency
    (:attr:`.Surface.neighbors`) when there is one.
    """
    triangles = np.asarray(triangles, dtype=np.int64)
    m = triangles.shape[0]
    a = triangles.ravel()
    b = triangles[:, [1, 2, 0]].ravel()
    n = int(max(a.max(initial=0), b.max(initial=0))) + 1
    key = a * n + b  # directed edge a->b
    twin = b * n + a
    order = np.argsort(key)
    pos = np.searchsorted(key[order], twin)
    pos = np.minimum(pos, key.size - 1)
    found = key[order][pos] == twin
    neighbors = np.where(found, order[pos] // 3, -1)
    return neighbors.reshape(m, 3).astype(np.int32)


def _int32(a: np.ndarray) -> np.ndarray:
    """Indices as aligned, read-only int32; wider integers must fit (a cast would wrap them)."""
    a = np.asarray(a)
    if a.dtype != np.int32 and a.dtype.kind in "iu" and a.size:
        low, high = int(a.min()), int(a.max())
        if low < -(2**31) or high >= 2**31:
            raise InputError(f"indices must fit in int32, got values {low}..{high}")
    return frozen(a, np.int32)


def _check_mesh(xy: np.ndarray, triangles: np.ndarray, neighbors: np.ndarray | None = None) -> None:
    """The kernels index with these arrays unchecked: their shapes and index ranges, or an
    :class:`~replication.errors.InputError` naming the bad one (not a crash)."""
    if xy.ndim != 2 or xy.shape[1] != 2:
        raise InputError(f"vertex positions must have shape (n, 2), got {xy.shape}")
    if triangles.ndim != 2 or triangles.shape[1] != 3:
        raise InputError(f"triangles must have shape (m, 3), got {triangles.shape}")
    n, m = xy.shape[0], triangles.shape[0]
    if m and (triangles.min() < 0 or triangles.max() >= n):
        raise InputError(
            f"triangle vertex indices must lie in 0..{n - 1}, got {triangles.min()}..{triangles.max()}"
        )
    if neighbors is not None:
        _check_neighbors(triangles, neighbors)


def _check_neighbors(triangles: np.ndarray, neighbors: np.ndarray) -> None:
    m = triangles.shape[0]
    if neighbors.shape != triangles.shape:
        raise InputError(f"neighbors must have the triangles' shape {triangles.shape}, got {neighbors.shape}")
    if m and neighbors.max() >= m:
        raise InputError(f"neighbour triangles must lie in 0..{m - 1} or be negative, got {neighbors.max()}")


def locate(
    uv: np.ndarray,
    triangles: np.ndarray,
    queries: np.ndarray,
    neighbors: np.ndarray | None = None,
    *,
    convex: bool = True,
) -> np.ndarray:
    """Index of the triangle containing each query point (boundary included), -1 outside.

    Parameters
    ----------
    uv : ndarray, shape (n, 2)
        Vertex positions.
    triangles : ndarray of int, shape (m, 3)
        Counter-clockwise triangles.
    queries : ndarray, shape (k, 2)
    neighbors : ndarray, optional
        The triangles' neighbours (:attr:`.Surface.neighbors` or :func:`triangle_neighbors`).
    convex : bool
        True when the triangles tile a convex region (any Delaunay triangulation, hence any
        ADT surface): leaving through the boundary then proves a query is outside. False
        searches every triangle before declaring a query outside (for arbitrary meshes).
    """
    return _walk(uv, triangles, queries, neighbors, convex)[0]


def locate_valid(
    uv: np.ndarray, triangles: np.ndarray, neighbors: np.ndarray, queries: np.ndarray, *, convex: bool
) -> np.ndarray:
    """:func:`locate` without its checks of the mesh, for meshes known to be valid (a
    :class:`~replication.surfaces.Surface`'s arrays, the jet model's checked meshes): in-range
    triangles and neighbours, vertex positions of shape (n, 2), queries of shape (k, 2).
    The checks cost twice the walk itself on the jet's hundred streamlets."""
    xy, queries = frozen(uv, np.float64), frozen(queries, np.float64)
    return _located(xy, _int32(triangles), _int32(neighbors), queries, convex)[0]


def _located(xy, triangles, neighbors, queries, convex):
    """The walk's kernel on prepared arrays: each query's triangle (-1 outside) and, for one
    outside, the triangle its walk left through (-1 otherwise)."""
    found = np.empty(queries.shape[0], dtype=np.int32)
    left = np.empty(queries.shape[0], dtype=np.int32)
    kernel("locate")(xy, triangles, neighbors, queries, not convex, found, left)
    return found, left


def _walk(uv, triangles, queries, neighbors, convex):
    triangles = _int32(triangles)
    queries = frozen(np.asarray(queries, dtype=np.float64).reshape(-1, 2))
    xy = frozen(uv, np.float64)
    _check_mesh(xy, triangles)
    if neighbors is None:
        nbr = _int32(triangle_neighbors(triangles))
    else:
        nbr = _int32(neighbors)
        _check_neighbors(triangles, nbr)
    found, left = _located(xy, triangles, nbr, queries, convex)
    return found, left, triangles, nbr, queries, xy


def fill_nearest(
    uv: np.ndarray,
    triangles: np.ndarray,
    neighbors: np.ndarray,
    queries: np.ndarray,
    start: np.ndarray,
) -> np.ndarray:
    """Nearest vertex of queries outside a Delaunay triangulation: a walk from a triangle
    ``start[i]`` near each query to the boundary, then the greedy walk of
    :func:`nearest_vertices` (of equally near vertices, the lexicographically smallest)."""
    queries = frozen(np.asarray(queries, dtype=np.float64).reshape(-1, 2))
    xy = frozen(uv, np.float64)
    triangles, neighbors = _int32(triangles), _int32(neighbors)
    _check_mesh(xy, triangles, neighbors)
    return _fill_nearest(xy, triangles, neighbors, queries, _int32(start))


def _fill_nearest(xy, triangles, neighbors, queries, start):
    """:func:`fill_nearest` without the checks of the mesh (the NURBS gridding's own arrays)."""
    xy, queries = frozen(xy, np.float64), frozen(queries, np.float64)
    triangles, neighbors, start = _int32(triangles), _int32(neighbors), _int32(start)
    left = np.empty(queries.shape[0], dtype=np.int32)
    _check_starts(start, queries.shape[0], triangles.shape[0])
    kernel("exits")(xy, triangles, neighbors, queries, start, left)
    if np.any(left < 0):
        raise ValueError("fill_nearest: a query lies inside the triangulation")
    out = np.empty(queries.shape[0], dtype=np.int32)
    kernel("nearest")(xy, triangles, neighbors, queries, _int32(left), out)
    return out


def nearest_vertices(
    uv: np.ndarray, triangles: np.ndarray, neighbors: np.ndarray, queries: np.ndarray, start: np.ndarray
) -> np.ndarray:
    """Nearest vertex of each query on a Delaunay triangulation (of equally near ones, the
    first in the lexicographic order of positions), by a greedy walk from a triangle
    ``start[i]`` near each query."""
    queries = frozen(np.asarray(queries, dtype=np.float64).reshape(-1, 2))
    out = np.empty(queries.shape[0], dtype=np.int32)
    xy = frozen(uv, np.float64)
    triangles, start, neighbors = _int32(triangles), _int32(start), _int32(neighbors)
    _check_mesh(xy, triangles, neighbors)
    _check_starts(start, queries.shape[0], triangles.shape[0])
    kernel("nearest")(xy, triangles, neighbors, queries, start, out)
    return out


def _check_starts(start: np.ndarray, queries: int, triangles: int) -> None:
    """The nearest-vertex walk reads triangle ``start[i]`` unchecked: one valid index per query."""
    if start.shape != (queries,):
        raise ValueError(f"start must hold one triangle per query ({queries}), got shape {start.shape}")
    if start.size and (start.min() < 0 or start.max() >= triangles):
        raise ValueError(f"start triangles must lie in 0..{triangles - 1}, got {start.min()}..{start.max()}")


def interpolate_linear(
    uv: np.ndarray,
    triangles: np.ndarray,
    values: np.ndarray,
    queries: np.ndarray,
    *,
    convex: bool = True,
    neighbors: np.ndarray | None = None,
    nearest_outside: bool = False,
    located: bool = False,
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Piecewise-linear (barycentric) interpolation of vertex ``values`` at ``queries``.

    Returns NaN for queries outside the triangulation, or with ``nearest_outside`` (convex
    Delaunay triangulations only) the value of the nearest vertex. At a vertex the vertex's
    own value is returned exactly. ``neighbors``: the triangles' adjacency, if known;
    ``located``: return ``(triangle of each query or -1, values)``.

    Notes
    -----
    The depth of an ADT surface at (u, v) (paper section 4) and MATLAB-style ``griddata``
    linear interpolation (section 3.1) are both this function on the Delaunay triangulation.
    """
    found, left, triangles, nbr, queries, xy = _walk(uv, triangles, queries, neighbors, convex)
    values = frozen(values, np.float64)
    if values.shape != (xy.shape[0],):
        raise InputError(f"values must hold one number per vertex ({xy.shape[0]}), got shape {values.shape}")
    out = np.empty(queries.shape[0])
    kernel("barycentric")(xy, triangles, found, queries, values, out)
    if nearest_outside:
        outside = np.flatnonzero(found < 0)
        if outside.size:
            near = np.empty(outside.size, dtype=np.int32)
            start = _int32(left[outside])
            if np.any(start < 0):  # a walk that did not leave through the boundary: not convex Delaunay
                raise ValueError("nearest_outside needs a convex Delaunay triangulation: a query is outside "
                                 "but its walk did not reach the boundary")  # fmt: skip
            kernel("nearest")(xy, triangles, nbr, frozen(queries[outside]), start, near)
            out[outside] = values[near]
    return (found, out) if located else out
