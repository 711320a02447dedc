"""Adapted Delaunay triangulation (ADT), paper section 3.2 steps 4-10.

Steps: (4) standard deviation of each coordinate; (5) the depth axis is the axis of minimum
spread (or of maximum spread on request, eq. 7); (6) ties are broken Z first, then Y (eq. 8);
(7) project onto the two remaining axes; (8-9) 2-D Delaunay triangulation; (10) the same
triangles, lifted back to the 3-D points, form the surface.

Choices where the paper is silent, documented here and tested:

* **Spread** is the population standard deviation (``ddof=0``); the choice does not affect
  which axis is chosen.
* **Tie**: two spreads tie when they differ by at most ``tie_rtol`` times the largest
  spread (default 1e-9). Among the axes that tie with the minimum (or maximum), the depth
  axis is z if z is among them, else y, else x (eq. 8 generalised to every tie pattern).
* **Projection axes** follow the cyclic order, (y, z) for depth x, (z, x) for depth y and
  (x, y) for depth z, so that (u, v, depth) is right-handed; triangles are counter-clockwise
  in (u, v), and their normals point towards +depth.
* **Duplicates**: points with the same projected position become one vertex by the
  duplicate policy (:mod:`.duplicates`), never silently.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal

import numpy as np
from numpy.typing import ArrayLike

from replication.errors import DegenerateInputError, InputError
from replication.params import real
from replication.surfaces._spread import validated_cloud
from replication.surfaces.cloud import underflow
from replication.surfaces.delaunay import Backend, planar_delaunay
from replication.surfaces.duplicates import (
    DUPLICATE_POLICIES,
    DuplicatePolicy,
    apply_policy,
    group_positions,
    groups_from_pairs,
)

if TYPE_CHECKING:  # pragma: no cover
    import pyvista

__all__ = [
    "AXES",
    "DEPTH_RULES",
    "DEFAULT_TIE_RTOL",
    "Surface",
    "adt",
    "parse_axis",
    "projection_axes",
    "select_depth_axis",
    "triangle_polydata",
]

#: The advice an ADT of too few distinct projected points ends with (a caller that fixes the
#: depth axis, such as the jet model's ``force``, replaces it with its own).
DEPTH_HINT = "; another --depth rule may help"
#: ... and when no rule can: the cloud lies on one line in 3-D, so every projection does too.
LINE_HINT = "; the points lie on one line in 3-D (or coincide), so no depth rule can help"

AXES: tuple[str, str, str] = ("x", "y", "z")
DEPTH_RULES: tuple[str, ...] = ("min", "max", "x", "y", "z")
DEFAULT_TIE_RTOL = 1e-9
DepthRule = Literal["min", "max", "x", "y", "z"]


def parse_axis(axis: int | str) -> int:
    """Return the axis index 0, 1, 2 of ``axis`` given as an index or as ``"x"/"y"/"z"``."""
    if isinstance(axis, str) and axis.lower() in AXES:
        return AXES.index(axis.lower())
    if isinstance(axis, (int, np.integer)) and not isinstance(axis, bool) and 0 <= axis <= 2:
        return int(axis)
    raise InputError(f"axis must be 0, 1, 2 or 'x', 'y', 'z', got {axis!r}")


def projection_axes(depth_axis: int) -> tuple[int, int]:
    """The (u, v) axes for a depth axis, in cyclic (right-handed) order."""
    return ((depth_axis + 1) % 3, (depth_axis + 2) % 3)


def select_depth_axis(
    spreads: ArrayLike, rule: Literal["min", "max"] = "min", *, tie_rtol: float = DEFAULT_TIE_RTOL
) -> int:
    """Choose the depth axis from the spreads of the coordinates.

    Parameters
    ----------
    spreads : array_like, shape (3,)
        Standard deviation of x, y and z.
    rule : {"min", "max"}
        Axis of minimum spread (narrow surface) or of maximum spread (widely spread surface).
    tie_rtol : float
        Spreads within ``tie_rtol * max(spreads)`` of the extreme value tie.

    Returns
    -------
    int
        0, 1 or 2 for x, y or z.

    Notes
    -----
    Paper eq. 7 (min or max) and eq. 8 (ties: Z first, then Y).
    """
    try:
        v = [float(s) for s in spreads]  # type: ignore[union-attr]
    except (TypeError, ValueError):
        v = []
    if len(v) != 3 or not all(math.isfinite(s) and s >= 0 for s in v):
        raise InputError(f"spreads must be 3 finite non-negative numbers, got {spreads!r}")
    if rule not in ("min", "max"):
        raise InputError(f"depth rule must be 'min' or 'max', got {rule!r}")
    if not real(tie_rtol, "tie_rtol") >= 0:
        raise InputError(f"tie tolerance must be non-negative, got {tie_rtol=}")
    extreme = min(v) if rule == "min" else max(v)
    scale = tie_rtol * max(v)
    return next(axis for axis in (2, 1, 0) if abs(v[axis] - extreme) <= scale)


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.ascontiguousarray(a)
    a.flags.writeable = False
    return a


def triangle_polydata(points: np.ndarray, triangles: np.ndarray) -> pyvista.PolyData:
    """A :class:`pyvista.PolyData` of triangles (pyvista is imported on first use)."""
    from replication.io.vtkload import vtk_imports

    with vtk_imports():
        import pyvista as pv

    return pv.PolyData.from_regular_faces(np.array(points, dtype=np.float64), np.asarray(triangles))


@dataclass(frozen=True, eq=False)
class Surface:
    """An ADT surface: vertices, triangles and how they were obtained.

    Attributes
    ----------
    points : ndarray of float64, shape (n_vertices, 3)
        Vertices. Without duplicates they are the input points in input order; otherwise one
        vertex per distinct projected position, in order of first occurrence.
    triangles : ndarray of int32, shape (n_triangles, 3)
        Vertex indices, counter-clockwise in the (u, v) projection plane (int64 only for
        clouds of more than 357 million points).
    neighbors : ndarray of int32, shape (n_triangles, 3)
        ``neighbors[t, k]`` is the triangle across the edge from ``triangles[t, k]`` to
        ``triangles[t, (k + 1) % 3]``, -1 on the boundary (the triangulator's adjacency,
        reused for point location and by the jet model).
    hull : ndarray of int32
        The boundary (convex hull) vertices, counter-clockwise.
    depth_axis : int
        Axis perpendicular to the surface (0, 1, 2 for x, y, z).
    projection_axes : tuple of int
        The (u, v) axes triangulated in 2-D.
    spreads : tuple of float
        Standard deviation of x, y and z of the input cloud.
    depth_rule : str
        ``"min"``, ``"max"``, or the axis name when the depth axis was imposed.
    duplicate_policy : str
        Policy applied to points sharing a projected position.
    vertex_of_input : ndarray of int32, shape (n_input,)
        The vertex each input point became (the merge record).
    backend : str
        Triangulation backend that produced the triangles.
    vertex_order : ndarray of int32 or None
        The vertices in the triangulator's storage order (block by block, each in sweep
        order): a spatially coherent numbering that kernels visiting every triangle use for
        memory locality (None when the backend has none).
    """

    points: np.ndarray
    triangles: np.ndarray
    neighbors: np.ndarray
    hull: np.ndarray
    depth_axis: int
    projection_axes: tuple[int, int]
    spreads: tuple[float, float, float]
    depth_rule: str
    duplicate_policy: str
    vertex_of_input: np.ndarray
    backend: str
    vertex_order: np.ndarray | None = field(default=None, repr=False)
    _input_size: int = field(init=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "points", _readonly(self.points))
        object.__setattr__(self, "triangles", _readonly(self.triangles))
        object.__setattr__(self, "neighbors", _readonly(self.neighbors))
        object.__setattr__(self, "hull", _readonly(self.hull))
        if self.vertex_order is not None:
            object.__setattr__(self, "vertex_order", _readonly(self.vertex_order))
            if self.vertex_order.shape != (self.points.shape[0],):  # kernels index with it unchecked
                raise InputError(
                    f"vertex_order must have one entry per vertex ({self.points.shape[0]}), "
                    f"got shape {self.vertex_order.shape}"
                )
        object.__setattr__(self, "vertex_of_input", _readonly(self.vertex_of_input))
        object.__setattr__(self, "_input_size", int(self.vertex_of_input.shape[0]))

    @property
    def n_input(self) -> int:
        """Number of points in the input cloud."""
        return self._input_size

    @property
    def n_vertices(self) -> int:
        return int(self.points.shape[0])

    @property
    def n_triangles(self) -> int:
        return int(self.triangles.shape[0])

    @property
    def n_merged(self) -> int:
        """Input points merged into another point's vertex (0 when all positions differ)."""
        return self.n_input - self.n_vertices

    @property
    def merged_inputs(self) -> np.ndarray:
        """Indices of input points whose vertex stands for more than one input point."""
        counts = np.bincount(self.vertex_of_input, minlength=self.n_vertices)
        return np.flatnonzero(counts[self.vertex_of_input] > 1)

    @property
    def depth_axis_name(self) -> str:
        return AXES[self.depth_axis]

    @property
    def projection_axes_names(self) -> tuple[str, str]:
        return (AXES[self.projection_axes[0]], AXES[self.projection_axes[1]])

    def projected(self) -> np.ndarray:
        """Vertices in the (u, v) projection plane, shape (n_vertices, 2)."""
        return self.points[:, list(self.projection_axes)]

    def to_polydata(self) -> pyvista.PolyData:
        """The surface as a :class:`pyvista.PolyData` of triangles."""
        return triangle_polydata(self.points, self.triangles)


def adt(
    points: ArrayLike,
    *,
    depth: DepthRule = "min",
    duplicates: DuplicatePolicy = "mean",
    backend: Backend = "auto",
    tie_rtol: float = DEFAULT_TIE_RTOL,
) -> Surface:
    """Build the ADT surface of a point cloud.

    Parameters
    ----------
    points : array_like, shape (n, 3)
        The cloud; finite coordinates. A pandas DataFrame's column names (or a structured
        array's field names) say which column is which axis, in any level of hierarchical
        columns (see :func:`~replication.surfaces.cloud.as_cloud`).
    depth : {"min", "max", "x", "y", "z"}
        Depth axis rule: the axis of minimum spread (default, a "narrow" surface), of
        maximum spread, or an imposed axis.
    duplicates : {"mean", "min", "max", "first", "raise"}
        Policy for points sharing a projected position (see :func:`.merge_duplicates`).
    backend : {"auto", "sweephull", "scipy"}
        2-D Delaunay backend (see :func:`.delaunay_2d`).
    tie_rtol : float
        Relative tolerance under which two spreads tie (see :func:`select_depth_axis`).

    Returns
    -------
    Surface

    Raises
    ------
    InputError
        Bad shape, non-finite coordinates, unknown options, duplicates under ``"raise"``.
    DegenerateInputError
        Fewer than three distinct projected points, or all of them collinear.

    Warns
    -----
    DuplicatePointsWarning
        When points sharing a projected position were merged.

    Notes
    -----
    Paper section 3.2, steps 4-10, eq. 5-9.
    """
    cloud, spreads = validated_cloud(points)
    if depth in ("min", "max"):
        axis = select_depth_axis(spreads, depth, tie_rtol=tie_rtol)
    elif isinstance(depth, str) and depth in AXES:
        axis = AXES.index(depth)
    else:
        raise InputError(f"depth rule must be one of {DEPTH_RULES}, got {depth!r}")
    if duplicates not in DUPLICATE_POLICIES:
        raise InputError(f"unknown duplicate policy {duplicates!r}; choose one of {DUPLICATE_POLICIES}")
    u_axis, v_axis = projection_axes(axis)
    try:
        planar, used = planar_delaunay(cloud, (u_axis, v_axis), backend=backend)
    except DegenerateInputError as exc:
        # the duplicate policy speaks first (its warning, or its error under "raise")
        group, first = group_positions(cloud[:, u_axis], cloud[:, v_axis])
        apply_policy(
            group, first, cloud[:, axis], duplicates, axis_names=(AXES[u_axis], AXES[v_axis], AXES[axis])
        )
        why = underflow(cloud[:, [u_axis, v_axis]], (AXES[u_axis], AXES[v_axis]))  # not collinear: tiny
        if why is not None:
            raise DegenerateInputError(why) from exc
        # points off one line in 3-D span a plane, and projecting along an axis that plane is
        # not parallel to keeps them off one line: then another depth axis triangulates them
        hint = DEPTH_HINT if np.linalg.matrix_rank(cloud - cloud[0]) >= 2 else LINE_HINT
        raise DegenerateInputError(
            f"{exc} (projection plane ({AXES[u_axis]}, {AXES[v_axis]}), depth axis "
            f"{AXES[axis]}, rule {depth!r}{hint})"
        ) from exc
    n = cloud.shape[0]
    if planar.duplicates.size == 0:  # every point is a vertex, in input order
        vertices = cloud.copy()
        vertex_of_input = np.arange(n, dtype=planar.triangles.dtype)
        triangles, hull, order = planar.triangles, planar.hull, planar.order
    else:
        group, first = groups_from_pairs(n, planar.duplicates, planar.representatives)
        merge = apply_policy(
            group, first, cloud[:, axis], duplicates, axis_names=(AXES[u_axis], AXES[v_axis], AXES[axis])
        )
        vertices = cloud[first]  # fancy indexing copies
        vertices[:, axis] = merge.depth
        vertex_of_input = group
        triangles, hull = group[planar.triangles], group[planar.hull]
        order = None if planar.order is None else group[planar.order]
    return Surface(
        points=vertices,
        triangles=triangles,
        neighbors=planar.neighbors,
        hull=hull,
        depth_axis=axis,
        projection_axes=(u_axis, v_axis),
        spreads=spreads,
        depth_rule=str(depth),  # a numpy string (np.str_) is stored as the Python str it equals
        duplicate_policy=duplicates,
        vertex_of_input=vertex_of_input,
        backend=used,
        vertex_order=order,
    )
