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


@njit(cache=True, nogil=True)
def _raster(xy, tri, values, u, v, lo, hi, owner, out):
    """Fill ``out[i, j]`` (the value at ``(u[i], v[j])``) and ``owner[i, j]`` (its triangle)
    from the triangles lo..hi-1. ``u`` and ``v`` are increasing and uniformly spaced;
    ``owner`` must hold -1 on entry."""
    mu = u.shape[0]
    mv = v.shape[0]
    u0 = u[0]
    v0 = v[0]
    iu = (mu - 1) / (u[mu - 1] - u0)
    iv = (mv - 1) / (v[mv - 1] - v0)
    for t in range(lo, hi):
        a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
        ax, ay, bx, by, cx, cy = xy[a, 0], xy[a, 1], xy[b, 0], xy[b, 1], xy[c, 0], xy[c, 1]
        i_lo = max(0, int(math.ceil((min(ax, bx, cx) - u0) * iu - _SLACK)))
        i_hi = min(mu - 1, int(math.floor((max(ax, bx, cx) - u0) * iu + _SLACK)))
        j_lo = max(0, int(math.ceil((min(ay, by, cy) - v0) * iv - _SLACK)))
        j_hi = min(mv - 1, int(math.floor((max(ay, by, cy) - v0) * iv + _SLACK)))
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
                la = _area2(px, py, bx, by, cx, cy) / den
                lb = _area2(ax, ay, px, py, cx, cy) / den
                lc = _area2(ax, ay, bx, by, px, py) / den
                owner[i, j] = t
                out[i, j] = la * values[a] + lb * values[b] + lc * values[c]


@njit(cache=True, nogil=True)
def _combine(owners, outs, lo, hi):
    """Rows lo..hi-1: a node no earlier run claimed takes the next run's triangle and value."""
    for r in range(1, len(owners)):
        owner, out, later, values = owners[0], outs[0], owners[r], outs[r]
        for i in range(lo, hi):
            for j in range(owner.shape[1]):
                if owner[i, j] < 0 and later[i, j] >= 0:
                    owner[i, j] = later[i, j]
                    out[i, j] = values[i, j]


@njit(cache=True, nogil=True)
def _gather(points, axes, order, lo, hi, position, xy, values, bounds):
    """Points lo..hi-1 of ``order``; ``bounds``: their (min u, max u, min v, max v)."""
    bounds[0] = np.inf
    bounds[1] = -np.inf
    bounds[2] = np.inf
    bounds[3] = -np.inf
    for k in range(lo, hi):
        i = order[k]
        position[i] = k
        u = points[i, axes[0]]
        v = points[i, axes[1]]
        xy[k, 0] = u
        xy[k, 1] = v
        values[k] = points[i, axes[2]]
        bounds[0] = min(bounds[0], u)
        bounds[1] = max(bounds[1], u)
        bounds[2] = min(bounds[2], v)
        bounds[3] = max(bounds[3], v)


@njit(cache=True, nogil=True)
def _renumber(triangles, position, lo, hi, tri):
    for t in range(lo, hi):
        for j in range(3):
            tri[t, j] = position[triangles[t, j]]


_numbacache.refresh(globals())  # numba keys its cache on this file only (see replication._numbacache)
