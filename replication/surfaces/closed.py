"""Closed ADT surfaces from a user-named split plane (paper section 3.2).

The paper: "closed surfaces could also be generated ... with the help of user inputs
regarding the presence of closed surface and the plane for split boundary. This will allow
the algorithm to separate the random points cloud into two sets and generate two different
non-overlapping surfaces which can be patched together to form the final closed surface."

Choices made here (documented and tested):

* The split plane is ``axis = offset`` for a coordinate axis, or ``normal . p = offset`` for
  any normal (an oblique plane; the normal is made a unit vector). Each half is
  triangulated as a height field over the plane, i.e. with the plane's normal as depth
  axis; for an oblique plane in a rotated frame (x', y' in the plane, z' along the normal),
  and vertices that are input points keep their exact input coordinates.
* Points within ``tol`` of the plane belong to both halves (default tolerance: 1e-9 times
  the cloud's largest extent); equal vertices of the two halves become one vertex.
* **Patching.** Each half's rim (the boundary of its triangulation, its convex hull in the
  plane) is joined to the other's by a strip of triangles that uses only rim vertices: no
  point is added. Unrolled by angle about the centroid of the overlap of the two footprints
  against the height above the plane, the upper rim runs above the lower one, and the band
  between them is filled by triangles with one vertex on each rim that stay inside it
  (:mod:`._closing`). Where the rims share
  vertices (points on the plane) the band is pinched there, so a cloud with a ring of points
  on the plane is stitched along the ring as before.
* The lower half's triangles are reversed and the strip follows, so the closed mesh is
  consistently oriented with normals pointing outwards.
* **When it is closed.** The result is watertight (every edge in exactly two triangles, in
  opposite directions, one fan of triangles round every vertex) for any cloud whose halves
  are height fields over the plane and whose footprints overlap, unless a point on the plane
  lies on one half's rim but inside the other's footprint (or inside both): the surface
  would touch itself there. Such clouds, and clouds whose footprints do not overlap, are not
  closed; :attr:`ClosedSurface.not_closed_reason` says why in one line and the halves are
  returned unjoined. The strip does not cross the halves when they move away from the plane
  towards their interior (convex bodies such as ellipsoids); for strongly concave halves it
  may.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from replication.errors import DegenerateInputError, InputError
from replication.surfaces._closing import (
    closing_strip,
    footprint_centre,
    mesh_defect,
    rim_and_inner,
)
from replication.surfaces.adt import (
    AXES,
    Surface,
    _readonly,
    adt,
    parse_axis,
    projection_axes,
    triangle_polydata,
)
from replication.surfaces.cloud import as_cloud
from replication.surfaces.delaunay import Backend
from replication.surfaces.duplicates import DuplicatePolicy
from replication.threadlimits import single_blas_thread

if TYPE_CHECKING:  # pragma: no cover
    import pyvista

__all__ = ["SplitPlane", "ClosedSurface", "closed_adt", "parse_split", "edge_use_counts"]


@dataclass(frozen=True)
class SplitPlane:
    """The plane that splits a closed cloud in two.

    ``axis`` is a coordinate axis (0, 1, 2 or ``"x"``, ``"y"``, ``"z"``: the plane
    ``axis = offset``) or a normal vector of three numbers (the plane ``n . p = offset`` with
    n the unit normal); a normal along +x, +y or +z becomes that axis.
    """

    axis: int | tuple[float, float, float]
    offset: float

    def __post_init__(self) -> None:
        axis = self.axis
        if isinstance(axis, (str, int, np.integer)) and not isinstance(axis, bool):
            object.__setattr__(self, "axis", parse_axis(axis))
        else:
            try:
                normal = np.asarray(axis, dtype=np.float64)
            except (TypeError, ValueError):
                raise InputError(
                    f"split plane axis must be x, y, z or a normal of 3 numbers, got {axis!r}"
                ) from None
            if not (normal.shape == (3,) and np.isfinite(normal).all() and normal.any()):
                raise InputError(f"split plane normal must be 3 finite numbers, not all zero, got {axis!r}")
            largest = float(np.abs(normal).max())
            if not 1e-150 < largest < 1e150:  # its squares would overflow or underflow: scale it first
                normal = normal / largest  # (was: "must be ... not all zero" for (1e200, 1, 0))
            normal = normal / float(np.linalg.norm(normal))
            unit = np.flatnonzero(normal == 1.0)
            object.__setattr__(self, "axis", int(unit[0]) if unit.size else tuple(float(c) for c in normal))
        if not np.isfinite(self.offset):
            raise InputError(f"split plane offset must be finite, got {self.offset!r}")
        object.__setattr__(self, "offset", float(self.offset))

    @property
    def aligned(self) -> bool:
        """True when the plane is normal to a coordinate axis (``axis`` is 0, 1 or 2)."""
        return isinstance(self.axis, int)

    @property
    def normal(self) -> np.ndarray:
        """The unit normal, pointing to the upper half."""
        return np.eye(3)[self.axis] if isinstance(self.axis, int) else np.asarray(self.axis)

    @property
    def depth_name(self) -> str:
        """The depth axis of the halves: ``"x"``/``"y"``/``"z"``, or the normal as text."""
        if isinstance(self.axis, int):
            return AXES[self.axis]
        return "normal " + ",".join(f"{c:.6g}" for c in self.axis)

    def frame(self) -> np.ndarray:
        """Rows e1, e2, n: a right-handed orthonormal frame whose third axis is the normal."""
        if isinstance(self.axis, int):
            u, v = projection_axes(self.axis)
            return np.eye(3)[[u, v, self.axis]]
        n = self.normal
        e1 = np.cross(n, np.eye(3)[int(np.argmin(np.abs(n)))])
        e1 /= np.linalg.norm(e1)
        return np.stack([e1, np.cross(n, e1), n])

    def __str__(self) -> str:
        if isinstance(self.axis, int):
            return f"{AXES[self.axis]}={self.offset:g}"
        return ",".join(f"{c:.6g}" for c in self.axis) + f"={self.offset:g}"


def parse_split(text: str) -> SplitPlane:
    """Parse ``"z=0.5"`` (or ``"z:0.5"``), or ``"1,1,0=0.5"`` for an oblique plane with that normal."""
    for sep in ("=", ":"):
        if sep in text:
            name, _, value = text.partition(sep)
            try:
                offset = float(value)
            except ValueError:
                break
            axis: object = name.strip().lower()
            if "," in name:
                try:
                    axis = tuple(float(c) for c in name.split(","))
                except ValueError:
                    break
            try:
                return SplitPlane(axis, offset)  # type: ignore[arg-type]
            except InputError as exc:
                raise InputError(f"split plane {text!r}: {exc}") from exc
    raise InputError(
        f"split plane must look like 'z=0.5' (axis=offset) or '1,1,0=0.5' (normal=offset), got {text!r}"
    )


def edge_use_counts(triangles: np.ndarray) -> np.ndarray:
    """How many triangles use each undirected edge of a triangle mesh."""
    edges = np.sort(triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return counts


@dataclass(frozen=True, eq=False)
class ClosedSurface:
    """Two ADT halves patched into one mesh along a split plane.

    Attributes
    ----------
    points, triangles : ndarray
        The patched mesh; triangles oriented outwards (away from the plane).
    split : SplitPlane
    upper, lower : Surface
        The halves on the ``>= offset`` and ``<= offset`` sides (for an oblique plane, in
        the plane's frame: depth along the normal).
    n_shared : int
        Vertices the two halves share (points on the plane).
    n_on_plane : int
        Input points within the tolerance of the plane (they belong to both halves).
    n_strip : int
        Triangles of the strip joining the two rims (0 when the rims coincide): the last
        ``n_strip`` rows of ``triangles``.
    not_closed_reason : str
        Why the mesh is not a closed surface, in one line; empty when it is.
    """

    points: np.ndarray
    triangles: np.ndarray
    split: SplitPlane
    upper: Surface
    lower: Surface
    n_shared: int
    n_on_plane: int
    n_strip: int = 0
    not_closed_reason: str = ""

    @property
    def n_vertices(self) -> int:
        return int(self.points.shape[0])

    @property
    def n_triangles(self) -> int:
        return int(self.triangles.shape[0])

    @property
    def n_input(self) -> int:
        """Input points, counting points on the plane once."""
        return self.upper.n_input + self.lower.n_input - self.n_on_plane

    @property
    def is_closed(self) -> bool:
        """True when the mesh is watertight: every edge in two triangles, in opposite directions,
        and one fan of triangles round every vertex."""
        return not self.not_closed_reason

    @property
    def euler_characteristic(self) -> int:
        """V - E + F (2 for a closed surface of genus 0)."""
        edges = np.unique(np.sort(self.triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0)
        return self.n_vertices - len(edges) + self.n_triangles

    def to_polydata(self) -> pyvista.PolyData:
        return triangle_polydata(self.points, self.triangles)


def _half(
    cloud: np.ndarray, frame_points: np.ndarray, mask: np.ndarray, name: str, plane: SplitPlane, **kw: object
) -> tuple[Surface, np.ndarray]:
    """One half as an ADT surface over the plane, and its vertices in the cloud's frame."""
    if mask.sum() < 3:
        raise DegenerateInputError(
            f"{name} half of split {plane} has {int(mask.sum())} point(s); need at least 3 "
            "(is the plane inside the cloud?)"
        )
    try:
        if plane.aligned:
            surface = adt(cloud[mask], depth=AXES[plane.axis], **kw)  # type: ignore[arg-type, index]
            return surface, surface.points
        surface = adt(frame_points[mask], depth="z", **kw)  # type: ignore[arg-type]
    except InputError as exc:
        raise type(exc)(f"{name} half of split {plane} ({int(mask.sum())} points): {exc}") from exc
    # back to the cloud's frame: a vertex that is one input point keeps its exact coordinates
    world = surface.points @ plane.frame()
    single = np.bincount(surface.vertex_of_input, minlength=surface.n_vertices) == 1
    inputs = cloud[mask]
    first = np.full(surface.n_vertices, -1)
    first[surface.vertex_of_input[::-1]] = np.arange(inputs.shape[0])[::-1]
    world[single] = inputs[first[single]]
    return surface, world


@single_blas_thread()  # its products have an inner dimension of 3: threads only stall them
def closed_adt(
    points: ArrayLike,
    split: SplitPlane | str,
    *,
    duplicates: DuplicatePolicy = "mean",
    backend: Backend = "auto",
    tol: float | None = None,
) -> ClosedSurface:
    """Build a closed ADT surface from a cloud and a split plane.

    Parameters
    ----------
    points : array_like, shape (n, 3)
    split : SplitPlane or str
        The split plane, e.g. ``SplitPlane("z", 0.0)``, ``"z=0"`` or ``"1,1,0=0.5"``.
    duplicates, backend
        As for :func:`~replication.surfaces.adt.adt`, applied to each half.
    tol : float, optional
        Distance within which a point lies on the plane (default 1e-9 times the cloud's
        largest extent).

    Returns
    -------
    ClosedSurface
        Watertight unless ``not_closed_reason`` says why not (see the module notes).

    Raises
    ------
    InputError, DegenerateInputError
        As for :func:`adt`, for either half (the message says which).

    Notes
    -----
    Paper section 3.2, the closed-surface variant (two non-overlapping surfaces patched).
    """
    cloud = as_cloud(points)
    plane = parse_split(split) if isinstance(split, str) else split
    if tol is None:
        tol = 1e-9 * float(np.ptp(cloud, axis=0).max() or 1.0)
    elif not (np.isfinite(tol) and tol >= 0):
        raise InputError(f"split tolerance must be finite and non-negative, got {tol=}")
    frame = plane.frame()
    frame_points = cloud[:, [int(np.argmax(row)) for row in frame]] if plane.aligned else cloud @ frame.T
    coord = frame_points[:, 2]
    on_plane = np.abs(coord - plane.offset) <= tol
    kw = {"duplicates": duplicates, "backend": backend}
    upper, upper_world = _half(cloud, frame_points, (coord >= plane.offset) | on_plane, "upper", plane, **kw)
    lower, lower_world = _half(cloud, frame_points, (coord <= plane.offset) | on_plane, "lower", plane, **kw)

    # a point on the plane is a vertex of both halves: one vertex of the closed mesh
    same = _same_vertices(upper, lower, upper_world, lower_world, on_plane, coord >= plane.offset)
    lower_ids = np.empty(lower.n_vertices, dtype=np.int64)
    new = np.ones(lower.n_vertices, dtype=bool)
    new[list(same)] = False
    lower_ids[new] = upper.n_vertices + np.arange(int(new.sum()))
    for v, u in same.items():
        lower_ids[v] = u
    upper_ids = np.arange(upper.n_vertices)
    points_out = np.vstack([upper_world, lower_world[new]])
    tri_upper = upper.triangles
    # ADT normals point to +depth: outwards for the upper half; reverse the lower half's
    tri_lower = lower_ids[lower.triangles][:, [0, 2, 1]]
    halves = np.vstack([tri_upper, tri_lower])
    n_shared = len(same)

    strip, reason, rims = _join(points_out, frame, plane.offset, upper_ids, lower_ids, upper, lower)
    triangles = halves if reason else np.vstack([halves, strip])
    # each half is a triangulated disk: the mesh can go wrong only at the rims, checked there
    reason = reason or mesh_defect(triangles, points_out, near=rims)
    return ClosedSurface(
        points=_readonly(points_out),
        triangles=_readonly(triangles),
        split=plane,
        upper=upper,
        lower=lower,
        n_shared=n_shared,
        n_on_plane=int(on_plane.sum()),
        n_strip=0 if reason else int(strip.shape[0]),
        not_closed_reason=reason,
    )


def _same_vertices(
    upper: Surface,
    lower: Surface,
    upper_world: np.ndarray,
    lower_world: np.ndarray,
    on_plane: np.ndarray,
    above: np.ndarray,
) -> dict[int, int]:
    """Lower vertex -> upper vertex for the vertices of points on the plane that are equal."""
    in_upper = np.flatnonzero(above | on_plane)
    in_lower = np.flatnonzero(~above | on_plane)
    cand_up = np.unique(upper.vertex_of_input[np.searchsorted(in_upper, np.flatnonzero(on_plane))])
    cand_lo = np.unique(lower.vertex_of_input[np.searchsorted(in_lower, np.flatnonzero(on_plane))])
    position = {tuple(upper_world[u].tolist()): int(u) for u in cand_up}
    found = {}
    for v in cand_lo.tolist():
        u = position.get(tuple(lower_world[v].tolist()))
        if u is not None:
            found[v] = u
    return found


def _join(
    points: np.ndarray,
    frame: np.ndarray,
    offset: float,
    upper_ids: np.ndarray,
    lower_ids: np.ndarray,
    upper: Surface,
    lower: Surface,
) -> tuple[np.ndarray, str, np.ndarray]:
    """The strip joining the halves' rims or why they cannot be joined, and the rims' vertices."""
    size = points.shape[0]
    (rim_up, inner_up), (rim_lo, inner_lo) = (
        rim_and_inner(ids[half.triangles], size) for ids, half in ((upper_ids, upper), (lower_ids, lower))
    )
    rims = np.union1d(rim_up, rim_lo)

    def fail(reason: str) -> tuple[np.ndarray, str, np.ndarray]:
        return np.zeros((0, 3), dtype=np.int64), reason, rims

    shared = np.flatnonzero(np.bincount(upper_ids, minlength=size) & np.bincount(lower_ids, minlength=size))
    on_up, on_lo = np.isin(shared, rim_up), np.isin(shared, rim_lo)
    for name, inside, bad in (
        ("lower", "upper", on_lo & ~on_up),
        ("upper", "lower", on_up & ~on_lo),
        ("neither", "both", ~on_up & ~on_lo),
    ):
        if bad.any():
            v = np.round(points[shared[np.flatnonzero(bad)[0]]], 6).tolist()
            where = f"on the rim of the {name} half but inside the {inside} half's footprint"
            if name == "neither":
                where = "inside both halves' footprints"
            return fail(
                f"the point {v} on the split plane lies {where}, so the surface would touch itself there "
                f"({int(bad.sum())} such point(s)): split the cloud elsewhere"
            )
    touching = _touching_edge(size, (rim_up, rim_lo), (inner_up, inner_lo))
    if touching is not None:
        a, b = (np.round(points[v], 6).tolist() for v in touching)
        return fail(
            f"the halves touch along the edge from {a} to {b} on the split plane (a rim edge of one half "
            "inside the other), so the surface would touch itself there: split the cloud elsewhere"
        )
    uv = points @ frame[:2].T
    centre, area = footprint_centre(uv[rim_up], uv[rim_lo])
    if not area > 1e-12 * float(np.ptp(uv, axis=0).max()) ** 2:
        return fail("the two halves' footprints on the split plane do not overlap, so no strip can join them")
    height = points @ frame[2] - offset
    try:
        return closing_strip(rim_up, rim_lo, uv, height, centre, (inner_up, inner_lo)), "", rims
    except ValueError as exc:
        return fail(f"the halves' rims cannot be joined: {exc}")


def _sorted_contains(sorted_keys: np.ndarray, keys: np.ndarray) -> np.ndarray:
    """Whether each key is in the sorted array (np.isin without sorting the large array again)."""
    if sorted_keys.size == 0:
        return np.zeros(keys.shape, dtype=bool)
    at = np.minimum(np.searchsorted(sorted_keys, keys), sorted_keys.size - 1)
    return sorted_keys[at] == keys


def _touching_edge(
    size: int, rims: tuple[np.ndarray, np.ndarray], inner: tuple[np.ndarray, np.ndarray]
) -> tuple[int, int] | None:
    """An edge on one half's rim that is an inner edge of the other half, if any."""
    for rim, other_inner in ((rims[0], inner[1]), (rims[1], inner[0])):
        following = np.roll(rim, -1)
        hit = np.flatnonzero(
            _sorted_contains(other_inner, np.minimum(rim, following) * size + np.maximum(rim, following))
        )
        if hit.size:
            return int(rim[hit[0]]), int(following[hit[0]])
    return None
