"""Reproducible replication of "adapted Delaunay triangulation" (ADT) surfaces.

The public API: point clouds and ADT surfaces (:mod:`replication.surfaces`), file formats
(:mod:`replication.io`) and the error hierarchy (:mod:`replication.errors`).
"""

from importlib.metadata import PackageNotFoundError, version

from replication.errors import (
    CloudFileError,
    DegenerateInputError,
    DuplicatePointsWarning,
    InputError,
    OutputError,
    ReplicationError,
)
from replication.io import load_cloud, read_surface, save_cloud, write_surface, write_vtk, write_vtp
from replication.surfaces import (
    Box,
    ClosedSurface,
    SplitPlane,
    Surface,
    adt,
    closed_adt,
    random_cloud,
    select_depth_axis,
)

try:
    __version__ = version("replication")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0+unknown"

__all__ = [
    "Box",
    "ClosedSurface",
    "CloudFileError",
    "DegenerateInputError",
    "DuplicatePointsWarning",
    "InputError",
    "OutputError",
    "ReplicationError",
    "SplitPlane",
    "Surface",
    "__version__",
    "adt",
    "closed_adt",
    "load_cloud",
    "random_cloud",
    "read_surface",
    "save_cloud",
    "select_depth_axis",
    "write_surface",
    "write_vtk",
    "write_vtp",
]
