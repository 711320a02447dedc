"""Closing two height-field halves into one surface: rims, their overlap, the strip, checks.

Helpers of :mod:`.closed`. Each half of a split cloud is an ADT surface over the split
plane, so its rim (the boundary of its triangulation) is its convex hull in the plane,
counter-clockwise seen from the half's side. The two rims are joined by a strip of
triangles that uses only their vertices (:func:`closing_strip`): unrolled by angle about a
point inside both footprints against the height above the plane, the upper rim runs above
the lower one, and the band between them is filled by triangles with one vertex on each
rim that stay inside it, so the strip does not fold back. Where the rims share vertices
(cloud points on the plane) the band is pinched to those vertices, and an edge both rims
share needs no strip at all.
"""

from __future__ import annotations

import numpy as np

__all__ = ["boundary_loop", "closing_strip", "footprint_centre", "mesh_defect", "rim_and_inner"]


def _edges(triangles: np.ndarray, size: int | None = None) -> tuple[np.ndarray, ...]:
    """Directed edges (start, end) of every triangle and their undirected keys, grouped.

    Returns start, end, keys (``min * size + max``), the edge indices sorted by key, the
    first sorted position of each distinct key, and how many triangles use it.
    """
    t = np.asarray(triangles, dtype=np.int64)
    start, end = t.ravel(), t[:, [1, 2, 0]].ravel()
    size = int(t.max()) + 1 if size is None else size
    keys = np.minimum(start, end) * size + np.maximum(start, end)
    order = np.argsort(keys)
    ordered = keys[order]
    first = np.flatnonzero(np.r_[True, ordered[1:] != ordered[:-1]])
    counts = np.diff(np.r_[first, ordered.size])
    return start, end, keys, order, first, counts


def _loop(
    start: np.ndarray, end: np.ndarray, order: np.ndarray, first: np.ndarray, counts: np.ndarray
) -> np.ndarray:
    rim = order[first[counts == 1]]
    a, b = start[rim], end[rim]
    if a.size == 0 or np.any(counts > 2) or np.unique(a).size != a.size or np.unique(b).size != b.size:
        raise ValueError("the triangulation's boundary is not a single cycle")
    nxt = np.full(int(max(a.max(), b.max())) + 1, -1, dtype=np.int64)
    nxt[a] = b
    loop = [int(a.min())]
    for _ in range(a.size - 1):
        loop.append(int(nxt[loop[-1]]))
        if loop[-1] < 0 or loop[-1] == loop[0]:
            raise ValueError("the triangulation's boundary has more than one cycle")
    if nxt[loop[-1]] != loop[0]:
        raise ValueError("the triangulation's boundary is not a single cycle")
    return np.asarray(loop, dtype=np.int64)


def boundary_loop(triangles: np.ndarray) -> np.ndarray:
    """The boundary of a triangulated disk as one cycle of vertices, in the triangles' direction.

    Raises
    ------
    ValueError
        When the boundary is not a single simple cycle.
    """
    start, end, _, order, first, counts = _edges(triangles)
    return _loop(start, end, order, first, counts)


def rim_and_inner(triangles: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`boundary_loop` of a triangulated disk, and the sorted keys ``min * size + max``
    of its inner edges (those two triangles share)."""
    start, end, keys, order, first, counts = _edges(triangles, size)
    return _loop(start, end, order, first, counts), keys[order[first[counts == 2]]]


def _clip(subject: np.ndarray, clip: np.ndarray) -> np.ndarray:
    """Sutherland-Hodgman: the part of polygon ``subject`` inside convex CCW polygon ``clip``."""
    out = np.asarray(subject, dtype=np.float64)
    for i in range(len(clip)):
        if len(out) == 0:
            break
        a, d = clip[i], clip[(i + 1) % len(clip)] - clip[i]
        side = d[0] * (out[:, 1] - a[1]) - d[1] * (out[:, 0] - a[0])
        nxt_out, nxt_side = np.roll(out, -1, axis=0), np.roll(side, -1)
        keep = side >= 0
        cross = keep != (nxt_side >= 0)
        with np.errstate(divide="ignore", invalid="ignore"):  # used only where the sides differ
            cut = out + (nxt_out - out) * (side / (side - nxt_side))[:, None]
        # per subject vertex: the vertex if inside, then the crossing of its edge if any
        candidates = np.stack([out, cut], axis=1).reshape(-1, 2)
        valid = np.stack([keep, cross], axis=1).ravel()
        out = candidates[valid]
    return out


def footprint_centre(first: np.ndarray, second: np.ndarray) -> tuple[np.ndarray, float]:
    """Area centroid and area of the overlap of two convex CCW polygons (area 0: no overlap)."""
    common = _clip(first, second)
    if len(common) < 3:
        return np.full(2, np.nan), 0.0
    nxt = np.roll(common, -1, axis=0)
    w = common[:, 0] * nxt[:, 1] - nxt[:, 0] * common[:, 1]
    area = 0.5 * float(w.sum())
    if not area > 0:
        return np.full(2, np.nan), 0.0
    centre = ((common + nxt) * w[:, None]).sum(axis=0) / (6.0 * area)
    return centre, area


def closing_strip(
    upper: np.ndarray,
    lower: np.ndarray,
    uv: np.ndarray,
    height: np.ndarray,
    centre: np.ndarray,
    inner_edges: tuple[np.ndarray, ...] = (),
) -> np.ndarray:
    """Triangles joining two rims: vertex cycles counter-clockwise about ``centre`` in the plane.

    Unrolled by angle about ``centre`` (x) against the height above the plane (y), the upper
    rim runs above the lower one and the strip fills the band between them. Starting from a
    vertex both rims share, or else from the diagonal between the rims' closest vertices in
    angle, each step joins the current diagonal's ends to the next vertex of one rim. A
    step whose new diagonal is an inner edge of a half (``inner_edges``: per half, sorted
    keys ``min * n + max`` of the vertex pairs; where the rims share vertices a diagonal may join
    two vertices of one half) or a diagonal the strip already has is refused, as it would
    use an edge more than twice; a step whose triangle lies inside the band (counter-
    clockwise in that chart, less than half a turn wide, no other rim vertex inside) is
    preferred; between equals, the step whose next vertex comes first in angle is taken. A
    step whose triangle would repeat a vertex (at a vertex both rims share) adds nothing. The strip
    runs the upper rim's edges backwards and the lower rim's forwards: with the lower half
    reversed, the closed mesh is consistently oriented. Vertices both rims share pinch the
    band: the strip is built pocket by pocket between them.

    Raises
    ------
    ValueError
        When the rims pass their shared vertices in different orders.
    """
    size = len(uv)
    used: set[int] = set()

    def key(a: int, b: int) -> int:
        return int(min(a, b)) * size + int(max(a, b))

    def inner_edge(k: int) -> bool:
        for inner in inner_edges:
            at = int(np.searchsorted(inner, k))
            if at < inner.size and int(inner[at]) == k:
                return True
        return False

    d_up, d_lo = uv[upper] - centre, uv[lower] - centre
    a_up = np.arctan2(d_up[:, 1], d_up[:, 0])
    a_lo = np.arctan2(d_lo[:, 1], d_lo[:, 0])
    shared = np.intersect1d(upper, lower)
    if shared.size:
        i, k = int(np.flatnonzero(upper == shared[0])[0]), int(np.flatnonzero(lower == shared[0])[0])
    else:  # start on the diagonal between the closest rim vertices in angle
        gap = np.abs(np.angle(np.exp(1j * (a_up[:, None] - a_lo[None, :]))))
        i, k = (int(c) for c in np.unravel_index(np.argmin(gap), gap.shape))
    up, lo = np.roll(upper, -i), np.roll(lower, -k)
    x_up = np.unwrap(np.roll(a_up, -i))
    x_lo = np.unwrap(np.roll(a_lo, -k))
    x_lo += x_up[0] + np.angle(np.exp(1j * (x_lo[0] - x_up[0]))) - x_lo[0]
    # the chart: each rim unrolled, its first vertex repeated one turn later
    up, lo = np.append(up, up[0]), np.append(lo, lo[0])
    x_up, x_lo = np.append(x_up, x_up[0] + 2 * np.pi), np.append(x_lo, x_lo[0] + 2 * np.pi)
    p_up = np.column_stack([x_up, height[up]])
    p_lo = np.column_stack([x_lo, height[lo]])
    nodes = np.vstack([p_up, p_lo])

    def inside_band(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> bool:
        """Triangle a, b, c counter-clockwise, less than half a turn wide, no other node inside."""
        area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        if not area > 0 or max(a[0], b[0], c[0]) - min(a[0], b[0], c[0]) >= np.pi:
            return False
        sides = [
            (q[0] - p[0]) * (nodes[:, 1] - p[1]) - (q[1] - p[1]) * (nodes[:, 0] - p[0])
            for p, q in ((a, b), (b, c), (c, a))
        ]
        return not np.any((sides[0] > 0) & (sides[1] > 0) & (sides[2] > 0))

    def rank(tri: tuple[int, int, int], diagonal: tuple[int, int], corners: tuple, closing: bool) -> int:
        """2: a step onto a shared vertex, or inside the band; 1: allowed; 0: would break the mesh."""
        if len(set(tri)) < 3:
            return 2
        k = key(*diagonal)
        if inner_edge(k) or (k in used and not closing):
            return 0
        return 2 if inside_band(*corners) else 1

    n_up, n_lo = len(up) - 1, len(lo) - 1
    # pockets between vertices both rims share (the band is pinched there), else one band
    if shared.size:
        on_up = np.flatnonzero(np.isin(up, shared))
        on_lo = np.flatnonzero(np.isin(lo, shared))
        if not np.array_equal(up[on_up], lo[on_lo]):
            raise ValueError("the rims pass their shared vertices in different orders")
        pockets = list(zip(on_up[:-1], on_lo[:-1], on_up[1:], on_lo[1:]))
    else:
        pockets = [(0, 0, n_up, n_lo)]
    strip = []
    for i, j, end_up, end_lo in pockets:
        used.add(key(up[i], lo[j]))
        while i < end_up or j < end_lo:
            ranks = [-1, -1]
            if i < end_up:
                closing = i + 1 == end_up and j == end_lo
                tri = (up[i + 1], up[i], lo[j])
                ranks[0] = rank(tri, (up[i + 1], lo[j]), (p_lo[j], p_up[i + 1], p_up[i]), closing)
            if j < end_lo:
                closing = i == end_up and j + 1 == end_lo
                tri = (lo[j], lo[j + 1], up[i])
                ranks[1] = rank(tri, (lo[j + 1], up[i]), (p_lo[j], p_lo[j + 1], p_up[i]), closing)
            if ranks[0] != ranks[1]:
                step_up = ranks[0] > ranks[1]
            else:  # equally good: the step whose next vertex comes first in angle
                step_up = (x_up[i + 1], 1) <= (x_lo[j + 1], 0)
            if step_up:
                tri, diagonal = (up[i + 1], up[i], lo[j]), (up[i + 1], lo[j])
                i += 1
            else:
                tri, diagonal = (lo[j], lo[j + 1], up[i]), (lo[j + 1], up[i])
                j += 1
            if len(set(tri)) == 3:
                strip.append(tuple(int(v) for v in tri))
                used.add(key(*diagonal))
    return np.asarray(strip, dtype=np.int64).reshape(-1, 3)


def mesh_defect(
    triangles: np.ndarray, points: np.ndarray | None = None, near: np.ndarray | None = None
) -> str:
    """Why a triangle mesh is not a closed, consistently oriented surface ("" when it is).

    Checks that every edge is used by exactly two triangles, in opposite directions, and
    that the triangles round every vertex form one fan (the surface does not touch itself).
    With ``near`` (vertex indices), only the edges and fans at those vertices are checked:
    enough where the rest of the mesh is known to be sound (the inside of a triangulation).
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    t = np.asarray(triangles, dtype=np.int64)
    if t.size == 0:
        return "the mesh has no triangles"
    size = int(t.max()) + 1
    chosen = np.ones(size, dtype=bool)
    if near is not None:
        chosen[:] = False
        chosen[np.asarray(near, dtype=np.int64)] = True
        t = t[chosen[t].any(axis=1)]

    def where(v: int) -> str:
        return f"vertex {v}" if points is None else f"vertex {v} at {np.round(points[v], 6).tolist()}"

    start, end, _, order, first_of, counts = _edges(t, size)
    checked = chosen[start[order[first_of]]] | chosen[end[order[first_of]]]
    if np.any(checked & (counts != 2)):
        g = int(np.flatnonzero(checked & (counts != 2))[0])
        k = int(order[first_of[g]])
        return (
            f"the edge between vertices {start[k]} and {end[k]} is used by {counts[g]} triangle(s) "
            f"({int(np.sum(checked & (counts == 1)))} edge(s) used once): a closed surface uses every "
            "edge twice"
        )
    pairs = first_of[checked]
    first, second = order[pairs], order[pairs + 1]
    if np.any(start[first] == start[second]):
        k = int(first[np.flatnonzero(start[first] == start[second])[0]])
        return f"two triangles run the same way along the edge {start[k]}-{end[k]}: inconsistent orientation"
    # corners (triangle, position) of one vertex are joined across each shared edge
    nxt = lambda e: 3 * (e // 3) + (e % 3 + 1) % 3  # noqa: E731  (the corner at an edge's end)
    rows = np.concatenate([first, nxt(first)])
    cols = np.concatenate([nxt(second), second])
    graph = coo_matrix((np.ones(rows.size), (rows, cols)), shape=(t.size, t.size))
    n_fans, label = connected_components(graph, directed=False)
    vertex_of_fan = np.empty(n_fans, dtype=np.int64)
    vertex_of_fan[label] = t.ravel()
    fans = np.bincount(vertex_of_fan, minlength=size) * chosen
    if np.any(fans > 1):
        v = int(np.argmax(fans))
        return f"the surface touches itself at {where(v)} ({int(fans[v])} separate fans of triangles)"
    return ""
