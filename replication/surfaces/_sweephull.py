"""Compiled 2-D Delaunay triangulation of one block of points by radial sweep (numba).

The sweep-hull idea (D. A. Sinclair, "S-hull: a fast radial sweep-hull routine for Delaunay
triangulation", 2010; popularised by the Delaunator library): points are inserted in order
of distance from the circumcentre of a seed triangle, so every new point lies outside the
convex hull built so far; it is joined to the hull edges it can see and the new edges are
made Delaunay by edge flips. Written from the published algorithm for this project, with
two changes that matter for lattice (highly degenerate) clouds:

* **Exact predicates** (:mod:`._predicates`): which hull edges a point sees and whether an
  edge is flipped are decided exactly, so collinear and co-circular lattice points are never
  misclassified and every edge of the result is locally Delaunay in exact arithmetic.
  Exactly co-circular points (every square of a lattice) have more than one Delaunay
  triangulation; a symbolic perturbation by the points' lexicographic order decides them
  (:func:`._predicates.incircle_perturbed`), so the flips terminate and the triangles depend
  on the point set alone, not on the order of the rows or of the insertions.
* **An empty-circle seed.** The seed edge joins a point to its nearest neighbour (always a
  Delaunay edge) and the third point is the one on the left whose circle through the edge has
  the smallest signed centre offset, so the seed triangle's circumcircle holds no other point.

The kernel works in a *global* index space so that several blocks can be triangulated at the
same time into shared arrays (:mod:`._triangulate`): block points are ``lo .. hi - 1`` of the
coordinate arrays, already sorted by distance from the sweep centre; triangle ``t`` occupies
slots ``3 t .. 3 t + 2`` of ``tri`` (vertex indices) and ``he`` (the opposite half-edge, -1 on
the hull). Half-edge ``e`` runs from ``tri[e]`` to ``tri[next(e)]``; triangles are
counter-clockwise. The convex hull is kept as a doubly linked cycle (``hull_next``,
``hull_prev``) with ``hull_tri[v]``, the half-edge of the hull edge ``v -> hull_next[v]``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from replication import _numbacache
from replication.surfaces._predicates import incircle_perturbed, orient
from replication.surfaces._status import STATUS_COLLINEAR, STATUS_OK, STATUS_SKIPPED

__all__ = [
    "STATUS_COLLINEAR",
    "STATUS_OK",
    "STATUS_SKIPPED",
    "incircle_perturbed",
    "legalize",
    "link",
    "orient",
    "seed_triangle",
    "sweep",
]


@njit(cache=True, inline="always")
def link(he, a, b):
    """Make half-edges ``a`` and ``b`` twins (``b`` = -1: ``a`` is a hull edge)."""
    he[a] = b
    if b != -1:
        he[b] = a


@njit(cache=True)
def _angle_key(dx, dy, mask):
    """Bucket of the pseudo-angle of (dx, dy) in a table of ``mask + 1`` buckets."""
    s = abs(dx) + abs(dy)
    p = dx / s if s > 0.0 else 0.0
    angle = (3.0 - p) if dy > 0.0 else (1.0 + p)  # in [0, 4), increasing with the angle
    return int(angle * 0.25 * (mask + 1)) & mask


@njit(cache=True, nogil=True, inline="always")
def legalize(stack, top, xy, tri, he, hull_tri):
    """Lawson's edge flips from the half-edges ``stack[:top]`` until each is locally Delaunay.

    A half-edge ``a`` of triangle (p, q, r), running p -> q, with twin ``b`` of (q, p, s) is
    flipped when s lies inside the circle through p, q, r (exact in-circle test; four
    co-circular points are decided by the symbolic perturbation of
    :func:`._predicates.incircle_perturbed`, which is the in-circle test of a point set in
    general position, so the flips terminate and their result, the Delaunay triangulation
    of the perturbed points, is unique). The flip puts the two
    triangles (s, q, r) and (r, p, s) in the same slots, so ``a`` then runs s -> q and ``b``
    r -> p; hull half-edges that move to another slot are re-registered in ``hull_tri``.
    After a flip the four outer edges of the pair, which may have become illegal, are
    pushed. This is the merge's general case (:mod:`._mergehull`, which enters it once per
    join); the sweep, where every flip has the new point as its apex, pushes only the two
    edges across from it and needs no capacity check (its stack holds more entries than the
    triangulation has edges).

    Returns 0 when the stack is empty, or the stack's height when the next flip's pushes
    might not fit: the caller grows the stack and calls again.

    Written out in one loop on purpose: numba takes and drops a reference to every array
    given to a function it calls or inlines, an atomic operation each time, which its
    pruning of reference counts did not remove here; a flip kernel of its own cost a quarter
    of the sweep (compiled ahead of time) that way. For the same reason :func:`sweep` holds
    its own copy of the flip (between the ``-- flip`` markers) instead of entering a
    function once per new triangle; a test keeps the two copies equal.
    """
    while top > 0:
        if top + 3 > stack.shape[0]:
            return top
        # -- flip: start --
        top -= 1
        a = stack[top]
        b = he[a]
        if b == -1:
            continue
        a0 = a - a % 3
        b0 = b - b % 3
        a1 = a0 + (a + 1) % 3
        a2 = a0 + (a + 2) % 3
        b2 = b0 + (b + 2) % 3
        fp = tri[a]
        fq = tri[a1]
        fr = tri[a2]
        fs = tri[b2]
        if (
            incircle_perturbed(
                xy[fp, 0], xy[fp, 1], xy[fq, 0], xy[fq, 1], xy[fr, 0], xy[fr, 1], xy[fs, 0], xy[fs, 1]
            )
            < 0.0
        ):
            continue
        ha2 = he[a2]
        hb2 = he[b2]
        tri[a] = fs
        tri[b] = fr
        he[a] = hb2
        if hb2 != -1:
            he[hb2] = a
        else:
            hull_tri[fs] = a  # hull edge s -> q now lives in slot a
        he[b] = ha2
        if ha2 != -1:
            he[ha2] = b
        else:
            hull_tri[fr] = b  # hull edge r -> p now lives in slot b
        he[a2] = b2
        he[b2] = a2
        # -- flip: end --
        stack[top] = a  # (s, q), (q, r), (r, p), (p, s)
        stack[top + 1] = a1
        stack[top + 2] = b
        stack[top + 3] = b - b % 3 + (b + 1) % 3
        top += 4
    return 0


@njit(cache=True, nogil=True, error_model="numpy")
def _seed_from(xy, i0):
    """The empty-circle seed triangle on the edge from point ``i0`` to its nearest neighbour:
    ``(i0, i1, i2, cx, cy)``, counter-clockwise, or -1s when there is none."""
    n = xy.shape[0]
    x0 = xy[i0, 0]
    y0 = xy[i0, 1]
    i1 = -1
    best = np.inf
    for k in range(n):
        if xy[k, 0] == x0 and xy[k, 1] == y0:
            continue
        d = (xy[k, 0] - x0) ** 2 + (xy[k, 1] - y0) ** 2
        if d < best:
            best = d
            i1 = k
    if i1 < 0:
        return -1, -1, -1, 0.0, 0.0
    # The nearest-neighbour edge i0-i1 is Delaunay; complete it on the side that has points
    # with the circle whose centre offset along the left normal is smallest (empty circle).
    for _side in range(2):
        ax = xy[i0, 0]
        ay = xy[i0, 1]
        bx = xy[i1, 0]
        by = xy[i1, 1]
        mx = 0.5 * (ax + bx)
        my = 0.5 * (ay + by)
        nx = -(by - ay)
        ny = bx - ax
        half2 = 0.25 * (nx * nx + ny * ny)
        i2 = -1
        best = np.inf
        for k in range(n):
            px = xy[k, 0]
            py = xy[k, 1]
            if orient(ax, ay, bx, by, px, py) <= 0.0:
                continue
            qx = px - mx
            qy = py - my
            denominator = 2.0 * (qx * nx + qy * ny)
            if not denominator > 0.0:  # underflow: the point is numerically on the line
                continue
            offset = (qx * qx + qy * qy - half2) / denominator
            if offset < best:
                best = offset
                i2 = k
        if i2 >= 0:
            ex = xy[i2, 0] - ax
            ey = xy[i2, 1] - ay
            dx = bx - ax
            dy = by - ay
            bl = dx * dx + dy * dy
            el = ex * ex + ey * ey
            f = 0.5 / (dx * ey - dy * ex)
            return i0, i1, i2, ax + (ey * bl - dy * el) * f, ay + (dx * el - ex * bl) * f
        i0, i1 = i1, i0
    return -1, -1, -1, 0.0, 0.0


#: A seed whose circumcentre lies farther than this many times the cloud's extent from the
#: seed is replaced by a rounder one if there is one: the sweep sorts the points by their
#: distance from that centre, and from very far away (a nearly collinear cloud's thin
#: triangles, 1e9 extents off) the distances differ by less than their rounding, so points
#: come in an order that puts some inside the hull and the sweep fails.
_FAR_CENTRE = 4.0


@njit(cache=True, nogil=True, error_model="numpy")
def seed_triangle(xy):
    """An empty-circle seed triangle of the points ``xy`` (n, 2) and its circumcentre.

    Returns ``(i0, i1, i2, cx, cy)``, counter-clockwise; the indices are -1 when the points
    are collinear (no triangle exists). Repeated positions are allowed (a point's duplicate
    is never chosen as its neighbour). The seed grows from the point nearest the middle of
    the bounding box; when its circumcentre is far off (see ``_FAR_CENTRE``), from each of
    the points extreme in u or v too, and the seed with the nearest circumcentre is taken.
    """
    n = xy.shape[0]
    if n < 3:
        return -1, -1, -1, 0.0, 0.0
    lo = np.full(2, np.inf)
    hi = np.full(2, -np.inf)
    extreme = np.zeros(4, dtype=np.int64)  # the first point of least u, greatest u, least v, greatest v
    for k in range(n):
        for c in range(2):
            if xy[k, c] < lo[c]:
                lo[c] = xy[k, c]
                extreme[2 * c] = k
            if xy[k, c] > hi[c]:
                hi[c] = xy[k, c]
                extreme[2 * c + 1] = k
    cx = 0.5 * (lo[0] + hi[0])
    cy = 0.5 * (lo[1] + hi[1])
    i0 = 0
    best = np.inf
    for k in range(n):
        d = (xy[k, 0] - cx) ** 2 + (xy[k, 1] - cy) ** 2
        if d < best:
            best = d
            i0 = k
    seed = _seed_from(xy, i0)
    if seed[0] < 0:
        return seed
    extent = max(hi[0] - lo[0], hi[1] - lo[1])
    far = (_FAR_CENTRE * extent) ** 2
    radius = (seed[3] - xy[seed[0], 0]) ** 2 + (seed[4] - xy[seed[0], 1]) ** 2
    if not radius > far:  # the usual case: a seed of nearest neighbours near the middle
        return seed
    for j in range(4):
        other = _seed_from(xy, extreme[j])
        if other[0] < 0:
            continue
        r = (other[3] - xy[other[0], 0]) ** 2 + (other[4] - xy[other[0], 1]) ** 2
        if r < radius:
            seed = other
            radius = r
    return seed


@njit(cache=True, nogil=True, error_model="numpy")
def sweep(xy, lo, hi, i0, i1, i2, ccx, ccy, tri, he, t_lo, hull_next, hull_prev, hull_tri):
    """Triangulate the points ``lo .. hi - 1`` of ``xy`` (n, 2), sorted by distance from (ccx, ccy).

    ``(i0, i1, i2)`` is the counter-clockwise seed triangle (global indices) whose
    circumcentre is (ccx, ccy). Triangles are written from slot ``t_lo`` on (at most
    ``2 (hi - lo) - 5`` of them). Returns ``(n_triangles, n_skipped, a hull vertex)``; a
    skipped point is one that rounding of the sort key put inside the hull (the caller
    must then triangulate another way).
    """
    n = hi - lo
    size = 1
    while size * size < n:
        size *= 2
    mask = size - 1
    hull_hash = np.full(size, -1, dtype=tri.dtype)
    stack = np.empty(3 * n + 8, dtype=tri.dtype)  # virtual memory: only the used part is touched
    for v in range(lo, hi):
        hull_next[v] = v  # a vertex v with hull_next[v] == v is not on the hull
    he[3 * t_lo : 3 * (t_lo + max(2 * n - 5, 1))] = -1

    t = 3 * t_lo
    tri[t] = i0
    tri[t + 1] = i1
    tri[t + 2] = i2
    n_tri = 1
    hull_next[i0] = i1
    hull_next[i1] = i2
    hull_next[i2] = i0
    hull_prev[i1] = i0
    hull_prev[i2] = i1
    hull_prev[i0] = i2
    hull_tri[i0] = t
    hull_tri[i1] = t + 1
    hull_tri[i2] = t + 2
    hull_hash[_angle_key(xy[i0, 0] - ccx, xy[i0, 1] - ccy, mask)] = i0
    hull_hash[_angle_key(xy[i1, 0] - ccx, xy[i1, 1] - ccy, mask)] = i1
    hull_hash[_angle_key(xy[i2, 0] - ccx, xy[i2, 1] - ccy, mask)] = i2

    skipped = 0
    last = i0
    for p in range(lo, hi):
        if p == i0 or p == i1 or p == i2:
            continue
        px = xy[p, 0]
        py = xy[p, 1]

        # a hull vertex near p's direction from the centre
        key = _angle_key(px - ccx, py - ccy, mask)
        start = i0
        for j in range(size):
            cand = hull_hash[(key + j) & mask]
            if cand != -1 and hull_next[cand] != cand:
                start = cand
                break
        start = hull_prev[start]

        # first hull edge e -> hull_next[e] that p sees (p strictly on its outer side)
        e = start
        found = False
        while True:
            q = hull_next[e]
            if orient(xy[e, 0], xy[e, 1], xy[q, 0], xy[q, 1], px, py) < 0.0:
                found = True
                break
            e = q
            if e == start:
                break
        if not found:
            skipped += 1
            continue

        # One triangle per edge that p sees: first on e -> nxt, then walking forward, then
        # backward when the first visible edge was where the search started. Each is made
        # Delaunay before the next is added, by the flip loop below: one copy in this loop,
        # not a call, since numba takes and drops a reference to every array a call (or an
        # inlined function) is given, which cost a fifth of the sweep when paid per triangle.
        nxt = hull_next[e]
        phase = 0  # 0: the first triangle, 1: walking forward, 2: walking backward
        while True:
            t = 3 * (t_lo + n_tri)
            if phase == 0:  # triangle (e, p, nxt) on the visible edge e -> nxt
                tri[t] = e
                tri[t + 1] = p
                tri[t + 2] = nxt
                link(he, t + 2, hull_tri[e])
                hull_tri[e] = t
                hull_tri[p] = t + 1
                phase = 1
            elif phase == 1:  # forward: triangle (nxt, p, q) on the visible edge nxt -> q
                q = hull_next[nxt]
                if orient(xy[nxt, 0], xy[nxt, 1], xy[q, 0], xy[q, 1], px, py) >= 0.0:
                    if e != start:
                        break
                    phase = 2
                    continue
                tri[t] = nxt
                tri[t + 1] = p
                tri[t + 2] = q
                link(he, t + 2, hull_tri[nxt])
                link(he, t, hull_tri[p])
                hull_tri[p] = t + 1
                hull_next[nxt] = nxt  # removed from the hull
                nxt = q
            else:  # backward: triangle (q, p, e) on the visible edge q -> e
                q = hull_prev[e]
                if orient(xy[q, 0], xy[q, 1], xy[e, 0], xy[e, 1], px, py) >= 0.0:
                    break
                tri[t] = q
                tri[t + 1] = p
                tri[t + 2] = e
                link(he, t + 2, hull_tri[q])
                link(he, t + 1, hull_tri[e])
                hull_tri[q] = t
                hull_next[e] = e  # removed from the hull
                e = q
            n_tri += 1
            # Lawson's flips from the new triangle's edge opposite p: legalize's flip, written
            # out (kept equal by a test), pushing only the two edges across from p after each
            # flip; the stack (3 n + 8) always has room
            stack[0] = t + 2
            top = 1
            while top > 0:
                # -- flip: start --
                top -= 1
                a = stack[top]
                b = he[a]
                if b == -1:
                    continue
                a0 = a - a % 3
                b0 = b - b % 3
                a1 = a0 + (a + 1) % 3
                a2 = a0 + (a + 2) % 3
                b2 = b0 + (b + 2) % 3
                fp = tri[a]
                fq = tri[a1]
                fr = tri[a2]
                fs = tri[b2]
                if (
                    incircle_perturbed(
                        xy[fp, 0], xy[fp, 1], xy[fq, 0], xy[fq, 1], xy[fr, 0], xy[fr, 1], xy[fs, 0], xy[fs, 1]
                    )
                    < 0.0
                ):
                    continue
                ha2 = he[a2]
                hb2 = he[b2]
                tri[a] = fs
                tri[b] = fr
                he[a] = hb2
                if hb2 != -1:
                    he[hb2] = a
                else:
                    hull_tri[fs] = a  # hull edge s -> q now lives in slot a
                he[b] = ha2
                if ha2 != -1:
                    he[ha2] = b
                else:
                    hull_tri[fr] = b  # hull edge r -> p now lives in slot b
                he[a2] = b2
                he[b2] = a2
                # -- flip: end --
                stack[top] = a
                stack[top + 1] = b - b % 3 + (b + 1) % 3
                top += 2

        hull_prev[p] = e
        hull_next[e] = p
        hull_prev[nxt] = p
        hull_next[p] = nxt
        hull_hash[_angle_key(px - ccx, py - ccy, mask)] = p
        hull_hash[_angle_key(xy[e, 0] - ccx, xy[e, 1] - ccy, mask)] = e
        last = p
    return n_tri, skipped, last


_numbacache.refresh(globals())  # numba keys its cache on this file only (see replication._numbacache)
