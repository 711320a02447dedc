"""2-D Delaunay triangulation backends (paper section 3.2, steps 8-9).

Two backends produce a Delaunay triangulation of the same distinct points:

``"sweephull"`` (default)
    This project's compiled radial-sweep triangulator (:mod:`._sweephull`, numba). About
    0.1 ms at 200 points and under a second at 1e6 points on a 2-core machine.
``"scipy"``
    :class:`scipy.spatial.Delaunay` (Qhull), the reference; about 12 s at 1e6 points.

Both return counter-clockwise triangles. Neither drops a point silently: a point the backend
could not use raises :class:`~replication.errors.DegenerateInputError` naming it (the
sweep-hull backend first retries with Qhull).
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from replication.errors import DegenerateInputError, InputError, shown
from replication.surfaces import _sweephull

__all__ = ["BACKENDS", "Backend", "delaunay_2d", "signed_areas"]

Backend = Literal["auto", "sweephull", "scipy"]
BACKENDS: tuple[str, ...] = ("auto", "sweephull", "scipy")


def signed_areas(uv: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Signed areas of triangles in the plane (positive when counter-clockwise)."""
    a, b, c = uv[triangles[:, 0]], uv[triangles[:, 1]], uv[triangles[:, 2]]
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))


def _scipy(uv: np.ndarray) -> np.ndarray:
    from scipy.spatial import Delaunay, QhullError

    try:
        tri = Delaunay(uv)
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
        f"(points {shown(unused)}): they lie within floating-point precision of another point; "
        "round the coordinates or remove them"
    )


def delaunay_2d(uv: np.ndarray, *, backend: Backend = "auto") -> tuple[np.ndarray, str]:
    """Delaunay triangulation of distinct points in the plane.

    Parameters
    ----------
    uv : ndarray of float64, shape (n, 2)
        Distinct, finite points.
    backend : {"auto", "sweephull", "scipy"}
        Triangulation backend; ``"auto"`` is ``"sweephull"``.

    Returns
    -------
    triangles : ndarray of int64, shape (m, 3)
        Counter-clockwise vertex triples; every point is a vertex of some triangle.
    used : str
        The backend that produced the triangulation.

    Raises
    ------
    DegenerateInputError
        Fewer than three points, all points collinear, or a point no backend could use.

    Notes
    -----
    Paper section 3.2, steps 8-9 ("apply 2D Delaunay algorithm to the generated set P").
    """
    if backend not in BACKENDS:
        raise InputError(f"unknown triangulation backend {backend!r}; choose one of {BACKENDS}")
    uv = np.asarray(uv, dtype=np.float64)
    n = uv.shape[0]
    if n < 3:
        raise DegenerateInputError(f"need at least 3 distinct projected points, got {n}")
    used = "sweephull" if backend == "auto" else backend
    if used == "sweephull":
        triangles, status, _ = _sweephull.sweep_hull(uv[:, 0], uv[:, 1])
        if status == _sweephull.STATUS_COLLINEAR:
            raise DegenerateInputError(
                f"all {n} distinct projected points are collinear: they span no surface"
            )
        if status == _sweephull.STATUS_SKIPPED:
            used = "scipy"  # rounding defeated the sweep; Qhull is slower but handles it
    if used == "scipy":
        triangles = _scipy(uv)
    counts = np.bincount(triangles.ravel(), minlength=n)
    if np.any(counts == 0):
        raise _unused_points_error(np.flatnonzero(counts == 0), used)
    return triangles, used
