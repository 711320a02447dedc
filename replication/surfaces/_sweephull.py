"""Compiled 2-D Delaunay triangulation by radial sweep (numba).

This is the project's fast triangulation backend, used by :mod:`replication.surfaces.delaunay`.
It implements the sweep-hull idea (D. A. Sinclair, "S-hull: a fast radial sweep-hull routine
for Delaunay triangulation", 2010; popularised by the Delaunator library): points are inserted
in order of distance from the circumcentre of a seed triangle, so every new point lies outside
the convex hull built so far; it is joined to the hull edges it can see and the new edges are
made Delaunay by edge flips. Written from the published algorithm for this project, with two
changes that matter for lattice (highly degenerate) clouds:

* **Exact orientation.** Which hull edges a point sees is decided by an orientation predicate
  with a floating-point filter and an exact fallback (products split into exact two-term
  expansions, summed exactly), so collinear lattice points are never misclassified.
* **An empty-circle seed.** The seed edge joins a point to its nearest neighbour (always a
  Delaunay edge) and the third point is the one on the left whose circle through the edge has
  the smallest signed centre offset, so the seed triangle's circumcircle holds no other point
  and the sorted points are guaranteed to lie outside the growing hull.

Edges are flipped only when the in-circle test is *certainly* violated (beyond its rounding
error bound), so the flip sequence always terminates; in exactly co-circular configurations
(a square lattice) either diagonal is a valid Delaunay choice.

All routines take contiguous float64 coordinate arrays holding distinct points; the Python
wrapper removes duplicates first and checks that every point was used.
"""

from __future__ import annotations

import numpy as np
from numba import njit

_EPS = 2.0**-53
_SPLITTER = 134217729.0  # 2**27 + 1, Dekker's splitter for float64
_CCW_ERRBOUND = (3.0 + 16.0 * _EPS) * _EPS
_ICC_ERRBOUND = (10.0 + 96.0 * _EPS) * _EPS

STATUS_OK = 0
STATUS_COLLINEAR = 1
STATUS_SKIPPED = 2


@njit(cache=True, inline="always")
def _two_sum(a, b):
    x = a + b
    bv = x - a
    av = x - bv
    return x, (a - av) + (b - bv)


@njit(cache=True, inline="always")
def _two_product(a, b):
    x = a * b
    c = _SPLITTER * a
    ahi = c - (c - a)
    alo = a - ahi
    c = _SPLITTER * b
    bhi = c - (c - b)
    blo = b - bhi
    err = x - ahi * bhi
    err -= alo * bhi
    err -= ahi * blo
    return x, alo * blo - err


@njit(cache=True)
def _grow(expansion, length, b):
    """Add the double ``b`` to a non-overlapping expansion in place (zero elimination)."""
    q = b
    out = 0
    for i in range(length):
        q, h = _two_sum(q, expansion[i])
        if h != 0.0:
            expansion[out] = h
            out += 1
    if q != 0.0 or out == 0:
        expansion[out] = q
        out += 1
    return out


@njit(cache=True)
def _orient_exact(ax, ay, bx, by, cx, cy):
    """Exact sign of the orientation determinant, as a sum of six exact products."""
    terms = np.empty(12)
    terms[0], terms[1] = _two_product(ax, by)
    terms[2], terms[3] = _two_product(-ax, cy)
    terms[4], terms[5] = _two_product(-cx, by)
    terms[6], terms[7] = _two_product(-ay, bx)
    terms[8], terms[9] = _two_product(ay, cx)
    terms[10], terms[11] = _two_product(cy, bx)
    expansion = np.zeros(25)
    length = 0
    for k in range(12):
        if terms[k] != 0.0:
            length = _grow(expansion, length, terms[k])
    for k in range(length - 1, -1, -1):  # most significant component last
        if expansion[k] != 0.0:
            return 1.0 if expansion[k] > 0.0 else -1.0
    return 0.0


@njit(cache=True)
def orient(ax, ay, bx, by, cx, cy):
    """Sign of the signed area of (a, b, c): +1 counter-clockwise, -1 clockwise, 0 collinear."""
    left = (ax - cx) * (by - cy)
    right = (ay - cy) * (bx - cx)
    det = left - right
    bound = _CCW_ERRBOUND * (abs(left) + abs(right))
    if det > bound:
        return 1.0
    if -det > bound:
        return -1.0
    return _orient_exact(ax, ay, bx, by, cx, cy)


@njit(cache=True, inline="always")
def _certainly_in_circle(ax, ay, bx, by, cx, cy, dx, dy):
    """True when d lies certainly inside the circle through the counter-clockwise a, b, c."""
    adx = ax - dx
    ady = ay - dy
    bdx = bx - dx
    bdy = by - dy
    cdx = cx - dx
    cdy = cy - dy
    bc1 = bdx * cdy
    bc2 = cdx * bdy
    alift = adx * adx + ady * ady
    ca1 = cdx * ady
    ca2 = adx * cdy
    blift = bdx * bdx + bdy * bdy
    ab1 = adx * bdy
    ab2 = bdx * ady
    clift = cdx * cdx + cdy * cdy
    det = alift * (bc1 - bc2) + blift * (ca1 - ca2) + clift * (ab1 - ab2)
    permanent = (abs(bc1) + abs(bc2)) * alift + (abs(ca1) + abs(ca2)) * blift + (abs(ab1) + abs(ab2)) * clift
    return det > _ICC_ERRBOUND * permanent


@njit(cache=True, inline="always")
def _link(halfedges, a, b):
    halfedges[a] = b
    if b != -1:
        halfedges[b] = a


@njit(cache=True, inline="always")
def _pseudo_angle_key(dx, dy, size):
    s = abs(dx) + abs(dy)
    p = dx / s if s > 0.0 else 0.0
    angle = (3.0 - p) / 4.0 if dy > 0.0 else (1.0 + p) / 4.0  # in [0, 1), increasing with angle
    return int(np.floor(angle * size)) % size


@njit(cache=True)
def _legalize(start, x, y, tri, halfedges, hull_tri, stack):
    """Flip edges opposite the newly inserted point until all are locally Delaunay.

    Every edge on the stack is a half-edge whose triangle has the new point as its apex.
    Hull half-edges that a flip moves to another slot are re-registered in ``hull_tri``.
    """
    top = 0
    stack[top] = start
    top += 1
    while top > 0:
        top -= 1
        a = stack[top]
        b = halfedges[a]
        if b == -1:
            continue
        a0 = a - a % 3
        b0 = b - b % 3
        a1 = a0 + (a + 1) % 3
        a2 = a0 + (a + 2) % 3
        b1 = b0 + (b + 1) % 3
        b2 = b0 + (b + 2) % 3
        p = tri[a]
        q = tri[a1]
        r = tri[a2]  # the new point
        s = tri[b2]
        if not _certainly_in_circle(x[p], y[p], x[q], y[q], x[r], y[r], x[s], y[s]):
            continue
        ha2 = halfedges[a2]
        hb2 = halfedges[b2]
        tri[a] = s
        tri[b] = r
        _link(halfedges, a, hb2)
        if hb2 == -1:
            hull_tri[s] = a  # hull edge s->q now lives in slot a
        _link(halfedges, b, ha2)
        if ha2 == -1:
            hull_tri[r] = b  # hull edge r->p now lives in slot b
        _link(halfedges, a2, b2)
        if top + 2 > stack.shape[0]:
            bigger = np.empty(2 * stack.shape[0], dtype=stack.dtype)
            bigger[:top] = stack[:top]
            stack = bigger
        stack[top] = a
        stack[top + 1] = b1
        top += 2
    return stack


@njit(cache=True, error_model="numpy")
def _seed(x, y):
    """Return an empty-circle seed triangle (i0, i1, i2), counter-clockwise, or -1s if collinear."""
    n = x.shape[0]
    cx = 0.5 * (x.min() + x.max())
    cy = 0.5 * (y.min() + y.max())
    i0 = 0
    best = np.inf
    for i in range(n):
        d = (x[i] - cx) ** 2 + (y[i] - cy) ** 2
        if d < best:
            best = d
            i0 = i
    i1 = -1
    best = np.inf
    for i in range(n):
        if i == i0:
            continue
        d = (x[i] - x[i0]) ** 2 + (y[i] - y[i0]) ** 2
        if d < best:
            best = d
            i1 = i
    # The nearest-neighbour edge i0-i1 is Delaunay; complete it on the side that has points
    # with the circle whose centre offset along the left normal is smallest (empty circle).
    for _side in range(2):
        mx = 0.5 * (x[i0] + x[i1])
        my = 0.5 * (y[i0] + y[i1])
        nx = -(y[i1] - y[i0])
        ny = x[i1] - x[i0]
        half2 = 0.25 * (nx * nx + ny * ny)
        i2 = -1
        best = np.inf
        for i in range(n):
            if i == i0 or i == i1:
                continue
            if orient(x[i0], y[i0], x[i1], y[i1], x[i], y[i]) <= 0.0:
                continue
            qx = x[i] - mx
            qy = y[i] - my
            denominator = 2.0 * (qx * nx + qy * ny)
            if not denominator > 0.0:  # underflow: the point is numerically on the line
                continue
            k = (qx * qx + qy * qy - half2) / denominator
            if k < best:
                best = k
                i2 = i
        if i2 >= 0:
            return i0, i1, i2
        i0, i1 = i1, i0
    return -1, -1, -1


@njit(cache=True, error_model="numpy")
def sweep_centre(x, y):
    """Return the seed triangle ``(i0, i1, i2)`` and its circumcentre (the sweep centre).

    The indices are -1 when all points are collinear (no triangle exists).
    """
    i0, i1, i2 = _seed(x, y)
    if i0 < 0:
        return i0, i1, i2, 0.0, 0.0
    bx = x[i1] - x[i0]
    by = y[i1] - y[i0]
    ex = x[i2] - x[i0]
    ey = y[i2] - y[i0]
    bl = bx * bx + by * by
    el = ex * ex + ey * ey
    d = 0.5 / (bx * ey - by * ex)
    ccx = x[i0] + (ey * bl - by * el) * d
    ccy = y[i0] + (bx * el - ex * bl) * d
    return i0, i1, i2, ccx, ccy


def sweep_hull(x, y):
    """Delaunay-triangulate distinct points; return ``(triangles, status, n_skipped)``.

    ``x`` and ``y`` are float64 arrays of distinct points. ``triangles`` is an (m, 3) int64
    array of counter-clockwise vertex triples. ``status`` is ``STATUS_OK``,
    ``STATUS_COLLINEAR`` (no triangle exists) or ``STATUS_SKIPPED`` (some point could not be
    inserted; the caller must fall back to another backend).
    """
    x = np.ascontiguousarray(x, dtype=np.float64)
    y = np.ascontiguousarray(y, dtype=np.float64)
    if x.shape[0] < 3:
        return np.empty((0, 3), dtype=np.int64), STATUS_COLLINEAR, 0
    i0, i1, i2, ccx, ccy = sweep_centre(x, y)
    if i0 < 0:
        return np.empty((0, 3), dtype=np.int64), STATUS_COLLINEAR, 0
    if not (np.isfinite(ccx) and np.isfinite(ccy)):  # coordinates beyond float64's range
        return np.empty((0, 3), dtype=np.int64), STATUS_SKIPPED, x.shape[0]
    # Renumber the points in sweep order: the hull and the triangles being flipped are then
    # always recent, so the working set stays in cache (about 3x faster at 1e6 points).
    order = np.argsort((x - ccx) ** 2 + (y - ccy) ** 2)
    rank = np.empty_like(order)
    rank[order] = np.arange(order.shape[0])
    tri, status, skipped = _sweep(x[order], y[order], rank[i0], rank[i1], rank[i2], ccx, ccy)
    return order[tri], status, skipped


@njit(cache=True, error_model="numpy")
def _sweep(x, y, i0, i1, i2, ccx, ccy):
    """Main sweep over points already sorted by distance from the centre (ccx, ccy)."""
    n = x.shape[0]
    max_tri = 2 * n - 5
    tri = np.empty(3 * max_tri, dtype=np.int64)
    halfedges = np.full(3 * max_tri, -1, dtype=np.int64)
    hull_next = np.arange(n)  # a vertex v with hull_next[v] == v is not on the hull
    hull_prev = np.arange(n)
    hull_tri = np.full(n, -1, dtype=np.int64)  # half-edge of the hull edge v -> hull_next[v]
    hash_size = max(1, int(np.ceil(np.sqrt(n))))
    hull_hash = np.full(hash_size, -1, dtype=np.int64)
    stack = np.empty(64, dtype=np.int64)

    tri[0] = i0
    tri[1] = i1
    tri[2] = i2
    n_tri = 1
    hull_next[i0] = i1
    hull_next[i1] = i2
    hull_next[i2] = i0
    hull_prev[i1] = i0
    hull_prev[i2] = i1
    hull_prev[i0] = i2
    hull_tri[i0] = 0
    hull_tri[i1] = 1
    hull_tri[i2] = 2
    for v in (i0, i1, i2):
        hull_hash[_pseudo_angle_key(x[v] - ccx, y[v] - ccy, hash_size)] = v

    skipped = 0
    for p in range(n):
        if p == i0 or p == i1 or p == i2:
            continue
        px = x[p]
        py = y[p]

        # a hull vertex near p's direction from the centre
        key = _pseudo_angle_key(px - ccx, py - ccy, hash_size)
        start = i0
        for j in range(hash_size):
            cand = hull_hash[(key + j) % hash_size]
            if cand != -1 and hull_next[cand] != cand:
                start = cand
                break
        start = hull_prev[start]

        # first hull edge e -> hull_next[e] that p sees (p strictly on its outer side)
        e = start
        found = False
        while True:
            q = hull_next[e]
            if orient(x[e], y[e], x[q], y[q], px, py) < 0.0:
                found = True
                break
            e = q
            if e == start:
                break
        if not found:
            skipped += 1
            continue

        # triangle (e, p, n) on the visible edge e -> n
        nxt = hull_next[e]
        t = 3 * n_tri
        n_tri += 1
        tri[t] = e
        tri[t + 1] = p
        tri[t + 2] = nxt
        _link(halfedges, t + 2, hull_tri[e])
        hull_tri[e] = t
        hull_tri[p] = t + 1
        stack = _legalize(t + 2, x, y, tri, halfedges, hull_tri, stack)

        # walk forward over further visible edges
        while True:
            q = hull_next[nxt]
            if orient(x[nxt], y[nxt], x[q], y[q], px, py) >= 0.0:
                break
            t = 3 * n_tri
            n_tri += 1
            tri[t] = nxt
            tri[t + 1] = p
            tri[t + 2] = q
            _link(halfedges, t + 2, hull_tri[nxt])
            _link(halfedges, t, hull_tri[p])
            hull_tri[p] = t + 1
            stack = _legalize(t + 2, x, y, tri, halfedges, hull_tri, stack)
            hull_next[nxt] = nxt  # removed from the hull
            nxt = q

        # walk backward when the first visible edge was where the search started
        if e == start:
            while True:
                q = hull_prev[e]
                if orient(x[q], y[q], x[e], y[e], px, py) >= 0.0:
                    break
                t = 3 * n_tri
                n_tri += 1
                tri[t] = q
                tri[t + 1] = p
                tri[t + 2] = e
                _link(halfedges, t + 2, hull_tri[q])
                _link(halfedges, t + 1, hull_tri[e])
                hull_tri[q] = t
                stack = _legalize(t + 2, x, y, tri, halfedges, hull_tri, stack)
                hull_next[e] = e
                e = q

        hull_prev[p] = e
        hull_next[e] = p
        hull_prev[nxt] = p
        hull_next[p] = nxt
        hull_hash[_pseudo_angle_key(px - ccx, py - ccy, hash_size)] = p
        hull_hash[_pseudo_angle_key(x[e] - ccx, y[e] - ccy, hash_size)] = e

    out = tri[: 3 * n_tri].reshape(n_tri, 3).copy()
    return out, (STATUS_SKIPPED if skipped else STATUS_OK), skipped
