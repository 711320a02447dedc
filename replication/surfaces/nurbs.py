"""The NURBS baseline of paper section 3.1, built with geomdl.

The paper: "point cloud data was fitted into linearly interpolated rectangular grid. Then, a
required number of points are taken from this grid to form the NURBS grid. The NURBS surface
is generated using these points as the control points. ... the weights of each grid point
are taken as one and the degree of the curve is taken as three. The knot vectors are defined
as zero for the first three and one for the last three with uniform spacing in the
remaining knots."

Where the paper is ambiguous or silent, this module decides as follows (tested, and stated
in every report):

* **Degree.** "Zero for the first three and one for the last three" is a clamped knot vector
  of order 3, i.e. **degree 2**, and a 3 x 3 net (the 9-point row of Table 1) admits no
  higher degree. Degree 2 is the default; degree 3 is available when the net has at least 4
  control points in each direction.
* **Frame.** The surface is a height field over the same projection plane as ADT: the depth
  axis is chosen by the same rule (paper eq. 7-8), so the two surfaces are comparable point
  by point.
* **Net size.** Table 1's point counts (9, 45, 100, 169, 200) are all products of two
  integers, so the net has ``m_u * m_v = n`` control points: among the factor pairs with at
  least ``degree + 1`` points per direction and a side ratio within a factor ``max_ratio``
  (3) of the cloud's aspect ratio (extent along u over extent along v), the pair whose ratio
  is closest to the aspect ratio (in log scale). When no pair qualifies (primes, skinny
  factorisations) the **fallback** net is ``m_u = round(sqrt(n * aspect))``,
  ``m_v = ceil(n / m_u)`` (each at least ``degree + 1``), which has at least n nodes. n
  counts every point of the cloud, points merged as duplicates included (Table 1 counts the
  points drawn, and its lattice clouds repeat positions): a duplicated row changes the net.
* **Grid.** The grid spans the bounding box of the projected cloud with uniformly spaced
  nodes. Node depths are the linear interpolation of the cloud, i.e. barycentric
  interpolation on its Delaunay triangulation (the ADT surface, with the same duplicate
  policy); nodes outside the cloud's convex hull, where linear interpolation is undefined,
  take the depth of the **nearest** cloud point (of equally near points, the first in the
  lexicographic order of their projections: smaller first coordinate, then smaller second,
  a rule of the point set alone, as the triangulation's), and their number is reported.
* **Knots.** Clamped: ``degree + 1`` zeros, uniform interior knots, ``degree + 1`` ones.
* **Tessellation.** Building the surface includes evaluating it on a ``50 x 50`` grid of
  parameters (``tessellation``), with geomdl (the paper-faithful reference) or with the
  fast evaluator of :mod:`.bspline`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from replication.errors import DegenerateInputError, InputError
from replication.params import count_pair
from replication.surfaces._spread import validated_cloud
from replication.surfaces.adt import AXES, DEFAULT_TIE_RTOL, Surface, _readonly, adt
from replication.surfaces.bspline import evaluate_grid
from replication.surfaces.delaunay import Backend
from replication.surfaces.duplicates import DuplicatePolicy
from replication.surfaces.patch import NurbsPatch  # re-exported: nurbs.NurbsPatch keeps working

__all__ = [
    "DEFAULT_TESSELLATION",
    "Grid",
    "NetShape",
    "NurbsPatch",
    "NurbsSurface",
    "clamped_uniform_knots",
    "control_net_shape",
    "fit_nurbs",
    "grid_depths",
]

DEFAULT_TESSELLATION = (50, 50)


@dataclass(frozen=True)
class NetShape:
    """Control-net size and which rule produced it (``"exact"`` or ``"fallback"``)."""

    m_u: int
    m_v: int
    rule: str

    @property
    def size(self) -> int:
        return self.m_u * self.m_v


def control_net_shape(n: int, aspect: float, degree: int = 2, *, max_ratio: float = 3.0) -> NetShape:
    """Choose the ``m_u x m_v`` control net for an n-point cloud (see the module notes).

    Parameters
    ----------
    n : int
        Number of points of the cloud.
    aspect : float
        Extent of the projected cloud along u divided by its extent along v.
    degree : int
        Spline degree; each direction needs at least ``degree + 1`` control points.
    max_ratio : float
        A factor pair qualifies only if its side ratio is within this factor of ``aspect``.

    Raises
    ------
    InputError
        When ``n < (degree + 1) ** 2``: too few points for the degree.
    """
    _check_degree(degree)
    if not (np.isfinite(aspect) and aspect > 0):
        raise InputError(f"aspect ratio must be positive and finite, got {aspect=}")
    low = degree + 1
    if n < low * low:
        raise InputError(
            f"a degree-{degree} NURBS needs at least {low} x {low} = {low * low} control points, "
            f"but the cloud has only {n} points"
        )
    target = math.log(aspect)
    best: tuple[float, int, int] | None = None
    divisors = [d for d in range(1, math.isqrt(n) + 1) if n % d == 0]
    pairs = sorted({(a, n // a) for d in divisors for a in (d, n // d)})  # increasing a
    for a, b in pairs:
        if a < low or b < low:
            continue
        distance = abs(math.log(a / b) - target)
        if distance <= math.log(max_ratio) + 1e-12 and (best is None or distance < best[0]):
            best = (distance, a, b)
    if best is not None:
        return NetShape(best[1], best[2], "exact")
    m_u = max(low, round(min(math.sqrt(n * aspect), n)))  # n * aspect may overflow to inf
    if math.ceil(n / m_u) < low:  # a very wide cloud: m_v stops at ``low``, so m_u stops at n / low
        m_u = max(low, math.ceil(n / low))
    m_v = max(low, math.ceil(n / m_u))
    return NetShape(m_u, m_v, "fallback")


def _check_degree(degree: int) -> None:
    if isinstance(degree, bool) or not isinstance(degree, (int, np.integer)) or degree < 1:
        raise InputError(f"NURBS degree must be a positive integer, got {degree=!r}")


def clamped_uniform_knots(m: int, degree: int) -> np.ndarray:
    """Clamped knot vector with uniform interior knots for ``m`` control points.

    ``degree + 1`` zeros, ``m - degree - 1`` interior knots ``i / (m - degree)``, and
    ``degree + 1`` ones (paper section 3.1).
    """
    _check_degree(degree)
    if m < degree + 1:
        raise InputError(f"{m} control points cannot carry a degree-{degree} spline (need {degree + 1})")
    interior = np.arange(1, m - degree) / (m - degree)
    return np.concatenate([np.zeros(degree + 1), interior, np.ones(degree + 1)])


@dataclass(frozen=True, eq=False)
class Grid:
    """The rectangular grid the cloud is interpolated onto (paper section 3.1)."""

    u: np.ndarray  # (m_u,) node positions along the first projection axis
    v: np.ndarray  # (m_v,) node positions along the second projection axis
    depth: np.ndarray  # (m_u, m_v)
    filled: np.ndarray  # (m_u, m_v) bool: outside the convex hull, nearest-neighbour depth

    @property
    def n_filled(self) -> int:
        return int(self.filled.sum())


def grid_depths(surface: Surface, shape: tuple[int, int]) -> Grid:
    """Interpolate an ADT-triangulated cloud linearly onto a uniform grid over its bounding box.

    Nodes outside the convex hull take the depth of the nearest vertex (of equally near ones,
    the first in the lexicographic order of (u, v), whatever the vertices' numbering). The
    grid is filled triangle by triangle (:mod:`._grid`), on the vertices relabelled in the
    triangulator's (spatially coherent) order; the nearest vertex of an outside node is found
    by a walk on the surface's own triangle adjacency from the triangle of the nearest inside
    node of its row, then a greedy walk on the Delaunay triangulation (no k-d tree is built).
    """
    from replication.surfaces._grid import raster, relabel
    from replication.surfaces.interpolate import _fill_nearest

    order = surface.vertex_order
    if order is None:
        order = np.arange(surface.n_vertices, dtype=np.int32)
    axes = np.array([*surface.projection_axes, surface.depth_axis])
    xy, depth, triangles, (u_lo, u_hi, v_lo, v_hi) = relabel(surface.points, axes, surface.triangles, order)
    u = np.linspace(u_lo, u_hi, shape[0])
    v = np.linspace(v_lo, v_hi, shape[1])
    owner, values = raster(xy, triangles, surface.neighbors, depth, u, v)
    outside = owner < 0
    # the nodes outside the hull, in row-major order: np.nonzero of the 2-D mask took 2.4 ms
    # at 1e6 nodes, the flat indices split into (row, column) 0.4 ms
    rows, cols = np.divmod(np.flatnonzero(outside), outside.shape[1])
    if rows.size:
        start = _start_triangles(owner, rows, cols)
        queries = np.column_stack([u[rows], v[cols]])
        nearest = _fill_nearest(xy, triangles, surface.neighbors, queries, start)
        values[rows, cols] = depth[nearest]
    return Grid(u=_readonly(u), v=_readonly(v), depth=_readonly(values), filled=_readonly(outside))


def _start_triangles(owner: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """For each outside node, the triangle of the nearest inside node of its row (of the
    nearest row that has one): the hull is convex, so a row's inside nodes are contiguous."""
    inside = owner >= 0
    has = inside.any(axis=1)
    usable = np.flatnonzero(has)
    first = np.argmax(inside, axis=1)
    last = owner.shape[1] - 1 - np.argmax(inside[:, ::-1], axis=1)
    row = usable[np.clip(np.searchsorted(usable, rows), 0, usable.size - 1)]
    col = np.where(cols < first[row], first[row], last[row])
    return owner[row, col]


@dataclass(frozen=True, eq=False)
class NurbsSurface:
    """The NURBS baseline fitted to a cloud, with how it was built.

    Attributes
    ----------
    patch : NurbsPatch
        Degrees, knots, control points (in x, y, z) and weights.
    depth_axis, projection_axes
        The frame shared with the ADT surface of the same cloud.
    net : NetShape
        Control-net size and the rule that chose it.
    grid : Grid
        The interpolated grid whose nodes are the control points.
    tessellation : ndarray, shape (s_u, s_v, 3) or None
        The surface evaluated on a uniform parameter grid.
    evaluator : str
        ``"geomdl"`` or ``"fast"``: what produced the tessellation.
    n_input : int
        Points of the cloud.
    n_merged : int
        Points merged into another point's vertex before the gridding (their positions
        repeat another point's projection; see the duplicate policy of :func:`fit_nurbs`).
    """

    patch: NurbsPatch
    depth_axis: int
    projection_axes: tuple[int, int]
    net: NetShape
    grid: Grid
    tessellation: np.ndarray | None
    evaluator: str
    n_input: int
    n_merged: int = 0

    @property
    def n_filled(self) -> int:
        """Grid nodes outside the cloud's convex hull, filled by the nearest point."""
        return self.grid.n_filled

    @property
    def depth_axis_name(self) -> str:
        return AXES[self.depth_axis]

    def tessellation_mesh(self) -> tuple[np.ndarray, np.ndarray]:
        """The tessellation as a triangle mesh: points (s_u * s_v, 3) and triangles."""
        if self.tessellation is None:
            raise InputError("this NURBS surface was built without a tessellation")
        s_u, s_v = self.tessellation.shape[:2]
        index = np.arange(s_u * s_v).reshape(s_u, s_v)
        a, b = index[:-1, :-1].ravel(), index[1:, :-1].ravel()
        c, d = index[1:, 1:].ravel(), index[:-1, 1:].ravel()
        triangles = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
        return self.tessellation.reshape(-1, 3), triangles


def _check_built_from(cloud: np.ndarray, surface: Surface) -> None:
    """Refuse a triangulation of another cloud: the grid is read from the triangulation alone,
    so another cloud's surface of as many points gave that cloud's NURBS without a word.

    Each point must lie where its vertex does in the projection plane, and at its depth when
    no other point merged into that vertex (a merged depth follows the duplicate policy).
    """
    vertex = np.asarray(surface.vertex_of_input)
    if (
        vertex.shape != (cloud.shape[0],)
        or vertex.dtype.kind not in "iu"
        or (vertex.size and (int(vertex.min()) < 0 or int(vertex.max()) >= surface.n_vertices))
    ):
        raise InputError(
            "triangulation.vertex_of_input does not fit the cloud: it was not built by adt() for it"
        )
    single = None
    for axis in (*surface.projection_axes, surface.depth_axis):
        ours, theirs = cloud[:, axis], surface.points[:, axis][vertex]
        if axis == surface.depth_axis and surface.n_vertices != cloud.shape[0]:  # merged points
            single = np.bincount(vertex, minlength=surface.n_vertices)[vertex] == 1
            ours, theirs = ours[single], theirs[single]
        if not np.array_equal(ours, theirs):
            k = int(np.flatnonzero(ours != theirs)[0])
            k = int(np.flatnonzero(single)[k]) if single is not None else k
            raise InputError(
                f"the triangulation was not built from these points: point {k} has {'xyz'[axis]} = "
                f"{cloud[k, axis]:.17g}, its vertex {int(vertex[k])} {surface.points[vertex[k], axis]:.17g}; "
                "pass the Surface that adt() built from this cloud"
            )


def _check_triangulation(surface: Surface) -> None:
    """Refuse a given Surface whose index arrays the compiled gridding would read out of bounds.

    ``adt`` builds them consistent; one changed by hand (``dataclasses.replace``) crashed the
    process (a segmentation fault). A few passes over the indices: about 1 % of a fit.
    """
    points = np.asarray(surface.points)
    n, m = points.shape[0], np.shape(surface.triangles)[0]
    if points.ndim != 2 or points.shape[1] != 3 or not np.all(np.isfinite(points)):
        raise InputError(f"triangulation.points must be finite, of shape (n, 3), got shape {points.shape}")
    for name, lowest, highest, shape in (
        ("triangles", 0, n - 1, (m, 3)),
        ("neighbors", -1, m - 1, (m, 3)),
        ("hull", 0, n - 1, None),
    ):
        a = np.asarray(getattr(surface, name))
        fits = a.dtype.kind in "iu" and a.size > 0 and (a.shape == shape if shape else a.ndim == 1)
        if not fits or int(a.min()) < lowest or int(a.max()) > highest:
            got = (
                f"shape {a.shape}, dtype {a.dtype}" if not fits else f"values {int(a.min())}..{int(a.max())}"
            )
            raise InputError(
                f"triangulation.{name} does not fit the surface's {n} vertices and {m} triangles ({got}): "
                "it was not built by adt() for this cloud"
            )


#: The smallest extent of the projected cloud the NURBS gridding takes: its barycentric
#: interpolation multiplies two lengths, and below 2**-511 their product underflows (a cloud
#: scaled by 2**-540 divided by zero in the raster).
MIN_EXTENT = 2.0**-500
#: The largest extent it takes, for the same reason: from 2**511 the product overflows (a cloud
#: of extent 2**517 found grid nodes "inside the triangulation" that the raster had not filled).
MAX_EXTENT = 2.0**500


def fit_nurbs(
    points: ArrayLike,
    *,
    degree: int = 2,
    net: tuple[int, int] | None = None,
    depth: Literal["min", "max", "x", "y", "z"] = "min",
    duplicates: DuplicatePolicy = "mean",
    tessellation: tuple[int, int] | None = DEFAULT_TESSELLATION,
    evaluator: Literal["geomdl", "fast"] = "geomdl",
    backend: Backend = "auto",
    tie_rtol: float = DEFAULT_TIE_RTOL,
    triangulation: Surface | None = None,
) -> NurbsSurface:
    """Fit the paper's NURBS surface to a point cloud (section 3.1).

    Parameters
    ----------
    points : array_like, shape (n, 3)
    degree : int
        Degree in both directions (default 2, see the module notes).
    net : (int, int), optional
        Impose the control-net size ``(m_u, m_v)``; default: the rule of
        :func:`control_net_shape`.
    depth, duplicates, backend, tie_rtol
        As for :func:`~replication.surfaces.adt.adt`; they fix the frame and the linear
        interpolation onto the grid.
    tessellation : (int, int) or None
        Parameter samples per direction evaluated as part of the build; None skips it.
    evaluator : {"geomdl", "fast"}
        Evaluate the tessellation with geomdl (reference) or with scipy's ``NdBSpline``.
    triangulation : Surface, optional
        The cloud's ADT surface, if already built: its frame and duplicate policy are used
        (``depth``, ``duplicates``, ``backend`` and ``tie_rtol`` are then ignored).

    Returns
    -------
    NurbsSurface

    Raises
    ------
    InputError
        Too few points for the degree, a bad net, non-finite coordinates, bad options, a
        projected extent below :data:`MIN_EXTENT` or above :data:`MAX_EXTENT`.
    DegenerateInputError
        A cloud with zero extent along a projection axis (no rectangular grid exists).

    Notes
    -----
    Paper section 3.1; every weight is 1 and the knot vectors are clamped and uniform.
    """
    _check_degree(degree)
    if evaluator not in ("geomdl", "fast"):
        raise InputError(f"evaluator must be 'geomdl' or 'fast', got {evaluator!r}")
    if triangulation is None:
        surface = adt(points, depth=depth, duplicates=duplicates, backend=backend, tie_rtol=tie_rtol)
    else:  # the triangulation fixes the frame and duplicate policy: it must be this cloud's
        if not isinstance(triangulation, Surface):
            raise InputError(
                f"triangulation must be the cloud's Surface from adt(), got {type(triangulation).__name__}"
            )
        cloud = validated_cloud(points)[0]
        n = cloud.shape[0]
        if triangulation.n_input != n:
            raise InputError(f"the triangulation is of {triangulation.n_input} points, the cloud has {n}")
        _check_triangulation(triangulation)
        _check_built_from(cloud, triangulation)
        surface = triangulation
    # the extremes of the vertices are hull vertices: the same numbers as over every vertex,
    # without four passes over a million-point cloud's strided columns (8 ms)
    boundary = surface.points[surface.hull]
    extent = np.array([np.max(boundary[:, a]) - np.min(boundary[:, a]) for a in surface.projection_axes])
    if np.any(extent <= 0):
        raise DegenerateInputError(f"the projected cloud has zero extent {extent.tolist()}: no grid spans it")
    if np.any(extent < MIN_EXTENT):
        raise InputError(
            f"the projected cloud's extent ({extent[0]:.3g} by {extent[1]:.3g}) is below {MIN_EXTENT:.3g} "
            "(2**-500): the gridding's interpolation multiplies two such lengths, which underflows "
            "float64; rescale the cloud (ADT itself triangulates it)"
        )
    if np.any(extent > MAX_EXTENT):
        raise InputError(
            f"the projected cloud's extent ({extent[0]:.3g} by {extent[1]:.3g}) is above {MAX_EXTENT:.3g} "
            "(2**500): the gridding's interpolation multiplies two such lengths, which overflows "
            "float64; rescale the cloud (ADT itself triangulates it)"
        )
    if net is None:
        shape = control_net_shape(surface.n_input, float(extent[0] / extent[1]), degree)
    else:
        m_u, m_v = count_pair(net, "net")
        if min(m_u, m_v) < degree + 1:
            raise InputError(
                f"a {m_u} x {m_v} net cannot carry degree {degree}: need {degree + 1} per direction"
            )
        shape = NetShape(m_u, m_v, "imposed")
    grid = grid_depths(surface, (shape.m_u, shape.m_v))
    frame = np.empty((shape.m_u, shape.m_v, 3))
    frame[..., surface.projection_axes[0]] = grid.u[:, None]
    frame[..., surface.projection_axes[1]] = grid.v[None, :]
    frame[..., surface.depth_axis] = grid.depth
    weights = np.ones((shape.m_u, shape.m_v))
    frame.flags.writeable = weights.flags.writeable = False  # ours alone: the patch keeps them uncopied
    patch = NurbsPatch(
        degree_u=degree,
        degree_v=degree,
        knots_u=clamped_uniform_knots(shape.m_u, degree),
        knots_v=clamped_uniform_knots(shape.m_v, degree),
        control_points=frame,
        weights=weights,
    )
    evaluated = None
    if tessellation is not None:
        s_u, s_v = count_pair(tessellation, "tessellation (samples per direction)", 2)
        if evaluator == "geomdl":
            geo = patch.to_geomdl()
            geo.sample_size_u = s_u
            geo.sample_size_v = s_v
            evaluated = np.asarray(geo.evalpts, dtype=np.float64).reshape(s_u, s_v, 3)
        else:
            evaluated = evaluate_grid(patch, (s_u, s_v))
        evaluated = _readonly(evaluated)
    return NurbsSurface(
        patch=patch,
        depth_axis=surface.depth_axis,
        projection_axes=surface.projection_axes,
        net=shape,
        grid=grid,
        tessellation=evaluated,
        evaluator=evaluator,
        n_input=surface.n_input,
        n_merged=surface.n_merged,
    )
