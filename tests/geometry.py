"""Exact geometric checks shared by the tests: validity of Delaunay triangulations.

Nothing here uses a floating-point tolerance. A triangulation of distinct points in the plane
is accepted when

1. it is a triangulated disk: indices in range, every point a vertex, each directed edge in
   at most one triangle, Euler's V - E + F = 1, and the boundary edges form one simple cycle;
2. every triangle is counter-clockwise with non-zero area (exact orientation);
3. the boundary is the convex hull: every point lies left of or on every boundary edge, and
   none lies inside a boundary edge (collinear hull points are vertices of the boundary);
   compiled: the boundary cycle equals the exact monotone-chain hull with its collinear
   points. With 1 and 2, the triangles then tile the hull exactly once;
4. every interior edge is locally Delaunay: the far vertex of the neighbouring triangle is
   not strictly inside the circle of the triangle (exact in-circle test), which by the
   Delaunay lemma makes the whole triangulation Delaunay.

Small cases (``exact="fraction"``) evaluate the predicates in exact rational arithmetic on
the float values, independently of the library: every float is a fraction with a power of two
as denominator, so after scaling by the largest denominator the coordinates are Python
integers and the predicates are integer polynomials (the same as with
:class:`fractions.Fraction`, only faster). Large cases use the library's adaptive exact
predicates (themselves tested against Fraction arithmetic in ``test_predicates.py``),
compiled once with numba.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
from numba import njit

from replication.surfaces._predicates import incircle, orient


def _sign(value) -> int:
    return (value > 0) - (value < 0)


def _exact(value):
    return value if isinstance(value, int) else Fraction(value)


def orient_q(a, b, c) -> int:
    """Exact sign of the orientation of three points (floats as Fractions, or integers)."""
    (ax, ay), (bx, by), (cx, cy) = ((_exact(p[0]), _exact(p[1])) for p in (a, b, c))
    return _sign((bx - ax) * (cy - ay) - (by - ay) * (cx - ax))


def incircle_q(a, b, c, d) -> int:
    """Exact sign of the in-circle determinant (d inside the circle of CCW a, b, c: +1)."""
    dx, dy = _exact(d[0]), _exact(d[1])
    rows = []
    for p in (a, b, c):
        px, py = _exact(p[0]) - dx, _exact(p[1]) - dy
        rows.append((px, py, px * px + py * py))
    (a1, a2, a3), (b1, b2, b3), (c1, c2, c3) = rows
    return _sign(a1 * (b2 * c3 - b3 * c2) - a2 * (b1 * c3 - b3 * c1) + a3 * (b1 * c2 - b2 * c1))


def interior_edges(triangles: np.ndarray) -> list[tuple[int, int, int, int]]:
    """(a, b, c, d): edge a-b shared by triangles (a, b, c) and (b, a, d)."""
    owner: dict[tuple[int, int], int] = {}
    for a, b, c in triangles.tolist():
        for p, q, r in ((a, b, c), (b, c, a), (c, a, b)):
            owner[(p, q)] = r
    return [(p, q, r, owner[(q, p)]) for (p, q), r in owner.items() if (q, p) in owner and p < q]


def combinatorial_disk(triangles: np.ndarray, n: int) -> tuple[np.ndarray, list[int]]:
    """Check that the triangles form a triangulated disk; return neighbours and the boundary cycle.

    Every directed edge at most once, Euler's V - E + F = 1 and one simple boundary cycle.
    ``neighbors[t, k]`` is the triangle across edge k (from vertex k to k + 1), -1 on the boundary.
    """
    m = triangles.shape[0]
    start = triangles.ravel()
    end = triangles[:, [1, 2, 0]].ravel()
    key = start * n + end
    order = np.argsort(key, kind="stable")
    assert np.all(np.diff(key[order]) > 0), "an edge is used twice in the same direction"
    twin = end * n + start
    pos = np.minimum(np.searchsorted(key[order], twin), key.size - 1)
    found = key[order][pos] == twin
    neighbors = np.where(found, order[pos] // 3, -1).reshape(m, 3)
    boundary = np.flatnonzero(~found)
    edges = (key.size - boundary.size) // 2 + boundary.size
    assert n - edges + m == 1, "not a triangulated disk (Euler)"
    following = dict(zip(start[boundary].tolist(), end[boundary].tolist()))
    assert len(following) == boundary.size, "two boundary edges leave one vertex"
    ring = [int(start[boundary[0]])]
    while following[ring[-1]] != ring[0]:
        ring.append(following[ring[-1]])
        assert len(ring) <= boundary.size, "the boundary is not one cycle"
    assert len(ring) == boundary.size, "the boundary is made of several cycles"
    return neighbors, ring


def boundary_cycle(triangles: np.ndarray) -> list[int]:
    """The boundary edges as one cycle of vertices (asserts that they form one simple cycle)."""
    return combinatorial_disk(triangles, int(triangles.max()) + 1)[1]


@njit(cache=True)
def _chain(xy, order, out):
    """Monotone chain over points sorted by (x, y), keeping collinear points; returns its length."""
    size = 0
    for k in range(order.shape[0]):
        p = order[k]
        while size >= 2:
            a, b = out[size - 2], out[size - 1]
            if orient(xy[a, 0], xy[a, 1], xy[b, 0], xy[b, 1], xy[p, 0], xy[p, 1]) >= 0.0:
                break
            size -= 1
        out[size] = p
        size += 1
    return size


def exact_hull(uv: np.ndarray) -> list[int]:
    """Counter-clockwise convex hull with every point on its boundary (exact predicates)."""
    order = np.lexsort((uv[:, 1], uv[:, 0]))
    out = np.empty(order.size, dtype=np.int64)
    lower = out[: _chain(uv, order, out)].tolist()
    upper = out[: _chain(uv, order[::-1].copy(), out)].tolist()
    return lower[:-1] + upper[:-1]


@njit(cache=True)
def _exact_counts(xy, tri, nbr):
    """(clockwise or flat triangles, edges that are not locally Delaunay)."""
    flat = 0
    for t in range(tri.shape[0]):
        a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
        if orient(xy[a, 0], xy[a, 1], xy[b, 0], xy[b, 1], xy[c, 0], xy[c, 1]) <= 0.0:
            flat += 1
    illegal = 0
    for t in range(tri.shape[0]):
        for k in range(3):
            s = nbr[t, k]
            if s < t:  # the boundary, or an edge already seen from the other side
                continue
            a, b, c = tri[t, k], tri[t, (k + 1) % 3], tri[t, (k + 2) % 3]
            d = -1
            for j in range(3):
                w = tri[s, j]
                if w != a and w != b:
                    d = w
            if incircle(xy[a, 0], xy[a, 1], xy[b, 0], xy[b, 1], xy[c, 0], xy[c, 1], xy[d, 0], xy[d, 1]) > 0.0:
                illegal += 1
    return flat, illegal


def exact_integers(uv: np.ndarray) -> list[tuple[int, int]]:
    """The points scaled by a common power of two into exact Python integers."""
    ratios = [float(c).as_integer_ratio() for c in np.asarray(uv, dtype=np.float64).ravel()]
    scale = max(den for _, den in ratios)
    values = [num * (scale // den) for num, den in ratios]
    return list(zip(values[0::2], values[1::2]))


def assert_valid_delaunay(uv: np.ndarray, triangles: np.ndarray, *, exact: str = "auto") -> None:
    """Assert that ``triangles`` is a Delaunay triangulation of the distinct points ``uv``.

    ``exact``: ``"fraction"`` (rational arithmetic), ``"compiled"`` (the library's exact
    predicates) or ``"auto"`` (fractions up to 400 points).
    """
    uv = np.ascontiguousarray(uv, dtype=np.float64)
    triangles = np.asarray(triangles, dtype=np.int64)
    n = uv.shape[0]
    assert triangles.ndim == 2 and triangles.shape[1] == 3 and triangles.shape[0] > 0
    assert triangles.min() >= 0 and triangles.max() < n
    assert np.all(np.bincount(triangles.ravel(), minlength=n) > 0), "a point is not a vertex"
    neighbors, ring = combinatorial_disk(triangles, n)
    if exact == "auto":
        exact = "fraction" if n <= 400 else "compiled"
    if exact == "compiled":
        flat, illegal = _exact_counts(uv, triangles, neighbors)
        assert flat == 0, f"{flat} triangle(s) clockwise or with exactly zero area"
        hull = exact_hull(uv)
        at = ring.index(hull[0]) if hull[0] in ring else 0
        assert ring[at:] + ring[:at] == hull, "the boundary is not the convex hull"
        assert illegal == 0, f"{illegal} edge(s) not locally Delaunay"
        return
    pts = exact_integers(uv)
    for a, b, c in triangles.tolist():
        assert orient_q(pts[a], pts[b], pts[c]) > 0, f"triangle {(a, b, c)} is clockwise or has zero area"
    for e in range(len(ring)):
        a, b = ring[e], ring[(e + 1) % len(ring)]
        (ax, ay), (bx, by) = pts[a], pts[b]
        ex, ey = bx - ax, by - ay
        for p in range(n):
            if p in (a, b):
                continue
            px, py = pts[p][0] - ax, pts[p][1] - ay
            side = ex * py - ey * px
            assert side >= 0, f"point {p} lies outside the boundary edge {(a, b)}"
            if side == 0:
                t = px * ex + py * ey
                assert not 0 < t < ex * ex + ey * ey, f"point {p} lies inside the hull edge {(a, b)}"
    for a, b, c, d in interior_edges(triangles):
        assert incircle_q(pts[a], pts[b], pts[c], pts[d]) <= 0, f"edge {(a, b)} is not locally Delaunay"


#: A thin cloud along the diagonal of a 10 x 10 square: its bounding-box corners (0, 10) and
#: (10, 0) lie outside its convex hull.
DIAGONAL_CLOUD = np.array(
    [[0, 0, 0], [10, 10, 1], [5, 5, 2], [6, 4, 0], [4, 6, 1], [5, 4, 2], [4, 5, 0], [6, 5, 1], [5, 6, 2.0]]
)
