"""An exact check that a triangulation of planar points is their Delaunay triangulation.

The Qhull fallback (:func:`.delaunay._qhull`) is computed in floating point, and on extreme
clouds (one axis 1e12 times longer than the other) it returns triangles that overlap, leave
part of the hull uncovered or break the empty-circle property, without an error. Its output is
therefore checked before it is used:

* no triangle is clockwise (exact orientation), and the triangle count is Euler's
  ``2n - 2 - h`` for ``n`` points with ``h`` on the boundary;
* the boundary is convex (no reflex turn): with consistent adjacency the triangles tile the
  convex hull, without overlaps or gaps;
* every interior edge between two proper triangles is locally Delaunay (exact in-circle
  test), which makes the tiling the Delaunay triangulation.

Qhull joins three collinear points of a lattice's hull into a flat triangle (zero area,
exactly, or up to rounding). Such triangles are accepted: they are Qhull's way of
triangulating collinear points and cover no area; the default backend never makes them. The
in-circle test means nothing on their edges, and they fold the boundary ring over their
points, so a triangulation with flat triangles is checked for clockwise triangles and for the
empty-circle property of its proper edges only (Qhull's gross failures, on clouds 1e12 times
longer than wide, were seen without flat triangles).

Each predicate is first evaluated in floating point for all triangles or edges at once, with
Shewchuk's error bounds (those of :mod:`._predicates`); only the few whose sign the bound
leaves open are decided by the exact predicates.
"""

from __future__ import annotations

import numpy as np

from replication.surfaces._predicates import _CCW_ERRBOUND, _ICC_ERRBOUND, incircle, orient

__all__ = ["is_delaunay"]


def _orient_signs(a: np.ndarray, b: np.ndarray, c: np.ndarray, tolerance: float = 0.0) -> np.ndarray:
    """Signs of orient(a, b, c) for rows of points (+1 counter-clockwise).

    ``tolerance`` 0: exact signs. A positive ``tolerance`` calls three points collinear (0)
    unless the determinant exceeds that fraction of its terms' magnitudes (see
    :func:`_incircle_signs`): points collinear before rounding (a lattice scaled by 0.1).
    """
    left = (a[:, 0] - c[:, 0]) * (b[:, 1] - c[:, 1])
    right = (a[:, 1] - c[:, 1]) * (b[:, 0] - c[:, 0])
    det = left - right
    bound = max(_CCW_ERRBOUND, tolerance) * (np.abs(left) + np.abs(right))
    signs = np.where(det > bound, 1.0, np.where(-det > bound, -1.0, 0.0 if tolerance else np.nan))
    for i in np.flatnonzero(np.isnan(signs)):
        signs[i] = orient(a[i, 0], a[i, 1], b[i, 0], b[i, 1], c[i, 0], c[i, 1])
    return signs


def _incircle_signs(
    a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray, tolerance: float = 0.0
) -> np.ndarray:
    """Signs of incircle(a, b, c, d) for rows of points (+1: d inside the ccw circle abc).

    ``tolerance`` 0: exact signs. A positive ``tolerance`` counts d as inside only when the
    determinant exceeds that fraction of its permanent (the sum of its terms' magnitudes):
    nearly co-circular points, whose sign is a matter of rounding, then count as on the circle.
    """
    adx, ady = a[:, 0] - d[:, 0], a[:, 1] - d[:, 1]
    bdx, bdy = b[:, 0] - d[:, 0], b[:, 1] - d[:, 1]
    cdx, cdy = c[:, 0] - d[:, 0], c[:, 1] - d[:, 1]
    alift, blift, clift = adx * adx + ady * ady, bdx * bdx + bdy * bdy, cdx * cdx + cdy * cdy
    det = alift * (bdx * cdy - cdx * bdy) + blift * (cdx * ady - adx * cdy) + clift * (adx * bdy - bdx * ady)
    permanent = (
        (np.abs(bdx * cdy) + np.abs(cdx * bdy)) * alift
        + (np.abs(cdx * ady) + np.abs(adx * cdy)) * blift
        + (np.abs(adx * bdy) + np.abs(bdx * ady)) * clift
    )
    bound = max(_ICC_ERRBOUND, tolerance) * permanent
    signs = np.where(det > bound, 1.0, np.where(-det > bound, -1.0, 0.0 if tolerance else np.nan))
    for i in np.flatnonzero(np.isnan(signs)):
        signs[i] = incircle(a[i, 0], a[i, 1], b[i, 0], b[i, 1], c[i, 0], c[i, 1], d[i, 0], d[i, 1])
    return signs


def is_delaunay(
    uv: np.ndarray, triangles: np.ndarray, neighbors: np.ndarray, hull: np.ndarray, *, tolerance: float = 0.0
) -> bool:
    """Whether ``triangles`` are the Delaunay triangulation of the points ``uv`` (all used).

    Parameters
    ----------
    uv : ndarray of float64, shape (n, 2)
        Distinct points, every one a vertex of some triangle.
    triangles : ndarray of int, shape (m, 3)
        Counter-clockwise triangles (indices into ``uv``).
    neighbors : ndarray of int, shape (m, 3)
        ``neighbors[t, k]``: the triangle across the edge from vertex k to vertex k + 1 of
        triangle t, or -1 on the boundary.
    hull : ndarray of int
        The boundary vertices, counter-clockwise.
    tolerance : float
        0 (default): exact. A positive value accepts a vertex inside a neighbour's
        circumcircle by less than that fraction of the in-circle determinant's permanent, and
        a triangle or a boundary turn that is clockwise by less than that fraction of the
        orientation's terms (see :func:`_incircle_signs`, :func:`_orient_signs`): Delaunay up
        to rounding.
    """
    uv = np.asarray(uv, dtype=np.float64)
    corners = [uv[triangles[:, k]] for k in range(3)]
    orientation = _orient_signs(*corners, tolerance)
    if np.any(orientation < 0):
        return False
    flat = orientation == 0
    # Euler's count and a convex boundary, for a tiling of proper triangles; Qhull's flat ones
    # fold the boundary ring over their collinear points, so they leave these two checks out
    n, h = uv.shape[0], hull.shape[0]
    if not flat.any():
        if triangles.shape[0] != 2 * n - 2 - h:
            return False
        ring = uv[hull]
        if np.any(_orient_signs(ring, np.roll(ring, -1, axis=0), np.roll(ring, -2, axis=0), tolerance) < 0):
            return False
    t, k = np.nonzero(neighbors > np.arange(triangles.shape[0])[:, None])  # each interior edge once
    proper = ~flat[t] & ~flat[neighbors[t, k]]
    t, k = t[proper], k[proper]
    other = neighbors[t, k]
    a, b = triangles[t, k], triangles[t, (k + 1) % 3]
    # the neighbour's vertex that is on neither end of the shared edge
    opposite_slot = np.argmax((triangles[other] != a[:, None]) & (triangles[other] != b[:, None]), axis=1)
    d = triangles[other, opposite_slot]
    c = triangles[t, (k + 2) % 3]
    return not np.any(_incircle_signs(uv[a], uv[b], uv[c], uv[d], tolerance) > 0)
