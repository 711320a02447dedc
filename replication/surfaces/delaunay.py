"""2-D Delaunay triangulation backends (paper section 3.2, steps 8-9).

Two backends triangulate the distinct projected positions of a cloud:

``"sweephull"`` (default)
    This project's compiled radial-sweep triangulator (:mod:`._triangulate`, numba): exact
    predicates, duplicates found from the sweep's own sort, and from ``PARALLEL_MIN`` points
    on two blocks triangulated on two threads and merged. About 0.05 ms at 200 points.
``"scipy"``
    :class:`scipy.spatial.Delaunay` (Qhull), the reference; about 12 s at 1e6 points.

Both return counter-clockwise triangles with their neighbours and the convex hull. Neither
drops a point silently: a point the backend could not use raises
:class:`~replication.errors.DegenerateInputError` naming it. The ``"auto"`` backend (the
default) is the sweep, retried with Qhull when rounding defeats it.

**Range.** The exact predicates multiply four coordinates, so products overflow above about
1e77 and underflow below about 1e-77, and clouds there got wrong triangles without an error.
A cloud whose largest projected coordinate lies outside [2^-128, 2^128] is therefore scaled
by a power of two, which is exact (the triangulation is that of the cloud as given) unless
the scaling would round a coordinate (a tiny one next to huge ones, pushed below float64's
normal range); then it is an error, not a guess. Qhull, which is not exact, is given
coordinates centred on the middle of their bounding box, since it loses the digits an offset
carries (map coordinates in metres, 1e6 from the origin, gave non-Delaunay triangles).
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np

from replication.errors import DegenerateInputError, InputError, shown
from replication.surfaces._status import STATUS_COLLINEAR, STATUS_OK, STATUS_RANGE
from replication.surfaces._triangulate import triangulate

__all__ = ["BACKENDS", "Backend", "delaunay_2d", "hull_from_neighbors", "planar_delaunay", "signed_areas"]

Backend = Literal["auto", "sweephull", "scipy"]
BACKENDS: tuple[str, ...] = ("auto", "sweephull", "scipy")


def signed_areas(uv: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Signed areas of triangles in the plane (positive when counter-clockwise)."""
    a, b, c = uv[triangles[:, 0]], uv[triangles[:, 1]], uv[triangles[:, 2]]
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))


def hull_from_neighbors(triangles: np.ndarray, neighbors: np.ndarray) -> np.ndarray:
    """The boundary vertices of a triangulated disk, counter-clockwise (from its neighbours)."""
    t, k = np.nonzero(neighbors < 0)
    start = triangles[t, k]
    end = triangles[t, (k + 1) % 3]
    following = dict(zip(start.tolist(), end.tolist()))
    ring = [int(start[0])]
    for _ in range(len(following) - 1):
        ring.append(following[ring[-1]])
    return np.asarray(ring, dtype=triangles.dtype)


def _scipy(uv: np.ndarray) -> np.ndarray:
    from scipy.spatial import Delaunay, QhullError

    middle = 0.5 * (uv.min(axis=0) + uv.max(axis=0))  # Qhull keeps the digits an offset would take
    try:
        tri = Delaunay(uv - middle)
    except QhullError as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else "Qhull error"
        raise DegenerateInputError(
            f"Qhull could not triangulate the {len(uv)} projected points (are they collinear?): {first}"
        ) from exc
    triangles = tri.simplices.astype(np.int64)
    flip = signed_areas(uv, triangles) < 0
    triangles[flip] = triangles[flip][:, [0, 2, 1]]
    return triangles


def _unused_points_error(unused: np.ndarray, backend: str) -> DegenerateInputError:
    return DegenerateInputError(
        f"{unused.size} distinct projected point(s) could not be triangulated by {backend} "
        f"(points {shown(unused)}): within its rounding they coincide with another point or lie on a "
        "line or circle through others; round the coordinates or remove them"
    )


def _too_few_or_collinear(points: np.ndarray, axes: tuple[int, int]) -> DegenerateInputError:
    from replication.surfaces.duplicates import group_positions

    _, first = group_positions(points[:, axes[0]], points[:, axes[1]])
    if first.shape[0] < 3:
        return DegenerateInputError(f"need at least 3 distinct projected points, got {first.shape[0]}")
    return DegenerateInputError(
        f"all {first.shape[0]} distinct projected points are collinear: they span no surface"
    )


#: Qhull's triangles are Delaunay up to its rounding: on nearly co-circular points (a lattice
#: scaled by 0.1) a vertex may lie inside a neighbour's circumcircle by about 1e-16 of the
#: in-circle determinant's terms, and on nearly collinear hull points the boundary may turn
#: the wrong way by as little. Its gross failures, on clouds about 1e12 times longer than
#: wide, reach 0.01-0.3; anything beyond this fraction is refused.
QHULL_TOLERANCE = 1e-12


def _check_qhull(uv: np.ndarray, triangles: np.ndarray, neighbors: np.ndarray) -> None:
    """Refuse Qhull's floating-point output unless it is checked (:mod:`._verify`): a tiling of
    the convex hull (exact orientations) that is Delaunay up to :data:`QHULL_TOLERANCE`.

    On clouds about 1e12 times longer than wide Qhull returned triangles that left part of
    the hull uncovered and broke the empty-circle property, without an error.
    """
    from replication.surfaces._verify import is_delaunay

    try:
        hull = hull_from_neighbors(triangles, neighbors)
        valid = is_delaunay(uv, triangles, neighbors, hull, tolerance=QHULL_TOLERANCE)
    except (KeyError, IndexError):  # no single boundary ring: not a triangulated disk
        valid = False
    if not valid:
        spans = np.ptp(uv, axis=0)
        raise DegenerateInputError(
            f"Qhull's triangulation of the {uv.shape[0]} projected points is not their Delaunay "
            "triangulation (checked with exact orientations and in-circle tests): the projection spans "
            f"{spans[0]:.3g} by {spans[1]:.3g}, an aspect at which float64 rounding defeats both backends"
        )


def _qhull(points: np.ndarray, axes: tuple[int, int]):
    """The scipy backend in the shape of :class:`._triangulate.Triangulation`."""
    from replication.surfaces._triangulate import Triangulation
    from replication.surfaces.duplicates import group_positions
    from replication.surfaces.interpolate import triangle_neighbors

    group, first = group_positions(points[:, axes[0]], points[:, axes[1]])
    if first.shape[0] < 3:
        raise _too_few_or_collinear(points, axes)
    # Qhull decides among co-circular points by the order it is given them: give it the
    # positions in lexicographic order (u, then v), so the triangles depend on the point set
    # alone, as the sweep's do, and not on the order of the cloud's rows
    order = np.lexsort((points[first, axes[1]], points[first, axes[0]]))
    first = first[order]
    group = np.argsort(order)[group]
    uv = points[first][:, list(axes)]
    local = _scipy(uv)
    counts = np.bincount(local.ravel(), minlength=first.shape[0])
    if np.any(counts == 0):
        raise _unused_points_error(first[counts == 0], "scipy")
    neighbors = triangle_neighbors(local).astype(np.int32)
    _check_qhull(uv, local, neighbors)
    triangles = first[local].astype(np.int32)
    duplicates = np.flatnonzero(first[group] != np.arange(group.shape[0])).astype(np.int32)
    return Triangulation(
        triangles=triangles,
        neighbors=neighbors,
        hull=hull_from_neighbors(triangles, neighbors),
        duplicates=duplicates,
        representatives=first[group[duplicates]].astype(np.int32),
        status=0,
        blocks=1,
    )


def _in_range(points: np.ndarray, axes: tuple[int, int]) -> tuple[np.ndarray, tuple[int, int]]:
    """``(points, axes)`` when the largest absolute (u, v) coordinate lies in the exact
    predicates' range (every cloud of sane units), else the (u, v) columns times the power of
    two that puts it in [0.5, 1): exact, or an error when the scaling would round a coordinate."""
    from replication.surfaces._status import out_of_range

    columns = points[:, list(axes)]
    size = np.abs(columns)
    top = float(size.max()) if points.shape[0] else 0.0
    if not out_of_range(top):
        return points, axes
    shift = -math.frexp(top)[1]
    uv = np.ldexp(columns, shift)
    if shift < 0 and not np.array_equal(np.ldexp(uv, -shift), columns):
        smallest = float(size[size > 0].min())
        raise DegenerateInputError(
            f"the projected coordinates span too wide a range to triangulate exactly: from {smallest:.3g} to "
            f"{top:.3g} in absolute value (products of four overflow float64 unless the small ones are "
            "rounded); rescale the cloud or drop the outlying points"
        )
    return uv, (0, 1)


def planar_delaunay(points: np.ndarray, axes: tuple[int, int] = (0, 1), *, backend: Backend = "auto"):
    """Delaunay triangulation of the distinct positions of columns ``axes`` of ``points``.

    Parameters
    ----------
    points : ndarray of float64, shape (n, k), C-contiguous
        Finite coordinates.
    axes : (int, int)
        The columns that are (u, v).
    backend : {"auto", "sweephull", "scipy"}
        ``"auto"`` is ``"sweephull"``, with Qhull as the fallback when rounding defeats it;
        ``"sweephull"`` is the sweep alone (its failure is an error), ``"scipy"`` Qhull alone.

    Returns
    -------
    result : :class:`._triangulate.Triangulation`
        Triangles, neighbours and hull in input indices, and the duplicate pairs.
    used : str
        The backend that produced the triangulation.

    Raises
    ------
    DegenerateInputError
        Fewer than three distinct points, all of them collinear, or a point no backend could use.
    """
    if backend not in BACKENDS:
        raise InputError(f"unknown triangulation backend {backend!r}; choose one of {BACKENDS}")
    if backend != "scipy":
        result = triangulate(points, axes)
        if result.status == STATUS_RANGE:  # scaled exactly: the indices and triangles are the cloud's
            points, axes = _in_range(points, axes)
            result = triangulate(points, axes)
        if result.status == STATUS_OK:
            return result, "sweephull"
        if result.status == STATUS_COLLINEAR:
            raise _too_few_or_collinear(points, axes)
        if backend == "sweephull":  # asked for the sweep alone: no silent change of backend
            raise DegenerateInputError(
                f"the sweep-hull triangulator could not triangulate the {points.shape[0]} projected "
                "points: rounding of its sort keys put a point inside the hull; the 'auto' backend falls "
                "back to Qhull"
            )
        # rounding defeated the sweep; Qhull is slower but handles it
        try:
            return _qhull(*_in_range(points, axes)), "scipy"
        except DegenerateInputError as exc:
            raise DegenerateInputError(f"rounding defeated the sweep-hull triangulator, then: {exc}") from exc
    return _qhull(*_in_range(points, axes)), "scipy"


def delaunay_2d(uv: np.ndarray, *, backend: Backend = "auto") -> tuple[np.ndarray, str]:
    """Delaunay triangulation of distinct points in the plane.

    Parameters
    ----------
    uv : ndarray of float64, shape (n, 2)
        Distinct, finite points.
    backend : {"auto", "sweephull", "scipy"}
        Triangulation backend; ``"auto"`` is ``"sweephull"``, retried with Qhull when rounding
        defeats it.

    Returns
    -------
    triangles : ndarray of int32, shape (m, 3)
        Counter-clockwise vertex triples; every point is a vertex of some triangle.
    used : str
        The backend that produced the triangulation.

    Raises
    ------
    DegenerateInputError
        Fewer than three points, repeated points, all points collinear, or a point no
        backend could use.

    Notes
    -----
    Paper section 3.2, steps 8-9 ("apply 2D Delaunay algorithm to the generated set P").
    """
    uv = np.ascontiguousarray(uv, dtype=np.float64)
    if uv.ndim != 2 or uv.shape[1] != 2:
        raise InputError(f"points must have shape (n, 2), got {uv.shape}")
    if uv.shape[0] < 3:
        raise DegenerateInputError(f"need at least 3 distinct projected points, got {uv.shape[0]}")
    result, used = planar_delaunay(uv, backend=backend)
    if result.duplicates.size:
        raise DegenerateInputError(
            f"{result.duplicates.size} point(s) repeat another point (points {shown(result.duplicates)}); "
            "merge them first (adt does)"
        )
    return result.triangles, used
