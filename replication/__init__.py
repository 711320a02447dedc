"""Reproducible replication of "adapted Delaunay triangulation" (ADT) surfaces.

The public API: point clouds, ADT and NURBS surfaces (:mod:`replication.surfaces`), their
paired comparison (:mod:`replication.compare`, :mod:`replication.stats`), file formats
(:mod:`replication.io`) and the error hierarchy (:mod:`replication.errors`).
"""

from importlib.metadata import PackageNotFoundError, version

from replication.compare import Comparison, compare
from replication.errors import (
    CloudFileError,
    DegenerateInputError,
    DuplicatePointsWarning,
    InputError,
    OutputError,
    ReplicationError,
)
from replication.io import load_cloud, read_surface, save_cloud, write_surface, write_vtk, write_vtp
from replication.io.nurbs import read_nurbs, write_nurbs
from replication.stats import PairedStatistics, paired_statistics
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
from replication.surfaces.nurbs import NurbsPatch, NurbsSurface, fit_nurbs

try:
    __version__ = version("replication")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0+unknown"

__all__ = [
    "Box",
    "Comparison",
    "NurbsPatch",
    "NurbsSurface",
    "PairedStatistics",
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
    "compare",
    "fit_nurbs",
    "load_cloud",
    "paired_statistics",
    "random_cloud",
    "read_nurbs",
    "read_surface",
    "save_cloud",
    "select_depth_axis",
    "write_nurbs",
    "write_surface",
    "write_vtk",
    "write_vtp",
]
