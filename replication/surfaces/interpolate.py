"""Point location and barycentric interpolation on a planar triangulation.

Used for the depth of an ADT surface at arbitrary (u, v) positions (paper section 4: the
surfaces are compared "for the same x-axis and y-axis coordinates"), for the linear gridding
of the NURBS baseline (section 3.1) and by the water-jet model to find where a streamlet
strikes a height-field surface.

Locating a point walks from triangle to triangle across the edge the point lies beyond
(a visibility walk, which terminates on Delaunay triangulations), deciding sides with the
exact orientation predicate; points on an edge or on the hull boundary are inside. A
brute-force search backs up the walk for triangulations on which it cycles. Barycentric
weights are ratios of orientation determinants, so a query at a vertex gets exactly that
vertex's value.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from replication.surfaces._sweephull import orient

__all__ = ["triangle_neighbors", "locate", "interpolate_linear"]


def triangle_neighbors(triangles: np.ndarray) -> np.ndarray:
    """Neighbour of each triangle across each edge, -1 on the boundary.

    ``neighbors[t, k]`` is the triangle across the edge from ``triangles[t, k]`` to
    ``triangles[t, (k + 1) % 3]``.
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
    return neighbors.reshape(m, 3)


@njit(cache=True)
def _inside(x, y, tri, t, qx, qy):
    a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
    return (
        orient(x[a], y[a], x[b], y[b], qx, qy) >= 0.0
        and orient(x[b], y[b], x[c], y[c], qx, qy) >= 0.0
        and orient(x[c], y[c], x[a], y[a], qx, qy) >= 0.0
    )


@njit(cache=True)
def _locate(x, y, tri, nbr, qx, qy, exhaustive):
    m = tri.shape[0]
    n = qx.shape[0]
    found = np.full(n, -1, dtype=np.int64)
    max_steps = 4 * m + 16
    t = 0
    for i in range(n):
        px = qx[i]
        py = qy[i]
        state = 0  # 0: walking, 1: found, 2: left through the boundary
        for step in range(max_steps):
            moved = False
            for kk in range(3):
                k = (kk + step) % 3  # rotate the edge order so the walk cannot cycle for long
                a = tri[t, k]
                b = tri[t, (k + 1) % 3]
                if orient(x[a], y[a], x[b], y[b], px, py) < 0.0:
                    if nbr[t, k] == -1:
                        state = 2
                    else:
                        t = nbr[t, k]
                        moved = True
                    break
            if state == 2:
                break
            if not moved:
                state = 1
                break
        if state == 1:
            found[i] = t
        elif state == 0 or exhaustive:
            # the walk ran out of steps, or the mesh may be non-convex: search every triangle
            for s in range(m):
                if _inside(x, y, tri, s, px, py):
                    found[i] = s
                    t = s
                    break
    return found


@njit(cache=True, inline="always")
def _area2(ax, ay, bx, by, cx, cy):
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


@njit(cache=True)
def _barycentric(x, y, tri, found, qx, qy, values):
    n = qx.shape[0]
    out = np.full(n, np.nan)
    for i in range(n):
        t = found[i]
        if t < 0:
            continue
        a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
        px = qx[i]
        py = qy[i]
        # the query replaces one vertex in the same expression, so at a vertex its weight is
        # exactly 1 and the others exactly 0
        den = _area2(x[a], y[a], x[b], y[b], x[c], y[c])
        la = _area2(px, py, x[b], y[b], x[c], y[c]) / den
        lb = _area2(x[a], y[a], px, py, x[c], y[c]) / den
        lc = _area2(x[a], y[a], x[b], y[b], px, py) / den
        out[i] = la * values[a] + lb * values[b] + lc * values[c]
    return out


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
        :func:`triangle_neighbors` of ``triangles``, if already computed.
    convex : bool
        True when the triangles tile a convex region (any Delaunay triangulation, hence any
        ADT surface): leaving through the boundary then proves a query is outside. False
        searches every triangle before declaring a query outside (for arbitrary meshes).
    """
    uv = np.asarray(uv, dtype=np.float64)
    triangles = np.ascontiguousarray(triangles, dtype=np.int64)
    queries = np.asarray(queries, dtype=np.float64).reshape(-1, 2)
    if neighbors is None:
        neighbors = triangle_neighbors(triangles)
    return _locate(
        np.ascontiguousarray(uv[:, 0]),
        np.ascontiguousarray(uv[:, 1]),
        triangles,
        np.ascontiguousarray(neighbors, dtype=np.int64),
        np.ascontiguousarray(queries[:, 0]),
        np.ascontiguousarray(queries[:, 1]),
        not convex,
    )


def interpolate_linear(
    uv: np.ndarray,
    triangles: np.ndarray,
    values: np.ndarray,
    queries: np.ndarray,
    *,
    convex: bool = True,
) -> np.ndarray:
    """Piecewise-linear (barycentric) interpolation of vertex ``values`` at ``queries``.

    Returns NaN for queries outside the triangulation. At a vertex the vertex's own value is
    returned exactly.

    Notes
    -----
    The depth of an ADT surface at (u, v) (paper section 4) and MATLAB-style ``griddata``
    linear interpolation (section 3.1) are both this function on the Delaunay triangulation.
    """
    uv = np.asarray(uv, dtype=np.float64)
    queries = np.asarray(queries, dtype=np.float64).reshape(-1, 2)
    triangles = np.ascontiguousarray(triangles, dtype=np.int64)
    found = locate(uv, triangles, queries, convex=convex)
    return _barycentric(
        np.ascontiguousarray(uv[:, 0]),
        np.ascontiguousarray(uv[:, 1]),
        triangles,
        found,
        np.ascontiguousarray(queries[:, 0]),
        np.ascontiguousarray(queries[:, 1]),
        np.ascontiguousarray(values, dtype=np.float64),
    )
