"""Merging two Delaunay triangulations, and the final compaction of the shared arrays (numba).

The parallel triangulator (:mod:`._triangulate`) cuts the cloud into blocks by a k-d tree,
triangulates the blocks at the same time (:func:`._sweephull.sweep`) and joins sibling blocks
here, up the tree; a horizontal cut is handled in a frame turned by -90 degrees, where it is
vertical (orientations do not change under rotation):

1. **Bridge.** The lower common tangent of the two convex hulls is found by the classical
   walk (both hulls are kept as linked cycles). Among collinear candidates the walk stops at
   the points nearest to the cut, so no bridge passes through a vertex.
2. **Zip.** From the lower tangent upwards the region between the two hulls is triangulated
   one triangle at a time, each with a new apex on the left or the right hull chain: a
   candidate is valid when it lies strictly left of the current base edge; when both are
   valid the one whose circle through the base does not contain the other is taken (the
   merge step of Guibas and Stolfi, "Primitives for the manipulation of general
   subdivisions and the computation of Voronoi diagrams", 1985, restricted to hull
   vertices). That choice never puts a vertex inside the new triangle, so the union is a
   valid triangulation of the joint convex hull. The zip stops at the upper tangent, where
   no candidate is valid.
3. **Flip.** Lawson's flip algorithm, seeded with the edges of the new triangles, makes every
   edge locally Delaunay again; by the Delaunay lemma the result is the Delaunay
   triangulation. The in-circle tests are exact, with co-circular points decided by a
   symbolic perturbation (:func:`._predicates.incircle_perturbed`), so the flips
   terminate, happen only near the cut, and give the one Delaunay triangulation of the
   perturbed points: the same triangles as one block would, whatever the cut.

Slots for the new triangles come from the unused capacity of the two sides (a side of m
points with a hull of h vertices fills 2 m - 2 - h of its 2 m - 5 slots) plus a few spare
slots per merge; :func:`compact` finally moves the few triangles beyond the total count into
the remaining holes, so the triangles occupy ``0 .. T - 1``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from replication import _numbacache
from replication.surfaces._predicates import incircle_perturbed, orient
from replication.surfaces._sweephull import legalize, link

__all__ = ["SPARE_SLOTS", "compact", "finish", "grown", "hull_cycle", "merge"]

#: Extra triangle slots reserved for each merge (see the module notes).
SPARE_SLOTS = 8


@njit(cache=True, nogil=True)
def grown(a, keep):
    """A twice larger copy of ``a`` holding its first ``keep`` entries."""
    out = np.empty(2 * a.shape[0] + 4, dtype=a.dtype)
    for k in range(keep):
        out[k] = a[k]
    return out


@njit(cache=True, nogil=True)
def hull_cycle(start, hull_next):
    """The hull vertices from ``start`` in counter-clockwise order."""
    count = 1
    v = hull_next[start]
    while v != start:
        count += 1
        v = hull_next[v]
    out = np.empty(count, dtype=np.int32)
    v = start
    for k in range(count):
        out[k] = v
        v = hull_next[v]
    return out


@njit(cache=True, inline="always")
def _keys(xy, v, horizontal):
    """Coordinates in the frame where the cut is vertical (turned by -90 degrees if horizontal)."""
    if horizontal:
        return xy[v, 1], -xy[v, 0]
    return xy[v, 0], xy[v, 1]


@njit(cache=True, nogil=True)
def merge(xy, tri, he, hull, left, right, slots, horizontal):
    """Join the triangulations of two blocks separated by a cut (see the module notes).

    ``hull`` holds the (next, previous, half-edge) rows of the hull table; ``left`` and
    ``right`` are hull vertices of the blocks. Every left point has a smaller x than every
    right point or, with ``horizontal``, a smaller y (the bottom block is the left one: the
    frame is turned by -90 degrees, which keeps orientations). New triangles take the slots
    ``slots[0], slots[1], ...``. Returns ``(slots used, a hull vertex of the union)``.
    """
    hull_next = hull[0]
    hull_prev = hull[1]
    hull_tri = hull[2]
    # start the bridge walk from the rightmost-lowest left and leftmost-lowest right vertex
    l = left
    la, lb_ = _keys(xy, l, horizontal)
    v = hull_next[left]
    while v != left:
        a, b = _keys(xy, v, horizontal)
        if a > la or (a == la and b < lb_):
            l, la, lb_ = v, a, b
        v = hull_next[v]
    r = right
    ra, rb_ = _keys(xy, r, horizontal)
    v = hull_next[right]
    while v != right:
        a, b = _keys(xy, v, horizontal)
        if a < ra or (a == ra and b < rb_):
            r, ra, rb_ = v, a, b
        v = hull_next[v]
    moved = True
    while moved:
        moved = False
        while True:
            w = hull_prev[l]
            if orient(xy[l, 0], xy[l, 1], xy[r, 0], xy[r, 1], xy[w, 0], xy[w, 1]) >= 0.0:
                break
            l = w
            moved = True
        while True:
            w = hull_next[r]
            if orient(xy[l, 0], xy[l, 1], xy[r, 0], xy[r, 1], xy[w, 0], xy[w, 1]) >= 0.0:
                break
            r = w
            moved = True

    lb = l
    rb = r
    stack = np.empty(64, dtype=np.int32)
    top = np.int64(0)
    used = 0
    base = -1  # half-edge r -> l of the previous triangle (none: the lower tangent is hull)
    bottom = -1
    while True:
        lc = hull_next[l]
        rc = hull_prev[r]
        left_ok = orient(xy[l, 0], xy[l, 1], xy[r, 0], xy[r, 1], xy[lc, 0], xy[lc, 1]) > 0.0
        right_ok = orient(xy[l, 0], xy[l, 1], xy[r, 0], xy[r, 1], xy[rc, 0], xy[rc, 1]) > 0.0
        if not (left_ok or right_ok):
            break
        if left_ok and right_ok:
            left_ok = (
                incircle_perturbed(
                    xy[l, 0], xy[l, 1], xy[r, 0], xy[r, 1], xy[lc, 0], xy[lc, 1], xy[rc, 0], xy[rc, 1]
                )
                < 0.0
            )
        t = 3 * slots[used]
        used += 1
        tri[t] = l
        tri[t + 1] = r
        link(he, t, base)
        if base == -1:
            bottom = t  # the lower tangent lb -> rb: a hull edge of the union
        if left_ok:  # triangle (l, r, lc): its edge lc -> l is the twin of the left hull edge l -> lc
            tri[t + 2] = lc
            link(he, t + 2, hull_tri[l])
            if l != lb:
                hull_next[l] = l
            base = t + 1
            l = lc
        else:  # triangle (l, r, rc): its edge r -> rc is the twin of the right hull edge rc -> r
            tri[t + 2] = rc
            link(he, t + 1, hull_tri[rc])
            if r != rb:
                hull_next[r] = r
            base = t + 2
            r = rc
        if top + 3 > stack.shape[0]:
            stack = grown(stack, top)
        stack[top] = t
        stack[top + 1] = t + 1
        stack[top + 2] = t + 2
        top += 3
    he[base] = -1  # the upper tangent r -> l is a hull edge of the union
    hull_tri[r] = base
    hull_tri[lb] = bottom
    hull_next[lb] = rb
    hull_prev[rb] = lb
    hull_next[r] = l
    hull_prev[l] = r
    while top:  # Lawson's flips, growing the stack when the next flip's pushes may not fit
        top = legalize(stack, top, xy, tri, he, hull_tri)
        if top:
            stack = grown(stack, top)
    return used, l


@njit(cache=True, nogil=True)
def compact(tri, he, free, n_tri):
    """Move the triangles in slots ``>= n_tri`` into the free slots ``< n_tri``.

    ``free`` lists every unused slot below the capacity; afterwards triangles occupy
    ``0 .. n_tri - 1``. Half-edge links are updated.
    """
    capacity = tri.shape[0] // 3
    unused = np.zeros(capacity - n_tri, dtype=np.bool_)
    holes = 0
    for k in range(free.shape[0]):
        s = free[k]
        if s >= n_tri:
            unused[s - n_tri] = True
        else:
            holes += 1
    k = 0
    for s in range(n_tri, capacity):
        if unused[s - n_tri]:
            continue
        while free[k] >= n_tri:
            k += 1
        t = free[k]
        k += 1
        for j in range(3):
            tri[3 * t + j] = tri[3 * s + j]
            f = he[3 * s + j]
            he[3 * t + j] = f
            if f != -1:
                he[f] = 3 * t + j
    return holes


@njit(cache=True, nogil=True)
def finish(tri, he, inp, lo, hi):
    """Slots ``lo .. hi - 1``: vertex positions to input indices, half-edges to triangles."""
    for k in range(lo, hi):
        tri[k] = inp[tri[k]]
        f = he[k]
        he[k] = f // 3 if f >= 0 else -1


_numbacache.refresh(globals())  # numba keys its cache on this file only (see replication._numbacache)
