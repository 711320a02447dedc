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
exactly the same distance the one of smallest index is taken.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from replication.surfaces._predicates import orient
from replication.surfaces._threads import frozen

__all__ = ["triangle_neighbors", "locate", "interpolate_linear", "nearest_vertices", "fill_nearest"]


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
    return frozen(a, np.int32)


@njit(cache=True)
def _inside(xy, tri, t, qx, qy):
    a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
    return (
        orient(xy[a, 0], xy[a, 1], xy[b, 0], xy[b, 1], qx, qy) >= 0.0
        and orient(xy[b, 0], xy[b, 1], xy[c, 0], xy[c, 1], qx, qy) >= 0.0
        and orient(xy[c, 0], xy[c, 1], xy[a, 0], xy[a, 1], qx, qy) >= 0.0
    )


@njit(cache=True)
def _walk_one(xy, tri, nbr, t, px, py, max_steps):
    """Visibility walk from triangle t towards (px, py): ``(state, triangle)``; state 1: the
    triangle contains the point, 2: the walk left through the boundary there, 0: out of steps."""
    for step in range(max_steps):
        moved = False
        for kk in range(3):
            k = (kk + step) % 3  # rotate the edge order so the walk cannot cycle for long
            a = tri[t, k]
            b = tri[t, (k + 1) % 3]
            if orient(xy[a, 0], xy[a, 1], xy[b, 0], xy[b, 1], px, py) < 0.0:
                if nbr[t, k] == -1:
                    return 2, t
                t = nbr[t, k]
                moved = True
                break
        if not moved:
            return 1, t
    return 0, t


@njit(cache=True)
def _locate(xy, tri, nbr, queries, exhaustive, found, left):
    """Triangle of each query in ``found`` (-1 outside); ``left``: the triangle it left through."""
    m = tri.shape[0]
    max_steps = 4 * m + 16
    t = np.int64(0)
    for i in range(queries.shape[0]):
        px = queries[i, 0]
        py = queries[i, 1]
        state, t = _walk_one(xy, tri, nbr, t, px, py, max_steps)
        found[i] = t if state == 1 else -1
        left[i] = t if state == 2 else -1
        if state == 0 or (state == 2 and exhaustive):
            # the walk ran out of steps, or the mesh may be non-convex: search every triangle
            for s in range(m):
                if _inside(xy, tri, s, px, py):
                    found[i] = s
                    left[i] = -1
                    t = s
                    break


@njit(cache=True)
def _exits(xy, tri, nbr, queries, start, left):
    """For queries outside a convex triangulation: the boundary triangle each walk leaves
    through (-1 if the query is inside after all). Each walk starts from triangle
    ``start[i]`` or, when it is nearer, from where the previous query's walk ended."""
    max_steps = 4 * tri.shape[0] + 16
    previous = -1
    for i in range(queries.shape[0]):
        px = queries[i, 0]
        py = queries[i, 1]
        t = start[i]
        if previous >= 0:
            a = tri[previous, 0]
            b = tri[t, 0]
            if (xy[a, 0] - px) ** 2 + (xy[a, 1] - py) ** 2 < (xy[b, 0] - px) ** 2 + (xy[b, 1] - py) ** 2:
                t = previous
        state, t = _walk_one(xy, tri, nbr, t, px, py, max_steps)
        left[i] = t if state == 2 else -1
        previous = t


@njit(cache=True)
def _corner(tri, t, v):
    return 0 if tri[t, 0] == v else (1 if tri[t, 1] == v else 2)


@njit(cache=True)
def _ring(tri, nbr, t, v, around, where):
    """The neighbours of vertex v (a vertex of triangle t), each with a triangle holding both;
    returns their number (a neighbour may be listed twice)."""
    count = 0
    cur = t
    closed = False
    for _ in range(tri.shape[0]):  # clockwise around v, across the edge (w, v) of each triangle
        j = _corner(tri, cur, v)
        around[count] = tri[cur, (j + 1) % 3]
        around[count + 1] = tri[cur, (j + 2) % 3]
        where[count] = cur
        where[count + 1] = cur
        count += 2
        nb = nbr[cur, (j + 2) % 3]
        if nb < 0:
            break
        if nb == t:
            closed = True
            break
        cur = nb
    if not closed:  # a boundary vertex: the other way round too
        cur = t
        for _ in range(tri.shape[0]):
            nb = nbr[cur, _corner(tri, cur, v)]
            if nb < 0:
                break
            cur = nb
            j = _corner(tri, cur, v)
            around[count] = tri[cur, (j + 1) % 3]
            around[count + 1] = tri[cur, (j + 2) % 3]
            where[count] = cur
            where[count + 1] = cur
            count += 2
    return count


@njit(cache=True)
def _nearest(xy, tri, nbr, queries, start, ids, out):
    """Nearest vertex of each query by a greedy walk on the triangulation from triangle ``start[i]``.

    Among vertices at the same distance the one of smallest ``ids`` wins (they are connected
    by Delaunay edges, so a search over them finds it).
    """
    around = np.empty(2 * tri.shape[0] + 6, dtype=tri.dtype)
    where = np.empty(2 * tri.shape[0] + 6, dtype=tri.dtype)
    seen = np.empty(64, dtype=tri.dtype)
    todo = np.empty(64, dtype=tri.dtype)
    todo_t = np.empty(64, dtype=tri.dtype)
    for i in range(queries.shape[0]):
        qx = queries[i, 0]
        qy = queries[i, 1]
        t = start[i]
        v = tri[t, 0]
        best = (xy[v, 0] - qx) ** 2 + (xy[v, 1] - qy) ** 2
        improved = True
        while improved:  # move to a closer vertex while there is one
            improved = False
            count = _ring(tri, nbr, t, v, around, where)
            nv = v
            nt = t
            for k in range(count):
                w = around[k]
                d = (xy[w, 0] - qx) ** 2 + (xy[w, 1] - qy) ** 2
                if d < best:
                    best = d
                    nv = w
                    nt = where[k]
            if nv != v:
                v = nv
                t = nt
                improved = True
        # every vertex at the same (nearest) distance: take the smallest index
        n_seen = 1
        seen[0] = v
        top = 1
        todo[0] = v
        todo_t[0] = t
        answer = v
        while top > 0:
            top -= 1
            count = _ring(tri, nbr, todo_t[top], todo[top], around, where)
            for k in range(count):
                w = around[k]
                if (xy[w, 0] - qx) ** 2 + (xy[w, 1] - qy) ** 2 != best:
                    continue
                known = False
                for s in range(n_seen):
                    known = known or seen[s] == w
                if known or n_seen == seen.shape[0] or top == todo.shape[0]:
                    continue
                seen[n_seen] = w
                n_seen += 1
                todo[top] = w
                todo_t[top] = where[k]
                top += 1
                if ids[w] < ids[answer]:
                    answer = w
        out[i] = answer


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


def _walk(uv, triangles, queries, neighbors, convex):
    triangles = _int32(triangles)
    queries = frozen(np.asarray(queries, dtype=np.float64).reshape(-1, 2))
    nbr = _int32(triangle_neighbors(triangles) if neighbors is None else neighbors)
    found = np.empty(queries.shape[0], dtype=np.int32)
    left = np.empty(queries.shape[0], dtype=np.int32)
    xy = frozen(uv, np.float64)
    _locate(xy, triangles, nbr, queries, not convex, found, left)
    return found, left, triangles, nbr, queries, xy


def fill_nearest(
    uv: np.ndarray,
    triangles: np.ndarray,
    neighbors: np.ndarray,
    queries: np.ndarray,
    start: np.ndarray,
    ids: np.ndarray | None = None,
) -> np.ndarray:
    """Nearest vertex of queries outside a Delaunay triangulation: a walk from a triangle
    ``start[i]`` near each query to the boundary, then the greedy walk of
    :func:`nearest_vertices` (smallest index, or smallest ``ids``, among equally near
    vertices)."""
    queries = frozen(np.asarray(queries, dtype=np.float64).reshape(-1, 2))
    xy = frozen(uv, np.float64)
    triangles, neighbors = _int32(triangles), _int32(neighbors)
    left = np.empty(queries.shape[0], dtype=np.int32)
    _exits(xy, triangles, neighbors, queries, _int32(start), left)
    if np.any(left < 0):
        raise ValueError("fill_nearest: a query lies inside the triangulation")
    out = np.empty(queries.shape[0], dtype=np.int32)
    ids = _int32(np.arange(xy.shape[0])) if ids is None else _int32(ids)
    _nearest(xy, triangles, neighbors, queries, _int32(left), ids, out)
    return out


def nearest_vertices(
    uv: np.ndarray, triangles: np.ndarray, neighbors: np.ndarray, queries: np.ndarray, start: np.ndarray
) -> np.ndarray:
    """Nearest vertex of each query (smallest index among equally near ones) on a Delaunay
    triangulation, by a greedy walk from a triangle ``start[i]`` near each query."""
    queries = frozen(np.asarray(queries, dtype=np.float64).reshape(-1, 2))
    out = np.empty(queries.shape[0], dtype=np.int32)
    xy = frozen(uv, np.float64)
    ids = _int32(np.arange(xy.shape[0]))
    _nearest(xy, _int32(triangles), _int32(neighbors), queries, _int32(start), ids, out)
    return out


@njit(cache=True, inline="always")
def _area2(ax, ay, bx, by, cx, cy):
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


@njit(cache=True)
def _barycentric(xy, tri, found, queries, values, out):
    for i in range(queries.shape[0]):
        t = found[i]
        if t < 0:
            out[i] = np.nan
            continue
        a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
        px = queries[i, 0]
        py = queries[i, 1]
        ax, ay, bx, by, cx, cy = xy[a, 0], xy[a, 1], xy[b, 0], xy[b, 1], xy[c, 0], xy[c, 1]
        # the query replaces one vertex in the same expression, so at a vertex its weight is
        # exactly 1 and the others exactly 0
        den = _area2(ax, ay, bx, by, cx, cy)
        la = _area2(px, py, bx, by, cx, cy) / den
        lb = _area2(ax, ay, px, py, cx, cy) / den
        lc = _area2(ax, ay, bx, by, px, py) / den
        out[i] = la * values[a] + lb * values[b] + lc * values[c]


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
    out = np.empty(queries.shape[0])
    _barycentric(xy, triangles, found, queries, values, out)
    if nearest_outside:
        outside = np.flatnonzero(found < 0)
        if outside.size:
            near = np.empty(outside.size, dtype=np.int32)
            ids = _int32(np.arange(xy.shape[0]))
            _nearest(xy, triangles, nbr, frozen(queries[outside]), _int32(left[outside]), ids, near)
            out[outside] = values[near]
    return (found, out) if located else out
