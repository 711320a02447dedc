"""Paired depth deviations between the ADT and NURBS surfaces of one cloud (paper section 4).

The paper compares "the z-axis coordinate for the same x-axis and y-axis coordinates" of
the two surfaces without saying which (x, y). Both natural pairings are provided:

``"nurbs-samples"`` (a)
    The (x, y) of points evaluated on the NURBS surface: a uniform parameter grid, by
    default the size of the control net, so that the number of pairs is about the number of
    cloud points. Their NURBS depth is known; the ADT depth is the barycentric interpolation
    in the ADT triangle that contains (x, y). Samples outside the cloud's convex hull (the
    ADT footprint) are excluded and counted.
``"cloud-points"`` (b)
    The (x, y) of the cloud's own points (its distinct projected positions, i.e. the ADT
    vertices). Their ADT depth is the vertex depth; the NURBS depth needs the parameters
    whose surface point has that (x, y), found by Newton inversion to 1e-9. Points outside
    the NURBS footprint are excluded and counted.

Differences are ADT minus NURBS.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from replication.errors import DegenerateInputError, InputError
from replication.params import count_pair, real
from replication.stats import PairedStatistics, check_alpha, paired_statistics
from replication.surfaces.adt import DEFAULT_TIE_RTOL, Surface, _readonly, adt
from replication.surfaces.bspline import evaluate, invert, parameter_grid
from replication.surfaces.cloud import as_cloud
from replication.surfaces.delaunay import Backend
from replication.surfaces.duplicates import DuplicatePolicy
from replication.surfaces.interpolate import interpolate_linear
from replication.surfaces.nurbs import NurbsSurface, fit_nurbs

__all__ = [
    "PAIRINGS",
    "Comparison",
    "PairedDepths",
    "compare",
    "pair_at_cloud_points",
    "pair_at_nurbs_samples",
]

PAIRINGS: tuple[str, str] = ("nurbs-samples", "cloud-points")
#: Fewest pairs the tests accept; a pairing with fewer has no statistics (None).
MIN_PAIRS = 3


@dataclass(frozen=True, eq=False)
class PairedDepths:
    """Depths of both surfaces at the same positions of the projection plane."""

    pairing: str
    positions: np.ndarray  # (k, 2) in the projection plane
    adt: np.ndarray  # (k,)
    nurbs: np.ndarray  # (k,)
    n_candidates: int
    n_outside_adt: int
    n_outside_nurbs: int

    @property
    def n(self) -> int:
        return int(self.adt.shape[0])

    @property
    def differences(self) -> np.ndarray:
        return self.adt - self.nurbs


def _check_frames(surface: Surface, nurbs: NurbsSurface) -> None:
    if surface.depth_axis != nurbs.depth_axis:
        raise InputError(
            f"the ADT surface (depth {surface.depth_axis_name}) and the NURBS surface "
            f"(depth {nurbs.depth_axis_name}) are height fields over different planes"
        )


def pair_at_nurbs_samples(
    surface: Surface, nurbs: NurbsSurface, shape: tuple[int, int] | None = None
) -> PairedDepths:
    """Pairing (a): at points evaluated on the NURBS surface (default grid: the net size)."""
    _check_frames(surface, nurbs)
    shape = shape or nurbs.patch.net_shape
    points = evaluate(nurbs.patch, parameter_grid(shape))
    # the surface spans the grid's box exactly (convex combinations of its nodes); rounding can put
    # a sample on the box's edge a hair outside it, where a lattice's hull edge runs: clipped, it
    # is kept or dropped by the geometry, not by the units or the offset of the cloud
    grid = nurbs.grid
    positions = np.column_stack(
        [
            np.clip(points[:, nurbs.projection_axes[0]], grid.u[0], grid.u[-1]),
            np.clip(points[:, nurbs.projection_axes[1]], grid.v[0], grid.v[-1]),
        ]
    )
    adt_depth = interpolate_linear(
        surface.projected(),
        surface.triangles,
        surface.points[:, surface.depth_axis],
        positions,
        neighbors=surface.neighbors,  # the triangulator's adjacency: no edge sort
    )
    inside = ~np.isnan(adt_depth)
    return PairedDepths(
        pairing="nurbs-samples",
        positions=_readonly(positions[inside]),
        adt=_readonly(adt_depth[inside]),
        nurbs=_readonly(points[inside, nurbs.depth_axis]),
        n_candidates=int(positions.shape[0]),
        n_outside_adt=int((~inside).sum()),
        n_outside_nurbs=0,
    )


def pair_at_cloud_points(surface: Surface, nurbs: NurbsSurface) -> PairedDepths:
    """Pairing (b): at the cloud's distinct projected positions (the ADT vertices)."""
    _check_frames(surface, nurbs)
    positions = surface.projected()
    adt_depth = surface.points[:, surface.depth_axis]
    inversion = invert(nurbs.patch, positions, nurbs.projection_axes)
    ok = inversion.converged
    return PairedDepths(
        pairing="cloud-points",
        positions=_readonly(positions[ok]),
        adt=_readonly(adt_depth[ok]),
        nurbs=_readonly(inversion.points[ok, nurbs.depth_axis]),
        n_candidates=int(positions.shape[0]),
        n_outside_adt=0,
        n_outside_nurbs=int((~ok).sum()),
    )


@dataclass(frozen=True, eq=False)
class Comparison:
    """The ADT and NURBS surfaces of one cloud, their paired depths and statistics.

    ``statistics[name]`` is None when the pairing has fewer than ``MIN_PAIRS`` pairs (for
    example a 9-point cloud whose convex hull holds fewer than 3 of the 3 x 3 NURBS samples).
    """

    adt: Surface
    nurbs: NurbsSurface
    depth_range: float
    pairings: Mapping[str, PairedDepths]
    statistics: Mapping[str, PairedStatistics | None]

    def __post_init__(self) -> None:  # frozen: the mappings too (a dict could be changed)
        object.__setattr__(self, "pairings", ReadOnlyDict(self.pairings))
        object.__setattr__(self, "statistics", ReadOnlyDict(self.statistics))


class ReadOnlyDict(dict):
    """A dict that refuses changes, and pickles, copies and ``asdict``-s as a dict does (a
    ``MappingProxyType`` cannot be pickled: a Comparison could not leave its process)."""

    def _refuse(self, *args: Any, **kwargs: Any) -> None:
        raise TypeError("the mappings of a Comparison are read-only")

    __setitem__ = __delitem__ = clear = pop = popitem = setdefault = update = _refuse  # type: ignore[assignment]
    __ior__ = _refuse  # type: ignore[assignment]

    def __reduce__(self) -> tuple[Any, ...]:
        return (type(self), (dict(self),))


def compare(
    points: ArrayLike,
    *,
    degree: int = 2,
    net: tuple[int, int] | None = None,
    depth: Literal["min", "max", "x", "y", "z"] = "min",
    duplicates: DuplicatePolicy = "mean",
    backend: Backend = "auto",
    sample_shape: tuple[int, int] | None = None,
    margin_fraction: float = 0.05,
    alpha: float = 0.05,
    tie_rtol: float = DEFAULT_TIE_RTOL,
) -> Comparison:
    """Build both surfaces of a cloud and compare their depths in both pairings.

    Parameters
    ----------
    points : array_like, shape (n, 3)
    degree, net
        NURBS degree and control net (see :func:`~replication.surfaces.nurbs.fit_nurbs`).
    depth, duplicates, backend, tie_rtol
        The shared frame and duplicate policy (see :func:`~replication.surfaces.adt.adt`).
    sample_shape : (int, int), optional
        NURBS parameter samples for pairing (a); default the control-net size.
    margin_fraction, alpha
        Equivalence margin (fraction of the depth range) and significance level.

    Returns
    -------
    Comparison

    Notes
    -----
    Paper section 4: "Student's paired t test and Wilcoxon signed-rank test" on the z
    deviations of the two surfaces.
    """
    check_alpha(alpha)  # the arguments are checked before the cloud and the fitting
    real(margin_fraction, "margin_fraction")
    if sample_shape is not None:  # (0, 5) gave no pairing without a word
        sample_shape = count_pair(sample_shape, "sample_shape", 2)
    cloud = as_cloud(points)
    surface = adt(cloud, depth=depth, duplicates=duplicates, backend=backend, tie_rtol=tie_rtol)
    nurbs = fit_nurbs(cloud, degree=degree, net=net, tessellation=None, triangulation=surface)
    depth_range = float(np.ptp(cloud[:, surface.depth_axis]))
    if depth_range == 0.0:
        raise DegenerateInputError(
            f"the cloud is flat along its depth axis {surface.depth_axis_name} (all depths equal): both "
            "surfaces are the same plane and deviations relative to the depth range are undefined"
        )
    pairings = {
        "nurbs-samples": pair_at_nurbs_samples(surface, nurbs, sample_shape),
        "cloud-points": pair_at_cloud_points(surface, nurbs),
    }
    statistics = {
        name: None
        if p.n < MIN_PAIRS
        else paired_statistics(
            p.adt, p.nurbs, depth_range=depth_range, margin_fraction=margin_fraction, alpha=alpha
        )
        for name, p in pairings.items()
    }
    return Comparison(
        adt=surface, nurbs=nurbs, depth_range=depth_range, pairings=pairings, statistics=statistics
    )
