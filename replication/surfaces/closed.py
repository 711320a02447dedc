"""Closed ADT surfaces from a user-named split plane (paper section 3.2).

The paper: "closed surfaces could also be generated ... with the help of user inputs
regarding the presence of closed surface and the plane for split boundary. This will allow
the algorithm to separate the random points cloud into two sets and generate two different
non-overlapping surfaces which can be patched together to form the final closed surface."

Choices made here (documented and tested):

* The split plane is axis-aligned, ``axis = offset``. Each half is triangulated as a height
  field over the plane, i.e. with the plane's normal as depth axis, so the upper half lies
  on one side of the plane and the lower half on the other: they cannot overlap.
* Points within ``tol`` of the plane belong to both halves (default tolerance: 1e-9 times
  the cloud's largest extent). In the patched mesh equal vertices of the two halves become
  one vertex, so the halves are stitched along the plane.
* The lower half's triangles are reversed so the closed mesh is consistently oriented
  with normals pointing away from the plane on both sides (outwards).
* The mesh is watertight exactly when the two halves have the same boundary; when points
  off the plane project outside the hull of the plane points it is not, and
  :attr:`ClosedSurface.is_closed` says so.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from replication.errors import DegenerateInputError, InputError
from replication.surfaces.adt import AXES, Surface, adt, parse_axis, triangle_polydata
from replication.surfaces.cloud import as_cloud
from replication.surfaces.delaunay import Backend
from replication.surfaces.duplicates import DuplicatePolicy

if TYPE_CHECKING:  # pragma: no cover
    import pyvista

__all__ = ["SplitPlane", "ClosedSurface", "closed_adt", "parse_split", "edge_use_counts"]


@dataclass(frozen=True)
class SplitPlane:
    """The axis-aligned plane ``axis = offset`` that splits a closed cloud in two."""

    axis: int
    offset: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "axis", parse_axis(self.axis))
        if not np.isfinite(self.offset):
            raise InputError(f"split plane offset must be finite, got {self.offset!r}")
        object.__setattr__(self, "offset", float(self.offset))

    def __str__(self) -> str:
        return f"{AXES[self.axis]}={self.offset:g}"


def parse_split(text: str) -> SplitPlane:
    """Parse ``"z=0.5"`` (or ``"z:0.5"``) into a :class:`SplitPlane`."""
    for sep in ("=", ":"):
        if sep in text:
            name, _, value = text.partition(sep)
            try:
                offset = float(value)
            except ValueError:
                break
            try:
                return SplitPlane(name.strip().lower(), offset)  # type: ignore[arg-type]
            except InputError as exc:
                raise InputError(f"split plane {text!r}: {exc}") from exc
    raise InputError(f"split plane must look like 'z=0.5' (axis=offset), got {text!r}")


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
        The halves on the ``>= offset`` and ``<= offset`` sides.
    n_shared : int
        Vertices the two halves share (points on the plane).
    n_on_plane : int
        Input points within the tolerance of the plane (they belong to both halves).
    """

    points: np.ndarray
    triangles: np.ndarray
    split: SplitPlane
    upper: Surface
    lower: Surface
    n_shared: int
    n_on_plane: int

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
        """True when every edge is shared by exactly two triangles (watertight)."""
        return bool(np.all(edge_use_counts(self.triangles) == 2))

    def to_polydata(self) -> pyvista.PolyData:
        return triangle_polydata(self.points, self.triangles)


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
        The split plane, e.g. ``SplitPlane("z", 0.0)`` or ``"z=0"``.
    duplicates, backend
        As for :func:`~replication.surfaces.adt.adt`, applied to each half.
    tol : float, optional
        Distance within which a point lies on the plane (default 1e-9 times the cloud's
        largest extent).

    Returns
    -------
    ClosedSurface

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
    coord = cloud[:, plane.axis]
    on_plane = np.abs(coord - plane.offset) <= tol
    halves = {}
    for name, mask in (
        ("upper", (coord >= plane.offset) | on_plane),
        ("lower", (coord <= plane.offset) | on_plane),
    ):
        if mask.sum() < 3:
            raise DegenerateInputError(
                f"{name} half of split {plane} has {int(mask.sum())} point(s); need at least 3 "
                "(is the plane inside the cloud?)"
            )
        try:
            halves[name] = adt(cloud[mask], depth=AXES[plane.axis], duplicates=duplicates, backend=backend)
        except InputError as exc:
            raise type(exc)(f"{name} half of split {plane} ({int(mask.sum())} points): {exc}") from exc
    upper, lower = halves["upper"], halves["lower"]
    stacked = np.vstack([upper.points, lower.points])
    unique, inverse = np.unique(stacked, axis=0, return_inverse=True)
    inverse = inverse.ravel()
    # keep the upper half's vertex order, then the lower half's new vertices
    order = np.argsort(np.unique(inverse, return_index=True)[1])
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    remap = rank[inverse]
    points_out = unique[order]
    tri_upper = remap[upper.triangles]
    # ADT normals point to +depth: outwards for the upper half; reverse the lower half's
    tri_lower = remap[upper.n_vertices + lower.triangles][:, [0, 2, 1]]
    return ClosedSurface(
        points=points_out,
        triangles=np.vstack([tri_upper, tri_lower]),
        split=plane,
        upper=upper,
        lower=lower,
        n_shared=int(upper.n_vertices + lower.n_vertices - points_out.shape[0]),
        n_on_plane=int(on_plane.sum()),
    )
