"""Validation of user meshes for the jet model: domain, welding, height-field checks.

A triangle mesh given to :func:`replication.casestudy.jet.jet_force` must be a height field
z(x, y) inside the case study's domain (paper section 6); these checks turn any other mesh
into an :class:`~replication.errors.InputError` naming the offending vertex or triangle.
"""

from __future__ import annotations

import hashlib

import numpy as np

from replication._aot import kernel
from replication.casestudy.jetconfig import JetConfig
from replication.casestudy.units import to_millimetres
from replication.errors import InputError
from replication.surfaces._threads import frozen

__all__ = ["check_domain", "check_height_field", "surface_signature", "weld"]


def check_domain(
    points: np.ndarray,
    config: JetConfig,
    used: np.ndarray | None = None,
    *,
    bounds: tuple[np.ndarray, np.ndarray] | None = None,
) -> None:
    """Raise when the surface (metres; the vertices ``used``) leaves the domain or crosses y = 0.

    ``bounds``: the points' smallest and largest coordinates, when the caller has them (all
    vertices are then checked).
    """
    index = None if used is None else np.asarray(used)
    if index is not None:
        points = points[index]
    # the bounds decide; the vertex to name is looked for only when they fail (the GA calls
    # this once per evaluation: one min and one max, not a mask over every coordinate)
    if bounds is None or index is not None:
        bounds = points.min(axis=0), points.max(axis=0)
    lo, hi = bounds[0].tolist(), bounds[1].tolist()
    span = max(b - a for a, b in zip(lo, hi)) or 1.0
    tol = 1e-9 * span
    if not config.full_jet and lo[1] < -tol:
        i = int(points[:, 1].argmin())
        advice = (
            "the surface lies wholly in y <= 0: mirror it (y -> -y), or use the full jet (full_jet=True; "
            "--full-jet on the command line)"
            if hi[1] <= tol
            else "use the full jet for a surface on both sides (full_jet=True; --full-jet on the command "
            "line)"
        )
        raise InputError(
            f"the half jet needs the surface on the side y >= 0 of its symmetry plane, but vertex "
            f"{_vertex(index, i)} has y = {to_millimetres(points[i, 1]):.6g} mm; {advice}"
        )
    if config.domain is None:
        return
    length, width, depth = config.domain
    lower = [-tol, (-width if config.full_jet else 0.0) - tol, -tol]
    upper = [length + tol, width + tol, depth + tol]
    if all(a >= b for a, b in zip(lo, lower)) and all(a <= b for a, b in zip(hi, upper)):
        return
    lower, upper = np.array(lower), np.array(upper)
    outside = np.flatnonzero(((points < lower) | (points > upper)).any(axis=1))
    if not outside.size:  # bounds that are not numbers: the callers refuse those first
        return
    i = int(outside[0])
    x, y, z = to_millimetres(points[i])
    length_mm, width_mm, depth_mm = to_millimetres([length, width, depth])
    y_lo = -width_mm if config.full_jet else 0.0
    raise InputError(
        f"surface vertex {_vertex(index, i)} at ({x:.6g}, {y:.6g}, {z:.6g}) mm lies outside the domain "
        f"x 0..{length_mm:g}, y {y_lo:g}..{width_mm:g}, z 0..{depth_mm:g} mm "
        f"({outside.size} vertices outside); enlarge the domain or do without one (domain=None; "
        "--no-domain on the command line)"
    )


def _vertex(index: np.ndarray | None, i: int) -> int:
    """The number of the i-th checked vertex in the caller's mesh."""
    return i if index is None else int(index[i])


def weld(points: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge vertices with equal coordinates; refuse two heights over one (x, y) position."""
    used = np.unique(triangles)
    xy, first, inverse = np.unique(points[used, :2], axis=0, return_index=True, return_inverse=True)
    if xy.shape[0] == used.size:
        return points, triangles
    z_first = points[used[first], 2]
    differs = np.flatnonzero(points[used, 2] != z_first[inverse.ravel()])
    if differs.size:
        i = int(used[differs[0]])
        j = int(used[first[inverse.ravel()[differs[0]]]])
        x, y = to_millimetres(points[i, :2])
        raise InputError(
            f"vertices {j} and {i} share the position (x, y) = ({x:.6g}, {y:.6g}) mm at different heights: "
            "the surface is not a height field z(x, y)"
        )
    remap = np.empty(points.shape[0], dtype=np.int64)
    remap[used] = used[first[inverse.ravel()]]
    return points, remap[triangles]


def check_height_field(points: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, bool]:
    """Validate a triangle mesh as a height field over x-y; return CCW triangles and convexity."""
    x = frozen(points[:, 0], np.float64)
    y = frozen(points[:, 1], np.float64)
    signs = kernel("sheet_orientations")(x, y, frozen(triangles, np.int64))
    if np.all(signs < 0):  # consistently oriented downwards: the same height field
        triangles = np.ascontiguousarray(triangles[:, ::-1])
        signs = -signs
    bad = np.flatnonzero(signs <= 0)
    if bad.size:
        t = int(bad[0])
        what = "has zero area (a vertical facet)" if signs[t] == 0 else "is clockwise while others are not"
        if signs[t] == 0 and (why := _out_of_range(x, y, triangles[t])) is not None:
            raise InputError(f"triangle {t} (vertices {triangles[t].tolist()}): {why}")
        raise InputError(
            f"triangle {t} (vertices {triangles[t].tolist()}) {what} in the x-y projection; {bad.size} such "
            "triangle(s): the jet model needs a height field z(x, y) with counter-clockwise triangles"
        )
    i, j, kind = kernel("sheet_first_overlap")(x, y, frozen(triangles, np.int64))
    if kind == 1:
        raise InputError(
            f"triangles {i} and {j} overlap in the x-y projection: the surface is not a height field"
        )
    if kind == 2:
        raise InputError(
            f"a vertex of triangle {j} lies inside an edge of triangle {i} (or the reverse): "
            "the mesh is not conforming; split the edge so neighbouring triangles share it"
        )
    from scipy.spatial import ConvexHull

    a, b, c = (points[triangles[:, k], :2] for k in range(3))
    area = 0.5 * np.sum((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
    hull = ConvexHull(points[np.unique(triangles), :2]).volume
    return triangles, bool(area >= hull * (1 - 1e-9))


def surface_signature(points: np.ndarray, triangles: np.ndarray) -> str:
    """SHA-256 of a surface's geometry, independent of vertex and triangle order.

    Two genomes whose points differ only in order, or in merged duplicates, give the same
    signature: they are the same surface.
    """
    p = np.asarray(points, dtype=np.float64)
    corners = p[np.asarray(triangles)]  # (m, 3, 3)
    rows = [sorted(map(tuple, tri)) for tri in corners.tolist()]
    rows.sort()
    return hashlib.sha256(np.asarray(rows, dtype="<f8").tobytes()).hexdigest()


def _out_of_range(x: np.ndarray, y: np.ndarray, triangle: np.ndarray) -> str | None:
    """Why a triangle of zero computed area is not vertical: its area over- or underflows float64.

    The orientation test multiplies coordinate differences; at 1e-300 or 1e300 mm the product
    is 0, infinite or NaN, and the triangle read as a vertical facet. Only where that can happen
    (sides or coordinates beyond 2**±500) is the triangle tested again, exactly, on coordinates
    rescaled by a power of two: a triangle that has an area then shows it. In range, a zero
    area is a vertical facet, and None is returned.
    """
    px, py = x[triangle], y[triangle]
    with np.errstate(over="ignore", invalid="ignore"):
        dx, dy = px - px[0], py - py[0]
        side = float(max(np.abs(dx).max(), np.abs(dy).max()))
    big = float(max(np.abs(px).max(), np.abs(py).max()))
    if side == 0 or (LOW < side < HIGH and big < HIGH):
        return None
    # the coordinates (not their rounded differences) scaled by a power of two, exactly: the
    # sides to about 1, or, where they overflowed, the coordinates (a side is at least a unit
    # in the last place of the coordinates, so these stay below 2**53)
    exponent = int(np.frexp(side if np.isfinite(side) else big)[1])
    sx, sy = np.ldexp(px, -exponent), np.ldexp(py, -exponent)
    if kernel("sheet_orientations")(sx, sy, np.array([[0, 1, 2]], dtype=np.int64))[0] == 0:
        return None  # vertical at any scale
    sides = f"its sides are about {to_millimetres(side):.3g} mm, " if np.isfinite(side) else ""
    return (
        f"its area in the x-y projection {'overflows' if side > 1 else 'underflows'} float64 ({sides}"
        f"coordinates up to {to_millimetres(big):.3g} mm); the jet model works in millimetres over a "
        "domain of tens of millimetres: rescale the surface"
    )


#: Sides and coordinates between these bounds (2**-500, 2**500) keep the orientation test's
#: products within float64's range.
LOW, HIGH = 2.0**-500, 2.0**500
