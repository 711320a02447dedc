"""Linear interpolation of a triangulation onto a uniform grid, triangle by triangle (numba).

The NURBS baseline samples the cloud's triangulation at as many grid nodes as the cloud has
points (paper section 3.1). Walking from node to node is a chain of dependent memory reads
through a large mesh; this kernel instead visits the triangles in order and fills the grid
nodes each one covers, so the reads are independent and the work is proportional to
triangles + nodes. The candidates are the nodes of the triangle's bounding box in grid
indices (widened by ``_SLACK`` steps, far more than the rounding of the index computation),
each tested with the exact orientation predicate. A node on an edge or a vertex belongs to the first
triangle (lowest index) that contains it; its value is the same barycentric formula as
:func:`.interpolate.interpolate_linear`. Nodes outside the triangulation stay unassigned
(-1).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from replication import _numbacache
from replication.surfaces._predicates import orient

#: Slack (in grid steps) of the candidate range against the rounding of its computation.
_SLACK = 1e-6


@njit(cache=True, inline="always")
def _area2(ax, ay, bx, by, cx, cy):
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


@njit(cache=True, inline="always")
def _box(ax, ay, bx, by, cx, cy, u, v):
    """The grid indices ``(i_lo, i_hi, j_lo, j_hi)`` of the candidate nodes of triangle abc:
    its bounding box on the uniform grid ``u x v``, widened by ``_SLACK`` steps."""
    mu = u.shape[0]
    mv = v.shape[0]
    u0 = u[0]
    v0 = v[0]
    iu = (mu - 1) / (u[mu - 1] - u0)
    iv = (mv - 1) / (v[mv - 1] - v0)
    i_lo = max(0, int(math.ceil((min(ax, bx, cx) - u0) * iu - _SLACK)))
    i_hi = min(mu - 1, int(math.floor((max(ax, bx, cx) - u0) * iu + _SLACK)))
    j_lo = max(0, int(math.ceil((min(ay, by, cy) - v0) * iv - _SLACK)))
    j_hi = min(mv - 1, int(math.floor((max(ay, by, cy) - v0) * iv + _SLACK)))
    return i_lo, i_hi, j_lo, j_hi


@njit(cache=True, inline="always")
def _value(px, py, ax, ay, bx, by, cx, cy, den, va, vb, vc):
    """The barycentric interpolation at p of the values at a, b, c (``den``: twice abc's area)."""
    la = _area2(px, py, bx, by, cx, cy) / den
    lb = _area2(ax, ay, px, py, cx, cy) / den
    lc = _area2(ax, ay, bx, by, px, py) / den
    return la * va + lb * vb + lc * vc


@njit(cache=True, nogil=True)
def _raster(xy, tri, values, u, v, lo, hi, owner, out):
    """Fill ``out[i, j]`` (the value at ``(u[i], v[j])``) and ``owner[i, j]`` (its triangle)
    from the triangles lo..hi-1. ``u`` and ``v`` are increasing and uniformly spaced;
    ``owner`` must hold -1 on entry."""
    for t in range(lo, hi):
        a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
        ax, ay, bx, by, cx, cy = xy[a, 0], xy[a, 1], xy[b, 0], xy[b, 1], xy[c, 0], xy[c, 1]
        i_lo, i_hi, j_lo, j_hi = _box(ax, ay, bx, by, cx, cy, u, v)
        den = 0.0
        for i in range(i_lo, i_hi + 1):
            px = u[i]
            for j in range(j_lo, j_hi + 1):
                if owner[i, j] >= 0:
                    continue
                py = v[j]
                if (
                    orient(ax, ay, bx, by, px, py) < 0.0
                    or orient(bx, by, cx, cy, px, py) < 0.0
                    or orient(cx, cy, ax, ay, px, py) < 0.0
                ):
                    continue
                if den == 0.0:
                    den = _area2(ax, ay, bx, by, cx, cy)
                owner[i, j] = t
                out[i, j] = _value(px, py, ax, ay, bx, by, cx, cy, den, values[a], values[b], values[c])


@njit(cache=True, nogil=True)
def _fan_min(tri, nbr, t, k):
    """The lowest index of the triangles around vertex ``tri[t, k]``: the triangles that
    contain a node lying on that vertex. Walks the vertex's fan through ``nbr`` both ways
    from ``t`` (at most ``len(tri)`` steps each, whatever ``nbr`` holds)."""
    w = tri[t, k]
    m = tri.shape[0]
    best = t
    for way in range(2):
        s, e = t, k if way == 0 else (k + 2) % 3  # leave through the edge that starts (ends) at w
        for _ in range(m):
            n = nbr[s, e]
            if n < 0 or n == t:
                break
            if n < best:
                best = n
            kw = 0 if tri[n, 0] == w else (1 if tri[n, 1] == w else 2)
            if tri[n, kw] != w:  # not a fan around w: a triangulation adt did not build
                break
            s, e = n, kw if way == 0 else (kw + 2) % 3
        else:
            continue
        if nbr[s, e] == t:  # an interior vertex: the walk came round, no need to walk back
            break
    return best


@njit(cache=True, nogil=True)
def _raster_shared(xy, tri, nbr, values, u, v, lo, hi, owner, out):
    """As :func:`_raster`, for the triangles lo..hi-1 of a conforming triangulation whose
    other triangles run at the same time on the same ``owner`` and ``out``.

    A node belongs to the lowest-index triangle that contains it, as in one sequential
    pass, decided by the claimant alone: a node inside a triangle has no other; one on an
    edge shares it with the neighbour across the edge (``nbr``); one on a vertex with the
    vertex's fan (:func:`_fan_min`). Every node is written by one triangle only, so runs of
    triangles can share the grid without a per-run copy and a merge. The ``owner[i, j] >=
    0`` test only skips a node taken already (by this run or another): it cannot change
    the result, since the taker is the one claimant.
    """
    for t in range(lo, hi):
        a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
        ax, ay, bx, by, cx, cy = xy[a, 0], xy[a, 1], xy[b, 0], xy[b, 1], xy[c, 0], xy[c, 1]
        i_lo, i_hi, j_lo, j_hi = _box(ax, ay, bx, by, cx, cy, u, v)
        den = 0.0
        for i in range(i_lo, i_hi + 1):
            px = u[i]
            for j in range(j_lo, j_hi + 1):
                if owner[i, j] >= 0:
                    continue
                py = v[j]
                oa = orient(ax, ay, bx, by, px, py)
                if oa < 0.0:
                    continue
                ob = orient(bx, by, cx, cy, px, py)
                if ob < 0.0:
                    continue
                oc = orient(cx, cy, ax, ay, px, py)
                if oc < 0.0:
                    continue
                if oa == 0.0 or ob == 0.0 or oc == 0.0:
                    if oa == 0.0 and oc == 0.0:
                        first = _fan_min(tri, nbr, t, 0)
                    elif oa == 0.0 and ob == 0.0:
                        first = _fan_min(tri, nbr, t, 1)
                    elif ob == 0.0 and oc == 0.0:
                        first = _fan_min(tri, nbr, t, 2)
                    else:
                        n = nbr[t, 0] if oa == 0.0 else (nbr[t, 1] if ob == 0.0 else nbr[t, 2])
                        first = t if n < 0 or n > t else n
                    if first != t:
                        continue
                if den == 0.0:
                    den = _area2(ax, ay, bx, by, cx, cy)
                owner[i, j] = t
                out[i, j] = _value(px, py, ax, ay, bx, by, cx, cy, den, values[a], values[b], values[c])


@njit(cache=True, nogil=True)
def _number(order, lo, hi, position):
    """``position[order[k]] = k`` for k in lo..hi-1: the inverse of the vertex order."""
    for k in range(lo, hi):
        position[order[k]] = k


@njit(cache=True, nogil=True)
def _gather(points, axes, position, lo, hi, xy, values, bounds):
    """Copy points lo..hi-1 (columns ``axes``) to their rows ``position`` of ``xy`` and
    ``values``; ``bounds``: their (min u, max u, min v, max v).

    The points are read in storage order and written where the vertex order puts them:
    reading them in the vertex order instead (one random read of a row per point) took four
    times as long at a million points.
    """
    a0 = axes[0]
    a1 = axes[1]
    a2 = axes[2]
    u_lo = np.inf
    u_hi = -np.inf
    v_lo = np.inf
    v_hi = -np.inf
    for i in range(lo, hi):
        k = position[i]
        u = points[i, a0]
        v = points[i, a1]
        xy[k, 0] = u
        xy[k, 1] = v
        values[k] = points[i, a2]
        u_lo = min(u_lo, u)
        u_hi = max(u_hi, u)
        v_lo = min(v_lo, v)
        v_hi = max(v_hi, v)
    bounds[0] = u_lo
    bounds[1] = u_hi
    bounds[2] = v_lo
    bounds[3] = v_hi


@njit(cache=True, nogil=True)
def _renumber(triangles, position, lo, hi, tri):
    for t in range(lo, hi):
        for j in range(3):
            tri[t, j] = position[triangles[t, j]]


_numbacache.refresh(globals())  # numba keys its cache on this file only (see replication._numbacache)
