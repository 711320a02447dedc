"""The case study's reference shapes: a flat plate and a Pelton-like half bucket.

Both are 101-point clouds on the 1 mm lattice of the paper's domain (integer millimetres,
x in 0..36, y in 0..30, z in 0..13), the size of the genetic algorithm's chromosomes, and
become surfaces through ``adt(cloud, depth="z")``. y is measured from the splitter
(symmetry) plane y = 0 and the jet arrives along -z, centred at (18, 0).

Their forces in the thin-sheet model (:mod:`.jet`, the paper's half jet, default resolution
8; resolution 32 in brackets): flat plate 2.397 N (2.397 N), exactly rho Q V of the half jet;
bucket 4.402 N (4.408 N), 1.84 rho Q V, because its rims turn the sheet back upwards. The
whole jet on the mirrored shapes gives twice as much (4.793 N and 8.804 N). The paper's SPH
values, 21.96 N (flat) and 19.08 N (bucket), exceed 2 rho Q V = 9.59 N, the largest steady
force this jet can exert on any stationary surface.
"""

from __future__ import annotations

import numpy as np

from replication.surfaces import Surface, adt

__all__ = [
    "PAPER_SPH_FORCES",
    "flat_plate_cloud",
    "flat_plate_surface",
    "pelton_bucket_cloud",
    "pelton_bucket_surface",
]

#: Forces (N) the paper reports from DualSPHysics for the two reference shapes (section 6).
PAPER_SPH_FORCES = {"flat plate": 21.96, "pelton bucket": 19.08}

_X_COLUMNS = np.array([0, 4, 8, 12, 16, 20, 24, 28, 32, 36])
_Y_ROWS = np.array([0, 3, 6, 10, 13, 16, 20, 23, 26, 30])


def flat_plate_cloud(height: int = 0) -> np.ndarray:
    """A flat plate z = ``height`` covering the whole domain: 101 lattice points (mm).

    A 10 x 10 lattice-aligned grid spanning 0..36 x 0..30 plus the point under the jet axis
    (18, 0).

    Notes
    -----
    Paper section 6: the flat surface of the initial population.
    """
    if not (isinstance(height, (int, np.integer)) and 0 <= height <= 13):
        from replication.errors import InputError

        raise InputError(f"plate height must be an integer 0..13 mm, got {height=!r}")
    gx, gy = np.meshgrid(_X_COLUMNS, _Y_ROWS, indexing="ij")
    xy = np.vstack([np.column_stack([gx.ravel(), gy.ravel()]), [[18, 0]]])
    return np.column_stack([xy, np.full(xy.shape[0], height)]).astype(np.float64)


def _bucket_depth(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Height (mm) of the smooth half bucket: 13 on the splitter and the rims, 0 at the bottom."""
    rho2 = ((x - 18.0) / 18.0) ** 2 + ((y - 15.0) / 15.0) ** 2
    return 13.0 * np.minimum(rho2, 1.0) ** 2


def pelton_bucket_cloud() -> np.ndarray:
    """An approximation of a Pelton half bucket: 101 lattice points (mm).

    The surface is 13 mm high along the splitter ridge y = 0, drops steeply into an
    elliptical cup centred at (18, 15) mm and rises again to the 13 mm outer rim (y = 30)
    and the two ends (x = 0, 36), whose steep walls turn the sheet back upwards. The height
    z = 13 min(rho^2, 1)^2, rho^2 = ((x - 18)/18)^2 + ((y - 15)/15)^2, is sampled on the
    grid of :func:`flat_plate_cloud` and rounded to the 1 mm lattice; the extra point is on
    the splitter under the jet axis.

    Notes
    -----
    Paper section 6: "an approximation of existing Pelton turbine bucket" in the initial
    population.
    """
    gx, gy = np.meshgrid(_X_COLUMNS, _Y_ROWS, indexing="ij")
    xy = np.vstack([np.column_stack([gx.ravel(), gy.ravel()]), [[18, 0]]]).astype(np.float64)
    z = np.rint(_bucket_depth(xy[:, 0], xy[:, 1]))
    return np.column_stack([xy, z])


def flat_plate_surface(height: int = 0) -> Surface:
    """ADT surface (depth axis z) of :func:`flat_plate_cloud`."""
    return adt(flat_plate_cloud(height), depth="z")


def pelton_bucket_surface() -> Surface:
    """ADT surface (depth axis z) of :func:`pelton_bucket_cloud`."""
    return adt(pelton_bucket_cloud(), depth="z")
