"""Compiled kernels of :mod:`.interpolate`: point location, barycentric weights, nearest vertices.

Kept apart from the functions that call them so that importing :mod:`.interpolate` does not
import numba: a command on a small cloud runs these kernels ahead-of-time compiled
(:mod:`replication._aot`) and never starts numba. The algorithms are described in
:mod:`.interpolate`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from replication import _numbacache
from replication.surfaces._predicates import orient


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


@njit(cache=True, nogil=True)
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


@njit(cache=True, nogil=True)
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


@njit(cache=True, nogil=True)
def _nearest(xy, tri, nbr, queries, start, out):
    """Nearest vertex of each query by a greedy walk on the triangulation from triangle ``start[i]``.

    Among vertices at the same distance the first in the lexicographic order of their
    positions wins (smaller first coordinate, then smaller second): a rule of the point set
    alone, so that the answer does not depend on how the vertices are numbered (a cloud
    file's row order). They are connected by Delaunay edges, so a search over them finds it.
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
        # every vertex at the same (nearest) distance: take the lexicographically smallest position
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
                if xy[w, 0] < xy[answer, 0] or (xy[w, 0] == xy[answer, 0] and xy[w, 1] < xy[answer, 1]):
                    answer = w
        out[i] = answer


@njit(cache=True, inline="always")
def _area2(ax, ay, bx, by, cx, cy):
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


@njit(cache=True, nogil=True)
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


_numbacache.refresh(globals())  # numba keys its cache on this file only (see replication._numbacache)
