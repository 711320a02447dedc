"""Geometric checks shared by the tests: validity of Delaunay triangulations."""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull

from replication.surfaces._sweephull import orient


def exact_orientations(uv: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Exact orientation sign (+1, 0, -1) of each triangle."""
    return np.array([orient(*uv[a], *uv[b], *uv[c]) for a, b, c in triangles])


def hull_area(uv: np.ndarray) -> float:
    return float(ConvexHull(uv).volume)


def interior_edges(triangles: np.ndarray) -> list[tuple[int, int, int, int]]:
    """(a, b, c, d): edge a-b shared by triangles (a, b, c) and (b, a, d)."""
    owner: dict[tuple[int, int], int] = {}
    for a, b, c in triangles:
        for p, q, r in ((a, b, c), (b, c, a), (c, a, b)):
            owner[(p, q)] = r
    return [(p, q, r, owner[(q, p)]) for (p, q), r in owner.items() if (q, p) in owner and p < q]


def delaunay_violations(uv: np.ndarray, triangles: np.ndarray, rtol: float = 1e-9) -> int:
    """Interior edges that are not locally Delaunay beyond a relative tolerance.

    By the Delaunay lemma a triangulation whose edges are all locally Delaunay is Delaunay.
    """
    bad = 0
    for a, b, c, d in interior_edges(triangles):
        ax, ay = uv[a] - uv[d]
        bx, by = uv[b] - uv[d]
        cx, cy = uv[c] - uv[d]
        la, lb, lc = ax * ax + ay * ay, bx * bx + by * by, cx * cx + cy * cy
        det = la * (bx * cy - cx * by) + lb * (cx * ay - ax * cy) + lc * (ax * by - bx * ay)
        scale = (
            la * (abs(bx * cy) + abs(cx * by))
            + lb * (abs(cx * ay) + abs(ax * cy))
            + lc * (abs(ax * by) + abs(bx * ay))
        )
        if det > rtol * scale:
            bad += 1
    return bad


def assert_valid_delaunay(uv: np.ndarray, triangles: np.ndarray) -> None:
    """Every point used, no degenerate or inverted triangle, hull tiled, Delaunay edges."""
    n = uv.shape[0]
    assert triangles.min() >= 0 and triangles.max() < n
    assert np.all(np.bincount(triangles.ravel(), minlength=n) > 0), "a point is not a vertex"
    assert np.all(exact_orientations(uv, triangles) > 0), "degenerate or clockwise triangle"
    a, b, c = uv[triangles[:, 0]], uv[triangles[:, 1]], uv[triangles[:, 2]]
    areas = 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
    span = np.ptp(uv, axis=0)
    np.testing.assert_allclose(areas.sum(), hull_area(uv), rtol=1e-7, atol=1e-12 * span[0] * span[1])
    # a proper planar triangulation of a disk: each directed edge once, Euler V - E + F = 1
    directed = triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    assert np.unique(directed, axis=0).shape[0] == directed.shape[0], "overlapping triangles"
    edges = np.unique(np.sort(directed, axis=1), axis=0).shape[0]
    assert n - edges + triangles.shape[0] == 1, "not a triangulated disk"
    assert delaunay_violations(uv, triangles) == 0


#: A thin cloud along the diagonal of a 10 x 10 square: its bounding-box corners (0, 10) and
#: (10, 0) lie outside its convex hull.
DIAGONAL_CLOUD = np.array(
    [[0, 0, 0], [10, 10, 1], [5, 5, 2], [6, 4, 0], [4, 6, 1], [5, 4, 2], [4, 5, 0], [6, 5, 1], [5, 6, 2.0]]
)
